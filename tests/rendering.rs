//! The rendering builtins through scripts: light transmissivity against Beer–Lambert, the
//! per-channel `kappa` form, and script-author errors for bad render options.

mod common;

#[test]
fn transmissivity_of_a_slab_follows_beer_lambert() {
    // Density 1 in the slab 0 <= y <= 1, light travelling down (-y): at height y inside the
    // slab the light has crossed 1 - y units, so T = exp(-kappa (1 - y)).
    let outcome = common::run_source(
        "slab.felt",
        r#"
        scalarfield rho = mask(identity() * (0, 1, 0)) * mask(1 - identity() * (0, 1, 0));
        domain d((-0.5, -0.25, -0.5), (1, 1.5, 1), (0, 0, 0), 1.0 / 64);
        scalarfield t = transmissivity(rho, distantlight((0, -1, 0)), d, 2.0);
        print(probe(t, (0, 0.5 - 1.0 / 128, 0)), probe(t, (0, 0.25 - 1.0 / 128, 0)));
        "#,
    );
    assert!(outcome.ok, "{}", outcome.rendered);
    let v: Vec<f64> = outcome
        .output
        .split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect();
    for (value, y) in v.iter().zip([0.5 - 1.0 / 128.0, 0.25 - 1.0 / 128.0]) {
        let expected = (-2.0f64 * (1.0 - y)).exp();
        // Step error of the light march: a cell's worth of density at most.
        assert!(
            (value - expected).abs() < 2.0 * expected / 64.0,
            "{value} vs {expected}"
        );
    }
}

#[test]
fn render_options_are_checked_in_the_script_authors_terms() {
    let dir = tempfile::tempdir().unwrap();
    let script = |body: &str| {
        common::run_source(
            "render.felt",
            &format!(
                r#"
                scalarfield rho = mask(0.5 - length(identity()));
                camera cam = camera((0, 0, 3), (0, 0, 0), (0, 1, 0), 40);
                {body}
                "#
            ),
        )
    };
    let out = dir.path().join("ok.exr");
    let ok = script(&format!(
        r#"render("{}", density = rho, camera = cam, kappa = (1, 2, 3), width = 8, height = 6,
                  lights = {{distantlight((0, -1, 0))}}, aovs = {{"depth"}});"#,
        out.display()
    ));
    assert!(ok.ok, "{}", ok.rendered);
    assert!(out.exists());
    let no_camera = script(r#"render("x.exr", density = rho, width = 8, height = 6);"#);
    assert!(
        !no_camera.ok
            && no_camera
                .rendered
                .contains("`render` is missing its argument `camera` (camera)"),
        "{}",
        no_camera.rendered
    );
    // A mode known only at run time is checked there, in the same words as a literal.
    let computed = script(
        r#"string mode = "mar" + "hc";
           render("x.exr", density = rho, camera = cam, shadows = mode);"#,
    );
    assert!(
        !computed.ok
            && computed
                .rendered
                .contains("unknown shadows mode \"marhc\"; did you mean \"march\"?"),
        "{}",
        computed.rendered
    );
    let bad_aov = script(r#"render("x.exr", density = rho, camera = cam, aovs = {"normals"});"#);
    assert!(
        bad_aov.rendered.contains("unknown AOV \"normals\""),
        "{}",
        bad_aov.rendered
    );
    let bad_size = script(r#"render("x.exr", density = rho, camera = cam, width = 0);"#);
    assert!(
        bad_size
            .rendered
            .contains("width must be a positive whole number"),
        "{}",
        bad_size.rendered
    );
}
