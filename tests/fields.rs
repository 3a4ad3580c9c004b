//! Fields and caches through scripts: the chapter's first example against closed forms, cache
//! reproduction of linear fields, laziness seen through the profile, non-finite reports, and
//! bit-identical results for any thread count.

mod common;

use std::path::Path;

use common::numbers;

#[test]
fn the_first_field_example_agrees_with_closed_forms() {
    let outcome = common::run_script(Path::new("examples/distance_field.felt"), &[]);
    assert!(outcome.ok, "{}", outcome.rendered);
    let lines: Vec<&str> = outcome.output.lines().collect();
    // |x| over the 20³ cell centres of [-1, 1]³, summed directly.
    let centre = |i: usize| -1.0 + 0.1 * (i as f64 + 0.5);
    let (mut min, mut max, mut sum) = (f64::INFINITY, 0.0f64, 0.0);
    for i in 0..20 {
        for j in 0..20 {
            for k in 0..20 {
                let r = (centre(i).powi(2) + centre(j).powi(2) + centre(k).powi(2)).sqrt();
                min = min.min(r);
                max = max.max(r);
                sum += r;
            }
        }
    }
    let exact = numbers(lines[0].split(':').nth(1).unwrap());
    assert!((exact[0] - min).abs() < 1e-15 && (exact[1] - max).abs() < 1e-15);
    assert!(
        (exact[2] - sum / 8000.0).abs() < 1e-12,
        "{} vs {}",
        exact[2],
        sum / 8000.0
    );
    // The cached distance read at the cell centres gives the samples back (f32 storage).
    let cached = numbers(lines[1].split(':').nth(1).unwrap());
    for (c, e) in cached.iter().zip(&exact) {
        assert!((c - e).abs() < 1e-6, "{cached:?} vs {exact:?}");
    }
    // |grad r| = 1 everywhere; grad r = x / |x| exactly.
    assert!(
        numbers(lines[2].split(':').nth(1).unwrap())
            .iter()
            .all(|v| (v - 1.0).abs() < 1e-15)
    );
    assert_eq!(
        numbers(lines[3].split(':').nth(1).unwrap()),
        [0.6, 0.8, 0.0]
    );
    // Both sampled normals are close to the exact one but not equal to it.
    for line in &lines[4..6] {
        let n = numbers(line.split(':').nth(1).unwrap());
        assert!(
            (n[0] - 0.6).abs() < 0.01 && (n[1] - 0.8).abs() < 0.01 && n[0] != 0.6,
            "{line}"
        );
    }
}

#[test]
fn caches_reproduce_linear_fields_in_both_interpolations() {
    let outcome = common::run_source(
        "linear.felt",
        r#"
        scalarfield f = 2 * identity() * (1, -3, 0.5) + 0.25;
        // A rotated domain: its centre is (0, 0, 0) + R (1, 1, 1), read well inside it.
        vector turn = (0.3, 0.2, -0.1);
        domain d((0, 0, 0), (2, 2, 2), turn, 0.125);
        scalarcache c(d);
        cachewrite(c, f);
        vector centre = probe(rotate(identity(), turn, -length(turn)), (1, 1, 1));
        domain inner(centre - (0.4, 0.4, 0.4), (0.8, 0.8, 0.8), (0, 0, 0), 0.0371);
        print(stats(abs(cacheread(c) - f), inner));
        print(stats(abs(cacheread(c, "cubic") - f), inner));
        print(stats(length(grad(cacheread(c)) - grad(f)), inner));
        // Central differences of the interpolated field are exact for a linear field too.
        print(stats(length(grad(cacheread(c, "linear", "central")) - grad(f)), inner));
        "#,
    );
    assert!(outcome.ok, "{}", outcome.rendered);
    for line in outcome.output.lines() {
        // Exact up to the f32 storage of the samples (values up to about 8).
        assert!(numbers(line)[1] < 4e-6, "{line}");
    }
}

#[test]
fn a_probe_fills_only_the_bricks_it_needs() {
    let outcome = common::run_source(
        "lazy.felt",
        r#"
        domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 2.0 / 64);
        scalarcache used(d);
        cachewrite(used, length(identity()) + perlin(4.0));
        scalarcache unused(d);
        cachewrite(unused, identity() * identity());
        print(probe(cacheread(used), (0.1, 0.2, 0.3)));
        "#,
    );
    assert!(outcome.ok, "{}", outcome.rendered);
    let rows: Vec<_> = outcome
        .profile
        .into_iter()
        .filter(|e| e.label.contains("lazy.felt"))
        .collect();
    assert_eq!(rows.len(), 2, "{rows:?}");
    let used = rows.iter().find(|e| e.label.contains(":4:")).unwrap();
    let unused = rows.iter().find(|e| e.label.contains(":6:")).unwrap();
    // 64³ cells are 512 bricks; a linear read at one point touches at most 8.
    assert_eq!(used.bricks_total, 512);
    assert!((1..=8).contains(&used.bricks_filled), "{used:?}");
    assert_eq!(
        unused.bricks_filled + unused.bricks_skipped,
        0,
        "{unused:?}"
    );
}

#[test]
fn non_finite_values_written_to_a_cache_are_reported() {
    let outcome = common::run_source(
        "nan.felt",
        r#"
        domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.5);
        scalarcache c(d);
        cachewrite(c, 1 / (identity() * (1, 0, 0) - 0.25));
        cachefill(c);
        print(probe(1 / (identity() * (1, 0, 0) - 0.25), (0.25, 0, 0)));
        "#,
    );
    assert!(outcome.ok, "{}", outcome.rendered);
    // IEEE at the pole, and a warning naming the cache with the first bad cell.
    assert_eq!(outcome.output, "inf\n");
    assert!(
        outcome.rendered.contains("non-finite value") && outcome.rendered.contains("nan.felt:5:"),
        "{}",
        outcome.rendered
    );
}

#[test]
fn results_are_bit_identical_for_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("threads.felt");
    std::fs::write(
        &script,
        r#"
        scalarfield f = fbm(perlin(), 4, scalarfield(3.0), scalarfield(2.0), scalarfield(0.5)) + length(identity());
        domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 2.0 / 40);
        scalarcache c(d);
        cachewrite(c, f);
        print(stats(f, d), stats(cacheread(c, "cubic"), d));
        cachesave(c, "out.vdb");
        "#,
    )
    .unwrap();
    let run = |threads: &str| {
        let out = common::felt_succeeds(dir.path(), &["run", "threads.felt", "--threads", threads]);
        let vdb = std::fs::read(dir.path().join("out.vdb")).unwrap();
        (out.stdout, vdb)
    };
    let (one, two) = (run("1"), run("2"));
    assert_eq!(
        String::from_utf8_lossy(&one.0),
        String::from_utf8_lossy(&two.0)
    );
    assert!(one.1 == two.1, "cache files differ between 1 and 2 threads");
}
