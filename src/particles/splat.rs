//! Splatting: accumulating a particle attribute into the cells of a cache (000 §2.2).
//!
//! The key decision: contributions are summed in 64-bit fixed point. Each contribution
//! `value × weight` is scaled by one power of two chosen so that the sum of every |value|
//! maps below 2⁶², rounded to an integer and added atomically to its cell. Integer addition
//! is exact and order-free, so the grid is bit-identical for any thread count and any order of
//! particles, no cell can overflow, and the total written differs from the total splatted only
//! by the rounding of each contribution (at most 2⁻⁶³ of the total each: far below the
//! `f32` rounding of the stored cells). Only the 8³ bricks a particle touches get storage.
//!
//! Kernels: `Trilinear` spreads a value over the eight cell centres around it with trilinear
//! weights (summing to one); `Nearest` gives it all to the nearest cell centre. Weight that
//! would fall beyond the outermost cell centres goes to the border cell, so every particle
//! inside the domain deposits its whole value; particles outside the domain are not
//! splatted and are counted.

use super::Particles;
use crate::failure::{Failure, Outcome};
use crate::grid::cache::{BRICK, BRICK_CELLS, Cache, SparseBuilder};
use crate::grid::domain::Domain;
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};

/// How a value is spread over cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    Trilinear,
    Nearest,
}

impl Kernel {
    pub fn parse(name: &str) -> Outcome<Kernel> {
        match name {
            "trilinear" => Ok(Kernel::Trilinear),
            "nearest" => Ok(Kernel::Nearest),
            other => Err(Failure::new(format!(
                "kernel must be \"trilinear\" or \"nearest\", found \"{other}\""
            ))),
        }
    }
}

/// What each particle deposits.
#[derive(Clone, Copy)]
pub enum Deposit<'a> {
    /// 1 per particle: the splat counts dots.
    One,
    Float(&'a [f32]),
    Vector(&'a [[f32; 3]]),
}

impl Deposit<'_> {
    fn width(&self) -> usize {
        match self {
            Deposit::Vector(_) => 3,
            _ => 1,
        }
    }

    fn value(&self, i: usize) -> [f64; 3] {
        match self {
            Deposit::One => [1.0, 0.0, 0.0],
            Deposit::Float(v) => [v[i] as f64, 0.0, 0.0],
            Deposit::Vector(v) => v[i].map(|c| c as f64),
        }
    }
}

/// What a splat did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SplatReport {
    pub splatted: u64,
    pub outside: u64,
    /// Sum of the deposited values per component, in `f64`.
    pub total: [f64; 3],
}

/// Particles per unit of parallel work: fixed, so the reductions do not depend on threads.
const CHUNK: usize = 1 << 14;

/// Maps world positions to continuous cell indices (cell centre `(i, j, k)` at `(i, j, k)`).
struct Indexer {
    origin: DVec3,
    to_index: DMat3,
    cells: [usize; 3],
}

impl Indexer {
    fn new(domain: &Domain) -> Outcome<Indexer> {
        let cells = domain
            .resolution
            .ok_or_else(|| Failure::new("splat needs a cache on a domain with cells"))?;
        Ok(Indexer {
            origin: domain.origin,
            to_index: DMat3::from_diagonal(DVec3::ONE / domain.cell) * domain.rotation.transpose(),
            cells,
        })
    }

    /// The cells and weights a particle at `p` writes, or `None` outside the domain.
    fn stencil(
        &self,
        p: [f32; 3],
        kernel: Kernel,
        out: &mut [([usize; 3], f64); 8],
    ) -> Option<usize> {
        let local =
            self.to_index * (DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) - self.origin);
        let u = local.to_array();
        for a in 0..3 {
            if !(0.0..self.cells[a] as f64).contains(&u[a]) {
                return None;
            }
        }
        let u = u.map(|c| c - 0.5);
        match kernel {
            Kernel::Nearest => {
                let c = [0, 1, 2].map(|a| (u[a].round().max(0.0) as usize).min(self.cells[a] - 1));
                out[0] = (c, 1.0);
                Some(1)
            }
            Kernel::Trilinear => {
                let mut lo = [0usize; 3];
                let mut hi = [0usize; 3];
                let mut f = [0.0f64; 3];
                for a in 0..3 {
                    let base = u[a].floor();
                    f[a] = u[a] - base;
                    let last = self.cells[a] as i64 - 1;
                    lo[a] = (base as i64).clamp(0, last) as usize;
                    hi[a] = (base as i64 + 1).clamp(0, last) as usize;
                }
                for (n, slot) in out.iter_mut().enumerate() {
                    let pick = |a: usize| {
                        if (n >> a) & 1 == 1 {
                            (hi[a], f[a])
                        } else {
                            (lo[a], 1.0 - f[a])
                        }
                    };
                    let (x, wx) = pick(0);
                    let (y, wy) = pick(1);
                    let (z, wz) = pick(2);
                    *slot = ([x, y, z], wx * wy * wz);
                }
                Some(8)
            }
        }
    }
}

/// Brick table geometry.
struct Bricks {
    counts: [usize; 3],
}

impl Bricks {
    fn index_of(&self, cell: [usize; 3]) -> (usize, usize) {
        let b = cell.map(|c| c / BRICK);
        let brick = b[0] + self.counts[0] * (b[1] + self.counts[1] * b[2]);
        let local = cell[0] % BRICK + BRICK * (cell[1] % BRICK + BRICK * (cell[2] % BRICK));
        (brick, local)
    }

    fn total(&self) -> usize {
        self.counts.iter().product()
    }
}

/// Splats `deposit` of `particles` onto `previous` (or the background when `None`) and
/// returns the new cache state with a report.
pub fn splat(
    particles: &Particles,
    deposit: Deposit,
    kernel: Kernel,
    domain: &Domain,
    background: &[f64],
    previous: Option<&Cache>,
) -> Outcome<(Cache, SplatReport)> {
    let width = deposit.width();
    if background.len() != width {
        return Err(Failure::new(format!(
            "a {}-component attribute cannot be splatted into a cache of {} components",
            width,
            background.len()
        )));
    }
    let indexer = Indexer::new(domain)?;
    let bricks = Bricks {
        counts: indexer.cells.map(|n| n.div_ceil(BRICK)),
    };
    let n = particles.len();
    // Pass 1: which bricks are touched, how many particles are outside, the sums.
    let touched: Vec<AtomicBool> = (0..bricks.total())
        .map(|_| AtomicBool::new(false))
        .collect();
    let chunks: Vec<(u64, [f64; 3], f64)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut stencil = [([0usize; 3], 0.0); 8];
            let (mut outside, mut total, mut magnitude) = (0u64, [0.0f64; 3], 0.0f64);
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                let Some(k) = indexer.stencil(particles.positions[i], kernel, &mut stencil) else {
                    outside += 1;
                    continue;
                };
                for (cell, _) in &stencil[..k] {
                    let flag = &touched[bricks.index_of(*cell).0];
                    if !flag.load(Ordering::Relaxed) {
                        flag.store(true, Ordering::Relaxed);
                    }
                }
                let v = deposit.value(i);
                for a in 0..width {
                    total[a] += v[a];
                    magnitude += v[a].abs();
                }
            }
            (outside, total, magnitude)
        })
        .collect();
    let mut report = SplatReport::default();
    let mut magnitude = 0.0;
    for (outside, total, m) in chunks {
        report.outside += outside;
        for a in 0..3 {
            report.total[a] += total[a];
        }
        magnitude += m;
    }
    report.splatted = n as u64 - report.outside;
    if !magnitude.is_finite() {
        return Err(Failure::new(
            "the splatted values add up to more than a float can hold",
        ));
    }
    // The largest power of two that keeps the sum of every |value| below 2^62.
    let scale = if magnitude > 0.0 {
        (62.0 - magnitude.log2().ceil()).min(1000.0).exp2()
    } else {
        1.0
    };
    let touched_count = touched.iter().filter(|t| t.load(Ordering::Relaxed)).count();
    let _accumulators = crate::budget::reserve(
        (touched_count * BRICK_CELLS * width * 8) as f64,
        "splat accumulators",
    )?;
    let sums: Vec<Option<Box<[AtomicI64]>>> = touched
        .iter()
        .map(|t| {
            t.load(Ordering::Relaxed).then(|| {
                (0..BRICK_CELLS * width)
                    .map(|_| AtomicI64::new(0))
                    .collect()
            })
        })
        .collect();
    // Pass 2: add each contribution in fixed point.
    (0..n.div_ceil(CHUNK)).into_par_iter().for_each(|c| {
        let mut stencil = [([0usize; 3], 0.0); 8];
        for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
            let Some(k) = indexer.stencil(particles.positions[i], kernel, &mut stencil) else {
                continue;
            };
            let v = deposit.value(i);
            for (cell, w) in &stencil[..k] {
                let (brick, local) = bricks.index_of(*cell);
                let Some(cells) = &sums[brick] else { continue };
                for a in 0..width {
                    let q = (v[a] * w * scale).round() as i64;
                    if q != 0 {
                        cells[local * width + a].fetch_add(q, Ordering::Relaxed);
                    }
                }
            }
        }
    });
    let mut builder = SparseBuilder::new(domain.clone(), width, background.to_vec())?;
    if let Some(old) = previous {
        for (cell, value) in old.cells() {
            if !touched[bricks.index_of(cell).0].load(Ordering::Relaxed) {
                builder.set(cell, value)?;
            }
        }
    }
    let cells = indexer.cells;
    let mut value = vec![0f32; width];
    for (brick, sum) in sums.iter().enumerate() {
        let Some(sum) = sum else { continue };
        let b = [
            brick % bricks.counts[0],
            (brick / bricks.counts[0]) % bricks.counts[1],
            brick / (bricks.counts[0] * bricks.counts[1]),
        ];
        for local in 0..BRICK_CELLS {
            let cell = [
                b[0] * BRICK + local % BRICK,
                b[1] * BRICK + (local / BRICK) % BRICK,
                b[2] * BRICK + local / (BRICK * BRICK),
            ];
            if (0..3).any(|a| cell[a] >= cells[a]) {
                continue;
            }
            let before: Vec<f64> =
                match previous.and_then(|p| p.value_at_cell(cell[0], cell[1], cell[2])) {
                    Some(v) => v.iter().map(|&x| x as f64).collect(),
                    None => background.to_vec(),
                };
            for a in 0..width {
                let added = sum[local * width + a].load(Ordering::Relaxed) as f64 / scale;
                value[a] = (before[a] + added) as f32;
            }
            builder.set(cell, &value)?;
        }
    }
    Ok((builder.build(), report))
}
