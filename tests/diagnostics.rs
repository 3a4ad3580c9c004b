//! Diagnostics as the script author sees them. Each broken script under
//! `tests/scripts/errors` must yield exactly one error, at the line and column listed here
//! (worked out by hand from the script text), and its rendered text is snapshot-tested so that
//! changes to wording or layout are reviewed.

mod common;

use felt::session::Session;
use felt::syntax::diagnostic::{self, MAX_RENDERED};
use std::path::Path;

/// (script, line, column of the primary span, a phrase the message must contain)
const CASES: &[(&str, usize, usize, &str)] = &[
    ("missing_semicolon", 1, 14, "`;`"),
    ("unknown_character", 2, 13, "`@`"),
    ("unterminated_string", 1, 12, "unterminated string"),
    ("unknown_variable", 2, 7, "unknown variable `radus`"),
    ("unknown_function", 2, 11, "unknown function `lenght`"),
    ("vector_plus_float", 2, 12, "cannot add vector and float"),
    (
        "field_kind_mismatch",
        3,
        19,
        "cannot add scalarfield and vectorfield",
    ),
    ("wrong_arity", 1, 11, "clamp"),
    ("missing_return", 1, 12, "without returning a float"),
    ("break_outside_loop", 2, 1, "`break` outside a loop"),
    ("assign_undeclared", 2, 1, "undeclared variable `total`"),
    ("index_out_of_range", 2, 8, "index 5 is out of range"),
    ("runaway_recursion", 2, 12, "nested deeper than"),
    ("runtime_call_stack", 2, 12, "integer division by zero"),
    (
        "keyword_to_script_function",
        2,
        13,
        "positional arguments only",
    ),
    (
        "field_comparison",
        2,
        5,
        "fields have a value at every point",
    ),
    ("condition_not_bool", 2, 8, "condition must be a bool"),
    ("duplicate_declaration", 2, 7, "already declared"),
    ("negative_domain", 1, 1, "must be positive"),
    ("singular_matrix", 2, 14, "singular"),
    ("cycle_a", 1, 1, "import cycle"),
    (
        "unknown_keyword",
        3,
        46,
        "`render` has no argument `samples`; did you mean `spp`?",
    ),
    (
        "missing_camera",
        2,
        1,
        "`render` is missing its argument `camera` (camera)",
    ),
    ("unknown_aov", 3, 63, "unknown AOV \"normals\""),
    (
        "unknown_shadows_mode",
        3,
        56,
        "unknown shadows mode \"mrach\"; did you mean \"march\"?",
    ),
    (
        "keyword_and_position",
        1,
        32,
        "argument `lo` of `clamp` is given twice, by position and by keyword",
    ),
    (
        "argument_of_wrong_type",
        1,
        27,
        "argument `hi` of `clamp` must be float, found vector",
    ),
    (
        "cache_as_field",
        3,
        19,
        "argument `density` of `render` must be scalarfield, found scalarcache",
    ),
    (
        "frame_pattern_without_frame",
        3,
        14,
        "its name has a frame pattern but the script declares no",
    ),
    (
        "envmap_missing_file",
        1,
        13,
        "no environment map 'nowhere.exr'",
    ),
    (
        "physicalsky_turbidity",
        2,
        13,
        "turbidity must be between 2 and 10, got 1",
    ),
    ("sun_below_horizon", 1, 13, "below the horizon"),
    (
        "sky_given_a_distant_light",
        3,
        1,
        "sky takes a vector or a sky, found a distant or point light",
    ),
    (
        "deep_with_path_tracer",
        3,
        1,
        "the path tracer does not keep",
    ),
    ("deep_to_png", 3, 1, "'out.png' is not one"),
    (
        "deep_with_aovs",
        3,
        1,
        "aovs is not carried in a deep image",
    ),
    ("deepsamples_without_deep", 3, 1, "this render is flat"),
    (
        "motion_aov_without_velocity",
        3,
        1,
        "this render has no velocity",
    ),
    (
        "deep_with_background",
        3,
        1,
        "a deep image holds the medium alone",
    ),
];

/// The cases `felt check` must find without running anything: each is reported by the
/// checker alone, at the same place as in a run.
const CHECKED: &[&str] = &[
    "unknown_keyword",
    "missing_camera",
    "unknown_aov",
    "unknown_shadows_mode",
    "keyword_and_position",
    "argument_of_wrong_type",
    "wrong_arity",
    "cache_as_field",
    "frame_pattern_without_frame",
];

#[test]
fn each_broken_script_gives_one_diagnostic_at_the_right_place() {
    let mut failures = Vec::new();
    for (name, line, column, phrase) in CASES {
        let path = Path::new("tests/scripts/errors").join(format!("{name}.felt"));
        let outcome = common::run_script(&path, &[]);
        let errors: Vec<_> = outcome
            .diagnostics
            .iter()
            .filter(|d| d.is_error())
            .collect();
        if outcome.ok || errors.len() != 1 {
            failures.push(format!(
                "{name}: expected one error, got {}:\n{}",
                errors.len(),
                outcome.rendered
            ));
            continue;
        }
        let expected = format!(":{line}:{column}]");
        // miette wraps long messages; compare with the whitespace flattened.
        let flat = outcome
            .rendered
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        if !flat.contains(&expected) || !flat.contains(phrase) {
            failures.push(format!(
                "{name}: expected {expected} and `{phrase}` in:\n{}",
                outcome.rendered
            ));
        }
        insta::assert_snapshot!(*name, outcome.rendered);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn call_errors_are_found_by_the_checker_before_any_work() {
    for name in CHECKED {
        let (_, line, column, phrase) = CASES.iter().find(|c| c.0 == *name).unwrap();
        let path = Path::new("tests/scripts/errors").join(format!("{name}.felt"));
        let mut session =
            Session::new(Box::new(common::Captured::default())).unwrap_or_else(|_| panic!());
        let units = session
            .load(&path)
            .unwrap_or_else(|_| panic!("{name} loads"));
        let diagnostics = session.check(&units);
        let rendered = diagnostic::render(&diagnostics, &session.sources.borrow(), false);
        // miette wraps long messages; compare with the whitespace flattened.
        let flat = rendered.split_whitespace().collect::<Vec<_>>().join(" ");
        assert_eq!(diagnostics.len(), 1, "{name}: {rendered}");
        assert!(
            flat.contains(&format!(":{line}:{column}]")) && flat.contains(phrase),
            "{name}: {rendered}"
        );
        // One form at most is shown, never the list of every form.
        assert!(flat.matches("->").count() <= 1, "{name}: {rendered}");
    }
}

/// The checker's diagnostics for `source`, rendered, with the whitespace flattened.
fn checked(source: &str) -> (Vec<felt::syntax::diagnostic::Diagnostic>, String) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("call.felt");
    std::fs::write(&path, source).unwrap();
    let mut session =
        Session::new(Box::new(common::Captured::default())).unwrap_or_else(|_| panic!());
    let units = session.load(&path).unwrap_or_else(|_| panic!("loads"));
    let diagnostics = session.check(&units);
    let rendered = diagnostic::render(&diagnostics, &session.sources.borrow(), false);
    (
        diagnostics,
        rendered.split_whitespace().collect::<Vec<_>>().join(" "),
    )
}

#[test]
fn the_checker_reports_every_bad_argument_of_a_call() {
    let (diagnostics, flat) = checked(
        "scalarcache c(domain((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.5));\n\
         camera cam = camera((0, 0, 3), (0, 0, 0), (0, 1, 0), 40);\n\
         render(\"out.exr\", samples = 16, density = c, camera = cam, width = \"wide\");\n",
    );
    assert_eq!(diagnostics.len(), 3, "{flat}");
    for (column, phrase) in [
        (
            19,
            "`render` has no argument `samples`; did you mean `spp`?",
        ),
        (
            33,
            "argument `density` of `render` must be scalarfield, found scalarcache",
        ),
        (60, "argument `width` of `render` must be int, found string"),
    ] {
        assert!(
            flat.contains(&format!(":3:{column}]")) && flat.contains(phrase),
            "{phrase}: {flat}"
        );
    }
    // A cache where a field is wanted names the read that makes one of it, for every shape.
    assert!(flat.contains("`cacheread(c)`"), "{flat}");
    for (cache, field) in [
        ("vectorcache", "vectorfield"),
        ("matrixcache", "matrixfield"),
    ] {
        let (diagnostics, flat) = checked(&format!(
            "{cache} c(domain((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.5));\n{field} f = c;\n"
        ));
        assert_eq!(diagnostics.len(), 1, "{flat}");
        assert!(
            flat.contains(&format!("read it as a {field} with `cacheread(c)`")),
            "{cache}: {flat}"
        );
    }
}

#[test]
fn runtime_errors_show_the_call_stack() {
    let outcome = common::run_script(
        Path::new("tests/scripts/errors/runtime_call_stack.felt"),
        &[],
    );
    let error = &outcome.diagnostics[0];
    let calls: Vec<_> = error.related.iter().map(|r| r.message.as_str()).collect();
    assert_eq!(
        calls,
        [
            "in `ratio`, called from here",
            "in `relay`, called from here"
        ]
    );
    assert!(
        outcome.rendered.contains("runtime_call_stack.felt:5:12]"),
        "{}",
        outcome.rendered
    );
    assert!(
        outcome.rendered.contains("runtime_call_stack.felt:7:7]"),
        "{}",
        outcome.rendered
    );
}

/// A script with thousands of errors: every one is found, the first hundred are shown and the
/// rest counted in one line, and only those hundred get a did-you-mean (each lookup compares
/// the name with every variable in scope; one per error made checking quadratic, and 16,000
/// unknown names took a minute, most of it spent rendering all of them).
#[test]
fn thousands_of_errors_are_all_found_and_the_first_hundred_shown_with_hints() {
    let n = 20_000;
    let script: String = (0..n)
        .map(|i| format!("float value{i} = 1;\nprint(valeu{i});\n"))
        .collect();
    let outcome = common::run_source("many_errors.felt", &script);
    assert!(!outcome.ok);
    assert_eq!(outcome.diagnostics.len(), n);
    let hinted: Vec<usize> = outcome
        .diagnostics
        .iter()
        .enumerate()
        .filter(|(_, d)| d.help.is_some())
        .map(|(i, _)| i)
        .collect();
    assert_eq!(hinted, (0..MAX_RENDERED).collect::<Vec<_>>());
    assert_eq!(
        outcome.diagnostics[7].help.as_deref(),
        Some("did you mean `value7`?")
    );
    let shown = outcome.rendered.matches("unknown variable").count();
    assert_eq!(shown, MAX_RENDERED);
    assert!(
        outcome
            .rendered
            .ends_with(&format!("… and {} more errors\n", n - MAX_RENDERED)),
        "{}",
        &outcome.rendered[outcome.rendered.len() - 200..]
    );
}

/// Runs of signs longer than a screen, at the prompt: a diagnostic each, with the line cut
/// around the label (miette panicked on labels past column ~65,530).
#[test]
fn long_runs_of_signs_give_diagnostics_at_the_prompt() {
    let out = common::Captured::default();
    let mut session = Session::new(Box::new(out.clone())).unwrap_or_else(|_| panic!("no stdlib"));
    let cases = [
        (
            format!("print({}1);", "-".repeat(100_000)),
            "unexpected `--`, expected an expression",
        ),
        (
            format!("float x = 1; print({}x);", "- ".repeat(100_000)),
            "expression nested too deeply (more than 256 levels)",
        ),
        (
            format!("print({}1{});", "-(".repeat(100_000), ")".repeat(100_000)),
            "expression nested too deeply (more than 256 levels)",
        ),
    ];
    for (input, message) in cases {
        let diagnostics = session
            .eval_input(&input, &mut |_, _| {})
            .expect_err(message);
        let rendered = diagnostic::render(&diagnostics, &session.sources.borrow(), false);
        assert!(rendered.contains(message), "{rendered}");
        assert!(
            rendered.lines().all(|line| line.chars().count() < 400),
            "the long line was not cut: {rendered}"
        );
    }
    // Signs written apart on a number fold into the number.
    session
        .eval_input(
            &format!("print({}1);", "- ".repeat(100_001)),
            &mut |_, _| {},
        )
        .unwrap_or_else(|d| {
            panic!(
                "{}",
                diagnostic::render(&d, &session.sources.borrow(), false)
            )
        });
    assert_eq!(out.text(), "-1\n");
}

/// The same keyword twice is named as such, at the second one, even for a builtin with
/// several forms (it used to be "no form of `render` takes ...").
#[test]
fn a_keyword_argument_given_twice_is_pointed_at() {
    let outcome = common::run_source(
        "twice.felt",
        "scalarfield d = identity().x;\nrender(\"a.exr\", density = d, density = d);\n",
    );
    assert!(!outcome.ok);
    assert_eq!(outcome.diagnostics.len(), 1, "{}", outcome.rendered);
    assert!(
        outcome
            .rendered
            .contains("argument `density` of `render` is given twice"),
        "{}",
        outcome.rendered
    );
    assert!(
        outcome.rendered.contains("twice.felt:2:30]"),
        "{}",
        outcome.rendered
    );
}

/// Editors on Windows may start a file with a byte-order mark; it is not part of the script.
#[test]
fn a_byte_order_mark_at_the_start_of_a_script_is_skipped() {
    let outcome = common::run_source("marked.felt", "\u{feff}print(1 + 1);\nprint(2);\n");
    assert!(outcome.ok, "{}", outcome.rendered);
    assert_eq!(outcome.output, "2\n2\n");
    // Positions are still those of the file as read: columns count bytes, the mark's three
    // included.
    let outcome = common::run_source("marked.felt", "\u{feff}print(nothing);\n");
    assert!(
        outcome.rendered.contains("marked.felt:1:10]"),
        "{}",
        outcome.rendered
    );
}
