//! Motion blur (`render(..., velocity = v, shutter, shutterposition)`), seen from scripts: a
//! still velocity changes nothing, bit for bit, in either integrator; a ball translating at a
//! constant velocity renders as the time average of still renders of the ball at the shifted
//! places (an independent route: felt's `compose` moves the ball, the renders are averaged
//! here); the path tracer agrees with the march on the blurred ball; and the keywords are
//! checked like every other.

mod common;

use std::path::Path;

/// The RGB of every pixel of an EXR.
fn pixels(path: &Path) -> Vec<[f32; 3]> {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |size, _| (size.width(), vec![[0f32; 3]; size.width() * size.height()]),
        |(width, pixels), position, (r, g, b, _a): (f32, f32, f32, f32)| {
            pixels[position.y() * *width + position.x()] = [r, g, b]
        },
    )
    .unwrap();
    image.layer_data.channel_data.pixels.1
}

/// Runs `source` in a fresh folder and returns the folder.
fn run(source: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("blur.felt");
    std::fs::write(&script, source).unwrap();
    let outcome = common::run_script(&script, &[]);
    assert!(outcome.ok, "{}", outcome.rendered);
    assert!(outcome.diagnostics.is_empty(), "{}", outcome.rendered);
    dir
}

/// A glowing ball and a camera looking at it, as felt source.
const SCENE: &str = "
camera cam = camera((0, 0, 4), (0, 0, 0), (0, 1, 0), 40);
scalarfield ball = mask(sphere((0, 0, 0), 0.35));
vector v = (0.9, 0.25, 0);
";

#[test]
fn a_still_velocity_renders_the_still_image_bit_for_bit() {
    for integrator in ["march", "path"] {
        let extra = if integrator == "path" {
            ", albedo = 0.8, spp = 4"
        } else {
            ""
        };
        let light = "light key = distantlight((0.3, -1, -0.4), (2, 2, 2));";
        let dir = run(&format!(
            "{SCENE}{light}\n\
             render(\"still.exr\", density = 3 * ball, camera = cam, lights = {{key}}, \
             width = 24, height = 16, integrator = \"{integrator}\"{extra});\n\
             render(\"moving.exr\", density = 3 * ball, camera = cam, lights = {{key}}, \
             width = 24, height = 16, integrator = \"{integrator}\"{extra}, \
             velocity = vectorfield((0, 0, 0)), shutter = 1);\n"
        ));
        let still = std::fs::read(dir.path().join("still.exr")).unwrap();
        let moving = std::fs::read(dir.path().join("moving.exr")).unwrap();
        assert!(
            still == moving,
            "{integrator}: a still velocity changed the image"
        );
    }
}

#[test]
fn a_translating_ball_renders_as_the_average_of_still_renders_over_the_shutter() {
    // Emission only, so each render is linear in where the ball is.
    let look = "emission = vectorfield(ball, ball, ball), kappa = 0.5, camera = cam, \
                width = 48, height = 24, step = 0.01";
    let steps = 32;
    let mut source = format!(
        "{SCENE}render(\"blurred.exr\", density = ball, {look}, spp = 256, velocity = \
         vectorfield(v), shutter = 1, shutterposition = \"start\");\n\
         render(\"still.exr\", density = ball, {look});\n"
    );
    // The shutter opens at the frame: times in [0, 1], the ball at v·t.
    for k in 0..steps {
        let t = (k as f64 + 0.5) / steps as f64;
        source.push_str(&format!(
            "{{ scalarfield moved = compose(ball, identity() - vectorfield(v * {t})); \
             render(\"at{k}.exr\", density = moved, emission = vectorfield(moved, moved, moved), \
             kappa = 0.5, camera = cam, width = 48, height = 24, step = 0.01); }}\n"
        ));
    }
    let dir = run(&source);
    let blurred = pixels(&dir.path().join("blurred.exr"));
    let still = pixels(&dir.path().join("still.exr"));
    let mut average = vec![0.0f64; blurred.len()];
    for k in 0..steps {
        for (a, p) in average
            .iter_mut()
            .zip(pixels(&dir.path().join(format!("at{k}.exr"))))
        {
            *a += f64::from(p[0]) / steps as f64;
        }
    }
    let peak = average.iter().cloned().fold(0.0, f64::max);
    let mean_error = blurred
        .iter()
        .zip(&average)
        .map(|(b, a)| (f64::from(b[0]) - a).abs())
        .sum::<f64>()
        / blurred.len() as f64;
    let blur = blurred
        .iter()
        .zip(&still)
        .map(|(b, s)| f64::from(b[0] - s[0]).abs())
        .sum::<f64>()
        / blurred.len() as f64;
    println!(
        "peak {peak:.4}, mean |blurred − average| {mean_error:.5}, mean |blurred − still| {blur:.5}"
    );
    // The blur is real (the still image is far from it) and is the time average (to the
    // noise of 256 times per pixel and the 32-step average).
    assert!(
        blur > 10.0 * mean_error,
        "blur {blur} vs error {mean_error}"
    );
    assert!(
        mean_error < 0.01 * peak,
        "error {mean_error} of peak {peak}"
    );
}

#[test]
fn the_path_tracer_blurs_as_the_march_does() {
    let look = "emission = vectorfield(ball, ball, ball), kappa = 0.5, camera = cam, \
                width = 32, height = 16, velocity = vectorfield(v), shutter = 0.8";
    let dir = run(&format!(
        "{SCENE}render(\"march.exr\", density = ball, {look}, spp = 64, step = 0.01);\n\
         render(\"path.exr\", density = ball, {look}, spp = 64, integrator = \"path\", \
         bounces = 0);\n"
    ));
    let march = pixels(&dir.path().join("march.exr"));
    let path = pixels(&dir.path().join("path.exr"));
    let sum = |p: &[[f32; 3]]| p.iter().map(|c| f64::from(c[0])).sum::<f64>();
    let (m, p) = (sum(&march), sum(&path));
    println!("march {m:.4}, path {p:.4}");
    assert!((p / m - 1.0).abs() < 0.03, "path {p} vs march {m}");
}

#[test]
fn shutter_keywords_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    for (call, message) in [
        ("shutter = 0.5", "need a velocity"),
        (
            "velocity = vectorfield((1, 0, 0)), shutter = -1",
            "shutter must be between 0 and 1000",
        ),
        (
            "velocity = vectorfield((1, 0, 0)), shutterposition = \"middle\"",
            "shutter position",
        ),
    ] {
        let script = dir.path().join("bad.felt");
        std::fs::write(
            &script,
            format!("{SCENE}render(\"x.exr\", density = ball, camera = cam, {call});\n"),
        )
        .unwrap();
        let outcome = common::run_script(&script, &[]);
        assert!(!outcome.ok, "{call} was accepted");
        assert!(
            outcome.rendered.contains(message),
            "{call}: {}",
            outcome.rendered
        );
    }
}
