//! Noise throughput: samples per second per kind on one thread (f32 values, and values with
//! gradients), the time to fill a dense 256³ grid with a five-octave pyroclastic sphere
//! of Perlin noise on two threads, the figure the design notes compare with OpenVDB AX, and
//! the time to synthesise FFT Gaussian random fields.
//!
//! Run with `cargo bench --bench noise`.

use felt::field::noise::{NoiseKind, NoiseOutput, eval_f32};
use felt::fluids::fft::gaussian_random_field;
use felt::space::BLOCK;
use felt::space::domain::Domain;
use glam::DVec3;
use rayon::prelude::*;
use std::hint::black_box;
use std::time::Instant;

/// Samples per second of one kind on one thread, over a slab of blocks that step through
/// many lattice cells (each block is a row of 256 points 0.037 apart).
fn throughput(kind: NoiseKind, with_gradient: bool) -> f64 {
    let x: Vec<f32> = (0..BLOCK).map(|i| i as f32 * 0.037).collect();
    let y: Vec<f32> = (0..BLOCK).map(|i| (i % 7) as f32 * 0.11).collect();
    let z: Vec<f32> = (0..BLOCK).map(|i| (i % 5) as f32 * 0.13).collect();
    let mut value = vec![0f32; BLOCK];
    let mut gx = vec![0f32; BLOCK];
    let mut gy = vec![0f32; BLOCK];
    let mut gz = vec![0f32; BLOCK];
    let mut run = |blocks: usize| {
        let mut sum = 0f32;
        for b in 0..blocks {
            let base = [0.5 * b as f64, 1.3 * (b % 17) as f64, 0.7 * (b % 31) as f64];
            let out = NoiseOutput {
                value: &mut value,
                gradient: if with_gradient {
                    Some([&mut gx[..], &mut gy[..], &mut gz[..]])
                } else {
                    None
                },
                hessian: None,
            };
            eval_f32(kind, 7, base, &x, &y, &z, out);
            sum += value[b % BLOCK];
        }
        black_box(sum);
    };
    run(2000);
    let mut best = f64::INFINITY;
    let blocks = 20_000;
    for _ in 0..3 {
        let start = Instant::now();
        run(blocks);
        best = best.min(start.elapsed().as_secs_f64());
    }
    (blocks * BLOCK) as f64 / best
}

/// A 256³ grid over [-1, 1]³ of `max(0, 1 − |p| + |fbm(2p)|·0.5)` with five octaves of Perlin
/// noise, filled row by row (one block per row) on `threads` threads. Returns seconds and a
/// checksum so nothing is optimised away.
fn pyroclastic_fill(threads: usize) -> (f64, f64) {
    const N: usize = 256;
    const OCTAVES: usize = 5;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool");
    let cell = 2.0 / N as f64;
    let mut grid = vec![0f32; N * N * N];
    let start = Instant::now();
    pool.install(|| {
        grid.par_chunks_mut(N).enumerate().for_each(|(row, out)| {
            let (j, k) = (row % N, row / N);
            let py = -1.0 + (j as f64 + 0.5) * cell;
            let pz = -1.0 + (k as f64 + 0.5) * cell;
            let mut fbm = [0f32; N];
            let mut octave = [0f32; N];
            let zeros = [0f32; N];
            let mut offsets = [0f32; N];
            let mut frequency = 2.0;
            let mut amplitude = 1.0f32;
            for o in 0..OCTAVES {
                for (i, x) in offsets.iter_mut().enumerate() {
                    *x = (i as f64 * cell * frequency) as f32;
                }
                let shift = 17.3 * o as f64;
                let base = [
                    (-1.0 + 0.5 * cell) * frequency + shift,
                    py * frequency + shift,
                    pz * frequency + shift,
                ];
                eval_f32(
                    NoiseKind::Perlin,
                    3,
                    base,
                    &offsets,
                    &zeros,
                    &zeros,
                    NoiseOutput::value(&mut octave),
                );
                for (f, v) in fbm.iter_mut().zip(&octave) {
                    *f += amplitude * v;
                }
                frequency *= 2.0;
                amplitude *= 0.5;
            }
            for (i, density) in out.iter_mut().enumerate() {
                let px = -1.0 + (i as f32 + 0.5) * cell as f32;
                let radius = (px * px + (py * py + pz * pz) as f32).sqrt();
                *density = (1.0 - radius + 0.5 * fbm[i].abs()).max(0.0);
            }
        });
    });
    let seconds = start.elapsed().as_secs_f64();
    (seconds, grid.iter().map(|v| *v as f64).sum())
}

fn main() {
    println!("noise samples per second, f32, one thread:");
    println!("{:<10} {:>14} {:>18}", "kind", "value", "value+gradient");
    for kind in [NoiseKind::Perlin, NoiseKind::Simplex, NoiseKind::Worley] {
        let value = throughput(kind, false);
        let gradient = throughput(kind, true);
        println!(
            "{:<10} {:>12.1} M {:>16.1} M",
            format!("{kind:?}"),
            value / 1e6,
            gradient / 1e6
        );
    }
    let mut best = f64::INFINITY;
    let mut checksum = 0.0;
    for _ in 0..3 {
        let (seconds, sum) = pyroclastic_fill(2);
        best = best.min(seconds);
        checksum = sum;
    }
    println!();
    println!("{:<56} {:>9}", "grid, two threads", "seconds");
    println!(
        "{:<56} {best:>9.3}",
        format!(
            "256³ pyroclastic sphere, 5 octaves Perlin ({:.0} M/s)",
            256.0f64.powi(3) * 5.0 / best / 1e6
        )
    );
    for (n, divergence_free) in [(128, false), (128, true), (256, false)] {
        let seconds = random_field(n, divergence_free);
        let what = if divergence_free {
            "divergence-free"
        } else {
            "scalar"
        };
        println!(
            "{:<56} {seconds:>9.3}",
            format!("{n}³ FFT Gaussian random field, {what}")
        );
    }
    println!("(checksum {checksum:.1})");
}

/// Seconds to synthesise one random field on an `n³` grid (best of two).
fn random_field(n: usize, divergence_free: bool) -> f64 {
    let cell = 1.0 / n as f64;
    let domain = Domain::with_cells(DVec3::ZERO, DVec3::ONE, DVec3::ZERO, cell, cell)
        .expect("a domain that fits in memory");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("a thread pool");
    let mut best = f64::INFINITY;
    for _ in 0..2 {
        let start = Instant::now();
        let field = pool
            .install(|| gaussian_random_field(&domain, 4.0 * cell, 1, divergence_free))
            .expect("a random field");
        best = best.min(start.elapsed().as_secs_f64());
        black_box(field);
    }
    best
}
