//! Splatting: accumulating a particle attribute into the cells of a cache (000 §2.2).
//!
//! The key decision: contributions are summed in 64-bit fixed point. One power of two, chosen
//! so that the sum of every particle's |value| maps into (2⁶¹, 2⁶²], scales each value; the
//! scaled value is rounded to an integer `q` once, each stencil cell but the last gets its
//! weight's share rounded to an integer, and the last cell gets what is left of `q`. Integer
//! addition is exact and order-free, so the grid is bit-identical for any thread count and any
//! order of particles, no cell can overflow, and the total written is exactly the sum of the
//! particles' rounded values: it differs from the total splatted by at most half a unit
//! (under 2⁻⁶² of the sum of |value|) per particle, far below the `f32` rounding of the cells.
//!
//! For speed, nothing is shared between threads while adding: particles are binned by the
//! bricks their stencils reach and each brick is added up by one task (`splat_bins`), and
//! bricks are handed to the cache whole. Only the 8³ bricks a stencil reaches get storage; the
//! others keep the previous state's values.
//!
//! Kernels: `Trilinear` spreads a value over the eight cell centres around it with trilinear
//! weights (summing to one); `Nearest` gives it all to the nearest cell centre. Weight that
//! would fall beyond the outermost cell centres goes to the border cell, so every particle
//! inside the domain deposits its whole value. The domain is half-open: a particle on its far
//! faces, or anywhere outside, is not splatted and is counted.

use super::Particles;
use super::splat_bins::{Bins, Entry, bin};
use crate::base::failure::{Failure, Outcome};
use crate::grid::cache::{BRICK, BRICK_CELLS, Cache, SparseBuilder};
use crate::space::domain::Domain;
use glam::{DMat3, DVec3};

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
}

/// What a splat did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SplatReport {
    pub splatted: u64,
    pub outside: u64,
    /// Sum of the deposited values per component, in `f64`.
    pub total: [f64; 3],
}

/// Edge of a brick's scratch accumulator: the brick and one layer of cells on every side,
/// where the stencils of particles near its faces begin or end.
pub(super) const PAD: usize = BRICK + 2;
/// Cells in a brick's scratch accumulator.
pub(super) const PADDED: usize = PAD * PAD * PAD;

/// Where a particle lands: the first cell of its stencil, the step (0 or 1) to the second
/// cell along each axis, and the fraction of the value that goes to the second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Landing {
    pub cell: [usize; 3],
    pub step: [usize; 3],
    frac: [f64; 3],
}

/// Maps world positions to continuous cell indices (cell `(i, j, k)` spans `[i, i + 1)`, its
/// centre at `i + 0.5`).
pub(super) struct Indexer {
    origin: DVec3,
    to_index: DMat3,
    /// The diagonal of `to_index` when the domain is not rotated: one product per axis
    /// instead of three, with the same landing (the dropped terms are zeros).
    axis_scale: Option<DVec3>,
    pub cells: [usize; 3],
    limit: [f64; 3],
    pub kernel: Kernel,
}

impl Indexer {
    pub(super) fn new(domain: &Domain, kernel: Kernel) -> Outcome<Indexer> {
        let cells = domain
            .resolution
            .ok_or_else(|| Failure::new("splat needs a cache on a domain with cells"))?;
        Ok(Indexer {
            origin: domain.origin,
            to_index: DMat3::from_diagonal(DVec3::ONE / domain.cell) * domain.rotation.transpose(),
            axis_scale: (domain.rotation == DMat3::IDENTITY).then(|| DVec3::ONE / domain.cell),
            cells,
            limit: cells.map(|n| n as f64),
            kernel,
        })
    }

    /// The same indexer, landing every particle through the full matrix.
    #[cfg(test)]
    pub(super) fn through_the_matrix(self) -> Indexer {
        Indexer {
            axis_scale: None,
            ..self
        }
    }

    /// Where a particle at `p` lands, or `None` outside the domain (NaN included). Floors are
    /// truncations of positive numbers: without SSE4.1 `f64::floor` is a library call.
    #[inline]
    pub fn land(&self, p: [f32; 3]) -> Option<Landing> {
        let offset = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) - self.origin;
        let u = match self.axis_scale {
            Some(scale) => scale * offset,
            None => self.to_index * offset,
        }
        .to_array();
        let inside = (u[0] >= 0.0 && u[0] < self.limit[0])
            & (u[1] >= 0.0 && u[1] < self.limit[1])
            & (u[2] >= 0.0 && u[2] < self.limit[2]);
        if !inside {
            return None;
        }
        let mut landing = Landing {
            cell: [0; 3],
            step: [0; 3],
            frac: [0.0; 3],
        };
        for a in 0..3 {
            let last = self.cells[a] - 1;
            match self.kernel {
                // The nearest centre is that of the cell holding u: floor(u).
                Kernel::Nearest => landing.cell[a] = (u[a] as usize).min(last),
                // The stencil starts at the centre below u, floor(u - 0.5) = floor(u + 0.5) - 1;
                // before the first centre or past the last, both weights go to the border cell.
                Kernel::Trilinear => {
                    let t = u[a] + 0.5;
                    let above = t as usize;
                    let first = above.saturating_sub(1).min(last);
                    landing.cell[a] = first;
                    landing.step[a] = above.min(last) - first;
                    landing.frac[a] = t - above as f64;
                }
            }
        }
        Some(landing)
    }
}

/// Rounds to the nearest integer, halves away from zero: a conversion, not a library call.
/// Every value rounded here is at most 2⁶² in magnitude (the scale sees to it), where the
/// processor's truncating conversion is exact; it skips the NaN and range checks of `as`,
/// several instructions for each of a dot's shares.
#[inline]
pub(super) fn fixed(x: f64) -> i64 {
    let rounded = x + 0.5f64.copysign(x);
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_cvttsd_si64, _mm_set_sd};
        // SAFETY: SSE2 is part of every x86_64 processor.
        unsafe { _mm_cvttsd_si64(_mm_set_sd(rounded)) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        rounded as i64
    }
}

/// Adds the binned particles `bin` (each with a stencil cell in the brick whose first cell is
/// `first_cell`) into the brick's scratch accumulator `acc`, `W` components per cell. Each
/// particle's shares are computed whole, the same in every brick it reaches, and only the
/// padding catches the cells of other bricks.
pub(super) fn accumulate<const W: usize>(
    indexer: &Indexer,
    bin: &[Entry<W>],
    scale: f64,
    first_cell: [usize; 3],
    acc: &mut [i64],
) {
    for entry in bin {
        let Some(l) = indexer.land(entry.position) else {
            continue;
        };
        // One cell of padding below the brick: a stencil may start in the brick below.
        let local = [0, 1, 2].map(|a| l.cell[a] + 1 - first_cell[a]);
        let at = local[0] + PAD * (local[1] + PAD * local[2]);
        let v = entry.value.map(|x| x as f64);
        if indexer.kernel == Kernel::Nearest {
            for c in 0..W {
                acc[at * W + c] += fixed(v[c] * scale);
            }
            continue;
        }
        let (sx, sy, sz) = (l.step[0], l.step[1] * PAD, l.step[2] * PAD * PAD);
        let cells = [
            at,
            at + sx,
            at + sy,
            at + sx + sy,
            at + sz,
            at + sx + sz,
            at + sy + sz,
            at + sx + sy + sz,
        ];
        let weights = l.weights();
        for c in 0..W {
            shares(v[c] * scale, &weights, |corner, q| {
                acc[cells[corner] * W + c] += q
            });
        }
    }
}

impl Landing {
    /// The trilinear weights of the stencil's first seven corners (corner bit 0 steps along x,
    /// bit 1 along y, bit 2 along z); the eighth gets what is left.
    #[inline]
    pub(super) fn weights(&self) -> [f64; 7] {
        let [fx, fy, fz] = self.frac;
        let (gx, gy, gz) = (1.0 - fx, 1.0 - fy, 1.0 - fz);
        let (lo_yz, hi_y, hi_z, hi_yz) = (gy * gz, fy * gz, gy * fz, fy * fz);
        [
            gx * lo_yz,
            fx * lo_yz,
            gx * hi_y,
            fx * hi_y,
            gx * hi_z,
            fx * hi_z,
            gx * hi_yz,
        ]
    }
}

/// Splits one particle's scaled value over the trilinear stencil: `add(corner, q)` for the
/// eight corners, each of the first seven getting its weight's share rounded to an integer and
/// the last what is left, so the shares add up to the rounded value exactly.
#[inline]
pub(super) fn shares(scaled: f64, weights: &[f64; 7], mut add: impl FnMut(usize, i64)) {
    let mut rest = fixed(scaled);
    for (corner, w) in weights.iter().enumerate() {
        let q = fixed(scaled * w);
        add(corner, q);
        rest -= q;
    }
    add(7, rest);
}

/// The interior of a scratch accumulator, the brick's own cells in brick order.
pub(super) fn interior<const W: usize>(acc: &[i64], out: &mut [i64]) {
    for z in 0..BRICK {
        for y in 0..BRICK {
            let from = (1 + PAD * ((y + 1) + PAD * (z + 1))) * W;
            let to = BRICK * (y + BRICK * z) * W;
            out[to..to + BRICK * W].copy_from_slice(&acc[from..from + BRICK * W]);
        }
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
    let indexer = Indexer::new(domain, kernel)?;
    check_shape(width, background, previous, &indexer)?;
    let positions = &particles.positions;
    match deposit {
        Deposit::One => run::<1>(&indexer, positions, |_| [1.0], domain, background, previous),
        Deposit::Float(v) => run::<1>(
            &indexer,
            positions,
            |i| [v[i]],
            domain,
            background,
            previous,
        ),
        Deposit::Vector(v) => run::<3>(&indexer, positions, |i| v[i], domain, background, previous),
    }
}

/// Fails when a cache of `background.len()` components, holding `previous`, cannot take a
/// `width`-component splat on the indexer's cells.
pub(super) fn check_shape(
    width: usize,
    background: &[f64],
    previous: Option<&Cache>,
    indexer: &Indexer,
) -> Outcome<()> {
    if background.len() != width {
        return Err(Failure::new(format!(
            "a {width}-component value cannot be splatted into a cache of {} components",
            background.len()
        )));
    }
    if let Some(old) = previous
        && (old.width() != width || old.resolution() != indexer.cells)
    {
        return Err(Failure::new(
            "the cache splatted onto has another shape than the splat's domain",
        ));
    }
    Ok(())
}

fn run<const W: usize>(
    indexer: &Indexer,
    positions: &[[f32; 3]],
    value: impl Fn(usize) -> [f32; W] + Sync,
    domain: &Domain,
    background: &[f64],
    previous: Option<&Cache>,
) -> Outcome<(Cache, SplatReport)> {
    let target = Target {
        domain,
        background,
        previous,
        counts: indexer.cells.map(|c| c.div_ceil(BRICK)),
    };
    let finish = |b: usize, sums: &[i64], scale: f64| target.values::<W>(b, sums, scale);
    let Bins { report, bricks } = bin(indexer, positions, &value, &finish)?;
    Ok((target.assemble(W, bricks)?, report))
}

/// The cache a splat adds into: its domain, background and earlier state.
pub(super) struct Target<'a> {
    pub domain: &'a Domain,
    pub background: &'a [f64],
    pub previous: Option<&'a Cache>,
    /// Bricks along each axis.
    pub counts: [usize; 3],
}

impl Target<'_> {
    /// Brick `b`'s new values: the earlier state's (or the background) plus the integer sums
    /// divided by the fixed-point scale.
    pub(super) fn values<const W: usize>(&self, b: usize, sums: &[i64], scale: f64) -> Box<[f32]> {
        self.values_of::<W>(b, sums, W, 0, scale)
    }

    /// As `values`, from sums of `stride` components per cell whose `W` components start at
    /// `first`.
    pub(super) fn values_of<const W: usize>(
        &self,
        b: usize,
        sums: &[i64],
        stride: usize,
        first: usize,
        scale: f64,
    ) -> Box<[f32]> {
        let inverse = 1.0 / scale;
        let before = self
            .previous
            .and_then(|p| p.brick_values_at(brick_coords(b, self.counts)));
        let mut out = vec![0f32; BRICK_CELLS * W].into_boxed_slice();
        let cells = out.chunks_exact_mut(W).zip(sums.chunks_exact(stride));
        match before {
            Some(v) => {
                for ((o, sum), b) in cells.zip(v.chunks_exact(W)) {
                    for c in 0..W {
                        o[c] = (b[c] as f64 + sum[first + c] as f64 * inverse) as f32;
                    }
                }
            }
            None => {
                for (o, sum) in cells {
                    for c in 0..W {
                        o[c] = (self.background[c] + sum[first + c] as f64 * inverse) as f32;
                    }
                }
            }
        }
        out
    }

    /// The new cache state: the bricks reached (ascending, with their new values), and the
    /// earlier state's other bricks as they were.
    pub(super) fn assemble(
        &self,
        width: usize,
        bricks: Vec<(usize, Box<[f32]>)>,
    ) -> Outcome<Cache> {
        let mut builder = SparseBuilder::new(self.domain.clone(), width, self.background.to_vec())?;
        if let Some(old) = self.previous {
            let mut reached = bricks.iter().map(|(b, _)| *b).peekable();
            for b in 0..self.counts.iter().product() {
                if reached.next_if_eq(&b).is_some() {
                    continue;
                }
                let at = brick_coords(b, self.counts);
                if old.brick_stored(at) {
                    let kept = old.brick_values_at(at).unwrap_or_default();
                    builder.set_brick(at, kept.into())?;
                }
            }
        }
        for (b, values) in bricks {
            builder.set_brick(brick_coords(b, self.counts), values)?;
        }
        Ok(builder.build())
    }
}

fn brick_coords(index: usize, counts: [usize; 3]) -> [usize; 3] {
    [
        index % counts[0],
        (index / counts[0]) % counts[1],
        index / (counts[0] * counts[1]),
    ]
}
