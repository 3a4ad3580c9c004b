//! A cache read that extrapolates linearly outside its domain instead of reading the background.
//!
//! This is the read a SELMA map needs (`cacheread(map, outside = "extrapolate")`): a map
//! `X(x)` is close to affine near the border of its domain (it is the identity plus a smooth
//! displacement), so a zero background or a clamped read there sends every point just
//! outside the box to the wrong place. Extrapolating from the two outermost cells along each
//! axis keeps an affine map exact everywhere. The one key decision: it is its own grid source
//! wrapping the cache, with an identity of its own, so field nodes reading a cache the ordinary
//! way and the extrapolating way are never confused by hash-consing.

use super::Cache;
use crate::failure::Outcome;
use crate::sample::{Aabb, GridSource, Interp, Lattice};
use glam::DVec3;
use std::sync::Arc;

#[derive(Debug)]
pub struct Extrapolated {
    cache: Arc<Cache>,
    identity: u64,
}

impl Extrapolated {
    pub fn new(cache: Arc<Cache>) -> Extrapolated {
        Extrapolated {
            cache,
            identity: crate::grid::next_identity(),
        }
    }
}

impl GridSource for Extrapolated {
    fn width(&self) -> usize {
        self.cache.width()
    }

    fn identity(&self) -> u64 {
        self.identity
    }

    fn label(&self) -> String {
        format!("{} (extrapolated)", self.cache.label())
    }

    fn sample(&self, interp: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        self.cache.sample_extrapolated(interp, xs, ys, zs, out);
    }

    fn sample_gradient(&self, interp: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        self.cache.gradient_extrapolated(interp, xs, ys, zs, out);
    }

    fn bounds(&self) -> Aabb {
        Aabb::everything()
    }

    fn background(&self) -> Vec<f64> {
        self.cache.background()
    }

    fn cell_size(&self) -> DVec3 {
        self.cache.cell_size()
    }

    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        self.cache.range_extrapolated(region)
    }

    fn lattice(&self) -> Option<Lattice> {
        self.cache.lattice().map(|l| Lattice {
            extrapolates: true,
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
