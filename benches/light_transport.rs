//! What light costs, in two parts.
//!
//! 1. The fast render (the march with its grid of indirect light) against felt's converged
//!    path tracer (1024 samples per pixel) on four scenes: a thin ball, a smoke plume, a dense
//!    cloud lit from the front and the same cloud backlit under a blue sky. For each: the mean
//!    brightness ratio, the relative RMSE of 4×4-block means over the blocks that show the
//!    medium, the time as a fraction of the reference's, and the error of a path trace given
//!    the same time. Single scattering alone is shown beside it.
//! 2. The path tracer's speed: a dense cloud (a 64³ cache, κ = 40, albedo 0.95, one sun and a
//!    sky) path-traced at 96×96 for a few sample counts, with Mitsuba 3's `volpath` on the same
//!    grid at equal samples when `python3 -c 'import mitsuba'` works, and the ratio.
//!
//! Run with `cargo bench --bench light_transport`; `LIGHT_SIZE` (default 192) sets the four
//! scenes' image side and `LIGHT_SPP` (default 1024) the reference's samples.

#[path = "common/cpu.rs"]
mod cpu;
#[path = "light_transport/scenes.rs"]
mod scenes;

use felt::field::{CompiledField, Field};
use felt::grid::cache::Cache;
use felt::render::settings::{Integrator, RenderSettings};
use felt::render::{Camera, Light, Phase, Scene, render_with_stats};
use felt::space::domain::Domain;
use felt::space::{Aabb, GridSource};
use glam::DVec3;
use std::path::Path;
use std::process::Command;
use std::sync::Arc;
use std::time::Instant;

use scenes::CELLS;
const SIZE: usize = 96;
const KAPPA: f64 = 40.0;
const ALBEDO: f64 = 0.95;
const G: f64 = 0.5;
const EYE: DVec3 = DVec3::new(0.4, 0.3, 3.0);
const SUN: DVec3 = DVec3::new(-0.5, -1.0, -0.4);
const SKY: DVec3 = DVec3::new(0.1, 0.15, 0.25);

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
    four_scenes();
    mitsuba_speed();
}

fn env_number(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Part 1: the fast render against the converged path tracer.
fn four_scenes() {
    let size = env_number("LIGHT_SIZE", 192);
    let spp = env_number("LIGHT_SPP", 1024) as u32;
    println!(
        "fast render against the path tracer at {spp} spp, {size}×{size}, {} threads",
        rayon::current_num_threads()
    );
    println!(
        "| scene | path s | fast s (share) | fast mean / ref | fast block RMSE | \
         equal-time path spp | its block RMSE | single mean / ref | single block RMSE |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for scene in scenes::scenes() {
        let density = scenes::density(&scene);
        let (reference, path_seconds) =
            scenes::render(&scene, &density, &scenes::path(&scene, size, spp));
        let (fast, fast_seconds) =
            scenes::render(&scene, &density, &scenes::settings(&scene, size));
        let single = RenderSettings {
            indirect: None,
            sky: DVec3::ZERO.into(),
            ..scenes::settings(&scene, size)
        };
        let (alone, _) = scenes::render(&scene, &density, &single);
        // The samples a path trace affords in the fast render's time, at the reference's pace.
        let equal = ((f64::from(spp) * fast_seconds / path_seconds).floor() as u32).max(1);
        let mut quick = scenes::path(&scene, size, equal);
        quick.seed = 1;
        let (traced, _) = scenes::render(&scene, &density, &quick);
        let (mean, rmse) = scenes::compare(&fast, &reference, size);
        let (_, traced_rmse) = scenes::compare(&traced, &reference, size);
        let (alone_mean, alone_rmse) = scenes::compare(&alone, &reference, size);
        println!(
            "| {} | {path_seconds:.2} | {fast_seconds:.2} ({:.1} %) | {mean:.3} | {:.1} % | {equal} | \
             {:.1} % | {alone_mean:.3} | {:.1} % |",
            scene.name,
            100.0 * fast_seconds / path_seconds,
            100.0 * rmse,
            100.0 * traced_rmse,
            100.0 * alone_rmse
        );
    }
}

/// Part 2: the path tracer's speed against Mitsuba 3's.
fn mitsuba_speed() {
    let values = scenes::cell_values(scenes::cloud);
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
