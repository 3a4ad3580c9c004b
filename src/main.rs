//! The `felt` command: run, study, check, explore (REPL), look up (doc) and edit (lsp) field
//! scripts.
//!
//! The one key decision: the whole run happens on a thread with a large stack, because scripts
//! may build field graphs thousands of nodes deep (long `advect` chains) and the checker,
//! interpreter and graph passes are allowed to recurse over the syntax tree. Exit codes: 0 on
//! success, 1 on a script error, 2 on bad usage (arguments, unreadable files, unknown `--set`),
//! 70 on an internal error (a bug in felt: a panic, reported in one line, or a
//! `Failure::internal`, whose diagnostic's help line asks for a report), 130 when interrupted.

// The command line is the binary's own; its files live with the command's tools in `app/`.
#[path = "app/cli.rs"]
mod cli;
#[path = "app/farm_command.rs"]
mod farm_command;

use clap::Parser;
use cli::{Cli, Command};
use farm_command::{farm, merge};
use felt::session::Session;
use felt::syntax::diagnostic::{self, Diagnostic};
use std::io::IsTerminal;
use std::process::ExitCode;

/// The exit status of a run that hit a bug in felt (`EX_SOFTWARE` of sysexits.h).
const INTERNAL_ERROR: u8 = 70;

/// Stack of the thread that runs scripts.
const RUN_STACK_BYTES: usize = 512 << 20;
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

/// Starts the worker pool of this thread (the one sessions run on) now, with `threads`
/// workers or one per core, so that a pool that cannot start is a usage error here rather than
/// a silent fallback at the first parallel loop. Under an address-space limit (`ulimit -v`)
/// the count is first cut to the threads whose stacks fit, with a warning.
fn set_threads(threads: Option<u16>) -> Result<(), ExitCode> {
    let wanted = threads.map(usize::from).unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    });
    let fitted = felt::engine::budget::threads_that_fit(wanted);
    if fitted < wanted {
        eprintln!(
            "felt: warning: {wanted} worker threads do not fit this process's address-space \
             limit (`ulimit -v`); using {fitted}"
        );
        eprintln!("  help: raise `ulimit -v` or pass a smaller `--threads`");
    }
    let count = (threads.is_some() || fitted < wanted).then_some(fitted);
    felt::engine::attach_pool(count).map_err(|e| {
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
            frames,
            tile,
        } => {
            let mut set = set;
            // First: any session made on this thread (even the one that reads the `frame`
            // param below) starts the thread's worker pool, at its default size.
            if let Err(code) = set_threads(threads) {
                return code;
            }
            // What this run owns (budget, output settings, band), set up before it starts.
            let engine = felt::engine::Engine::new();
            if let Some(range) = &frames {
                if let Err(code) = frame_param(&file, &set) {
                    return code;
                }
                if range.frames.len() > 1 {
                    let args: Vec<std::ffi::OsString> = std::env::args_os().skip(1).collect();
                    stop_children_when_interrupted();
                    return ExitCode::from(felt::app::sequence::run(range, &args));
                }
                engine.output.set_frame_range();
                set.push(("frame".to_string(), range.frames[0].to_string()));
            }
            if let Some(band) = tile {
                let _ = engine.band.set(band);
            }
            // Ctrl-C or SIGTERM in a batch run: no half-written temporary is left behind.
            let _ = ctrlc::set_handler(|| {
                felt::io::output::remove_temporaries();
                eprintln!("felt: interrupted");
                std::process::exit(130);
            });
            if let Some(dir) = output_dir
                && let Err(e) = engine.output.set_directory(&dir)
            {
                eprintln!("felt: --output-dir: {e}");
                return ExitCode::from(2);
            }
            if let Some(megabytes) = memory_limit {
                engine.budget.set_limit(megabytes.saturating_mul(1 << 20));
            }
            let mut session = match Session::with_engine(Box::new(std::io::stdout()), engine) {
                Ok(s) => s,
                Err(failure) => {
                    return report(&failure.sources, &failure.diagnostics, color, 1);
                }
            };
            session.interp.overrides = set.into_iter().collect();
            let code = match session.run_file(&file) {
                Ok(warnings) => report(&session.sources.borrow(), &warnings, color, 0),
                Err(diags) => report(
                    &session.sources.borrow(),
                    &diags,
                    color,
                    failed_status(&diags),
                ),
            };
            let late = session.finish();
            if !late.is_empty() {
                report(&session.sources.borrow(), &late, color, 0);
            }
            if profile {
                eprint!("{}", session.profile_report());
            }
            code
        }
        Command::Study {
            file,
            sweeps,
            reference,
            set,
            repeat,
            trade,
            out,
            threads,
            memory_limit,
        } => {
            // Ctrl-C or SIGTERM: the running setting's process group is stopped first (it
            // removes its temporaries), then the study exits as an interrupted run does.
            stop_children_when_interrupted();
            ExitCode::from(felt::app::study::run(&felt::app::study::StudyArgs {
                script: file,
                sweeps,
                reference,
                set,
                repeat,
                trade,
                out,
                threads,
                memory_limit,
            }))
        }
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
            felt::app::repl::run()
        }
        Command::Doc { name } => felt::app::doc::print(name.as_deref()),
        Command::Lsp => felt::app::lsp::serve(),
        Command::Merge {
            images,
            frames,
            tiles,
            output_dir,
        } => merge(
            &images,
            frames.as_ref(),
            tiles.map(usize::from),
            output_dir.as_deref(),
        ),
        Command::Farm { engine } => farm(engine, color),
    }
}

/// The exit status of a run that stopped on `diags`: 70 when felt itself failed (an internal
/// error: the diagnostic's help asks for a report), 2 for bad usage, 1 for the script's errors.
fn failed_status(diags: &[Diagnostic]) -> u8 {
    let stopped_by =
        |stage: diagnostic::Stage| diags.iter().any(|d| d.stage == stage && d.is_error());
    if stopped_by(diagnostic::Stage::Internal) {
        INTERNAL_ERROR
    } else if stopped_by(diagnostic::Stage::Usage) {
        2
    } else {
        1
    }
}

pub(crate) fn report(
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

/// Checks, before any frame runs, that the script declares `param int frame` and that
/// `--set` leaves it to `--frames`.
pub(crate) fn frame_param(
    file: &std::path::Path,
    set: &[(String, String)],
) -> Result<(), ExitCode> {
    if set.iter().any(|(name, _)| name == "frame") {
        eprintln!("felt: --frames sets the param `frame`; do not also --set it");
        return Err(ExitCode::from(2));
    }
    let Ok(mut session) = Session::new(Box::new(std::io::sink())) else {
        return Ok(()); // the run itself reports a broken installation
    };
    let Ok(units) = session.load(file) else {
        return Ok(()); // and an unreadable script
    };
    let declared = Session::params(&units)
        .into_iter()
        .find(|(name, _)| name == "frame")
        .map(|(_, ty)| ty);
    match declared {
        Some(felt::check::types::Type::Int) => Ok(()),
        Some(other) => {
            eprintln!("felt: --frames: the script's param `frame` is a {other}, not an int");
            eprintln!("  help: declare it as `param int frame = 1;`");
            Err(ExitCode::from(2))
        }
        None => {
            eprintln!(
                "felt: --frames: {} declares no `param int frame` to set",
                file.display()
            );
            eprintln!(
                "  help: add `param int frame = 1;` at the top and use `frame` where the \
                 script changes over time"
            );
            Err(ExitCode::from(2))
        }
    }
}

/// On Ctrl-C or SIGTERM, a command that runs felt processes stops the running child's whole
/// process group first (the child removes its own temporaries), then exits as an interrupted
/// run does.
fn stop_children_when_interrupted() {
    let _ = ctrlc::set_handler(|| {
        felt::engine::interrupt::stop_children();
        eprintln!("felt: interrupted");
        std::process::exit(130);
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use felt::syntax::diagnostic::Stage;

    fn error(stage: Stage) -> Diagnostic {
        Diagnostic::bare(stage, String::from("failed"))
    }

    #[test]
    fn an_internal_failure_exits_70_whatever_else_failed() {
        assert_eq!(failed_status(&[error(Stage::Runtime)]), 1);
        assert_eq!(
            failed_status(&[error(Stage::Usage), error(Stage::Runtime)]),
            2
        );
        assert_eq!(failed_status(&[error(Stage::Internal)]), 70);
        assert_eq!(
            failed_status(&[error(Stage::Usage), error(Stage::Internal)]),
            70
        );
    }
}
