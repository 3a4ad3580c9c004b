//! Ranges of a cache: what its interpolant can reach over a region, for interval evaluation,
//! brick skipping and a render's empty space.
//!
//! The range covers the *interpolant*, not only the stored samples: cubic weights can be
//! negative and the border extrapolates, so the samples' range is widened around its midpoint
//! by the largest sum of absolute weights that can occur in the region (see `grid::reach`). A
//! region whose samples are all zero gets exactly zero, so empty space stays exactly empty. The
//! one key decision is how finely the samples are looked at: whole bricks' extremes where a
//! region covers a brick, and where it covers part of one, the extremes of its own cells when
//! the region is small (`EXACT_RANGE_CELLS`), else the brick's bit rows of non-zero cells. So a
//! render's empty-space grid finds the empty cells beside a surface, not only the empty bricks.

use super::{BRICK, Cache, local_index};
use crate::grid::reach;
use crate::space::{Aabb, GridSource, Interp};
use glam::{BVec3, DVec3};

/// A range over at most this many cells (six per axis) reads the cells themselves where it
/// covers part of a brick, rather than the whole brick's extremes: a render's empty-space bricks
/// at a one-voxel step are four cells across, and a cache brick that holds a surface is mostly
/// empty on one side of it. Larger regions ask the brick's bit rows, which only tell zero from
/// not zero (reading the cells of regions up to 512 cells made the render's empty-space build a
/// fifth slower and skipped nothing more).
const EXACT_RANGE_CELLS: usize = 216;

impl Cache {
    /// What the interpolant of reads through `interp` can reach over `region`, filling the
    /// bricks it needs on the calling thread; for reads that hold the outermost cells in the
    /// half-cell border when `held`.
    pub(super) fn range_of(&self, region: &Aabb, interp: Interp, held: bool) -> Vec<(f64, f64)> {
        let lattice = self.domain.lattice();
        reach::range(
            &lattice,
            region,
            interp,
            held,
            &self.background,
            BRICK,
            |b, reach, samples| {
                let index = self.shape.brick_index(b);
                let brick = self.brick(index);
                let (lo, hi) = self.shape.brick_cells(index);
                let first: [usize; 3] = std::array::from_fn(|a| reach.first[a].max(lo[a]));
                let last: [usize; 3] = std::array::from_fn(|a| reach.last[a].min(hi[a] - 1));
                let part: usize = (0..3).map(|a| last[a] + 1 - first[a]).product();
                let whole = first == lo && (0..3).all(|a| last[a] + 1 == hi[a]);
                let exact = reach.cells() <= EXACT_RANGE_CELLS && !whole;
                match brick.values.as_deref() {
                    Some(values) if exact && part > 0 => {
                        self.merge_cells(values, lo, first, last, samples)
                    }
                    // A larger region's part of the brick may still be all zeros, as beside a
                    // surface: the brick's bit rows say so without reading its cells.
                    Some(_)
                        if !whole
                            && part > 0
                            && brick
                                .nonzero
                                .as_deref()
                                .is_some_and(|rows| all_zero(rows, lo, first, last)) =>
                    {
                        for (low, high) in samples.iter_mut() {
                            *low = low.min(0.0);
                            *high = high.max(0.0);
                        }
                    }
                    _ => {
                        for (c, (low, high)) in samples.iter_mut().enumerate() {
                            *low = low.min(f64::from(brick.range[c].0));
                            *high = high.max(f64::from(brick.range[c].1));
                        }
                    }
                }
            },
        )
    }

    /// Merges into `samples` the extremes of the cells `first..=last` (grid cells, all inside
    /// the brick whose first cell is `lo` and whose values are `values`); a NaN makes its
    /// component's range unbounded, as a brick's own range does.
    fn merge_cells(
        &self,
        values: &[f32],
        lo: [usize; 3],
        first: [usize; 3],
        last: [usize; 3],
        samples: &mut [(f64, f64)],
    ) {
        let w = self.width;
        for z in first[2]..=last[2] {
            for y in first[1]..=last[1] {
                let row = local_index(first[0] - lo[0], y - lo[1], z - lo[2]) * w;
                let cells = &values[row..row + (last[0] + 1 - first[0]) * w];
                for (c, (low, high)) in samples.iter_mut().enumerate() {
                    // `f32::min` and `max` pass over NaN, so it is looked for on its own, in
                    // the same branch-free fold; a scalar cache's row is read without a stride.
                    let extremes = |(least, most, nan): (f32, f32, bool), &v: &f32| {
                        (least.min(v), most.max(v), nan | v.is_nan())
                    };
                    let start = (f32::INFINITY, f32::NEG_INFINITY, false);
                    let (least, most, nan) = if w == 1 {
                        cells.iter().fold(start, extremes)
                    } else {
                        cells.iter().skip(c).step_by(w).fold(start, extremes)
                    };
                    if nan {
                        (*low, *high) = (f64::NEG_INFINITY, f64::INFINITY);
                    } else {
                        *low = low.min(f64::from(least));
                        *high = high.max(f64::from(most));
                    }
                }
            }
        }
    }

    /// A conservative range of the extrapolating read over `region`. Inside the box it
    /// is the ordinary range; `d` cells beyond the outermost centre along an axis, linear
    /// weights `(1 + d, −d)` sum to `1 + 2d` in absolute value, so the samples' range is
    /// widened by the product of those sums.
    pub fn range_extrapolated(&self, region: &Aabb) -> Vec<(f64, f64)> {
        if region.is_empty() {
            return self.range(region);
        }
        if !region.is_finite() {
            return vec![(f64::NEG_INFINITY, f64::INFINITY); self.width];
        }
        let (lo, hi, _) = reach::index_box(&self.domain.lattice(), region);
        let mut widen = 1.0;
        for a in 0..3 {
            let last = (self.shape.cells[a] - 1) as f64;
            let beyond = (-lo[a]).max(hi[a] - last).max(0.0);
            if self.shape.cells[a] > 1 {
                widen *= 1.0 + 2.0 * beyond;
            }
        }
        // The cells that feed the extrapolation are those nearest the region inside the box.
        let inside = |u: f64, a: usize| {
            (u.clamp(-0.5, self.shape.cells[a] as f64 - 0.5) + 0.5) * self.domain.cell[a]
        };
        let corner_lo = DVec3::new(inside(lo.x, 0), inside(lo.y, 1), inside(lo.z, 2));
        let corner_hi = DVec3::new(inside(hi.x, 0), inside(hi.y, 1), inside(hi.z, 2));
        let mut clamped = Aabb::new(DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for n in 0..8 {
            let pick = BVec3::new(n & 1 != 0, n & 2 != 0, n & 4 != 0);
            let local = DVec3::select(pick, corner_hi, corner_lo);
            let world = self.domain.local_to_world(local);
            clamped.min = clamped.min.min(world);
            clamped.max = clamped.max.max(world);
        }
        // A touch inside, so the clamped box never reads as leaving the domain.
        let shrink = (clamped.size() * 1e-9).max(DVec3::ZERO);
        let clamped = Aabb::new(clamped.min + shrink, clamped.max - shrink);
        self.range(&clamped)
            .into_iter()
            .map(|(low, high)| {
                if widen == 1.0 || low == high {
                    (low, high)
                } else {
                    let middle = 0.5 * (low + high);
                    let radius = 0.5 * (high - low) * widen * (1.0 + 1e-12);
                    (middle - radius, middle + radius)
                }
            })
            .collect()
    }
}

/// Whether every cell `first..=last` (grid cells, inside the brick whose first cell is `lo`)
/// has its bit clear in the brick's `nonzero` rows: then they all hold exactly zero.
fn all_zero(
    nonzero: &[u8; BRICK * BRICK],
    lo: [usize; 3],
    first: [usize; 3],
    last: [usize; 3],
) -> bool {
    let run = last[0] + 1 - first[0];
    let bits = (((1u16 << run) - 1) << (first[0] - lo[0])) as u8;
    (first[2]..=last[2]).all(|z| {
        (first[1]..=last[1]).all(|y| nonzero[(y - lo[1]) + BRICK * (z - lo[2])] & bits == 0)
    })
}
