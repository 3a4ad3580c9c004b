//! Flames splatted as they are made, as a script author meets them: the same caches as
//! `splat` of the stored dots, and errors that name the mistake at the call.

mod common;

use common::{lines_of, numbers, run_source};

const FLAME: &str = r#"
particles guides = particles({(0, 0, 0), (0.5, 0.2, 0.1)});
vectorfield[] maps = {flame("linear", {0.5, 0, 0, 0.5, 0, 0.5, 0, 0.3, 0, 0, 0.5, 0}),
                      flame("swirl", {0.6, 0.3, 0, -0.2, -0.3, 0.6, 0, 0.1, 0, 0, 0.6, 0.1}),
                      flame("spherical")};
float[] weights = {1, 1, 0.5};
vector[] colors = {(1, 0.6, 0.3), (0.3, 0.5, 1), (0.9, 0.9, 1)};
domain d((-1.5, -1.5, -1.5), (3, 3, 3), (0, 0, 0), 3.0 / 40);
"#;

#[test]
fn flamesplat_fills_the_caches_that_splat_of_flamewisp_fills() {
    let script = format!(
        "{FLAME}
scalarcache stored(d);
vectorcache stored_color(d);
scalarcache made(d);
vectorcache made_color(d);
particles p = flamewisp(guides, maps, weights, colors, 20000, 3);
splat(stored, p);
splat(stored_color, p, \"Cd\");
flamesplat(made, guides, maps, weights, colors, 20000, 3, colorcache = made_color);
print(stats(abs(cacheread(stored) - cacheread(made)), d));
print(stats(cacheread(made), d));
print(stats(length(cacheread(stored_color) - cacheread(made_color)), d));
print(stats(length(cacheread(made_color)), d));
"
    );
    let lines = lines_of(run_source("flames.felt", &script));
    // The count is the same float in every cell.
    assert_eq!(numbers(&lines[0]), vec![0.0, 0.0, 0.0]);
    let count = numbers(&lines[1]);
    assert!(count[1] > 10.0 && count[2] > 0.0, "{count:?}");
    // The colours differ at most in the last bits of a float.
    let color_difference = numbers(&lines[2]);
    let color = numbers(&lines[3]);
    assert!(
        color_difference[1] <= 1e-6 * color[1],
        "{color_difference:?} against {color:?}"
    );
}

#[test]
fn flamesplat_mistakes_are_errors_at_the_call() {
    let cases = [
        (
            "scalarcache c(d);\nflamesplat(c, guides, maps, weights, colors, 100, 3, colorcache = c);",
            "vectorcache",
        ),
        (
            "scalarcache c(d);\nflamesplat(c, guides, maps, weights, colors, 100, 3, kernel = \"cubic\");",
            "kernel must be",
        ),
        (
            "scalarcache c(d);\nflamesplat(c, guides, maps, {1, 1}, colors, 100, 3);",
            "give one weight and one color per map",
        ),
        (
            "scalarcache c(d);\nflamesplat(c, guides, maps, weights, colors, -5, 3);",
            "count",
        ),
    ];
    for (call, phrase) in cases {
        let outcome = run_source("broken.felt", &format!("{FLAME}{call}\n"));
        assert!(!outcome.ok, "{call}");
        assert!(
            outcome.rendered.contains(phrase),
            "{call}: {}",
            outcome.rendered
        );
        // The diagnostic points at the flamesplat line (the last line of the script).
        let line = FLAME.lines().count() + 2;
        assert!(
            outcome.rendered.contains(&format!("broken.felt:{line}:")),
            "{call}: {}",
            outcome.rendered
        );
    }
}

/// Loads `name` holding `bytes` through a script, as a user does.
fn load_file(name: &str, bytes: &[u8]) -> common::Outcome {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join(name), bytes).unwrap();
    let script = dir.path().join("load.felt");
    std::fs::write(
        &script,
        format!("particles p = loadparticles(\"{name}\");\nprint(p);\nprint(size(p));\n"),
    )
    .unwrap();
    common::run_script(&script, &[])
}

#[test]
fn a_column_or_property_named_twice_is_refused_by_name_and_place() {
    let csv = load_file("dup.csv", b"x,y,z,x\n1,2,3,4\n");
    assert!(!csv.ok, "{}", csv.rendered);
    assert!(
        csv.diagnostics.iter().any(|d| d
            .message
            .contains("this CSV file has two columns named \"x\" (columns 1 and 4)"))
            && csv.rendered.contains("load.felt:1:"),
        "{}",
        csv.rendered
    );
    let ply = load_file(
        "dup.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
          property float z\nproperty float temperature\nproperty float temperature\n\
          end_header\n1 2 3 4 5\n",
    );
    assert!(!ply.ok, "{}", ply.rendered);
    // The message as written (the rendered one is wrapped to the terminal's width).
    assert!(
        ply.diagnostics.iter().any(|d| d.message.contains(
            "this PLY file has two vertex properties named \"temperature\" (vertex properties 4 and 5)"
        )) && ply.rendered.contains("load.felt:1:"),
        "{}",
        ply.rendered
    );
}

#[test]
fn a_csv_file_may_start_with_a_byte_order_mark() {
    let plain = b"x,y,z,heat\n1,2,3,0.5\n-1.25,0,7,2\n".to_vec();
    let marked = [b"\xef\xbb\xbf".as_slice(), &plain].concat();
    let a = felt::particles::io::read(&plain, "a.csv").unwrap();
    let b = felt::particles::io::read(&marked, "b.csv").unwrap();
    assert_eq!(a.positions, vec![[1.0, 2.0, 3.0], [-1.25, 0.0, 7.0]]);
    assert_eq!(a.floats("heat").unwrap(), &[0.5, 2.0]);
    assert_eq!(a, b);
    // And through a script, as a user loads it.
    let outcome = load_file("marked.csv", &marked);
    assert_eq!(lines_of(outcome)[1], "2");
}

/// Dots outside a cache's domain: `splat` counts every particle it drops, and `flamesplat`,
/// which drops the same dots, reports the same count once more than 1 % of them fall outside.
#[test]
fn flamesplat_counts_the_dots_outside_as_splat_does() {
    let script = format!(
        "{FLAME}
domain small((-0.8, -0.8, -0.8), (1.6, 1.6, 1.6), (0, 0, 0), 0.1);
particles p = flamewisp(guides, maps, weights, colors, 20000, 3);
scalarcache stored(small);
splat(stored, p);
scalarcache made(small);
flamesplat(made, guides, maps, weights, colors, 20000, 3);
"
    );
    let outcome = run_source("outside.felt", &script);
    assert!(outcome.ok, "{}", outcome.rendered);
    let counts: Vec<&str> = outcome
        .diagnostics
        .iter()
        .filter(|d| d.message.contains("were not splatted"))
        .map(|d| d.message.split(' ').next().unwrap_or_default())
        .collect();
    assert_eq!(counts.len(), 2, "{}", outcome.rendered);
    assert_eq!(counts[0], counts[1], "{}", outcome.rendered);
    let outside: u64 = counts[0].parse().unwrap();
    assert!(outside * 100 > 40_000, "{outside}");
}
