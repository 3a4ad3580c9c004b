//! Scripts that are long without being deep: thousands of terms in one sum, thousands of
//! `else if`s, thousands of advection steps. Each must check and run, on an ordinary thread's
//! stack; only real nesting has a limit. (That the work is linear in the length is a matter of
//! speed, measured by benchmarks, not asserted here: a loaded machine would make it flaky.)

mod common;

/// Runs `source` and returns its printed lines, failing on any diagnostic.
fn run_clean(name: &str, source: &str) -> Vec<String> {
    let outcome = common::run_source(name, source);
    assert!(outcome.ok, "{name}: {}", outcome.rendered);
    assert!(
        outcome.diagnostics.is_empty(),
        "{name}: {}",
        outcome.rendered
    );
    common::lines_of(outcome)
}

#[test]
fn ten_thousand_term_chains_check_and_run() {
    let terms = 10_000;
    let sum = format!("int n = 1{};\nprint(n);\n", " + 1".repeat(terms - 1));
    assert_eq!(run_clean("sum.felt", &sum), ["10000"]);
    let mixed = format!(
        "float x = 0{};\nprint(x);\n",
        " + 2 * 3 - 10 / 2".repeat(terms)
    );
    assert_eq!(run_clean("mixed.felt", &mixed), ["10000.0"]);
    let all = format!("bool b = true{};\nprint(b);\n", " && 1 < 2".repeat(terms));
    assert_eq!(run_clean("and.felt", &all), ["true"]);
    // `||` still stops at the first true operand: the division by zero is never evaluated.
    let any = format!(
        "int z = 0;\nbool b = false{} || true || 1 / z == 1;\nprint(b);\n",
        " || 1 > 2".repeat(terms)
    );
    assert_eq!(run_clean("or.felt", &any), ["true"]);
    // A field graph 10,000 additions deep, built and probed.
    let field = format!(
        "scalarfield f = identity().x{};\nprint(probe(f, (0.5, 0, 0)));\n",
        " + identity().x".repeat(terms - 1)
    );
    assert_eq!(run_clean("field.felt", &field), ["5000.0"]);
}

#[test]
fn two_thousand_else_ifs_check_and_run() {
    let branches = 2_000;
    let chain: String = (1..branches)
        .map(|k| format!("  else if (k == {k}) {{ return {}; }}\n", k * 10))
        .collect();
    // In a function (which is cloned when it is defined, and whose every path must return),
    // and at the top level with bare bodies.
    let script = format!(
        "func int classify(int k) {{\n  if (k == 0) {{ return 0; }}\n{chain}  else {{ return -1; }}\n}}\n\
         print(classify(0), classify(1999), classify(5000));\n\
         int k = 1234;\nint found = -1;\nif (k == 0) found = 0;\n{}else found = -2;\nprint(found);\n",
        (1..branches)
            .map(|j| format!("else if (k == {j}) found = {j};\n"))
            .collect::<String>()
    );
    assert_eq!(run_clean("chain.felt", &script), ["0 19990 -1", "1234"]);
}

#[test]
fn real_nesting_states_its_limit() {
    let outcome = common::run_source(
        "deep.felt",
        &format!("float x = {}1{};\n", "(".repeat(300), ")".repeat(300)),
    );
    assert!(!outcome.ok);
    assert!(
        outcome
            .rendered
            .contains("expression nested too deeply (more than 256 levels)"),
        "{}",
        outcome.rendered
    );
    let outcome = common::run_source(
        "deep.felt",
        &format!("int x = 0;\n{}x = 1;\n", "if (x == 0) ".repeat(300)),
    );
    assert!(
        outcome
            .rendered
            .contains("statements nested too deeply (more than 256 levels)"),
        "{}",
        outcome.rendered
    );
}

/// 5,000 fourth-order advection steps of a procedural field build and probe in well under a
/// second (building was quadratic and never reached the `print`).
#[test]
fn five_thousand_advection_steps_build_and_probe() {
    let script = "vectorfield u = vectorfield(-identity().y, identity().x, scalarfield(0));\n\
                  scalarfield f = identity().x;\n\
                  for (int i = 0; i < 5000; i++) { f = advect(f, u, 0.001, 4); }\n\
                  print(probe(f, (0.1, 0.2, 0)));\n";
    let lines = run_clean("advect.felt", script);
    // A rotation by 5 radians about z: the back-traced x of (0.1, 0.2, 0).
    let expected = 0.1 * 5f64.cos() + 0.2 * 5f64.sin();
    let value: f64 = lines[0].parse().unwrap();
    assert!((value - expected).abs() < 1e-9, "{value} vs {expected}");
}
