//! The `felt` command: run, study, check, explore (REPL) and look up (doc) field scripts.
//!
//! The one key decision: the whole run happens on a thread with a large stack, because scripts
//! may build field graphs thousands of nodes deep (long `advect` chains) and the checker,
//! interpreter and graph passes are allowed to recurse over the syntax tree. Exit codes: 0 on
//! success, 1 on a script error, 2 on bad usage (arguments, unreadable files, unknown `--set`),
//! 70 on an internal error (a panic: a bug in felt, reported in one line).

use clap::{Parser, Subcommand};
use felt::diagnostic::{self, Diagnostic};
use felt::session::Session;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

/// The exit status of a run that hit a bug in felt (`EX_SOFTWARE` of sysexits.h).
const INTERNAL_ERROR: u8 = 70;

/// Stack of the thread that runs scripts.
const RUN_STACK_BYTES: usize = 512 << 20;

/// Most worker threads `--threads` accepts: far more than any machine felt runs on has cores,
/// and few enough that asking for them cannot exhaust the process's thread limit by itself.
const MAX_THREADS: u16 = 1024;

#[derive(Parser)]
#[command(
    name = "felt",
    version,
    about = "A field expression language for volumetric effects"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a script.
    Run {
        /// The script to run.
        file: PathBuf,
        /// Override a `param` declaration: `--set name=value` (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_assignment)]
        set: Vec<(String, String)>,
        /// Worker threads for field evaluation and rendering (default: all cores).
        #[arg(
            long,
            value_name = "N",
            value_parser = clap::value_parser!(u16).range(1..=MAX_THREADS as i64)
        )]
        threads: Option<u16>,
        /// After the run, print each grid that was computed and the grids never needed.
        #[arg(long)]
        profile: bool,
        /// The run's memory budget in megabytes: caches, FFT buffers, images and large
        /// strings and arrays all count (default: half of the memory felt may use).
        #[arg(long, value_name = "MB", value_parser = clap::value_parser!(u64).range(1..))]
        memory_limit: Option<u64>,
        /// Write outputs named by relative paths under DIR (created if missing) instead of
        /// the script's folder; inputs are still read from the script's folder.
        #[arg(long, value_name = "DIR")]
        output_dir: Option<PathBuf>,
    },
    /// Measure what accuracy costs: run a script once per setting of its swept params and
    /// compare each run's outputs with a reference setting's.
    #[command(long_about = STUDY_ABOUT)]
    Study {
        /// The script to study.
        file: PathBuf,
        /// A param and the values to try: `--sweep NAME=v1,v2,...` (repeatable; the study
        /// runs every combination).
        #[arg(long = "sweep", value_name = "NAME=V1,V2,...", value_parser = parse_assignment, required = true)]
        sweeps: Vec<(String, String)>,
        /// The value a param takes in the reference: `--reference NAME=VALUE` (repeatable).
        /// Each setting is compared with itself with these values applied.
        #[arg(long = "reference", value_name = "NAME=VALUE", value_parser = parse_assignment, required = true)]
        reference: Vec<(String, String)>,
        /// Fix a param for every run, reference included: `--set name=value` (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_assignment)]
        set: Vec<(String, String)>,
        /// Run each setting N times and report the median times.
        #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
        repeat: u32,
        /// The study's folder: runs, the cached references, study.csv and the plots
        /// (default: SCRIPT-study in the current folder).
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Worker threads for each run (default: all cores).
        #[arg(
            long,
            value_name = "N",
            value_parser = clap::value_parser!(u16).range(1..=MAX_THREADS as i64)
        )]
        threads: Option<u16>,
        /// The memory budget of each run, in megabytes, as for `felt run`.
        #[arg(long, value_name = "MB", value_parser = clap::value_parser!(u64).range(1..))]
        memory_limit: Option<u64>,
    },
    /// Check a script for errors without running it.
    Check {
        /// The script to check.
        file: PathBuf,
        /// Check a `param` override as `felt run --set name=value` would take it (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_assignment)]
        set: Vec<(String, String)>,
    },
    /// Start an interactive session.
    Repl {
        /// Worker threads for field evaluation and rendering (default: all cores).
        #[arg(
            long,
            value_name = "N",
            value_parser = clap::value_parser!(u16).range(1..=MAX_THREADS as i64)
        )]
        threads: Option<u16>,
    },
    /// List the builtins and library functions, or describe one.
    Doc {
        /// A builtin or library function.
        name: Option<String>,
    },
}

const STUDY_ABOUT: &str = "\
Measure what accuracy costs: run a script once per setting of its swept params and compare \
each run's outputs with a reference setting's.

Every combination of the --sweep values is one setting. Each setting runs as its own \
`felt run` process, with the values passed as --set does and its relative outputs written \
to a folder of its own, and is measured for wall time, CPU time and peak memory. Its \
reference is the same setting with the --reference values applied (a --reference may name a \
param that is not swept, such as a finer resolution for the reference alone). What each run \
wrote and printed is compared with what its reference wrote and printed:

  images (.exr, .png)   RMSE, PSNR and relative MSE of RGBA, and SSIM of the displayed colour
  VDB files (.vdb)      RMSE and largest error over the union of active voxels, per grid
  printed numbers       each number's value, absolute and relative error; a line's label is
                        its text without the numbers (print(\"area error\", e) is \"area error\")

A printed line whose label contains \"error\" or \"seconds\" (or \"time\") is a quantity the \
script measured itself, against an exact answer or with clock(): it is shown as it is, not \
compared with the reference's.

The study prints a table and writes, into --out: study.csv (one row per setting), \
pareto-MEASURE.svg (each error against seconds on log-log axes, the Pareto front marked), \
MEASURE-vs-PARAM.svg (each error against each swept param) and seconds-vs-PARAM.svg and \
peak-mib-vs-PARAM.svg (the costs). Errors plotted are the RMSEs and largest errors, relative \
errors of printed numbers, and the errors the script printed itself (by their size).

Reference runs are cached in --out/reference, keyed by the text of the script and every file \
it imports, felt's version and the reference's params: running the study again with more \
settings reuses them. A setting whose run fails is reported and the study goes on.

Exit status: 0 when every setting ran and was compared; 1 when the script has errors or a \
run (or the reference) failed; 2 for bad usage: unknown params, values of the wrong type, \
empty sweeps, or settings that write other files than their reference.

Example:
  felt study examples/studies/raymarch_step.felt --sweep step=0.04,0.02,0.01 \\
      --reference step=0.0025 --set scene=cloud --out step-study";

fn parse_assignment(text: &str) -> Result<(String, String), String> {
    match text.split_once('=') {
        Some((name, value)) if !name.trim().is_empty() => {
            Ok((name.trim().to_string(), value.to_string()))
        }
        _ => Err(format!("expected NAME=VALUE, found `{text}`")),
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    // A panic is a bug in felt, never the user's fault: one line saying so, then exit 70.
    std::panic::set_hook(Box::new(|info| {
        eprintln!(
            "felt: internal error ({info}); please report it, with the script that caused it"
        );
    }));
    let runner = std::thread::Builder::new()
        .name("felt".into())
        .stack_size(RUN_STACK_BYTES)
        .spawn(move || run(cli));
    match runner.map(|handle| handle.join()) {
        Ok(Ok(code)) => code,
        Ok(Err(_)) => ExitCode::from(INTERNAL_ERROR),
        Err(e) => {
            eprintln!("felt: cannot start: {e}");
            ExitCode::from(2)
        }
    }
}

/// Starts the worker pool now, with `threads` workers or one per core, so that a pool that
/// cannot start is a usage error here rather than a panic at the first parallel loop.
fn set_threads(threads: Option<u16>) -> Result<(), ExitCode> {
    let workers = threads.map_or(0, usize::from);
    rayon::ThreadPoolBuilder::new()
        .num_threads(workers)
        .build_global()
        .map_err(|e| {
            match threads {
                Some(n) => eprintln!("felt: cannot start {n} worker threads: {e}"),
                None => eprintln!("felt: cannot start the worker threads: {e}"),
            }
            eprintln!("  help: try a smaller `--threads`");
            ExitCode::from(2)
        })
}

fn run(cli: Cli) -> ExitCode {
    let color = std::io::stderr().is_terminal();
    match cli.command {
        Command::Run {
            file,
            set,
            threads,
            profile,
            memory_limit,
            output_dir,
        } => {
            if let Err(code) = set_threads(threads) {
                return code;
            }
            // Ctrl-C or SIGTERM in a batch run: no half-written temporary is left behind.
            let _ = ctrlc::set_handler(|| {
                felt::output::remove_temporaries();
                eprintln!("felt: interrupted");
                std::process::exit(130);
            });
            if let Some(dir) = output_dir
                && let Err(e) = felt::output::set_directory(&dir)
            {
                eprintln!("felt: --output-dir: {e}");
                return ExitCode::from(2);
            }
            if let Some(megabytes) = memory_limit {
                felt::grid::domain::set_memory_limit(megabytes.saturating_mul(1 << 20));
            }
            let mut session = match Session::new(Box::new(std::io::stdout())) {
                Ok(s) => s,
                Err(failure) => {
                    return report(&failure.sources, &failure.diagnostics, color, 1);
                }
            };
            session.interp.overrides = set.into_iter().collect();
            let code = match session.run_file(&file) {
                Ok(warnings) => report(&session.sources.borrow(), &warnings, color, 0),
                Err(diags) => {
                    let usage = diags
                        .iter()
                        .any(|d| d.stage == diagnostic::Stage::Usage && d.is_error());
                    let code = if usage { 2 } else { 1 };
                    report(&session.sources.borrow(), &diags, color, code)
                }
            };
            let late = session.finish();
            if !late.is_empty() {
                report(&session.sources.borrow(), &late, color, 0);
            }
            if profile {
                eprint!("{}", Session::profile_report());
            }
            code
        }
        Command::Study {
            file,
            sweeps,
            reference,
            set,
            repeat,
            out,
            threads,
            memory_limit,
        } => ExitCode::from(felt::study::run(&felt::study::StudyArgs {
            script: file,
            sweeps,
            reference,
            set,
            repeat,
            out,
            threads,
            memory_limit,
        })),
        Command::Check { file, set } => {
            let mut session = match Session::new(Box::new(std::io::stdout())) {
                Ok(s) => s,
                Err(failure) => {
                    return report(&failure.sources, &failure.diagnostics, color, 1);
                }
            };
            session.interp.overrides = set.into_iter().collect();
            let diags = match session.load(&file) {
                Ok(units) => {
                    let mut diags = session.check(&units);
                    if !diags.iter().any(|d| d.is_error())
                        && let Err(d) = session.check_overrides(&units)
                    {
                        diags.push(d);
                    }
                    diags
                }
                Err(diags) => diags,
            };
            let usage = diags
                .iter()
                .any(|d| d.stage == diagnostic::Stage::Usage && d.is_error());
            let failed = diags.iter().any(|d| d.is_error());
            let code = match (usage, failed) {
                (true, _) => 2,
                (false, true) => 1,
                (false, false) => 0,
            };
            let code = report(&session.sources.borrow(), &diags, color, code);
            if !failed {
                println!("{}: no errors", file.display());
            }
            code
        }
        Command::Repl { threads } => {
            if let Err(code) = set_threads(threads) {
                return code;
            }
            felt::repl::run()
        }
        Command::Doc { name } => felt::doc::print(name.as_deref()),
    }
}

fn report(
    sources: &felt::syntax::span::SourceMap,
    diags: &[Diagnostic],
    color: bool,
    code: u8,
) -> ExitCode {
    if !diags.is_empty() {
        eprint!("{}", diagnostic::render(diags, sources, color));
    }
    ExitCode::from(code)
}
