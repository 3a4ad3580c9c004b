//! Majorants: an upper bound of the density over each cell of a coarse grid on the render box,
//! walked cell by cell along a ray.
//!
//! Delta and ratio tracking are exact only where the majorant bounds the density on the whole
//! segment it serves. The bounds come from what felt already knows about a field: its interval
//! range over a box (`FieldSampler::range`: interval evaluation of procedural fields, brick
//! extremes of caches), so a procedural field is path-traced exactly without being voxelised.
//! The one key decision: cells are bounded top-down, halving a box only while its range is not
//! zero, so an empty region costs one range query; each occupied cell gets its own, tighter
//! query. A field whose range is unknown or infinite somewhere in the box cannot be tracked
//! without bias, and says so.

use crate::base::failure::{Failure, Outcome};
use crate::render::camera::Ray;
use crate::space::{Aabb, FieldSampler};
use glam::DVec3;

/// The most cells along the box's longest side: a few range queries per cell over 32³ cells
/// is a fraction of a second for a noise field, and tighter cells shorten every flight.
pub const MAJORANT_CELLS: usize = 32;

/// Upper bounds of the density, one per cell of a grid over the render box.
pub struct Majorants {
    bounds: Aabb,
    counts: [usize; 3],
    cell: DVec3,
    /// The largest density in each cell (x fastest), at least 0.
    density: Vec<f64>,
    /// Cells where the emission may be non-zero: flights must stop there even where the
    /// density is zero, or they would miss the light emitted in empty space.
    emissive: Vec<bool>,
}

/// A stretch `[t0, t1)` of a ray inside one cell, the cell's density bound, and whether the
/// cell may emit light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub t0: f64,
    pub t1: f64,
    pub density: f64,
    pub emissive: bool,
}

impl Majorants {
    /// Bounds `density` over a grid on `bounds` with at most `cells` cells along its longest
    /// side (cells as near cubic as the box allows), and marks where `emission` may glow.
    pub fn build(
        density: &dyn FieldSampler,
        emission: Option<&dyn FieldSampler>,
        bounds: Aabb,
        cells: usize,
    ) -> Outcome<Majorants> {
        let size = bounds.size();
        let side = size.max_element() / cells.max(1) as f64;
        let counts = [0, 1, 2].map(|a| ((size[a] / side).ceil() as usize).clamp(1, cells.max(1)));
        let cell = size / DVec3::new(counts[0] as f64, counts[1] as f64, counts[2] as f64);
        let mut grid = Majorants {
            bounds,
            counts,
            cell,
            density: vec![0.0; counts[0] * counts[1] * counts[2]],
            emissive: vec![false; counts[0] * counts[1] * counts[2]],
        };
        let mut bounded = Vec::new();
        grid.bound(density, [0, 0, 0], counts, &mut bounded)?;
        for (index, value) in bounded {
            grid.density[index] = value;
        }
        if let Some(emission) = emission {
            let mut glowing = Vec::new();
            grid.mark_emissive(emission, [0, 0, 0], counts, &mut glowing);
            for index in glowing {
                grid.emissive[index] = true;
            }
        }
        Ok(grid)
    }

    /// The rate of tentative collisions that samples the emission in an emissive cell whose
    /// density bound is lower: a few per cell along any ray.
    pub fn emission_rate(&self) -> f64 {
        4.0 / self.cell.min_element()
    }

    /// Marks the cells of `[lo, hi)` where `emission` is not certainly zero.
    fn mark_emissive(
        &self,
        emission: &dyn FieldSampler,
        lo: [usize; 3],
        hi: [usize; 3],
        out: &mut Vec<usize>,
    ) {
        let zero = emission
            .range(&self.region(lo, hi))
            .iter()
            .all(|&(a, b)| a == 0.0 && b == 0.0);
        if zero {
            return;
        }
        match self.halves(lo, hi) {
            None => out.push(self.index(lo)),
            Some(((lo1, hi1), (lo2, hi2))) => {
                self.mark_emissive(emission, lo1, hi1, out);
                self.mark_emissive(emission, lo2, hi2, out);
            }
        }
    }

    fn index(&self, c: [usize; 3]) -> usize {
        c[0] + self.counts[0] * (c[1] + self.counts[1] * c[2])
    }

    /// The block `[lo, hi)` halved along its longest side, or `None` for a single cell.
    #[allow(clippy::type_complexity)]
    fn halves(
        &self,
        lo: [usize; 3],
        hi: [usize; 3],
    ) -> Option<(([usize; 3], [usize; 3]), ([usize; 3], [usize; 3]))> {
        let extent = [0, 1, 2].map(|a| hi[a] - lo[a]);
        if extent == [1, 1, 1] {
            return None;
        }
        let axis = (0..3).max_by_key(|&a| (extent[a], 3 - a)).unwrap_or(0);
        let middle = lo[axis] + extent[axis] / 2;
        let (mut first_hi, mut second_lo) = (hi, lo);
        first_hi[axis] = middle;
        second_lo[axis] = middle;
        Some(((lo, first_hi), (second_lo, hi)))
    }

    /// The box of cells `[lo, hi)`.
    fn region(&self, lo: [usize; 3], hi: [usize; 3]) -> Aabb {
        super::super::space::lattice_region(&self.bounds, self.cell, self.counts, lo, hi)
    }

    /// Bounds the cells `[lo, hi)`: nothing to record where the density is at most 0, else
    /// halves the block along its longest side down to single cells.
    fn bound(
        &self,
        density: &dyn FieldSampler,
        lo: [usize; 3],
        hi: [usize; 3],
        out: &mut Vec<(usize, f64)>,
    ) -> Outcome<()> {
        // Padded by a millionth of a cell, so a sample that rounding puts just outside its
        // cell is still bounded.
        let pad = self.cell * 1e-6;
        let region = self.region(lo, hi);
        let region = Aabb::new(region.min - pad, region.max + pad);
        let (_, top) = density.range(&region)[0];
        if top.is_nan() || top == f64::INFINITY {
            return Err(Failure::new(format!(
                "the path tracer needs a bound on the density, and its range between {} and {} \
                 is unknown",
                region.min, region.max
            ))
            .with_help(
                "a density read from a cache or built from felt's field operations has known \
                 bounds; the march renders any density",
            ));
        }
        if top <= 0.0 {
            return Ok(());
        }
        match self.halves(lo, hi) {
            None => {
                out.push((self.index(lo), top));
                Ok(())
            }
            Some(((lo1, hi1), (lo2, hi2))) => {
                self.bound(density, lo1, hi1, out)?;
                self.bound(density, lo2, hi2, out)
            }
        }
    }

    /// How many cells the grid has, and how many are certainly empty.
    pub fn cells(&self) -> usize {
        self.density.len()
    }

    pub fn empty_cells(&self) -> usize {
        self.density.iter().filter(|&&d| d <= 0.0).count()
    }

    /// The largest density bound of any cell: what a flight would use with one majorant.
    pub fn largest(&self) -> f64 {
        self.density.iter().copied().fold(0.0, f64::max)
    }

    /// The box the majorants cover.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Whether any cell overlapping `region` may hold density (parts outside the box hold
    /// none).
    pub fn any_density(&self, region: &Aabb) -> bool {
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        for a in 0..3 {
            let from = (region.min[a] - self.bounds.min[a]) / self.cell[a];
            let to = (region.max[a] - self.bounds.min[a]) / self.cell[a];
            if to < 0.0 || from >= self.counts[a] as f64 {
                return false;
            }
            lo[a] = from.floor().max(0.0) as usize;
            hi[a] = (to.floor().max(0.0) as usize).min(self.counts[a] - 1);
        }
        (lo[2]..=hi[2]).any(|k| {
            (lo[1]..=hi[1])
                .any(|j| (lo[0]..=hi[0]).any(|i| self.density[self.index([i, j, k])] > 0.0))
        })
    }

    /// The density bound of the cell holding `p` (clamped into the grid).
    pub fn at(&self, p: DVec3) -> f64 {
        let c = [0, 1, 2].map(|a| {
            let local = (p[a] - self.bounds.min[a]) / self.cell[a];
            (local.floor().max(0.0) as usize).min(self.counts[a] - 1)
        });
        self.density[self.index(c)]
    }

    /// A walk over the cells `ray` crosses between `t0` and `t1` (both inside the box).
    pub fn walk(&self, ray: &Ray, t0: f64, t1: f64) -> CellWalk<'_> {
        let start = ray.at(t0);
        let mut cell = [0i64; 3];
        let mut t_next = [f64::INFINITY; 3];
        let mut t_delta = [f64::INFINITY; 3];
        let mut step = [0i64; 3];
        for axis in 0..3 {
            let n = self.counts[axis] as i64;
            let local = (start[axis] - self.bounds.min[axis]) / self.cell[axis];
            let c = (local.floor() as i64).clamp(0, n - 1);
            cell[axis] = c;
            let d = ray.direction[axis];
            if d != 0.0 {
                step[axis] = if d > 0.0 { 1 } else { -1 };
                let edge =
                    self.bounds.min[axis] + (c + i64::from(d > 0.0)) as f64 * self.cell[axis];
                t_next[axis] = t0 + (edge - start[axis]) / d;
                t_delta[axis] = self.cell[axis] / d.abs();
            }
        }
        CellWalk {
            grid: self,
            t: t0,
            t1,
            cell,
            step,
            t_next,
            t_delta,
        }
    }
}

/// A 3D DDA over the majorant cells along a ray, one `Segment` per cell.
pub struct CellWalk<'a> {
    grid: &'a Majorants,
    t: f64,
    t1: f64,
    cell: [i64; 3],
    step: [i64; 3],
    t_next: [f64; 3],
    t_delta: [f64; 3],
}

impl Iterator for CellWalk<'_> {
    type Item = Segment;

    fn next(&mut self) -> Option<Segment> {
        if self.t >= self.t1 {
            return None;
        }
        let counts = self.grid.counts;
        if (0..3).any(|a| self.cell[a] < 0 || self.cell[a] >= counts[a] as i64) {
            return None;
        }
        let index = self.grid.index(self.cell.map(|c| c as usize));
        let axis = (0..3)
            .min_by(|&a, &b| self.t_next[a].total_cmp(&self.t_next[b]))
            .unwrap_or(0);
        let exit = self.t_next[axis].min(self.t1).max(self.t);
        let segment = Segment {
            t0: self.t,
            t1: exit,
            density: self.grid.density[index],
            emissive: self.grid.emissive[index],
        };
        self.t = exit;
        self.cell[axis] += self.step[axis];
        self.t_next[axis] += self.t_delta[axis];
        Some(segment)
    }
}
