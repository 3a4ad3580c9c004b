//! Reach: which cells of a grid a region of space can read, and the range of values the
//! interpolant can take there — the interval form of a grid read, shared by caches and dense
//! solve results.
//!
//! The one key decision: the range is computed from the *samples* the region's stencils touch,
//! then widened about its midpoint by the largest sum of absolute interpolation weights that
//! can occur there (`interp`'s bounds: cubic weights go negative, the border extrapolates), so
//! it is conservative for every interpolation rule; a region whose samples are all zero gets
//! exactly zero, so empty space stays exactly empty. Reads through a known rule reach only the
//! cells that rule reads (two per axis for a linear read, four for a cubic one).

use crate::grid::interp::{BORDER_WEIGHT_BOUND, CUBIC_WEIGHT_BOUND};
use crate::space::{Aabb, Interp, Lattice};
use glam::{BVec3, DVec3};

/// The cells a region reads along each axis and the weight bound that applies there.
pub struct Reach {
    /// First and last cell along each axis (inclusive).
    pub first: [usize; 3],
    pub last: [usize; 3],
    /// The product over axes of the largest sum of absolute weights.
    pub spread: f64,
    /// Whether the region reaches outside the domain box (so the background is in range).
    pub leaves: bool,
}

/// The continuous index coordinates of the corners of `region`, as a box (`lo`, `hi`), and
/// whether any corner lies outside the domain box. An unbounded region spans everything.
pub fn index_box(lattice: &Lattice, region: &Aabb) -> (DVec3, DVec3, bool) {
    if !region.is_finite() {
        return (
            DVec3::splat(f64::NEG_INFINITY),
            DVec3::splat(f64::INFINITY),
            true,
        );
    }
    let to_local = lattice.rotation.transpose();
    let lengths = lattice.cell * DVec3::from_array(lattice.counts.map(|n| n as f64));
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut leaves = false;
    for n in 0..8 {
        let pick = BVec3::new(n & 1 != 0, n & 2 != 0, n & 4 != 0);
        let corner = DVec3::select(pick, region.max, region.min);
        let local = to_local * (corner - lattice.origin);
        leaves |= !(local.cmpge(DVec3::ZERO).all() && local.cmple(lengths).all());
        let u = local / lattice.cell - DVec3::splat(0.5);
        lo = lo.min(u);
        hi = hi.max(u);
    }
    (lo, hi, leaves)
}

impl Reach {
    /// How many cells the region reads.
    pub fn cells(&self) -> usize {
        (0..3).map(|a| self.last[a] + 1 - self.first[a]).product()
    }
}

/// What `region` reads of a grid on `lattice` through `interp`; `None` when it misses the
/// domain box.
pub fn reach(lattice: &Lattice, region: &Aabb, interp: Interp) -> Option<Reach> {
    reach_of(lattice, region, interp, false)
}

/// As [`reach`], for reads that hold the outermost cells' values in the half-cell border when
/// `held` (`outside = "hold"`): a linear read's weights are then convex there too.
pub fn reach_of(lattice: &Lattice, region: &Aabb, interp: Interp, held: bool) -> Option<Reach> {
    let (lo, hi, leaves) = index_box(lattice, region);
    let mut first = [0usize; 3];
    let mut last = [0usize; 3];
    let mut spread = 1.0;
    for a in 0..3 {
        let cells = lattice.counts[a];
        let low = lo[a].max(-0.5);
        let high = hi[a].min(cells as f64 - 0.5);
        if low.partial_cmp(&high).is_none_or(|o| o.is_gt()) {
            return None;
        }
        let inside = low >= 0.0 && high <= (cells - 1) as f64;
        match interp {
            Interp::Cubic => {
                // A cubic stencil reads one cell below floor(u) and two above.
                first[a] = (low.floor() - 1.0).max(0.0) as usize;
                last[a] = ((high.floor() + 2.0).max(0.0) as usize).min(cells - 1);
            }
            Interp::Linear => {
                // A linear stencil reads the cell at or below u, kept below the last cell, and
                // the next one (`interp::axis_stencil`).
                let below = |u: f64| (u.max(0.0).floor() as usize).min(cells.saturating_sub(2));
                first[a] = below(low);
                last[a] = (below(high) + 1).min(cells - 1);
            }
        }
        spread *= if cells == 1 || (held && interp == Interp::Linear && !inside) {
            1.0
        } else if !inside {
            BORDER_WEIGHT_BOUND
        } else if interp == Interp::Cubic {
            CUBIC_WEIGHT_BOUND
        } else {
            // Linear weights inside the box are convex.
            1.0
        };
    }
    Some(Reach {
        first,
        last,
        spread,
        leaves,
    })
}

/// The interpolant's range from the samples' range per component: widened by `spread` (and
/// the rounding of a sum of up to 64 weighted samples), unbounded if a sample is not finite,
/// joined with the background where the region leaves the domain.
pub fn widen(samples: Vec<(f64, f64)>, background: &[f64], reach: &Reach) -> Vec<(f64, f64)> {
    samples
        .into_iter()
        .zip(background)
        .map(|((low, high), &b)| {
            // Zeros sum to exactly zero whatever the weights; any other value may come back an
            // ulp or so off, since rounded weights need not sum to exactly one.
            let (low, high) = if low == 0.0 && high == 0.0 {
                (low, high)
            } else if low.is_finite() && high.is_finite() {
                let middle = 0.5 * (low + high);
                let rounding = 128.0 * f64::EPSILON * reach.spread * low.abs().max(high.abs());
                let radius = 0.5 * (high - low) * reach.spread + rounding;
                (middle - radius, middle + radius)
            } else {
                (f64::NEG_INFINITY, f64::INFINITY)
            };
            if reach.leaves {
                (low.min(b), high.max(b))
            } else {
                (low, high)
            }
        })
        .collect()
}

/// The range of a grid read over `region`: the blocks of `block` cells per side that its
/// stencils reach, each block's per-component extremes merged by `merge_block` (given the
/// block's coordinates, the first and last cell the region reads, and the running extremes),
/// widened as [`widen`] says (for held reads when `held`, see [`reach_of`]). Outside the domain,
/// or for an empty region, the background.
pub fn range(
    lattice: &Lattice,
    region: &Aabb,
    interp: Interp,
    held: bool,
    background: &[f64],
    block: usize,
    mut merge_block: impl FnMut([usize; 3], &Reach, &mut [(f64, f64)]),
) -> Vec<(f64, f64)> {
    let flat: Vec<(f64, f64)> = background.iter().map(|&b| (b, b)).collect();
    if region.is_empty() {
        return flat;
    }
    let Some(reach) = reach_of(lattice, region, interp, held) else {
        return flat;
    };
    let mut samples = vec![(f64::INFINITY, f64::NEG_INFINITY); background.len()];
    for bz in reach.first[2] / block..=reach.last[2] / block {
        for by in reach.first[1] / block..=reach.last[1] / block {
            for bx in reach.first[0] / block..=reach.last[0] / block {
                merge_block([bx, by, bz], &reach, &mut samples);
            }
        }
    }
    let lows: Vec<f64> = samples.iter().map(|s| s.0).collect();
    let mut ranges = widen(samples, background, &reach);
    if held && reach.spread == 1.0 {
        // Convex weights of samples that are all at least zero give at least zero in floating
        // point too (every product and partial sum is), so the rounding allowance need not
        // reach below zero: a held read of a non-negative cache is provably non-negative.
        for ((range, low), &b) in ranges.iter_mut().zip(lows).zip(background) {
            if low >= 0.0 {
                let floor = if reach.leaves { b.min(0.0) } else { 0.0 };
                range.0 = range.0.max(floor);
            }
        }
    }
    ranges
}
