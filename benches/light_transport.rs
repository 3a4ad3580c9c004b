//! The path tracer's speed: a dense cloud (a 64³ cache, κ = 40, albedo 0.95, one sun and a
//! sky) path-traced at 96×96 for a few sample counts, with Mitsuba 3's `volpath` on the same
//! grid at equal samples when `python3 -c 'import mitsuba'` works, and the ratio.
//!
//! Run with `cargo bench --bench light_transport`.

#[path = "common/cpu.rs"]
mod cpu;

use felt::field::{CompiledField, Field};
use felt::grid::cache::Cache;
use felt::grid::domain::Domain;
use felt::render::settings::{Integrator, RenderSettings};
use felt::render::{Camera, Light, Phase, Scene, render_with_stats};
use felt::sample::{Aabb, GridSource};
use glam::DVec3;
use std::path::Path;
use std::process::Command;
use std::sync::Arc;
use std::time::Instant;

const CELLS: usize = 64;
const SIZE: usize = 96;
const KAPPA: f64 = 40.0;
const ALBEDO: f64 = 0.95;
const G: f64 = 0.5;
const EYE: DVec3 = DVec3::new(0.4, 0.3, 3.0);
const SUN: DVec3 = DVec3::new(-0.5, -1.0, -0.4);
const SKY: DVec3 = DVec3::new(0.1, 0.15, 0.25);

/// A lumpy ball, dense inside, zero in the two outer cells.
fn cloud(p: DVec3) -> f64 {
    let lumps = (7.0 * p.x).sin() * (5.0 * p.y + 1.0).sin() * (6.0 * p.z).cos();
    let r = p.length() - 0.35 - 0.08 * lumps;
    (-r * 12.0).clamp(0.0, 1.0)
}

fn grid_values() -> Vec<f32> {
    let cell = 1.2 / CELLS as f64;
    let mut values = Vec::with_capacity(CELLS.pow(3));
    for k in 0..CELLS {
        for j in 0..CELLS {
            for i in 0..CELLS {
                let border = [i, j, k].iter().any(|&c| c < 2 || c + 2 >= CELLS);
                let p = DVec3::splat(-0.6)
                    + DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * cell;
                values.push(if border { 0.0 } else { cloud(p) as f32 });
            }
        }
    }
    values
}

fn write_vol(path: &Path, values: &[f32]) {
    let mut bytes = b"VOL\x03".to_vec();
    for v in [1, CELLS, CELLS, CELLS, 1] {
        bytes.extend((v as i32).to_le_bytes());
    }
    for v in [-0.6f32, -0.6, -0.6, 0.6, 0.6, 0.6] {
        bytes.extend(v.to_le_bytes());
    }
    for v in values {
        bytes.extend(v.to_le_bytes());
    }
    std::fs::write(path, bytes).expect("write the .vol grid");
}

/// Mitsuba's render seconds at `spp`, if Mitsuba is installed.
fn mitsuba_seconds(dir: &Path, spp: u32) -> Option<f64> {
    let v = |d: DVec3| format!("[{}, {}, {}]", d.x, d.y, d.z);
    let config = format!(
        r#"{{"vol": "{}", "bbox_min": [-0.6, -0.6, -0.6], "bbox_max": [0.6, 0.6, 0.6],
             "kappa": {KAPPA}, "albedo": {ALBEDO}, "g": {G}, "eye": {}, "lookat": [0, 0, 0],
             "up": [0, 1, 0], "fov": 35, "width": {SIZE}, "height": {SIZE}, "spp": {spp},
             "max_depth": 65, "sky": {},
             "lights": [{{"type": "distant", "direction": {}, "color": [3, 3, 3]}}],
             "out": "{}"}}"#,
        dir.join("density.vol").display(),
        v(EYE),
        v(SKY),
        v(SUN.normalize()),
        dir.join("mitsuba.raw").display(),
    );
    let json = dir.join("scene.json");
    std::fs::write(&json, config).ok()?;
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/mitsuba_volume.py");
    let run = Command::new("python3")
        .arg(script)
        .arg(json)
        .output()
        .ok()?;
    if !run.status.success() {
        return None;
    }
    String::from_utf8_lossy(&run.stdout).trim().parse().ok()
}

fn main() {
    let values = grid_values();
    let dir = tempfile::tempdir().expect("temporary directory");
    write_vol(&dir.path().join("density.vol"), &values);
    let domain = Domain::with_cells(
        DVec3::splat(-0.6),
        DVec3::splat(1.2),
        DVec3::ZERO,
        1.2 / CELLS as f64,
        1.2 / CELLS as f64,
    )
    .expect("domain");
    let cache = Cache::from_dense(domain, 1, vec![values], vec![0.0]).expect("cache");
    let grid: Arc<dyn GridSource> = Arc::new(cache);
    let density = CompiledField::new(&Field::from_linear_grid(grid).expect("field"));
    let scene = Scene {
        density: &density,
        color: None,
        emission: None,
        holdout: None,
        velocity: None,
        camera: Camera::new(EYE, DVec3::ZERO, DVec3::Y, 35.0).expect("camera"),
        lights: vec![Light::distant(SUN, DVec3::splat(3.0)).expect("light")],
    };
    let mut settings = RenderSettings {
        width: SIZE,
        height: SIZE,
        kappa: DVec3::splat(KAPPA),
        albedo: Some(ALBEDO),
        phase: Phase::HenyeyGreenstein { g: G },
        integrator: Integrator::Path,
        sky: SKY.into(),
        bounds: Some(Aabb::new(DVec3::splat(-0.6), DVec3::splat(0.6))),
        ..RenderSettings::default()
    };
    println!(
        "dense cloud, {CELLS}³ cache, κ {KAPPA}, albedo {ALBEDO}, {SIZE}×{SIZE}, {} threads",
        rayon::current_num_threads()
    );
    println!("| spp | felt s (cpu s) | mean | mitsuba s | felt / mitsuba |");
    println!("|---|---|---|---|---|");
    for spp in [4, 16, 64] {
        settings.spp = spp;
        let (wall, cpu) = (Instant::now(), cpu::cpu_seconds());
        let (image, _) = render_with_stats(&scene, &settings).expect("render");
        let seconds = wall.elapsed().as_secs_f64();
        let cpu = cpu::cpu_seconds() - cpu;
        let mean = image
            .rgba
            .iter()
            .map(|p| f64::from(p[0] + p[1] + p[2]) / 3.0)
            .sum::<f64>()
            / image.rgba.len() as f64;
        match mitsuba_seconds(dir.path(), spp) {
            Some(theirs) => println!(
                "| {spp} | {seconds:.2} ({cpu:.2}) | {mean:.4} | {theirs:.2} | {:.2} |",
                seconds / theirs
            ),
            None => println!("| {spp} | {seconds:.2} ({cpu:.2}) | {mean:.4} | (no mitsuba) | |"),
        }
    }
}
