//! Cloud-automaton benchmark at the source's size (seed 003, §8): a 256 × 32 × 256 cloud
//! volume, each stage of an update timed on this machine and printed beside the source's
//! figures on its GPU (GeForce 8700M GT): region-volume update 5.263 ms, simulation step
//! 12.5 ms, smoothing 6.024 ms, shading 8.696 ms.
//!
//! The scene is the `cloud_sky` example's: 26 drifting ellipsoids (felt fields, compiled as a
//! script's are) give the probabilities, the
//! automaton has grown for 48 steps, the density is smoothed over two cells and two earlier
//! steps, and the sun is swept slice by slice over the cloud's own cells. Each stage is timed
//! as the median of repeated runs on all threads (`RAYON_NUM_THREADS` to change).
//!
//! Run with `cargo bench --bench clouds`.

use felt::cloud::{CloudState, Planes, Probabilities, Probability, SmoothedCloud, Smoothing, Wind};
use felt::field::shapes::ellipsoid_field;
use felt::field::{CompiledField, Field};
use felt::grid::cache::Cache;
use felt::render::transmittance::light_columns;
use felt::render::{Light, TransmissivityMethod};
use felt::space::domain::Domain;
use felt::space::{GridDerivative, GridSource, Interp};
use glam::DVec3;
use std::sync::Arc;
use std::time::Instant;

#[path = "common/cpu.rs"]
mod cpu;
use cpu::cpu_seconds;

const CELLS: [usize; 3] = [256, 32, 256];

fn jitter(i: usize, salt: f64) -> f64 {
    let x = (12.9898 * i as f64 + 78.233 * salt).sin() * 43758.5453;
    x - x.floor()
}

/// The example's region volume at time `t` (in steps): the maximum of 26 ellipsoid profiles,
/// built from felt field nodes as `cloudellipsoid` builds them.
fn regions(t: f64, cell: f64) -> Field {
    let drift = DVec3::new(0.675, 0.0, 0.16) * cell;
    let mut r = Field::constant_scalar(0.0);
    for i in 0..26 {
        let size = 0.55 + 0.75 * jitter(i, 3.0);
        let c = DVec3::new(
            -12.0 + 20.0 * jitter(i, 1.0),
            1.75 + 0.25 * size,
            -7.0 + 14.0 * jitter(i, 2.0),
        );
        let radii = DVec3::new(1.6 * size, 0.45 + 0.5 * size, 1.3 * size);
        r = Field::max(&r, &ellipsoid_field(c + t * drift, radii).unwrap()).unwrap();
    }
    r
}

fn constant(c: f64) -> Field {
    Field::constant_scalar(c)
}

/// The example's three probability fields of a region field `r`, compiled together as
/// `cloudstep` compiles them.
fn probability_fields(r: &Field) -> CompiledField {
    let one_minus = constant(1.0).sub(r).unwrap();
    let hum = r.mul(&constant(0.25)).unwrap();
    let act = r.mul(&constant(0.004)).unwrap();
    let ext = constant(0.02)
        .add(
            &one_minus
                .mul(&one_minus)
                .unwrap()
                .mul(&constant(0.3))
                .unwrap(),
        )
        .unwrap();
    CompiledField::prepared(&Field::vector_from(&hum, &act, &ext).unwrap()).unwrap()
}

/// Timing of a stage: median wall seconds of the runs, and CPU seconds per run (all threads).
#[derive(Clone, Copy)]
struct Timing {
    wall: f64,
    cpu: f64,
}

/// Times `runs` calls of `f` after one warm-up call (which also fills reusable buffers, as
/// the previous frame of an animation does).
fn median<T>(runs: usize, mut f: impl FnMut() -> T) -> (Timing, T) {
    let mut last = std::hint::black_box(f());
    let mut times = Vec::with_capacity(runs);
    let cpu = cpu_seconds();
    for _ in 0..runs {
        let started = Instant::now();
        last = std::hint::black_box(f());
        times.push(started.elapsed().as_secs_f64());
    }
    let cpu = (cpu_seconds() - cpu) / runs as f64;
    times.sort_by(f64::total_cmp);
    (
        Timing {
            wall: times[runs / 2],
            cpu,
        },
        last,
    )
}

/// The region-volume update: the three probability fields sampled at the cells.
fn probabilities(fields: &CompiledField, domain: &Domain, planes: &Planes) -> Probabilities {
    Probabilities::sample(fields, domain, planes)
}

fn main() {
    let threads = rayon::current_num_threads();
    let cell = 16.0 / CELLS[0] as f64;
    let domain = Domain::with_cells(
        DVec3::new(-8.0, 1.2, -8.0),
        DVec3::new(16.0, 2.0, 16.0),
        DVec3::ZERO,
        cell,
        cell,
    )
    .unwrap();
    let planes = Planes::new(CELLS);
    let wind = Wind {
        bottom: [0.45, 0.12],
        top: [0.9, 0.2],
        wrap: false,
    };
    println!(
        "cloud automaton, {}x{}x{} cells, {threads} threads",
        CELLS[0], CELLS[1], CELLS[2]
    );
    // Grow the sky to frame 48 as the example does (regions every 8 steps).
    let start = {
        let hum = regions(0.0, cell).mul(&constant(0.5)).unwrap();
        let joint = Field::vector_from(&hum, &constant(0.0), &constant(0.0)).unwrap();
        let sampled = probabilities(&CompiledField::prepared(&joint).unwrap(), &domain, &planes);
        Probabilities {
            hum: sampled.hum,
            act: Probability::uniform(0.0),
            ext: Probability::uniform(0.0),
        }
    };
    let mut state = CloudState::initial(domain.clone(), CELLS, 7, &start);
    let grow = Instant::now();
    for f in (0..48).step_by(8) {
        let p = probabilities(
            &probability_fields(&regions(f as f64 + 4.0, cell)),
            &domain,
            &planes,
        );
        for _ in 0..8 {
            state = state.step(&p, &wind);
        }
    }
    println!(
        "grown to step 48 in {:.2} s; cover {:?} of {} cells",
        grow.elapsed().as_secs_f64(),
        state.counts(),
        planes.cells()
    );

    let fields = probability_fields(&regions(52.0, cell));
    let smoothing = Smoothing {
        radius: 2,
        window: 2,
    };
    let smooth = || {
        let sampler = SmoothedCloud::new(
            domain.clone(),
            state.planes,
            state.cloud_frames(3),
            smoothing,
        );
        let cache = Cache::from_source(
            domain.clone(),
            1,
            Arc::new(sampler),
            vec![0.0],
            "clouddensity",
            "bench".into(),
        )
        .unwrap();
        cache.fill_all();
        cache
    };
    let sun = Light::distant(DVec3::new(0.55, -0.6, -0.55), DVec3::ONE).unwrap();
    let density_of = |cache: Cache| {
        let grid: Arc<dyn GridSource> = Arc::new(cache);
        CompiledField::prepared(
            &Field::from_grid(grid, Interp::Linear, GridDerivative::Interpolant).unwrap(),
        )
        .unwrap()
    };
    let shade = |density: &CompiledField, method| {
        light_columns(density, &sun, &domain, method, f64::INFINITY).unwrap()
    };
    // `FELT_CLOUD_STAGE=regions|step|smooth|shade` repeats one stage, for a profiler.
    if let Ok(stage) = std::env::var("FELT_CLOUD_STAGE") {
        let p_all = probabilities(&fields, &domain, &planes);
        let density = density_of(smooth());
        let (t, _) = median(41, || match stage.as_str() {
            "regions" => drop(probabilities(&fields, &domain, &planes)),
            "step" => drop(state.step(&p_all, &wind)),
            "smooth" => drop(smooth()),
            _ => drop(shade(&density, TransmissivityMethod::Sweep)),
        });
        println!(
            "{stage}: {:.2} ms wall (median of 41), {:.2} CPU-ms per run",
            t.wall * 1e3,
            t.cpu * 1e3
        );
        return;
    }
    let (t_region, p_all) = median(5, || probabilities(&fields, &domain, &planes));
    let (t_step, _) = median(21, || state.step(&p_all, &wind));
    let (t_smooth, cache) = median(5, smooth);
    let filled = cache.bricks_filled();
    let total = cache.bricks_total();
    let density = density_of(cache);
    let (t_shade, _) = median(5, || shade(&density, TransmissivityMethod::Sweep));
    let (t_march, _) = median(1, || shade(&density, TransmissivityMethod::March));

    let ms = |s: f64| s * 1e3;
    println!();
    println!(
        "| stage | felt, {threads} threads (ms, median wall) | felt CPU-ms per run | source, GeForce 8700M GT (ms) | felt wall / source |"
    );
    println!("|---|---|---|---|---|");
    let rows = [
        (
            "region-volume update (3 fields of 26 ellipsoids, one pass)",
            t_region,
            5.263,
        ),
        ("simulation step", t_step, 12.5),
        ("smoothing (radius 2, window 2)", t_smooth, 6.024),
        ("shading (light sweep)", t_shade, 8.696),
    ];
    for (name, t, source) in rows {
        println!(
            "| {name} | {:.2} | {:.2} | {source} | {:.2} |",
            ms(t.wall),
            ms(t.cpu),
            ms(t.wall) / source
        );
    }
    let wall: f64 = rows.iter().map(|r| r.1.wall).sum();
    let cpu: f64 = rows.iter().map(|r| r.1.cpu).sum();
    let source: f64 = rows.iter().map(|r| r.2).sum();
    println!(
        "| whole update | {:.2} | {:.2} | {source:.1} | {:.2} |",
        ms(wall),
        ms(cpu),
        ms(wall) / source
    );
    println!();
    println!("smoothing filled {filled} of {total} bricks (the rest had no cloud within reach)");
    println!(
        "shading by the light cache's per-cell march instead: {:.0} ms ({:.0}x the sweep)",
        ms(t_march.wall),
        t_march.wall / t_shade.wall
    );
}
