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

/// The `worldToNDC` matrix of an EXR file's header (the `exr` crate reads this standard
/// attribute into its own field), as Imath's row-major matrix.
fn world_to_ndc(path: &std::path::Path) -> [f64; 16] {
    use exr::prelude::traits::*;
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .unwrap();
    image.layer_data[0]
        .attributes
        .world_to_normalized_device
        .unwrap_or_else(|| panic!("no worldToNDC in {}", path.display()))
        .map(f64::from)
}

#[test]
fn a_small_blob_lands_where_the_headers_world_to_ndc_projects_its_centre() {
    // A Gaussian blob of density, small beside its distance (sigma / depth = 0.01, so the
    // perspective shifts its image's centroid from its centre's projection by under 0.01 px),
    // well off the image centre, rendered with one ray per pixel centre. Thin (peak optical
    // depth 0.025), so alpha is nearly proportional to the density along each ray.
    let (width, height) = (160usize, 120usize);
    let centre = [0.9, 0.5, 0.3];
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("blob.exr");
    let outcome = common::run_source(
        "blob.felt",
        &format!(
            r#"
            vector c = ({}, {}, {});
            float sigma = 0.05;
            scalarfield r2 = (identity() - c) * (identity() - c);
            scalarfield rho = exp(-r2 / (2 * sigma * sigma));
            domain box(c - (0.35, 0.35, 0.35), (0.7, 0.7, 0.7), (0, 0, 0), 0.05);
            camera cam = camera((0, 0, 5), (0, 0, 0), (0, 1, 0), 40);
            render("{}", density = rho, camera = cam, bounds = box, kappa = 0.2, step = 0.005,
                   width = {width}, height = {height});
            "#,
            centre[0],
            centre[1],
            centre[2],
            path.display()
        ),
    );
    assert!(outcome.ok, "{}", outcome.rendered);
    let image = exr::prelude::read_first_rgba_layer_from_file(
        &path,
        move |size, _| vec![0f32; size.width() * size.height()],
        move |alpha, at, (_, _, _, a): (f32, f32, f32, f32)| {
            alpha[at.y() * width + at.x()] = a;
        },
    )
    .unwrap();
    let alpha = image.layer_data.channel_data.pixels;
    // Pixel (x, y) covers [x, x + 1) x [y, y + 1) in raster space, its ray through the centre.
    let (mut sum, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
    for y in 0..height {
        for x in 0..width {
            let a = f64::from(alpha[y * width + x]);
            sum += a;
            sx += a * (x as f64 + 0.5);
            sy += a * (y as f64 + 0.5);
        }
    }
    let (cx, cy) = (sx / sum, sy / sum);
    // OpenEXR's worldToNDC: a row vector times the matrix, divided by w; NDC (0, 0) is the
    // top-left corner of the image and (1, 1) the bottom-right.
    let m = world_to_ndc(&path);
    let row = [centre[0], centre[1], centre[2], 1.0];
    let ndc: Vec<f64> = (0..4)
        .map(|j| (0..4).map(|i| row[i] * m[i * 4 + j]).sum())
        .collect();
    let (px, py) = (
        ndc[0] / ndc[3] * width as f64,
        ndc[1] / ndc[3] * height as f64,
    );
    // Well away from the centre of the image, so an offset or a flip would show.
    assert!(px > 110.0 && py < 45.0, "({px}, {py})");
    assert!(
        (cx - px).abs() < 0.05 && (cy - py).abs() < 0.05,
        "centroid ({cx}, {cy}), projected ({px}, {py})"
    );
}
