//! The language's semantics, end to end: each script under `tests/scripts/lang` runs and its
//! output must equal the `.out` file beside it, which was written by hand from the rules in
//! the language reference (not by running felt).

mod common;

use std::path::Path;

fn check(name: &str) {
    let script = Path::new("tests/scripts/lang").join(format!("{name}.felt"));
    let expected = std::fs::read_to_string(script.with_extension("out")).expect("expected output");
    let outcome = common::run_script(&script, &[]);
    assert!(outcome.ok, "{name} failed:\n{}", outcome.rendered);
    assert_eq!(outcome.output, expected, "output of {name}");
}

#[test]
fn values() {
    check("values");
}

#[test]
fn operators() {
    check("operators");
}

#[test]
fn control_flow() {
    check("control");
}

#[test]
fn functions() {
    check("functions");
}

#[test]
fn strings() {
    check("strings");
}

#[test]
fn imports() {
    check("imports");
}

#[test]
fn params_default() {
    check("params");
}

#[test]
fn params_overridden() {
    let script = Path::new("tests/scripts/lang/params.felt");
    let outcome = common::run_script(
        script,
        &[("step", "0.005"), ("frames", "10"), ("offset", "(1, 2, 3)")],
    );
    assert!(outcome.ok, "{}", outcome.rendered);
    assert_eq!(outcome.output, "0.005 10 shot (1.0, 2.0, 3.0)\n");
}

#[test]
fn unknown_override_is_a_usage_error() {
    let script = Path::new("tests/scripts/lang/params.felt");
    let outcome = common::run_script(script, &[("stpe", "1")]);
    assert!(!outcome.ok);
    assert!(
        outcome.rendered.contains("no param named `stpe`"),
        "{}",
        outcome.rendered
    );
    assert!(
        outcome.rendered.contains("did you mean `step`?"),
        "{}",
        outcome.rendered
    );
    let bad = common::run_script(script, &[("frames", "many")]);
    assert!(bad.rendered.contains("expected an int"), "{}", bad.rendered);
}

#[test]
fn every_error_of_a_file_is_reported() {
    let outcome = common::run_script(Path::new("tests/scripts/errors/several_errors.felt"), &[]);
    let errors: Vec<_> = outcome
        .diagnostics
        .iter()
        .filter(|d| d.is_error())
        .collect();
    assert_eq!(errors.len(), 3, "{}", outcome.rendered);
    assert_eq!(outcome.output, "", "nothing runs when the check fails");
}

#[test]
fn recursion_is_limited_with_a_clear_error() {
    let outcome = common::run_script(
        Path::new("tests/scripts/errors/runaway_recursion.felt"),
        &[],
    );
    assert!(!outcome.ok);
    assert!(
        outcome.rendered.contains("nested deeper than"),
        "{}",
        outcome.rendered
    );
}

#[test]
fn standard_library_is_shadowed_with_a_warning() {
    let outcome = common::run_source(
        "shadow.felt",
        "func float size2(float x) { return x; }\nprint(size2(2));\n",
    );
    assert!(outcome.ok, "{}", outcome.rendered);
    assert_eq!(outcome.output, "2.0\n");
}
