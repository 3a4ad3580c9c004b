//! Helpers shared by the integration tests: run a script through the library with its output
//! captured, and render diagnostics as plain text.

#![allow(dead_code)]

use felt::session::Session;
use felt::syntax::diagnostic::{self, Diagnostic};
use std::cell::RefCell;
use std::io::Write;
use std::path::Path;
use std::rc::Rc;

/// A `Write` that keeps what it was given, shared with the test.
#[derive(Clone, Default)]
pub struct Captured(pub Rc<RefCell<Vec<u8>>>);

impl Write for Captured {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.borrow_mut().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Captured {
    pub fn text(&self) -> String {
        String::from_utf8_lossy(&self.0.borrow()).into_owned()
    }
}

/// What running a script produced.
pub struct Outcome {
    pub output: String,
    pub diagnostics: Vec<Diagnostic>,
    pub rendered: String,
    pub ok: bool,
    /// The run's `--profile` rows: the grids this run (and no other) made.
    pub profile: Vec<felt::engine::profile::ProfileEntry>,
}

pub fn run_script(path: &Path, overrides: &[(&str, &str)]) -> Outcome {
    run_script_on(felt::engine::Engine::new(), path, overrides)
}

/// `run_script` on a given engine (its memory budget, its interrupt flag).
pub fn run_script_on(
    engine: std::sync::Arc<felt::engine::Engine>,
    path: &Path,
    overrides: &[(&str, &str)],
) -> Outcome {
    let out = Captured::default();
    let mut session = Session::with_engine(Box::new(out.clone()), engine).unwrap_or_else(|f| {
        panic!(
            "{}",
            felt::syntax::diagnostic::render(&f.diagnostics, &f.sources, false)
        )
    });
    session.interp.overrides = overrides
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let (ok, mut diagnostics) = match session.run_file(path) {
        Ok(w) => (true, w),
        Err(d) => (false, d),
    };
    diagnostics.extend(session.finish());
    let rendered = diagnostic::render(&diagnostics, &session.sources.borrow(), false);
    Outcome {
        output: out.text(),
        diagnostics,
        rendered,
        ok,
        profile: session.engine().profile.report(),
    }
}

/// Runs source text given inline (written to a temporary file so imports and names work).
pub fn run_source(name: &str, source: &str) -> Outcome {
    let dir = tempfile::tempdir().expect("temporary directory");
    let path = dir.path().join(name);
    std::fs::write(&path, source).expect("write script");
    run_script(&path, &[])
}

/// Runs a script and returns its printed lines, failing the test on any error.
pub fn lines_of(outcome: Outcome) -> Vec<String> {
    assert!(outcome.ok, "{}", outcome.rendered);
    outcome.output.lines().map(str::to_string).collect()
}

/// The numbers in a printed line, in order.
pub fn numbers(line: &str) -> Vec<f64> {
    line.split(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c)))
        .filter(|t| !t.is_empty() && t.chars().any(|c| c.is_ascii_digit()))
        .map(|t| t.parse().unwrap_or_else(|_| panic!("not a number: {t}")))
        .collect()
}

/// Runs the `felt` binary with `args` in `dir`, failing the test with felt's stderr unless it
/// succeeds; the output, for what it printed.
pub fn felt_succeeds(dir: &Path, args: &[&str]) -> std::process::Output {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_felt"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "felt {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}
