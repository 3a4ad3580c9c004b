//! Values that used to go wrong without a word, through scripts: NaN, infinite and negative
//! render inputs, noise and domains whose numbers overflow, far cameras, NaN grids on load,
//! files whose content is not what their name says, and an empty grid name.

mod common;

use std::path::Path;

/// The text after `key` in `text` up to the next space, as a count written `1,234`.
fn count_after(text: &str, key: &str) -> u64 {
    let at = text
        .find(key)
        .unwrap_or_else(|| panic!("no '{key}' in {text}"))
        + key.len();
    text[at..]
        .split(' ')
        .next()
        .unwrap()
        .replace(',', "")
        .parse()
        .unwrap_or_else(|_| panic!("no count after '{key}' in {text}"))
}

/// Every diagnostic's message and help, one line each (the rendered text wraps long lines).
fn all_text(outcome: &common::Outcome) -> String {
    let mut text = String::new();
    for d in &outcome.diagnostics {
        text += &d.message;
        text += "\n";
        if let Some(help) = &d.help {
            text += help;
            text += "\n";
        }
    }
    text
}

fn warnings_of(outcome: &common::Outcome) -> Vec<String> {
    outcome
        .diagnostics
        .iter()
        .filter(|d| !d.is_error())
        .map(|d| d.message.clone())
        .collect()
}

#[test]
fn render_warns_once_per_input_with_counts_and_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    // sqrt is NaN on the left half (x < 0) of the box; the emission is the position, negative
    // in the left, lower and far parts.
    let outcome = common::run_source(
        "render.felt",
        &format!(
            r#"
            scalarfield rho = sqrt(identity() * (1, 0, 0));
            domain box((-1, -1, -1), (2, 2, 2), (0, 0, 0));
            camera cam = camera((0, 0, 4), (0, 0, 0), (0, 1, 0), 40, 1, 2);
            render("{}", density = rho, emission = identity(), camera = cam, bounds = box, width = 24, height = 24, step = 0.05);
            render("{}", density = rho, camera = cam, bounds = box, width = 24, height = 24, step = 0.05);
            "#,
            a.display(),
            b.display()
        ),
    );
    assert!(outcome.ok, "{}", outcome.rendered);
    let warnings = warnings_of(&outcome);
    let density: Vec<&String> = warnings
        .iter()
        .filter(|w| w.starts_with("render: density was NaN or infinite at "))
        .collect();
    assert_eq!(density.len(), 2, "{warnings:?}");
    for w in &density {
        assert!(
            w.contains("samples (treated as 0: empty), the first at ("),
            "{w}"
        );
        // The left half of an orthographic view of the box: half the samples, to a ray.
        let (bad, all) = (count_after(w, "infinite at "), count_after(w, " of "));
        let share = bad as f64 / all as f64;
        assert!((0.45..0.55).contains(&share), "{w}");
    }
    let emission: Vec<&String> = warnings
        .iter()
        .filter(|w| w.starts_with("render: emission was negative at "))
        .collect();
    assert_eq!(emission.len(), 1, "{warnings:?}");
    assert!(
        emission[0].ends_with("samples (clamped to 0)"),
        "{}",
        emission[0]
    );
    assert_eq!(warnings.len(), 3, "{warnings:?}");
    // Each warning points at its own render call.
    assert!(
        outcome.rendered.contains("render.felt:5:"),
        "{}",
        outcome.rendered
    );
    assert!(
        outcome.rendered.contains("render.felt:6:"),
        "{}",
        outcome.rendered
    );
    assert!(all_text(&outcome).contains("guard it with select or max"));
    // The images hold no NaN and no negative value.
    for path in [&a, &b] {
        let image = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |size, _| vec![[0f32; 4]; size.width() * size.height()],
            |pixels, at, (r, g, b, a): (f32, f32, f32, f32)| {
                pixels[at.y() * 24 + at.x()] = [r, g, b, a];
            },
        )
        .unwrap();
        let pixels = image.layer_data.channel_data.pixels;
        assert!(pixels.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
        // The right half is there, the left (NaN density) is empty.
        assert_eq!(pixels[12 * 24 + 2][3], 0.0);
        assert!(pixels[12 * 24 + 21][3] > 0.1);
    }
}

#[test]
fn a_cache_of_a_non_negative_density_renders_without_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let image = |name: &str| dir.path().join(name).display().to_string();
    // Cells at x = -0.875, -0.625, ...: the first two hold 0 and 0.075, so the default read's
    // linear extrapolation in the half cell inside the face at x = -1 goes below zero.
    let outcome = common::run_source(
        "faces.felt",
        &format!(
            r#"
            domain box((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.25);
            scalarcache c(box);
            cachewrite(c, max(identity() * (1, 0, 0) + 0.7, 0));
            scalarcache signed(box);
            cachewrite(signed, identity() * (1, 0, 0));
            camera cam = camera((0, 0, 4), (0, 0, 0), (0, 1, 0), 40);
            render("{}", density = cacheread(c), camera = cam, bounds = box, width = 24, height = 24, step = 0.05);
            render("{}", density = 2 * cacheread(c) + cacheread(c, outside = "hold"), camera = cam, bounds = box, width = 24, height = 24, step = 0.05);
            render("{}", density = cacheread(signed), camera = cam, bounds = box, width = 24, height = 24, step = 0.05);
            "#,
            image("a.exr"),
            image("b.exr"),
            image("c.exr"),
        ),
    );
    assert!(outcome.ok, "{}", outcome.rendered);
    // Only the cache with negative cells warns, and its help names the read that holds.
    let warnings = warnings_of(&outcome);
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].starts_with("render: density was negative at "),
        "{warnings:?}"
    );
    assert!(
        outcome.rendered.contains("faces.felt:10:"),
        "{}",
        outcome.rendered
    );
    assert!(
        all_text(&outcome).contains("outside = \"hold\""),
        "{}",
        outcome.rendered
    );
}

#[test]
fn noise_correlations_that_overflow_are_refused() {
    let outcome = common::run_source(
        "noise.felt",
        r#"
        domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.125);
        scalarfield n = gaussiannoise(d, 1e308);
        print(probe(n, (0.5, 0.5, 0.5)));
        "#,
    );
    assert!(!outcome.ok);
    assert!(
        all_text(&outcome).contains(
            "gaussiannoise correlation must be a length above 0 and at most 1e150, got 1e308"
        ) && outcome.rendered.contains("noise.felt:3:"),
        "{}",
        outcome.rendered
    );
}

#[test]
fn domains_whose_rotation_overflows_are_refused_and_stats_warns_of_nan() {
    let spun = common::run_source(
        "domain.felt",
        r#"
        domain d((0, 0, 0), (1, 1, 1), (1e155, 1e155, 1e155), 0.1);
        print(stats(scalarfield(1.0), d));
        "#,
    );
    assert!(!spun.ok);
    assert!(
        all_text(&spun).contains(
            "domain orientation (1e155, 1e155, 1e155) turns by 1.7320508075688772e155 radians"
        ) && spun.rendered.contains("domain.felt:2:"),
        "{}",
        spun.rendered
    );
    // The field is NaN for x < 0.25: 2 of the 8 columns of 8 x 8 cells.
    let partly = common::run_source(
        "stats.felt",
        r#"
        domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.125);
        print(stats(sqrt(identity() * (1, 0, 0) - 0.25) + 1, d));
        domain none((-1, 0, 0), (1, 1, 1), (0, 0, 0), 0.125);
        print(stats(sqrt(identity() * (1, 0, 0)), none));
        "#,
    );
    assert!(partly.ok, "{}", partly.rendered);
    let lines: Vec<&str> = partly.output.lines().collect();
    let v = common::numbers(lines[0]);
    // min over the finite cells x = 0.3125 .. 0.9375, mean of sqrt(x - 0.25) + 1 over them.
    let xs: Vec<f64> = (2..8).map(|i| (i as f64 + 0.5) * 0.125).collect();
    let mean = xs.iter().map(|x| (x - 0.25).sqrt() + 1.0).sum::<f64>() / 6.0;
    assert!((v[0] - ((0.0625f64).sqrt() + 1.0)).abs() < 1e-12, "{v:?}");
    assert!((v[1] - ((0.6875f64).sqrt() + 1.0)).abs() < 1e-12, "{v:?}");
    assert!((v[2] - mean).abs() < 1e-12, "{v:?} vs {mean}");
    assert_eq!(lines[1], "(NaN, NaN, NaN)");
    assert_eq!(
        warnings_of(&partly),
        vec![
            "stats: the field was NaN or infinite at 128 of 512 cells; min, max and mean are of \
             the other 384 cells"
                .to_string(),
            "stats: the field was NaN or infinite at 512 of 512 cells; no value is finite, so \
             min, max and mean are NaN"
                .to_string(),
        ]
    );
}

#[test]
fn far_cameras_say_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let image = dir.path().join("far.exr");
    let script = |eye: &str| {
        common::run_source(
            "camera.felt",
            &format!(
                r#"
                camera cam = camera({eye}, (0, 0, 0), (0, 1, 0), 40);
                render("{}", density = mask(0.5 - length(identity())), camera = cam,
                       width = 4, height = 4);
                "#,
                image.display()
            ),
        )
    };
    // 1e300 away is not "the same point": the camera is fine, the render cannot resolve steps.
    let far = script("(1e300, 1e300, 1e300)");
    assert!(!far.ok);
    assert!(!far.rendered.contains("same point"), "{}", far.rendered);
    assert!(
        all_text(&far).contains(
            "the camera eye (1e300, 1e300, 1e300) is so far from the render box that positions \
             along its rays are only accurate to"
        ) && far.rendered.contains("camera.felt:3:"),
        "{}",
        far.rendered
    );
    let overflow = common::run_source(
        "camera.felt",
        "camera cam = camera((1e308, 0, 0), (-1e308, 0, 0), (0, 1, 0), 40);\n",
    );
    assert!(
        all_text(&overflow).contains(
            "camera eye (1e308, 0.0, 0.0) is too far from lookat (-1e308, 0.0, 0.0): the \
             distance between them is beyond the range of floating-point numbers"
        ),
        "{}",
        overflow.rendered
    );
    let same = common::run_source(
        "camera.felt",
        "camera cam = camera((1, 2, 3), (1, 2, 3), (0, 1, 0), 40);\n",
    );
    assert!(all_text(&same).contains("camera eye and lookat are the same point"));
    assert!(!image.exists());
    // An ordinary far eye still renders.
    let ok = script("(0, 0, 1e6)");
    assert!(ok.ok, "{}", ok.rendered);
    assert!(image.exists());
}

#[test]
fn nan_grids_warn_on_load_and_empty_grid_names_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let vdb = dir.path().join("h1.vdb");
    let outcome = common::run_source(
        "vdb.felt",
        &format!(
            r#"
            domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.125);
            scalarcache c(d);
            cachewrite(c, sqrt(identity() * (1, 0, 0) - 0.5));
            cachesave(c, "{0}");
            scalarfield back = cacheload("{0}", "density");
            print(probe(back, (0.75, 0.5, 0.5)));
            "#,
            vdb.display()
        ),
    );
    assert!(outcome.ok, "{}", outcome.rendered);
    let warnings = warnings_of(&outcome);
    let load = format!(
        "cacheload: grid 'density' of {} is NaN or infinite at 256 of its 512 voxels",
        vdb.display()
    );
    assert!(warnings.contains(&load), "{warnings:?}");
    assert!(
        outcome.rendered.contains("vdb.felt:6:"),
        "{}",
        outcome.rendered
    );

    let hashed = dir.path().join("h2.vdb#");
    let outcome = common::run_source(
        "vdb.felt",
        &format!(
            r#"
            domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.25);
            scalarcache c(d);
            cachewrite(c, scalarfield(1.0));
            cachesave(c, "{}");
            "#,
            hashed.display()
        ),
    );
    assert!(!outcome.ok);
    assert!(
        all_text(&outcome).contains(&format!(
            "the grid name after '#' in \"{}\" is empty",
            hashed.display()
        )),
        "{}",
        outcome.rendered
    );
    assert!(!hashed.exists() && !dir.path().join("h2.vdb").exists());
}

#[test]
fn a_vdb_file_named_as_a_mesh_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let vdb = dir.path().join("h1.vdb");
    let run = |body: String| common::run_source("shape.felt", &body);
    let saved = run(format!(
        r#"
        domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.25);
        scalarcache c(d);
        cachewrite(c, scalarfield(1.0));
        cachesave(c, "{}");
        "#,
        vdb.display()
    ));
    assert!(saved.ok, "{}", saved.rendered);
    for name in ["h1.obj", "h1.ply"] {
        let renamed = dir.path().join(name);
        std::fs::copy(&vdb, &renamed).unwrap();
        let outcome = run(format!("shape s = loadshape(\"{}\");\n", renamed.display()));
        assert!(!outcome.ok, "{}", outcome.rendered);
        let kind = if name.ends_with("obj") {
            "an OBJ"
        } else {
            "a PLY"
        };
        assert!(
            all_text(&outcome).contains(&format!("this is a VDB file, not {kind} mesh")),
            "{}",
            outcome.rendered
        );
    }
    // And a mesh named as a VDB file says what it is.
    let mesh = dir.path().join("box.vdb");
    std::fs::write(&mesh, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let outcome = run(format!(
        "scalarfield f = cacheload(\"{}\", \"density\");\n",
        mesh.display()
    ));
    assert!(
        all_text(&outcome).contains(
            "not an OpenVDB file: it does not start with the VDB magic number (it is a text file)"
        ),
        "{}",
        outcome.rendered
    );
    assert!(Path::new(&mesh).exists());
}
