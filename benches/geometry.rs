//! Geometry throughput: marching cubes in cells per second (a cheap analytic sphere, so the
//! extraction itself dominates, and a wobbly one that costs more per sample), the build time of
//! a mesh's signed-distance structure, and signed-distance queries per second over a grid of
//! points around a ~20k-triangle mesh, with one and two threads. Prints the best wall-clock
//! rate of a few runs. An argument `mesh` or `distance` runs only that half.

use felt::geometry::{MeshDistance, marching_cubes};
use felt::space::domain::Domain;
use felt::space::{BLOCK, FieldSampler, FnField};
use glam::DVec3;
use rayon::prelude::*;
use std::time::Instant;

const RUNS: usize = 3;

fn cube(cells: usize) -> Domain {
    let cell = 2.0 / cells as f64;
    Domain::with_cells(
        DVec3::splat(-1.0),
        DVec3::splat(2.0),
        DVec3::ZERO,
        cell,
        cell,
    )
    .expect("the benchmark domain fits in memory")
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool")
}

/// Best wall time in seconds of `RUNS` runs of `work`.
fn best_seconds(mut work: impl FnMut()) -> f64 {
    (0..RUNS)
        .map(|_| {
            let start = Instant::now();
            work();
            start.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Signed distances at every point of an `n³` grid over `[-1, 1]³`, in parallel z slices of
/// blocks, as a cache fill would ask for them.
fn fill(field: &MeshDistance, n: usize) -> f64 {
    let step = 2.0 / n as f64;
    (0..n)
        .into_par_iter()
        .map(|k| {
            let mut eval = field.evaluator();
            let (mut xs, mut ys, mut zs) = (Vec::new(), Vec::new(), Vec::new());
            let mut out = vec![0.0; BLOCK];
            let mut sum = 0.0;
            for j in 0..n {
                for i in 0..n {
                    xs.push(-1.0 + (i as f64 + 0.5) * step);
                    ys.push(-1.0 + (j as f64 + 0.5) * step);
                    zs.push(-1.0 + (k as f64 + 0.5) * step);
                    if xs.len() == BLOCK || (i + 1 == n && j + 1 == n) {
                        eval.eval_f64(&xs, &ys, &zs, &mut out[..xs.len()]);
                        sum += out[..xs.len()].iter().sum::<f64>();
                        xs.clear();
                        ys.clear();
                        zs.clear();
                    }
                }
            }
            sum
        })
        .sum()
}

fn main() {
    let sphere = FnField::new(1, |p: DVec3, out: &mut [f64]| out[0] = 0.7 - p.length());
    let wobbly = FnField::new(1, |p: DVec3, out: &mut [f64]| {
        out[0] =
            0.6 - p.length() + 0.08 * (9.0 * p.x).sin() * (7.0 * p.y).cos() * (8.0 * p.z).sin();
    });
    let only = std::env::args().nth(1).unwrap_or_default();
    if only != "distance" {
        mesh_rates(&sphere, &wobbly);
    }
    if only != "mesh" {
        distance_rates(&wobbly);
    }
}

fn mesh_rates(sphere: &dyn FieldSampler, wobbly: &dyn FieldSampler) {
    println!("marching cubes (cells per second, best of {RUNS})");
    println!(
        "{:<18} {:>6} {:>12} {:>12} {:>11}",
        "level set", "cells", "1 thread", "2 threads", "triangles"
    );
    for (name, field) in [("sphere", sphere), ("wobbly sphere", wobbly)] {
        for n in [128, 256] {
            let domain = cube(n);
            let cells = (n * n * n) as f64;
            let triangles = marching_cubes(field, &domain)
                .expect("meshes")
                .triangles
                .len();
            let rates: Vec<f64> = [1, 2]
                .iter()
                .map(|&t| {
                    let seconds = pool(t).install(|| {
                        best_seconds(|| {
                            marching_cubes(field, &domain).expect("meshes");
                        })
                    });
                    cells / seconds
                })
                .collect();
            println!(
                "{name:<18} {n:>5}³ {:>10.1} M {:>10.1} M {triangles:>11}",
                rates[0] / 1e6,
                rates[1] / 1e6
            );
        }
    }
}

fn distance_rates(wobbly: &dyn FieldSampler) {
    println!();
    println!("signed distance to a mesh (queries per second over a 64³ grid, best of {RUNS})");
    println!(
        "{:>10} {:>7} {:>10} {:>12} {:>12}",
        "triangles", "closed", "build", "1 thread", "2 threads"
    );
    for cells in [80, 180] {
        let closed = marching_cubes(wobbly, &cube(cells)).expect("meshes");
        // Without one triangle the mesh is open, and every point in its box asks the winding
        // number for its sign.
        let mut open = closed.clone();
        open.triangles.pop();
        for mesh in [closed, open] {
            let start = Instant::now();
            let field = MeshDistance::new(&mesh).expect("a valid mesh");
            let build = start.elapsed().as_secs_f64();
            let queries = 64usize.pow(3) as f64;
            let rates: Vec<f64> = [1, 2]
                .iter()
                .map(|&t| {
                    queries
                        / pool(t).install(|| {
                            best_seconds(|| {
                                std::hint::black_box(fill(&field, 64));
                            })
                        })
                })
                .collect();
            println!(
                "{:>10} {:>7} {:>7.0} ms {:>10.2} M {:>10.2} M",
                mesh.triangles.len(),
                mesh.is_closed(),
                build * 1e3,
                rates[0] / 1e6,
                rates[1] / 1e6
            );
        }
    }
}
