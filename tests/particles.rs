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
