//! Particle benchmarks: prints the tables the README quotes.
//!
//! 1. Flame-wisp dots generated (stored) per second, stored dots splatted per second, and dots
//!    made and splatted as made (`flamesplat`, count and colour) per second, on one and two
//!    threads; memory per million stored dots.
//! 2. End to end at 10 and 80 million dots: made and splatted as made (count and colour), and
//!    an emission-only render at 1280×720, with wall time and the process's peak memory.
//! 3. felt's chaos game against `flam3-render` on the same 2D flame (same variations, same
//!    affine transforms) at the same number of iterations; skipped when flam3 is absent.
//!
//! The flame is three xforms — linear, swirl and spherical with 2D pre-transforms — so both
//! programs evaluate the same maps. The post-transforms send z to 0, so felt's dots lie in the
//! plane z = 0 as flam3's points do.
//!
//! Run with `cargo bench --bench particles` (`FELT_BENCH_BIG=0` skips the 80-million run;
//! `FELT_BENCH_ONLY=rates`, `end` or `flam3` runs one of the three parts, and `felt-nearest`
//! felt's side of the flam3 comparison alone, for profiling).

use felt::field::{CompiledField, Field};
use felt::grid::cache::Cache;
use felt::particles::chaos::{self, Map, Settings};
use felt::particles::flame_splat::{SplatInto, splat_flame};
use felt::particles::guide::guides;
use felt::particles::splat::{Deposit, Kernel, splat};
use felt::particles::{Particles, bytes_per_point};
use felt::render::tonemap::ToneMap;
use felt::render::{Camera, RenderSettings, Scene, render_with_stats};
use felt::space::domain::Domain;
use felt::space::{FieldSampler, GridDerivative, GridSource, Interp};
use glam::DVec3;
use std::process::Command;
use std::sync::Arc;
use std::time::Instant;

/// The three xforms: (variation, 2D coefficients a b c d e f as flam3 writes `coefs`, weight).
/// flam3's `coefs="a d b e c f"` maps (x, y) to (a x + b y + c, d x + e y + f).
const XFORMS: [(&str, [f64; 6], f64); 3] = [
    ("linear", [0.5, 0.0, 0.5, 0.0, 0.5, 0.3], 1.0),
    ("swirl", [0.6, -0.3, 0.3, 0.6, -0.2, 0.1], 1.0),
    ("spherical", [0.8, 0.1, -0.1, 0.8, -0.3, -0.2], 0.5),
];

fn maps() -> Vec<CompiledField> {
    XFORMS
        .iter()
        .map(|(name, c, _)| {
            // Thesis order a b c d | e f g h | k l m n. The 3D variations give points off
            // the plane (swirl's z is x cos r² − z sin r²), so the post-transform sends z to
            // 0: every dot lies in the plane z = 0, as flam3's 2D points do.
            let pre = [
                c[0], c[1], 0.0, c[2], c[3], c[4], 0.0, c[5], 0.0, 0.0, 0.0, 0.0,
            ];
            let flat = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
            let affine = |c: &[f64]| felt::particles::flame::affine_from_coefficients(c).unwrap();
            let f =
                felt::particles::flame::flame(name, &[], Some(affine(&pre)), Some(affine(&flat)))
                    .unwrap();
            CompiledField::prepared(&f).unwrap()
        })
        .collect()
}

fn settings(fields: &[CompiledField]) -> Settings<'_> {
    let colors = [
        DVec3::new(1.0, 0.6, 0.3),
        DVec3::new(0.3, 0.5, 1.0),
        DVec3::new(0.9, 0.9, 1.0),
    ];
    Settings {
        maps: fields
            .iter()
            .zip(XFORMS.iter())
            .zip(colors)
            .map(|((f, x), color)| Map {
                field: f as &dyn FieldSampler,
                weight: x.2,
                color,
            })
            .collect(),
        displace: None,
        amount: 0.0,
        color: None,
        iterations: 1000,
        skip: 20,
    }
}

fn generate(fields: &[CompiledField], dots: usize) -> Particles {
    let g = guides(&Particles::new(vec![[0.0; 3]])).unwrap();
    chaos::generate(&g, dots, 1, &settings(fields)).unwrap().0
}

fn pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// A frame 4 units wide, centred on the origin as flam3's camera is, of `width` × `height`
/// cells, `layers` cells deep (a multiple of 8). The flame lies in the plane z = 0, placed
/// inside a layer of bricks (a trilinear stencil there stays in one brick, as flam3's
/// histogram is one layer), not on a brick face.
fn domain(width: usize, height: usize, layers: usize) -> Domain {
    let cell = 4.0 / width as f64;
    let below = (8 * (layers / 16)) as f64 + 3.5;
    Domain::with_cells(
        DVec3::new(-2.0, -(height as f64) * cell / 2.0, -below * cell),
        DVec3::new(4.0, height as f64 * cell, layers as f64 * cell),
        DVec3::ZERO,
        cell,
        cell,
    )
    .unwrap()
}

/// `dots` dots of the flame made and splatted as made into a count and a colour cache on
/// `d`; returns the two caches.
fn made_and_splatted(
    fields: &[CompiledField],
    dots: usize,
    d: &Domain,
    kernel: Kernel,
) -> (Cache, Cache) {
    let count = SplatInto {
        domain: d,
        kernel,
        background: &[0.0],
        previous: None,
    };
    let color = SplatInto {
        domain: d,
        kernel,
        background: &[0.0; 3],
        previous: None,
    };
    let g = guides(&Particles::new(vec![[0.0; 3]])).unwrap();
    let (mut caches, _) =
        splat_flame(&g, dots, 1, &settings(fields), Some(&count), Some(&color)).unwrap();
    assert_eq!(caches[0].1.splatted + caches[0].1.outside, dots as u64);
    let (color, _) = caches.pop().unwrap();
    let (count, _) = caches.pop().unwrap();
    (count, color)
}

/// CPU seconds (user + system) used so far by this process, or by its finished children.
fn cpu_seconds(children: bool) -> f64 {
    let who = if children {
        libc::RUSAGE_CHILDREN
    } else {
        libc::RUSAGE_SELF
    };
    // SAFETY: getrusage writes into the zeroed struct we own.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(who, &mut usage) };
    let t = |v: libc::timeval| v.tv_sec as f64 + v.tv_usec as f64 * 1e-6;
    t(usage.ru_utime) + t(usage.ru_stime)
}

/// The process's peak resident memory (VmHWM), in MiB.
fn peak_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kib| kib / 1024.0)
}

fn rates() {
    let fields = maps();
    let n = 2_000_000;
    println!("## Dots per second (flame of 3 xforms, one guide, {n} dots)\n");
    println!(
        "| threads | generated (M dots/s) | per CPU-second (M) | splatted, trilinear (M dots/s) | per CPU-second (M) | splatted, nearest (M dots/s) | made and splatted as made, trilinear (M dots/s) | per CPU-second (M) |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let d = domain(512, 512, 8);
    for threads in [1, 2] {
        let (dots, gen_s, gen_cpu) = pool(threads, || {
            let (t, cpu) = (Instant::now(), cpu_seconds(false));
            let dots = generate(&fields, n);
            (dots, t.elapsed().as_secs_f64(), cpu_seconds(false) - cpu)
        });
        let mut splat_s = [0.0; 2];
        let mut splat_cpu = 0.0;
        for (k, kernel) in [Kernel::Trilinear, Kernel::Nearest].into_iter().enumerate() {
            let (wall, cpu) = pool(threads, || {
                let (t, cpu) = (Instant::now(), cpu_seconds(false));
                splat(&dots, Deposit::One, kernel, &d, &[0.0], None).unwrap();
                (t.elapsed().as_secs_f64(), cpu_seconds(false) - cpu)
            });
            splat_s[k] = wall;
            if k == 0 {
                splat_cpu = cpu;
            }
        }
        drop(dots);
        let (made_s, made_cpu) = pool(threads, || {
            let (t, cpu) = (Instant::now(), cpu_seconds(false));
            made_and_splatted(&fields, n, &d, Kernel::Trilinear);
            (t.elapsed().as_secs_f64(), cpu_seconds(false) - cpu)
        });
        let m = n as f64 / 1e6;
        println!(
            "| {threads} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
            m / gen_s,
            m / gen_cpu,
            m / splat_s[0],
            m / splat_cpu,
            m / splat_s[1],
            m / made_s,
            m / made_cpu
        );
    }
    println!(
        "\nMemory per million dots: {:.1} MiB for position and colour ({} bytes per dot; a bare position is {} bytes).\n",
        bytes_per_point(&[3]) as f64 * 1e6 / (1 << 20) as f64,
        bytes_per_point(&[3]),
        bytes_per_point(&[])
    );
}

fn end_to_end(dots: usize) {
    let fields = maps();
    let cpu = cpu_seconds(false);
    let d = domain(768, 768, 192);
    let t = Instant::now();
    let (count, color) = made_and_splatted(&fields, dots, &d, Kernel::Trilinear);
    let made = t.elapsed().as_secs_f64();
    let kappa = 1e-3;
    let density = Field::from_grid(
        Arc::new(count) as Arc<dyn GridSource>,
        Interp::Linear,
        GridDerivative::Interpolant,
    )
    .unwrap();
    let emission = Field::from_grid(
        Arc::new(color) as Arc<dyn GridSource>,
        Interp::Linear,
        GridDerivative::Interpolant,
    )
    .unwrap()
    .mul(&Field::constant_scalar(kappa))
    .unwrap();
    let density = CompiledField::prepared(&density).unwrap();
    let emission = CompiledField::prepared(&emission).unwrap();
    let camera = Camera::new(DVec3::new(0.0, 0.0, 4.5), DVec3::ZERO, DVec3::Y, 55.0).unwrap();
    let scene = Scene {
        density: &density,
        color: None,
        emission: Some(&emission),
        holdout: None,
        velocity: None,
        camera,
        lights: Vec::new(),
    };
    let settings = RenderSettings {
        width: 1280,
        height: 720,
        kappa: DVec3::splat(kappa),
        step: Some(4.0 / 768.0),
        bounds: Some(d.bounds()),
        ..RenderSettings::default()
    };
    let t = Instant::now();
    let (mut image, _) = render_with_stats(&scene, &settings).unwrap();
    ToneMap::MaxPlusOne.apply(&mut image);
    let rendered = t.elapsed().as_secs_f64();
    println!(
        "| {} M | {made:.2} | {rendered:.2} | {:.2} | {:.2} | {:.0} |",
        dots / 1_000_000,
        made + rendered,
        cpu_seconds(false) - cpu,
        peak_mib()
    );
}

/// flam3's genome for the same flame: `coefs="a d b e c f"`.
fn genome(quality: usize, width: usize, height: usize) -> String {
    let mut xforms = String::new();
    for (name, c, w) in XFORMS {
        xforms.push_str(&format!(
            "<xform weight=\"{w}\" color=\"0\" {name}=\"1\" coefs=\"{} {} {} {} {} {}\"/>\n",
            c[0], c[3], c[1], c[4], c[2], c[5]
        ));
    }
    format!(
        "<flame name=\"bench\" size=\"{width} {height}\" center=\"0 0\" scale=\"{}\" \
         oversample=\"1\" filter=\"0.5\" quality=\"{quality}\" background=\"0 0 0\" \
         brightness=\"4\" gamma=\"4\" estimator_radius=\"0\">\n{xforms}\
         <color index=\"0\" rgb=\"255 255 255\"/>\n<color index=\"255\" rgb=\"255 255 255\"/>\n</flame>\n",
        width as f64 / 4.0
    )
}

fn against_flam3() {
    if Command::new("flam3-render")
        .arg("--version")
        .output()
        .is_err()
    {
        println!("flam3-render is not installed: skipping the comparison.");
        return;
    }
    let (width, height, quality) = (640usize, 360usize, 40usize);
    // flam3 draws quality × width × height samples (one per pixel per unit of quality).
    let iterations = quality * width * height;
    let dir = tempfile::tempdir().unwrap();
    let flame = dir.path().join("bench.flam3");
    std::fs::write(&flame, genome(quality, width, height)).unwrap();
    println!(
        "## felt's chaos game against flam3-render ({} M iterations, 3 xforms, 640×360)\n",
        iterations / 1_000_000
    );
    println!(
        "felt makes the dots and adds them straight into a count cache and a colour cache \
         (`flamesplat`): four sums per dot, as flam3's histogram keeps red, green, blue and a \
         count per bucket. \"nearest\" adds each dot to one cell, as flam3 bins each sample in \
         one bucket (oversample 1); \"trilinear\" spreads it over eight. \"stored\" is \
         `flamewisp` followed by `splat` of the count alone.\n"
    );
    println!(
        "| threads | flam3-render wall (s) | flam3 CPU (s) | felt, nearest: wall (s) | CPU (s) | felt / flam3, wall | felt / flam3, CPU | felt, trilinear: CPU (s) | / flam3 | felt, stored: CPU (s) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let fields = maps();
    // The cells of flam3's picture: dots outside it are dropped by both programs.
    let d = domain(width, height, 8);
    for threads in [1, 2] {
        let (t, cpu) = (Instant::now(), cpu_seconds(true));
        let out = Command::new("flam3-render")
            .env("in", &flame)
            .env("prefix", dir.path().join("out_"))
            .env("nthreads", threads.to_string())
            .env("verbose", "0")
            .output()
            .unwrap();
        let (flam3_s, flam3_cpu) = (t.elapsed().as_secs_f64(), cpu_seconds(true) - cpu);
        if !out.status.success() {
            println!(
                "flam3-render failed: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            return;
        }
        let made = |kernel| {
            pool(threads, || {
                let (t, cpu) = (Instant::now(), cpu_seconds(false));
                made_and_splatted(&fields, iterations, &d, kernel);
                (t.elapsed().as_secs_f64(), cpu_seconds(false) - cpu)
            })
        };
        let (near_s, near_cpu) = made(Kernel::Nearest);
        let (_, tri_cpu) = made(Kernel::Trilinear);
        let (_, stored_cpu) = pool(threads, || {
            let (t, cpu) = (Instant::now(), cpu_seconds(false));
            let set = generate(&fields, iterations);
            splat(&set, Deposit::One, Kernel::Trilinear, &d, &[0.0], None).unwrap();
            (t.elapsed().as_secs_f64(), cpu_seconds(false) - cpu)
        });
        println!(
            "| {threads} | {flam3_s:.2} | {flam3_cpu:.2} | {near_s:.2} | {near_cpu:.2} | {:.2} | {:.2} | {tri_cpu:.2} | {:.2} | {stored_cpu:.2} |",
            near_s / flam3_s,
            near_cpu / flam3_cpu,
            tri_cpu / flam3_cpu
        );
    }
    println!();
}

fn main() {
    let only = std::env::var("FELT_BENCH_ONLY").ok();
    let part = |name: &str| only.as_deref().is_none_or(|o| o == name);
    if part("rates") {
        rates();
    }
    if part("end") {
        println!(
            "## End to end (dots made and splatted as made, count and colour, into 768×768×192 cells; render 1280×720)\n"
        );
        println!(
            "| dots | make and splat (s) | render (s) | total wall (s) | total CPU (s) | peak memory (MiB) |"
        );
        println!("|---|---|---|---|---|---|");
        end_to_end(10_000_000);
        if std::env::var("FELT_BENCH_BIG").as_deref() != Ok("0") {
            end_to_end(80_000_000);
        }
        println!();
    }
    if part("flam3") {
        against_flam3();
    }
    // Not part of the tables: felt's side of the flam3 comparison alone (nearest, one pass
    // on the current pool), for profiling.
    if only.as_deref() == Some("felt-nearest") {
        let (t, cpu) = (Instant::now(), cpu_seconds(false));
        made_and_splatted(
            &maps(),
            40 * 640 * 360,
            &domain(640, 360, 8),
            Kernel::Nearest,
        );
        println!(
            "felt, nearest, 9.2 M iterations: {:.3} s wall, {:.3} CPU-s",
            t.elapsed().as_secs_f64(),
            cpu_seconds(false) - cpu
        );
    }
}
