//! Cache fill and read throughput: cells per second filling a 256³ cache from a closure field
//! (a distance computation) and from a constant (what the cache itself costs), with one and two
//! threads, and points per second reading it back with linear and cubic interpolation.
//! Prints a table: the best wall-clock rate of a few runs, and the rate per second of CPU time
//! over all runs (steadier when other work shares the machine). An argument `fill` or `read`
//! runs only that half.

use felt::grid::cache::Cache;
use felt::space::domain::Domain;
use felt::space::{BLOCK, FieldSampler, FnField, GridSource, Interp};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

const CELLS: usize = 256;
const RUNS: usize = 5;
const READ_POINTS: usize = 1 << 21;

fn domain() -> Domain {
    Domain::with_cells(
        DVec3::splat(-1.0),
        DVec3::splat(2.0),
        DVec3::ZERO,
        2.0 / CELLS as f64,
        2.0 / CELLS as f64,
    )
    .expect("the benchmark domain fits in memory")
}

fn distance_field() -> Arc<dyn FieldSampler> {
    let centres = [
        DVec3::new(0.3, -0.2, 0.1),
        DVec3::new(-0.4, 0.35, -0.1),
        DVec3::new(0.05, 0.5, 0.45),
    ];
    Arc::new(FnField::new(1, move |p: DVec3, out: &mut [f64]| {
        let nearest = centres
            .iter()
            .map(|c| (p - *c).length())
            .fold(f64::INFINITY, f64::min);
        out[0] = 0.6 - nearest;
    }))
}

fn constant_field() -> Arc<dyn FieldSampler> {
    Arc::new(FnField::new(1, |_p: DVec3, out: &mut [f64]| out[0] = 1.0))
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool")
}

/// CPU time used by this process so far, user and system, from `/proc/self/stat` (Linux
/// reports it in ticks of 1/100 s); zero where that file does not exist.
fn process_cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let after_name = stat.rsplit(')').next().unwrap_or("");
    let fields: Vec<&str> = after_name.split_whitespace().collect();
    let ticks = |n: usize| {
        fields
            .get(n)
            .and_then(|f| f.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    (ticks(11) + ticks(12)) / 100.0
}

/// Runs `work` `RUNS` times; returns items per second for the best wall time and items per
/// second of CPU time summed over all runs.
fn measure(items: usize, mut work: impl FnMut()) -> (f64, f64) {
    let mut best = f64::INFINITY;
    let cpu_start = process_cpu_seconds();
    for _ in 0..RUNS {
        let start = Instant::now();
        work();
        best = best.min(start.elapsed().as_secs_f64());
    }
    let cpu = process_cpu_seconds() - cpu_start;
    let per_cpu = if cpu > 0.0 {
        (items * RUNS) as f64 / cpu
    } else {
        f64::NAN
    };
    (items as f64 / best, per_cpu)
}

/// Cells per second filling fresh caches (the cache is made outside the timed part).
fn fill_rate(source: fn() -> Arc<dyn FieldSampler>, threads: usize) -> (f64, f64) {
    let pool = pool(threads);
    let mut caches: Vec<Cache> = (0..RUNS)
        .map(|_| {
            Cache::from_field(domain(), 1, source(), vec![0.0], "bench".into())
                .expect("the benchmark cache fits in memory")
        })
        .collect();
    caches.reverse();
    let mut filled = Vec::new();
    measure(CELLS * CELLS * CELLS, || {
        let cache = caches.pop().expect("one cache per run");
        pool.install(|| cache.fill_all());
        // Dropping a filled cache takes time too; keep that out of the measurement.
        filled.push(cache);
    })
}

/// Points per second reading in blocks, spread across threads.
fn read_rate(cache: &Cache, interp: Interp, threads: usize) -> (f64, f64) {
    let pool = pool(threads);
    // Points along a smooth space-filling walk, as a ray would ask, not scattered at random.
    let points: Vec<DVec3> = (0..READ_POINTS)
        .map(|n| {
            let t = n as f64 / READ_POINTS as f64;
            DVec3::new(
                (t * 97.0).sin(),
                (t * 61.0 + 1.0).sin(),
                (t * 13.0 + 2.0).cos(),
            ) * 0.99
        })
        .collect();
    measure(READ_POINTS, || {
        let total: f64 = pool.install(|| {
            points
                .par_chunks(BLOCK)
                .map(|block| {
                    let xs: Vec<f64> = block.iter().map(|p| p.x).collect();
                    let ys: Vec<f64> = block.iter().map(|p| p.y).collect();
                    let zs: Vec<f64> = block.iter().map(|p| p.z).collect();
                    let mut out = [0.0; BLOCK];
                    cache.sample(interp, &xs, &ys, &zs, &mut out[..block.len()]);
                    out.iter().sum::<f64>()
                })
                .sum()
        });
        std::hint::black_box(total);
    })
}

fn main() {
    let only: Option<String> = std::env::args()
        .skip(1)
        .find(|a| a == "fill" || a == "read");
    if only.as_deref() != Some("read") {
        fill_table();
    }
    if only.as_deref() != Some("fill") {
        read_table();
    }
}

fn fill_table() {
    println!("cache fill, {CELLS}^3 cells, scalar, best of {RUNS}");
    println!(
        "{:<34} {:>8} {:>10} {:>16}",
        "source", "threads", "Mcells/s", "Mcells/CPU-s"
    );
    for (name, source) in [
        ("closure: distance to 3 points", distance_field as fn() -> _),
        ("constant (cache overhead)", constant_field as fn() -> _),
    ] {
        for threads in [1, 2] {
            let (wall, cpu) = fill_rate(source, threads);
            println!(
                "{name:<34} {threads:>8} {:>10.1} {:>16.1}",
                wall * 1e-6,
                cpu * 1e-6
            );
        }
    }
}

fn read_table() {
    let cache = Cache::from_field(domain(), 1, distance_field(), vec![0.0], "bench".into())
        .expect("the benchmark cache fits in memory");
    cache.fill_all();
    println!();
    println!("cache read, {READ_POINTS} points in blocks of {BLOCK}, best of {RUNS}");
    println!(
        "{:<34} {:>8} {:>10} {:>16}",
        "interpolation", "threads", "Mpoints/s", "Mpoints/CPU-s"
    );
    for interp in [Interp::Linear, Interp::Cubic] {
        for threads in [1, 2] {
            let (wall, cpu) = read_rate(&cache, interp, threads);
            let name = format!("{interp:?}");
            println!(
                "{name:<34} {threads:>8} {:>10.1} {:>16.1}",
                wall * 1e-6,
                cpu * 1e-6
            );
        }
    }
}
