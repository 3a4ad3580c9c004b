//! The contract between whatever produces values at points and whatever consumes them.
//!
//! Producers are compiled fields (`field`), grids (`grid`: caches, files, FFT results) and
//! anything later features add; consumers are cache fills, the raymarcher, mesh extraction and
//! inspection builtins. Both sides meet here, in a handful of small traits, so that neither
//! needs the other's internals. The one key decision: values move in *blocks* of up to
//! `BLOCK` points, as separate x/y/z slices (structure of arrays), so every per-point cost of
//! dispatch or interpretation is paid once per block instead of once per point.
//! Positions are always `f64` world coordinates; values come back in `f32` (storage and
//! rendering precision) or `f64` (inspection precision), component-major:
//! component `c` of point `i` is `out[c * n + i]`.

pub mod demand;
pub mod domain;

use crate::base::failure::Outcome;
use crate::space::domain::Domain;
use glam::{DMat3, DVec3};
use std::fmt::Debug;
use std::sync::Arc;

/// The largest number of points in one evaluation block.
pub const BLOCK: usize = 256;

/// An axis-aligned box in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: DVec3,
    pub max: DVec3,
}

impl Aabb {
    pub fn new(min: DVec3, max: DVec3) -> Aabb {
        Aabb { min, max }
    }

    /// The box of all space; what a field with no known support reports.
    pub fn everything() -> Aabb {
        Aabb::new(DVec3::splat(f64::NEG_INFINITY), DVec3::splat(f64::INFINITY))
    }

    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y && self.min.z <= self.max.z)
    }

    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }

    pub fn intersection(&self, other: &Aabb) -> Aabb {
        Aabb::new(self.min.max(other.min), self.max.min(other.max))
    }

    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb::new(self.min.min(other.min), self.max.max(other.max))
    }

    pub fn contains(&self, p: DVec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// The eight corners; bit 0 of the index picks x's end, bit 1 y's, bit 2 z's.
    pub fn corners(&self) -> [DVec3; 8] {
        let pick = |k: usize, bit: usize, lo: f64, hi: f64| if k & bit == 0 { lo } else { hi };
        std::array::from_fn(|k| {
            DVec3::new(
                pick(k, 1, self.min.x, self.max.x),
                pick(k, 2, self.min.y, self.max.y),
                pick(k, 4, self.min.z, self.max.z),
            )
        })
    }

    pub fn size(&self) -> DVec3 {
        self.max - self.min
    }

    pub fn center(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }
}

/// How a grid interpolates between its samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Interp {
    /// Trilinear between the eight nearest cell centres.
    #[default]
    Linear,
    /// Catmull-Rom (Keys, a = -1/2) over the 4x4x4 nearest cell centres: third-order accurate.
    Cubic,
}

/// How the gradient of a grid-backed field is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum GridDerivative {
    /// The exact derivative of the interpolating function.
    #[default]
    Interpolant,
    /// Central differences of the interpolated field at one cell size.
    Central,
}

/// Where a grid's samples sit: the centre of cell `(i, j, k)` is
/// `origin + rotation · ((i + ½, j + ½, k + ½) ∘ cell)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lattice {
    pub origin: DVec3,
    /// Columns are the grid's axes in world space.
    pub rotation: DMat3,
    pub cell: DVec3,
    pub counts: [usize; 3],
    /// Reads outside the box extrapolate (instead of giving the background).
    pub extrapolates: bool,
}

/// A sampled grid that a field program can read: a cache, a grid loaded from a file, the
/// result of an FFT. Implemented in `grid`, called from the field evaluator.
pub trait GridSource: Send + Sync + Debug {
    /// Components per sample: 1 (scalar), 3 (vector) or 9 (matrix, row-major).
    fn width(&self) -> usize;
    /// A number unique to this grid's contents, used to hash-cons field nodes that read it.
    fn identity(&self) -> u64;
    /// A short description for profiles and error messages (`scalarcache over [-1,1]^3`).
    fn label(&self) -> String;
    /// Interpolated values at `xs.len()` world points, component-major, `f64`.
    /// Points outside the grid read the background value.
    fn sample(&self, interp: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]);
    /// Spatial derivatives of the interpolant: `out[(c * 3 + j) * n + i]` is d(component c)/dx_j
    /// at point i. Zero outside the grid.
    fn sample_gradient(&self, interp: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]);
    /// The world box outside which every value is the background.
    fn bounds(&self) -> Aabb;
    /// The value outside the grid, per component.
    fn background(&self) -> Vec<f64>;
    /// Cell spacing along the grid's own axes (for central differences).
    fn cell_size(&self) -> DVec3;
    /// A conservative range `(lo, hi)` per component of the values inside `region`, for any
    /// interpolation. May fill the parts of the grid it needs.
    fn range(&self, region: &Aabb) -> Vec<(f64, f64)>;
    /// The same for reads through `interp` only, which a grid may bound more tightly.
    fn range_read(&self, region: &Aabb, interp: Interp) -> Vec<(f64, f64)> {
        let _ = interp;
        self.range(region)
    }
    /// The same as if the read held its outermost cells' values in the half-cell border
    /// rather than extrapolating there (`outside = "hold"`). A render asks it to tell negative
    /// densities of the samples themselves from those the border's extrapolation makes.
    fn range_held(&self, region: &Aabb, interp: Interp) -> Vec<(f64, f64)> {
        self.range_read(region, interp)
    }
    /// Where the samples sit, for schemes that look at the cells around a point (the
    /// clamp of MacCormack advection).
    fn lattice(&self) -> Option<Lattice> {
        None
    }
    /// The grids that values not yet computed still read (a pending fill's or solve's
    /// inputs). Empty once everything is computed.
    fn pending_inputs(&self) -> Vec<Arc<dyn GridSource>> {
        Vec::new()
    }
    /// Writes the stored values of `domain`'s cells `[lo, hi)` into `out` (x fastest,
    /// components innermost) and returns true, when this grid's samples are exactly those
    /// cells; the default returns false. Those are the values any interpolation reads at the
    /// cells' centres, so a grid sampled on its own cells is copied, not interpolated.
    fn cells(&self, _domain: &Domain, _lo: [usize; 3], _hi: [usize; 3], _out: &mut [f32]) -> bool {
        false
    }
    /// Computes the grid now if it is a whole-grid solve that has not run (an FFT projection);
    /// brick-lazy grids do nothing here. Called by `grid::demand` before an output runs, in
    /// dependency order, so that solves run on all threads and never inside another
    /// parallel evaluation.
    fn solve(&self) -> Outcome<()> {
        Ok(())
    }
}

/// Evaluates a field on blocks of points. Holds the per-thread scratch space, so each thread
/// makes its own with `FieldSampler::evaluator`.
pub trait BlockEval {
    /// Values at `xs.len() <= BLOCK` points in `f32`, component-major into `out`.
    fn eval_f32(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f32]);
    /// The same in `f64`.
    fn eval_f64(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]);
    /// Narrows the evaluator to points inside `region` until the next call, and returns the
    /// field's range there (as `FieldSampler::range` would), for evaluators that can shorten
    /// their work over a region (a compiled field drops the choices the region decides). The
    /// default does neither and returns `None`. Values at points inside the region are the
    /// same bit for bit either way.
    fn focus(&mut self, _region: &Aabb) -> Option<Vec<(f64, f64)>> {
        None
    }
}

/// A field ready to be evaluated: what cache fills, the raymarcher and mesh extraction consume.
pub trait FieldSampler: Send + Sync {
    /// Components per value: 1, 3 or 9.
    fn width(&self) -> usize;
    /// Scratch space for one thread.
    fn evaluator(&self) -> Box<dyn BlockEval + '_>;
    /// A conservative box outside which the field is zero, if one is known.
    fn bounds(&self) -> Option<Aabb>;
    /// A conservative range `(lo, hi)` per component over `region` (interval evaluation).
    fn range(&self, region: &Aabb) -> Vec<(f64, f64)>;
    /// The same with every grid read taken as held in its half-cell border
    /// (`GridSource::range_held`); for a field that reads no grid, `range`.
    fn range_held(&self, region: &Aabb) -> Vec<(f64, f64)> {
        self.range(region)
    }
    /// The grids the field reads (for `grid::demand`); none for a closure.
    fn grids(&self) -> Vec<Arc<dyn GridSource>> {
        Vec::new()
    }
    /// Writes the values at the centres of `domain`'s cells `[lo, hi)` into `out` (x fastest,
    /// components innermost) and returns true, for a field that is itself a grid on `domain`
    /// and can give its cells without evaluating points; the default returns false. What it
    /// writes is what the block evaluator gives at those centres: for a grid, its stored
    /// values, which a read there returns (up to the last-bit rounding of locating a centre
    /// whose coordinates are not exact in binary). A cache fill uses it for every brick alike,
    /// so its bricks stay the same for any thread count and order.
    fn fill_cells(
        &self,
        _domain: &Domain,
        _lo: [usize; 3],
        _hi: [usize; 3],
        _out: &mut [f32],
    ) -> bool {
        false
    }
}

/// A field given by a Rust closure of the world position: for tests, benchmarks, and
/// engine-internal fields that have no graph. `f(p, out)` writes `width` components.
pub struct FnField<F> {
    width: usize,
    function: F,
    bounds: Option<Aabb>,
    range: Option<(f64, f64)>,
}

impl<F> FnField<F>
where
    F: Fn(DVec3, &mut [f64]) + Send + Sync,
{
    pub fn new(width: usize, function: F) -> FnField<F> {
        FnField {
            width,
            function,
            bounds: None,
            range: None,
        }
    }

    pub fn with_bounds(mut self, bounds: Aabb) -> FnField<F> {
        self.bounds = Some(bounds);
        self
    }

    /// Declares every component to lie in `[lo, hi]` everywhere, so the path tracer can bound
    /// the field; the caller vouches for it, as a closure has no interval form.
    pub fn with_range(mut self, lo: f64, hi: f64) -> FnField<F> {
        self.range = Some((lo, hi));
        self
    }
}

struct FnEval<'a, F> {
    field: &'a FnField<F>,
    value: Vec<f64>,
}

impl<F> BlockEval for FnEval<'_, F>
where
    F: Fn(DVec3, &mut [f64]) + Send + Sync,
{
    fn eval_f32(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f32]) {
        let n = xs.len();
        for i in 0..n {
            (self.field.function)(DVec3::new(xs[i], ys[i], zs[i]), &mut self.value);
            for (c, v) in self.value.iter().enumerate() {
                out[c * n + i] = *v as f32;
            }
        }
    }

    fn eval_f64(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        let n = xs.len();
        for i in 0..n {
            (self.field.function)(DVec3::new(xs[i], ys[i], zs[i]), &mut self.value);
            for (c, v) in self.value.iter().enumerate() {
                out[c * n + i] = *v;
            }
        }
    }
}

impl<F> FieldSampler for FnField<F>
where
    F: Fn(DVec3, &mut [f64]) + Send + Sync,
{
    fn width(&self) -> usize {
        self.width
    }

    fn evaluator(&self) -> Box<dyn BlockEval + '_> {
        Box::new(FnEval {
            field: self,
            value: vec![0.0; self.width],
        })
    }

    fn bounds(&self) -> Option<Aabb> {
        self.bounds
    }

    /// A closure has no interval form: the range is the declared one, or unbounded.
    fn range(&self, _region: &Aabb) -> Vec<(f64, f64)> {
        let range = self.range.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
        vec![range; self.width]
    }
}

#[cfg(test)]
mod tests {
    use super::Aabb;
    use glam::DVec3;

    #[test]
    fn a_box_has_its_eight_corners_in_bit_order() {
        let b = Aabb::new(DVec3::new(-1.0, 2.0, 3.0), DVec3::new(4.0, 5.0, 7.5));
        let corners = b.corners();
        for (k, c) in corners.iter().enumerate() {
            let expect = |bit: usize, axis: usize| {
                if k & bit == 0 {
                    b.min[axis]
                } else {
                    b.max[axis]
                }
            };
            assert_eq!(
                *c,
                DVec3::new(expect(1, 0), expect(2, 1), expect(4, 2)),
                "corner {k}"
            );
        }
        assert_eq!((corners[0], corners[7]), (b.min, b.max));
        assert_eq!(corners[5], DVec3::new(4.0, 2.0, 7.5));
    }
}
