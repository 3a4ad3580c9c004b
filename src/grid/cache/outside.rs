//! Cache reads that treat the edges of the domain differently from the default.
//!
//! By default a read extrapolates linearly in the half cell between the outermost cell
//! centres and the faces (so a linear field is reproduced up to the faces) and gives the
//! background beyond. Two other behaviours matter for simulations:
//! - `outside = "extrapolate"` continues the linear extrapolation beyond the faces. This is
//!   the read a SELMA map needs: a map `X(x)` is close to affine near the border of its domain
//!   (the identity plus a smooth displacement), so a zero background or a clamped read there
//!   sends every point just outside the box to the wrong place.
//! - `outside = "hold"` holds the outermost cells' values in that half cell instead, and gives
//!   the background beyond: every read is then a convex combination of samples (or the
//!   background), so a density never reads below its smallest sample or above its largest,
//!   and semi-Lagrangian advection of it stays bounded up to the walls.
//!
//! The one key decision: each is its own grid source wrapping the cache, with an identity of
//! its own, so field nodes reading one cache in different ways are never confused by
//! hash-consing.

use super::Cache;
use crate::base::failure::Outcome;
use crate::space::{Aabb, GridSource, Interp, Lattice};
use glam::DVec3;
use std::sync::Arc;

/// How a read treats the domain's edges, beyond the default.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outside {
    /// Linear extrapolation from the two outermost cells, everywhere outside their span.
    Extrapolate,
    /// The outermost cells' values in the half-cell border; the background beyond.
    Hold,
}

#[derive(Debug)]
pub struct OutsideRead {
    cache: Arc<Cache>,
    outside: Outside,
    identity: u64,
}

impl OutsideRead {
    pub fn new(cache: Arc<Cache>, outside: Outside) -> OutsideRead {
        OutsideRead {
            cache,
            outside,
            identity: crate::grid::next_identity(),
        }
    }
}

impl GridSource for OutsideRead {
    fn width(&self) -> usize {
        self.cache.width()
    }

    fn identity(&self) -> u64 {
        self.identity
    }

    fn label(&self) -> String {
        let how = match self.outside {
            Outside::Extrapolate => "extrapolated",
            Outside::Hold => "held at its edges",
        };
        format!("{} ({how})", self.cache.label())
    }

    fn sample(&self, interp: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        self.cache
            .sample_outside(self.outside, interp, xs, ys, zs, out);
    }

    fn sample_gradient(&self, interp: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        self.cache
            .gradient_outside(self.outside, interp, xs, ys, zs, out);
    }

    fn bounds(&self) -> Aabb {
        match self.outside {
            Outside::Extrapolate => Aabb::everything(),
            Outside::Hold => self.cache.bounds(),
        }
    }

    fn background(&self) -> Vec<f64> {
        self.cache.background()
    }

    fn cell_size(&self) -> DVec3 {
        self.cache.cell_size()
    }

    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        match self.outside {
            Outside::Extrapolate => self.cache.range_extrapolated(region),
            // Held reads are convex combinations of what the default read combines.
            Outside::Hold => self.cache.range(region),
        }
    }

    fn range_held(&self, region: &Aabb, interp: Interp) -> Vec<(f64, f64)> {
        match self.outside {
            Outside::Extrapolate => self.range(region),
            Outside::Hold => self.cache.range_of(region, interp, true),
        }
    }

    fn lattice(&self) -> Option<Lattice> {
        self.cache.lattice().map(|l| Lattice {
            extrapolates: self.outside == Outside::Extrapolate,
            ..l
        })
    }

    fn pending_inputs(&self) -> Vec<Arc<dyn GridSource>> {
        self.cache.pending_inputs()
    }

    fn solve(&self) -> Outcome<()> {
        self.cache.solve()
    }
}
