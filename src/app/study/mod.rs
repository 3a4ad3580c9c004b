//! `felt study`: what accuracy costs in time, measured on any script.
//!
//! A study runs a script once per setting of its swept params, each run its own `felt run`
//! process (`measure`), and compares every file the run wrote and every number it printed with
//! the same outputs of the setting's reference (`compare`). It reports seconds, CPU seconds,
//! peak memory and each error as a table, `study.csv` and plots (`report`, `plot`).
//!
//! The one key decision: a reference run is cached in the study's folder, keyed by the text of
//! every file the script loads, felt's version and the reference's params. The reference is
//! usually the expensive run (the finest step, the highest resolution), and a study is often
//! run again with more settings; the cached one is reused, never rerun.
//!
//! Each setting runs `--repeat` times (3 unless told) and its times are the medians; CPU time
//! (the child's user plus system time from `wait4`) is reported beside wall time, since it is
//! what other jobs on the machine disturb least.
//!
//! Exit codes: 0 when every setting ran and was compared; 1 when the script has errors or some
//! setting's run failed (the study still finishes the others); 2 for bad usage — unknown
//! params, values of the wrong type, empty sweeps, a reference that is itself bad usage, or
//! settings some of whose outputs cannot be compared with their reference's (the rest of
//! their outputs are still compared and reported).

mod axes;
mod compare;
mod grids;
mod labels;
mod measure;
mod plan;
mod plot;
mod report;
mod svg;

pub use compare::{Kind, Measure};
pub use plan::{Assignments, Plan, Setting};

use crate::session::Session;
use crate::syntax::diagnostic::{self, Stage};
use measure::{Measured, Runner};
use std::path::{Path, PathBuf};

/// What `felt study` was asked to do.
pub struct StudyArgs {
    pub script: PathBuf,
    pub sweeps: Vec<(String, String)>,
    pub reference: Vec<(String, String)>,
    pub set: Vec<(String, String)>,
    pub repeat: u32,
    /// The swept param the Pareto fronts trade (see `Plan::trade`).
    pub trade: Option<String>,
    pub out: Option<PathBuf>,
    pub threads: Option<u16>,
    pub memory_limit: Option<u64>,
}

/// How one setting came out.
pub enum Outcome {
    /// Compared in every output that could be; `problems` names those that could not.
    Compared {
        timing: Timing,
        measures: Vec<Measure>,
        problems: Vec<String>,
    },
    /// The run failed; the reason is its first error line.
    Failed(String),
    /// The run succeeded but none of its outputs can be compared with the reference's.
    Incomparable(String),
}

/// The cost of one setting: medians over its runs, and the largest peak.
#[derive(Clone, Copy, Debug)]
pub struct Timing {
    pub seconds: f64,
    pub cpu_seconds: f64,
    pub peak_bytes: u64,
    /// How many runs the medians are of.
    pub runs: u32,
}

/// One row of the study.
pub struct Row {
    pub setting: Setting,
    pub outcome: Outcome,
}

/// Runs a study; returns the process's exit code.
pub fn run(args: &StudyArgs) -> u8 {
    match study(args) {
        Ok(code) => code,
        Err(Stop { message, code }) => {
            if !message.is_empty() {
                eprintln!("felt study: {message}");
            }
            code
        }
    }
}

/// Why a study stopped early: the message (already shown when empty) and the exit code.
struct Stop {
    message: String,
    code: u8,
}

fn usage(message: String) -> Stop {
    Stop { message, code: 2 }
}

fn study(args: &StudyArgs) -> Result<u8, Stop> {
    let (params, fingerprint) = load_script(&args.script)?;
    let plan = plan::plan(
        &params,
        &args.sweeps,
        &args.reference,
        &args.set,
        args.trade.as_deref(),
    )
    .map_err(usage)?;
    let folder = args.out.clone().unwrap_or_else(|| {
        let stem = args
            .script
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| String::from("script"));
        PathBuf::from(format!("{stem}-study"))
    });
    std::fs::create_dir_all(&folder)
        .map_err(|e| usage(format!("cannot create '{}': {e}", folder.display())))?;
    let felt = std::env::current_exe()
        .map_err(|e| usage(format!("cannot find the felt program to run: {e}")))?;
    let runner = Runner {
        felt,
        script: std::fs::canonicalize(&args.script).unwrap_or_else(|_| args.script.clone()),
        threads: args.threads,
        memory_limit: args.memory_limit,
    };
    let repeat = args.repeat.max(1);

    // The distinct references first: a setting cannot be compared without its own.
    let mut references: Vec<(Assignments, Reference)> = Vec::new();
    let distinct: Vec<Assignments> = {
        let mut all: Vec<Assignments> = Vec::new();
        for setting in &plan.settings {
            let r = plan.reference_assignments(setting);
            if !all.contains(&r) {
                all.push(r);
            }
        }
        all
    };
    let cached: Vec<bool> = distinct
        .iter()
        .map(|r| {
            reference_folder(&folder, &fingerprint, r)
                .join(MEASURED)
                .is_file()
        })
        .collect();
    let runs = cached.iter().filter(|c| !**c).count() as u64 * repeat as u64
        + plan
            .settings
            .iter()
            .filter(|s| plan.assignments(s) != plan.reference_assignments(s))
            .count() as u64
            * repeat as u64;
    let bar = progress(runs);
    for assignments in distinct {
        let place = reference_folder(&folder, &fingerprint, &assignments);
        let shown = plan::describe(&plan.without_fixed(&assignments));
        bar.set_message(format!("reference {shown}"));
        let reference = match Reference::load(&place) {
            Some(r) => {
                say(
                    &bar,
                    format!("  reference {shown}: cached in {}", place.display()),
                );
                r
            }
            None => {
                let r = Reference::run(&runner, &assignments, &place, repeat, &bar)
                    .map_err(|e| usage(format!("cannot run felt: {e}")))?;
                if !r.measured.succeeded() {
                    bar.finish_and_clear();
                    eprintln!("{}", r.measured.stderr.trim_end());
                    let code = if r.measured.exit == Some(2) { 2 } else { 1 };
                    return Err(Stop {
                        message: format!(
                            "the reference setting ({shown}) failed ({}); the study needs it",
                            r.measured.failure()
                        ),
                        code,
                    });
                }
                r
            }
        };
        references.push((assignments, reference));
    }

    let mut rows = Vec::new();
    for (index, setting) in plan.settings.iter().enumerate() {
        let shown = plan.describe(setting);
        bar.set_message(shown.clone());
        let wanted = plan.reference_assignments(setting);
        let reference = &references
            .iter()
            .find(|(a, _)| *a == wanted)
            .expect("every setting's reference was run above")
            .1;
        let assignments = plan.assignments(setting);
        let (measured, outputs) = if assignments == wanted {
            (reference.measured.clone(), reference.outputs())
        } else {
            let place = folder.join("runs").join(format!("{:03}", index + 1));
            let outputs = place.join("outputs");
            let measured = repeated(&runner, &assignments, &outputs, repeat, &bar)
                .map_err(|e| usage(format!("cannot run felt: {e}")))?;
            let _ = std::fs::write(place.join("stdout.txt"), &measured.stdout);
            let _ = std::fs::write(place.join("stderr.txt"), &measured.stderr);
            let _ = std::fs::write(place.join("settings.txt"), settings_text(&assignments));
            (measured, outputs)
        };
        let outcome = if !measured.succeeded() {
            Outcome::Failed(measured.failure())
        } else {
            let found = compare::compare(
                &outputs,
                &measured.stdout,
                &reference.outputs(),
                &reference.measured.stdout,
            );
            if found.measures.is_empty() && !found.problems.is_empty() {
                Outcome::Incomparable(found.problems.join("; "))
            } else {
                Outcome::Compared {
                    timing: Timing {
                        seconds: measured.seconds,
                        cpu_seconds: measured.cpu_seconds,
                        peak_bytes: measured.peak_bytes,
                        runs: measured.runs,
                    },
                    measures: found.measures,
                    problems: found.problems,
                }
            }
        };
        match &outcome {
            Outcome::Failed(why) => say(&bar, format!("  ✗ {shown}: the run failed ({why})")),
            Outcome::Incomparable(why) => say(&bar, format!("  ✗ {shown}: {why}")),
            Outcome::Compared {
                timing, problems, ..
            } => {
                say(&bar, format!("  ✓ {shown}: {:.3} s", timing.seconds));
                for why in problems {
                    say(&bar, format!("    ✗ not compared: {why}"));
                }
            }
        }
        rows.push(Row {
            setting: setting.clone(),
            outcome,
        });
    }
    bar.finish_and_clear();

    print!("{}", report::table(&plan, &rows));
    for (assignments, reference) in &references {
        let m = &reference.measured;
        println!(
            "reference {}: {:.3} s, {:.3} CPU s (medians of {} runs), {:.1} MiB",
            plan::describe(&plan.without_fixed(assignments)),
            m.seconds,
            m.cpu_seconds,
            m.runs,
            m.peak_bytes as f64 / (1 << 20) as f64
        );
    }
    let csv = folder.join("study.csv");
    std::fs::write(&csv, report::csv(&plan, &rows))
        .map_err(|e| usage(format!("cannot write '{}': {e}", csv.display())))?;
    let plots = plot::all(&folder, &plan, &rows)
        .map_err(|e| usage(format!("cannot draw the plots: {e}")))?;
    println!("wrote {}", csv.display());
    for path in plots {
        println!("wrote {}", path.display());
    }

    let incomparable = rows.iter().any(|r| match &r.outcome {
        Outcome::Incomparable(_) => true,
        Outcome::Compared { problems, .. } => !problems.is_empty(),
        Outcome::Failed(_) => false,
    });
    let failed = rows.iter().any(|r| matches!(r.outcome, Outcome::Failed(_)));
    Ok(if incomparable {
        2
    } else if failed {
        1
    } else {
        0
    })
}

/// Loads and checks the script: its params, and a fingerprint of every file it loads.
fn load_script(script: &Path) -> Result<(Vec<(String, crate::check::types::Type)>, u64), Stop> {
    let mut session = Session::new(Box::new(std::io::sink())).map_err(|failure| {
        eprint!(
            "{}",
            diagnostic::render(&failure.diagnostics, &failure.sources, false)
        );
        Stop {
            message: String::new(),
            code: 1,
        }
    })?;
    let color = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let loaded = session.load(script);
    let diags = match &loaded {
        Ok(units) => session.check(units),
        Err(diags) => diags.clone(),
    };
    if diags.iter().any(|d| d.is_error()) {
        eprint!(
            "{}",
            diagnostic::render(&diags, &session.sources.borrow(), color)
        );
        let usage = diags
            .iter()
            .any(|d| d.stage == Stage::Usage && d.is_error());
        return Err(Stop {
            message: String::new(),
            code: if usage { 2 } else { 1 },
        });
    }
    let units = loaded.unwrap_or_default();
    let mut fingerprint = Fingerprint::new();
    fingerprint.add(env!("CARGO_PKG_VERSION").as_bytes());
    {
        let sources = session.sources.borrow();
        for unit in &units {
            fingerprint.add(sources.get(unit.file).text.as_bytes());
        }
    }
    Ok((Session::params(&units), fingerprint.value()))
}

/// FNV-1a over length-prefixed parts: a stable key for the cached references (the standard
/// library's hasher may change between Rust releases, which would orphan every cache).
struct Fingerprint(u64);

impl Fingerprint {
    fn new() -> Fingerprint {
        Fingerprint(0xcbf2_9ce4_8422_2325)
    }

    fn add(&mut self, bytes: &[u8]) {
        for b in (bytes.len() as u64).to_le_bytes().iter().chain(bytes) {
            self.0 ^= *b as u64;
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }

    fn value(&self) -> u64 {
        self.0
    }
}

/// The file whose presence marks a complete cached reference.
const MEASURED: &str = "measured.txt";

fn reference_folder(folder: &Path, fingerprint: &u64, assignments: &Assignments) -> PathBuf {
    let mut key = Fingerprint(*fingerprint);
    let mut sorted = assignments.clone();
    sorted.sort();
    for (name, value) in &sorted {
        key.add(name.as_bytes());
        key.add(value.trim().as_bytes());
    }
    folder
        .join("reference")
        .join(format!("{:016x}", key.value()))
}

fn settings_text(assignments: &Assignments) -> String {
    assignments
        .iter()
        .map(|(n, v)| format!("{n}={v}\n"))
        .collect()
}

/// A reference run and where its outputs are.
struct Reference {
    place: PathBuf,
    measured: Measured,
}

impl Reference {
    fn outputs(&self) -> PathBuf {
        self.place.join("outputs")
    }

    /// A complete cached reference in `place`, if there is one.
    fn load(place: &Path) -> Option<Reference> {
        let text = std::fs::read_to_string(place.join(MEASURED)).ok()?;
        let field = |name: &str| {
            text.lines()
                .find_map(|l| l.strip_prefix(name)?.strip_prefix('='))
                .map(str::trim)
        };
        Some(Reference {
            place: place.to_path_buf(),
            measured: Measured {
                seconds: field("seconds")?.parse().ok()?,
                cpu_seconds: field("cpu_seconds")?.parse().ok()?,
                peak_bytes: field("peak_bytes")?.parse().ok()?,
                // References cached before the count was recorded were run once.
                runs: field("runs").and_then(|r| r.parse().ok()).unwrap_or(1),
                exit: Some(0),
                stdout: std::fs::read_to_string(place.join("stdout.txt")).ok()?,
                stderr: String::new(),
            },
        })
    }

    /// Runs the reference into `place`; a successful run is recorded for next time.
    fn run(
        runner: &Runner,
        assignments: &Assignments,
        place: &Path,
        repeat: u32,
        bar: &indicatif::ProgressBar,
    ) -> std::io::Result<Reference> {
        // A partial folder from an interrupted study is replaced whole.
        if place.exists() {
            std::fs::remove_dir_all(place)?;
        }
        std::fs::create_dir_all(place)?;
        let measured = repeated(runner, assignments, &place.join("outputs"), repeat, bar)?;
        std::fs::write(place.join("settings.txt"), settings_text(assignments))?;
        if measured.succeeded() {
            std::fs::write(place.join("stdout.txt"), &measured.stdout)?;
            std::fs::write(
                place.join(MEASURED),
                format!(
                    "seconds={}\ncpu_seconds={}\npeak_bytes={}\nruns={}\n",
                    measured.seconds, measured.cpu_seconds, measured.peak_bytes, measured.runs
                ),
            )?;
        }
        Ok(Reference {
            place: place.to_path_buf(),
            measured,
        })
    }
}

/// Runs a setting `repeat` times into `outputs` (emptied first): the median times, the largest
/// peak, and the last run's output; the first failure stops the repeats.
fn repeated(
    runner: &Runner,
    assignments: &Assignments,
    outputs: &Path,
    repeat: u32,
    bar: &indicatif::ProgressBar,
) -> std::io::Result<Measured> {
    if outputs.exists() {
        std::fs::remove_dir_all(outputs)?;
    }
    let mut all: Vec<Measured> = Vec::new();
    for _ in 0..repeat {
        let m = runner.run(assignments, outputs)?;
        bar.inc(1);
        let ok = m.succeeded();
        all.push(m);
        if !ok {
            break;
        }
    }
    let seconds: Vec<f64> = all.iter().map(|m| m.seconds).collect();
    let cpu: Vec<f64> = all.iter().map(|m| m.cpu_seconds).collect();
    let peak = all.iter().map(|m| m.peak_bytes).max().unwrap_or(0);
    let mut last = all.pop().expect("repeat is at least 1");
    last.seconds = measure::median(&seconds);
    last.cpu_seconds = measure::median(&cpu);
    last.peak_bytes = peak;
    last.runs = seconds.len() as u32;
    Ok(last)
}

fn progress(runs: u64) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(runs);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} runs  {msg}",
    ) {
        bar.set_style(style);
    }
    bar
}

/// A line above the progress bar, or on standard error when there is no bar to draw.
fn say(bar: &indicatif::ProgressBar, line: String) {
    if bar.is_hidden() {
        eprintln!("{line}");
    } else {
        bar.println(line);
    }
}
