//! Deep output's cost: a cloud rendered at 320×180 flat and deep (`deep = true`, 32 samples
//! per pixel), at 1 and 4 samples per pixel; prints the seconds of each (median of five) and
//! the deep render's time over the flat one's. The target is at most 1.3.
//!
//! The cloud is a few overlapping soft blobs with lumps (an exact interval range, so empty
//! space is skipped as for compiled fields), lit by one distant light with ambient light.
//!
//! Run with `cargo bench --bench deep`.

use felt::render::{Camera, Light, RenderSettings, Scene, render_deep, render_with_stats};
use felt::space::{Aabb, BlockEval, FieldSampler};
use glam::DVec3;
use std::time::Instant;

/// Blob centres and radii of the cloud.
const BLOBS: [([f64; 3], f64); 4] = [
    ([0.0, 0.0, 0.0], 0.8),
    ([0.7, 0.2, 0.1], 0.55),
    ([-0.65, 0.1, -0.2], 0.6),
    ([0.2, 0.45, -0.3], 0.5),
];

fn cloud(x: f64, y: f64, z: f64) -> f64 {
    let lumps = 0.55 + 0.45 * (9.0 * x).sin() * (11.0 * y + 1.0).sin() * (10.0 * z + 2.0).sin();
    let mut shape: f64 = 0.0;
    for ([cx, cy, cz], r) in BLOBS {
        let d = ((x - cx).powi(2) + (y - cy).powi(2) + (z - cz).powi(2)).sqrt();
        shape = shape.max((3.0 * (1.0 - d / r)).clamp(0.0, 1.0));
    }
    shape * lumps
}

struct Cloud;
struct CloudEval;

impl BlockEval for CloudEval {
    fn eval_f32(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f32]) {
        for i in 0..xs.len() {
            out[i] = cloud(xs[i], ys[i], zs[i]) as f32;
        }
    }

    fn eval_f64(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        for i in 0..xs.len() {
            out[i] = cloud(xs[i], ys[i], zs[i]);
        }
    }
}

impl FieldSampler for Cloud {
    fn width(&self) -> usize {
        1
    }

    fn evaluator(&self) -> Box<dyn BlockEval + '_> {
        Box::new(CloudEval)
    }

    fn bounds(&self) -> Option<Aabb> {
        Some(Aabb::new(
            DVec3::new(-1.3, -0.8, -1.0),
            DVec3::new(1.3, 1.0, 0.9),
        ))
    }

    /// Conservative over a box: each blob's profile falls with the distance to its centre and
    /// the lumps are at most 1.
    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        let most = BLOBS
            .iter()
            .map(|&(c, r)| {
                let c = DVec3::from_array(c);
                let d = (c.clamp(region.min, region.max) - c).length();
                (3.0 * (1.0 - d / r)).clamp(0.0, 1.0)
            })
            .fold(0.0, f64::max);
        vec![(0.0, most)]
    }
}

fn median(mut times: Vec<f64>) -> f64 {
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn main() {
    let light = Light::distant(DVec3::new(-0.5, -1.0, -0.4), DVec3::splat(2.0)).expect("light");
    let camera =
        Camera::new(DVec3::new(0.0, 0.5, 4.5), DVec3::ZERO, DVec3::Y, 45.0).expect("camera");
    let scene = Scene {
        density: &Cloud,
        color: None,
        emission: None,
        holdout: None,
        velocity: None,
        camera,
        lights: vec![light],
    };
    println!("threads: {}", rayon::current_num_threads());
    println!("| spp | flat s | deep s | deep / flat | samples per pixel (mean) |");
    println!("|---|---|---|---|---|");
    for spp in [1, 4] {
        let flat = RenderSettings {
            width: 320,
            height: 180,
            spp,
            kappa: DVec3::splat(6.0),
            ambient: DVec3::splat(0.05),
            ..RenderSettings::default()
        };
        let deep = RenderSettings {
            deep: Some(32),
            ..flat.clone()
        };
        let (mut flat_times, mut deep_times) = (Vec::new(), Vec::new());
        let mut mean_samples = 0.0;
        for _ in 0..5 {
            let start = Instant::now();
            render_with_stats(&scene, &flat).expect("flat render");
            flat_times.push(start.elapsed().as_secs_f64());
            let start = Instant::now();
            let (_, image, _) = render_deep(&scene, &deep).expect("deep render");
            deep_times.push(start.elapsed().as_secs_f64());
            mean_samples = image.samples.len() as f64 / image.counts.len() as f64;
        }
        let (f, d) = (median(flat_times), median(deep_times));
        println!(
            "| {spp} | {f:.3} | {d:.3} | {:.2} | {mean_samples:.1} |",
            d / f
        );
    }
}
