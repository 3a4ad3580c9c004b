//! Rendering benchmarks: prints the tables the README quotes.
//!
//! A procedural sphere of density (soft-edged, with an exact interval range so empty space is
//! skipped as it is for compiled fields) lit by one distant light, rendered at 640×360:
//! 1. shadow-grid fills, sweep against per-cell march (time and agreement);
//! 2. whole renders with cached against marched shadows;
//! 3. the step study: seconds and RMSE of RGBA against a fine-step reference.
//!
//! Run with `cargo bench --bench render`.

use felt::render::{
    Adaptive, Camera, Image, Light, RenderSettings, Scene, Shadows, TransmissivityMethod,
    render_with_stats, transmissivity,
};
use felt::space::domain::Domain;
use felt::space::{Aabb, BlockEval, FieldSampler};
use glam::DVec3;
use std::time::Instant;

/// Density `clamp(4·(1 − |p|), 0, 1)·(0.6 + 0.4·sin 12x·sin 12y·sin 12z)`: a unit ball with a
/// soft rim a quarter unit thick and lumps about 0.26 across, so the step matters.
struct SoftSphere;

fn soft_sphere(x: f64, y: f64, z: f64) -> f64 {
    let r = (x * x + y * y + z * z).sqrt();
    let lumps = 0.6 + 0.4 * (12.0 * x).sin() * (12.0 * y).sin() * (12.0 * z).sin();
    (4.0 * (1.0 - r)).clamp(0.0, 1.0) * lumps
}

struct SoftSphereEval;

impl BlockEval for SoftSphereEval {
    fn eval_f32(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f32]) {
        for i in 0..xs.len() {
            out[i] = soft_sphere(xs[i], ys[i], zs[i]) as f32;
        }
    }

    fn eval_f64(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        for i in 0..xs.len() {
            out[i] = soft_sphere(xs[i], ys[i], zs[i]);
        }
    }
}

impl FieldSampler for SoftSphere {
    fn width(&self) -> usize {
        1
    }

    fn evaluator(&self) -> Box<dyn BlockEval + '_> {
        Box::new(SoftSphereEval)
    }

    fn bounds(&self) -> Option<Aabb> {
        Some(Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)))
    }

    /// Conservative over a box: the ball's profile falls with the distance to the centre and
    /// the lumps are at most 1.
    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        let nearest = DVec3::ZERO.clamp(region.min, region.max).length();
        vec![(0.0, (4.0 * (1.0 - nearest)).clamp(0.0, 1.0))]
    }
}

fn rmse(a: &Image, b: &Image) -> f64 {
    let sum: f64 = a
        .rgba
        .iter()
        .zip(&b.rgba)
        .flat_map(|(p, q)| (0..4).map(move |c| ((p[c] - q[c]) as f64).powi(2)))
        .sum();
    (sum / (4 * a.rgba.len()) as f64).sqrt()
}

fn main() {
    let sphere = SoftSphere;
    let light = Light::distant(DVec3::new(-0.5, -1.0, -0.4), DVec3::splat(2.0)).expect("light");
    let camera =
        Camera::new(DVec3::new(0.0, 0.6, 4.0), DVec3::ZERO, DVec3::Y, 40.0).expect("camera");
    let scene = Scene {
        density: &sphere,
        color: None,
        emission: None,
        holdout: None,
        velocity: None,
        camera,
        lights: vec![light.clone()],
    };
    let base = RenderSettings {
        kappa: DVec3::splat(8.0),
        ambient: DVec3::splat(0.05),
        ..RenderSettings::default()
    };
    println!("threads: {}", rayon::current_num_threads());
    // `cargo bench --bench render -- sweep`: one 128³ sweep, for profiling.
    if std::env::args().any(|a| a == "sweep") {
        let cell = 2.0 / 128.0;
        let domain = Domain::with_cells(
            DVec3::splat(-1.0),
            DVec3::splat(2.0),
            DVec3::ZERO,
            cell,
            cell,
        )
        .expect("domain");
        for _ in 0..5 {
            let start = Instant::now();
            transmissivity(&sphere, &light, &domain, 8.0, TransmissivityMethod::Sweep)
                .expect("sweep");
            println!("{:.3} s", start.elapsed().as_secs_f64());
        }
        return;
    }
    // `cargo bench --bench render -- once`: one cached render, for profiling.
    if std::env::args().any(|a| a == "once") {
        let start = Instant::now();
        let (_, stats) = render_with_stats(&scene, &base).expect("render");
        println!(
            "{:.3} s, {} samples",
            start.elapsed().as_secs_f64(),
            stats.march.samples
        );
        return;
    }

    println!("\n## shadow grid fill, 1 distant light, kappa 8 (transmissivity)");
    println!("| cells | method | seconds | mean abs diff vs march | max abs diff |");
    println!("|---|---|---|---|---|");
    for cells in [64usize, 128] {
        let cell = 2.0 / cells as f64;
        let domain = Domain::with_cells(
            DVec3::splat(-1.0),
            DVec3::splat(2.0),
            DVec3::ZERO,
            cell,
            cell,
        )
        .expect("domain");
        let timed = |method| {
            let start = Instant::now();
            let t = transmissivity(&sphere, &light, &domain, 8.0, method).expect("transmissivity");
            (t, start.elapsed().as_secs_f64())
        };
        let (march, march_s) = timed(TransmissivityMethod::March);
        let (sweep, sweep_s) = timed(TransmissivityMethod::Sweep);
        let diffs: Vec<f64> = march
            .iter()
            .zip(&sweep)
            .map(|(a, b)| (a - b).abs() as f64)
            .collect();
        let mean = diffs.iter().sum::<f64>() / diffs.len() as f64;
        let max = diffs.iter().copied().fold(0.0, f64::max);
        println!("| {cells}³ | march | {march_s:.3} | – | – |");
        println!("| {cells}³ | sweep | {sweep_s:.3} | {mean:.2e} | {max:.2e} |");
    }

    println!("\n## 640×360, soft sphere, 1 distant light: cached vs marched shadows");
    println!("| shadows | step | shadow grid s | march s | total s | samples | RMSE vs march |");
    println!("|---|---|---|---|---|---|---|");
    let timed = |settings: &RenderSettings| {
        let start = Instant::now();
        let (image, stats) = render_with_stats(&scene, settings).expect("render");
        (image, stats, start.elapsed().as_secs_f64())
    };
    let marched_settings = RenderSettings {
        shadows: Shadows::March,
        ..base.clone()
    };
    let (marched, march_stats, march_total) = timed(&marched_settings);
    let (cached, cache_stats, cache_total) = timed(&base);
    println!(
        "| cache (sweep) | {:.5} | {:.3} | {:.3} | {:.3} | {} | {:.2e} |",
        cache_stats.step,
        cache_stats.shadow_seconds,
        cache_stats.march_seconds,
        cache_total,
        cache_stats.march.samples,
        rmse(&cached, &marched)
    );
    println!(
        "| march | {:.5} | – | {:.3} | {:.3} | {} | 0 |",
        march_stats.step, march_stats.march_seconds, march_total, march_stats.march.samples
    );
    println!(
        "empty-space bricks: {} of {} proven empty",
        cache_stats.empty_bricks, cache_stats.bricks
    );

    println!("\n## step study (cache shadows, 640×360), reference step 2/2048");
    println!("| step | seconds | samples | RMSE RGBA vs reference |");
    println!("|---|---|---|---|");
    let at = |step: f64, adaptive: Option<Adaptive>| {
        let settings = RenderSettings {
            step: Some(step),
            adaptive,
            shadows: Shadows::Cache {
                cell_size: Some(2.0 / 128.0),
                method: TransmissivityMethod::Auto,
            },
            ..base.clone()
        };
        timed(&settings)
    };
    let (reference, _, _) = at(2.0 / 2048.0, None);
    for divisions in [32.0, 64.0, 128.0, 256.0, 512.0, 1024.0] {
        let step = 2.0 / divisions;
        let (image, stats, seconds) = at(step, None);
        println!(
            "| 2/{divisions} | {seconds:.3} | {} | {:.2e} |",
            stats.march.samples,
            rmse(&image, &reference)
        );
    }
    for divisions in [64.0, 128.0] {
        let step = 2.0 / divisions;
        let (image, stats, seconds) = at(step, Some(Adaptive::around(step)));
        println!(
            "| 2/{divisions} adaptive (to step/8) | {seconds:.3} | {} | {:.2e} |",
            stats.march.samples,
            rmse(&image, &reference)
        );
    }
}
