//! The four scenes on which the fast render is measured against the path tracer: a thin
//! medium, a smoke plume, a dense cloud lit from the front and the same cloud backlit under a
//! blue sky. Each is a 64³ cache over the box [−0.6, 0.6]³, zero in its two outer cells, seen
//! by one camera.

use felt::field::{CompiledField, Field};
use felt::grid::cache::Cache;
use felt::render::settings::{Integrator, RenderSettings};
use felt::render::{Camera, Light, Phase, Scene, render_with_stats};
use felt::space::domain::Domain;
use felt::space::{Aabb, GridSource};
use glam::DVec3;
use std::sync::Arc;
use std::time::Instant;

pub const CELLS: usize = 64;
pub const EYE: DVec3 = DVec3::new(0.4, 0.3, 3.0);

/// One lighting case.
pub struct LightScene {
    pub name: &'static str,
    pub density: fn(DVec3) -> f64,
    pub kappa: f64,
    pub albedo: f64,
    pub g: f64,
    /// The direction the sunlight travels, and its strength.
    pub sun: (DVec3, DVec3),
    pub sky: DVec3,
}

/// A lumpy ball, dense inside.
pub fn cloud(p: DVec3) -> f64 {
    let lumps = (7.0 * p.x).sin() * (5.0 * p.y + 1.0).sin() * (6.0 * p.z).cos();
    let r = p.length() - 0.35 - 0.08 * lumps;
    (-r * 12.0).clamp(0.0, 1.0)
}

/// A rising column that widens and fades.
pub fn plume(p: DVec3) -> f64 {
    let height = (p.y + 0.5).clamp(0.0, 1.0);
    let radius = 0.08 + 0.15 * height;
    let swirl = 0.05 * (8.0 * p.y).sin();
    let d = ((p.x - swirl).powi(2) + p.z.powi(2)).sqrt();
    (1.0 - d / radius).max(0.0) * (1.0 - height)
}

/// A soft ball, densest at its centre.
pub fn ball(p: DVec3) -> f64 {
    (1.0 - p.length_squared() / 0.25).max(0.0)
}

pub fn scenes() -> Vec<LightScene> {
    let front = (-EYE).normalize();
    let back = DVec3::new(-0.4, -0.5, 3.0).normalize();
    vec![
        LightScene {
            name: "thin ball, albedo 0.8, g 0.5",
            density: ball,
            kappa: 3.0,
            albedo: 0.8,
            g: 0.5,
            sun: (DVec3::new(-0.5, -1.0, -0.4), DVec3::splat(3.0)),
            sky: DVec3::ZERO,
        },
        LightScene {
            name: "smoke plume, albedo 0.75",
            density: plume,
            kappa: 30.0,
            albedo: 0.75,
            g: 0.3,
            sun: (DVec3::new(-0.5, -1.0, -0.4), DVec3::splat(3.0)),
            sky: DVec3::new(0.1, 0.15, 0.25),
        },
        LightScene {
            name: "dense cloud, albedo 1, g 0.8, sun behind the camera",
            density: cloud,
            kappa: 60.0,
            albedo: 1.0,
            g: 0.8,
            sun: (front, DVec3::splat(3.0)),
            sky: DVec3::ZERO,
        },
        LightScene {
            name: "dense cloud backlit under a blue sky",
            density: cloud,
            kappa: 60.0,
            albedo: 1.0,
            g: 0.8,
            sun: (back, DVec3::splat(3.0)),
            sky: DVec3::new(0.2, 0.35, 0.7),
        },
    ]
}

/// `density` at the centres of the 64³ cells, x fastest, zero in the two outer cells.
pub fn cell_values(density: fn(DVec3) -> f64) -> Vec<f32> {
    let cell = 1.2 / CELLS as f64;
    let mut values = Vec::with_capacity(CELLS.pow(3));
    for k in 0..CELLS {
        for j in 0..CELLS {
            for i in 0..CELLS {
                let border = [i, j, k].iter().any(|&c| c < 2 || c + 2 >= CELLS);
                let p = DVec3::splat(-0.6)
                    + DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * cell;
                let v = if border { 0.0 } else { density(p) };
                values.push(v as f32);
            }
        }
    }
    values
}

/// The scene's density as a cache.
pub fn density(scene: &LightScene) -> CompiledField {
    let cell = 1.2 / CELLS as f64;
    let values = cell_values(scene.density);
    let domain = Domain::with_cells(
        DVec3::splat(-0.6),
        DVec3::splat(1.2),
        DVec3::ZERO,
        cell,
        cell,
    )
    .expect("domain");
    let cache = Cache::from_dense(domain, 1, vec![values], vec![0.0]).expect("cache");
    let grid: Arc<dyn GridSource> = Arc::new(cache);
    CompiledField::new(&Field::from_linear_grid(grid).expect("field"))
}

/// The settings both integrators share for `scene` at `size` × `size` pixels.
pub fn settings(scene: &LightScene, size: usize) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        kappa: DVec3::splat(scene.kappa),
        albedo: Some(scene.albedo),
        phase: Phase::HenyeyGreenstein { g: scene.g },
        sky: scene.sky.into(),
        bounds: Some(Aabb::new(DVec3::splat(-0.6), DVec3::splat(0.6))),
        ..RenderSettings::default()
    }
}

/// Renders `scene` with `settings`: the image's RGB and the seconds it took.
pub fn render(
    scene: &LightScene,
    density: &CompiledField,
    settings: &RenderSettings,
) -> (Vec<DVec3>, f64) {
    let felt_scene = Scene {
        density,
        color: None,
        emission: None,
        holdout: None,
        velocity: None,
        camera: Camera::new(EYE, DVec3::ZERO, DVec3::Y, 35.0).expect("camera"),
        lights: vec![Light::distant(scene.sun.0, scene.sun.1).expect("light")],
    };
    let started = Instant::now();
    let (image, _) = render_with_stats(&felt_scene, settings).expect("render");
    let seconds = started.elapsed().as_secs_f64();
    let rgb = image
        .rgba
        .iter()
        .map(|p| DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
        .collect();
    (rgb, seconds)
}

/// The path tracer's settings for `scene` at `spp`.
pub fn path(scene: &LightScene, size: usize, spp: u32) -> RenderSettings {
    RenderSettings {
        integrator: Integrator::Path,
        spp,
        ..settings(scene, size)
    }
}

/// An image's mean brightness over a reference's, and the relative RMSE of their 4×4-block
/// means (of the mean of RGB) over the blocks where the reference shows the medium (a block
/// mean above 1 % of the brightest block's), relative to the reference's mean over them.
pub fn compare(image: &[DVec3], reference: &[DVec3], size: usize) -> (f64, f64) {
    let grey = |p: &DVec3| p.element_sum() / 3.0;
    let mean = |v: &[DVec3]| v.iter().map(grey).sum::<f64>() / v.len() as f64;
    let blocks = size / 4;
    let mut pairs = Vec::with_capacity(blocks * blocks);
    for by in 0..blocks {
        for bx in 0..blocks {
            let (mut a, mut b) = (0.0, 0.0);
            for y in 4 * by..4 * by + 4 {
                for x in 4 * bx..4 * bx + 4 {
                    a += grey(&image[y * size + x]) / 16.0;
                    b += grey(&reference[y * size + x]) / 16.0;
                }
            }
            pairs.push((a, b));
        }
    }
    let brightest = pairs.iter().map(|p| p.1).fold(0.0, f64::max);
    let covered: Vec<_> = pairs.iter().filter(|p| p.1 > 0.01 * brightest).collect();
    let n = covered.len() as f64;
    let squares: f64 = covered.iter().map(|(a, b)| (a - b).powi(2)).sum();
    let level: f64 = covered.iter().map(|p| p.1).sum::<f64>() / n;
    (mean(image) / mean(reference), (squares / n).sqrt() / level)
}
