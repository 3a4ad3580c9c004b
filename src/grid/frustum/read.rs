//! Reading a frustum cache at world points: the grid a `cacheread` of a frustum cache reads.
//!
//! The one key decision: the read is the index-domain grid's own read at the mapped point, so
//! interpolation, the half-cell border and the background outside are exactly a cache's, and
//! every bound is the index-domain grid's bound over the index box of the world region asked
//! about (`Frustum::index_box`), which keeps the path tracer's majorants sound.

use super::Frustum;
use crate::base::failure::Outcome;
use crate::space::{Aabb, BLOCK, GridSource, Interp};
use glam::DVec3;
use std::sync::Arc;

/// A grid over a frustum's index domain, read at world points.
#[derive(Debug)]
pub struct FrustumRead {
    frustum: Arc<Frustum>,
    grid: Arc<dyn GridSource>,
    identity: u64,
}

impl FrustumRead {
    /// `grid` lives on `frustum.index_domain()` and reads its background beyond it.
    pub fn new(frustum: Arc<Frustum>, grid: Arc<dyn GridSource>) -> FrustumRead {
        FrustumRead {
            frustum,
            grid,
            identity: crate::grid::next_identity(),
        }
    }

    /// The index coordinates of a block of world points.
    fn mapped(&self, xs: &[f64], ys: &[f64], zs: &[f64]) -> [[f64; BLOCK]; 3] {
        let mut q = [[0.0; BLOCK]; 3];
        for i in 0..xs.len() {
            let at = self.frustum.world_to_index(DVec3::new(xs[i], ys[i], zs[i]));
            for axis in 0..3 {
                q[axis][i] = at[axis];
            }
        }
        q
    }

    /// The same region in index coordinates.
    fn region(&self, region: &Aabb) -> Aabb {
        self.frustum.index_box(region)
    }
}

impl GridSource for FrustumRead {
    fn width(&self) -> usize {
        self.grid.width()
    }

    fn identity(&self) -> u64 {
        self.identity
    }

    fn label(&self) -> String {
        format!("{} over a {}", self.grid.label(), self.frustum.label())
    }

    fn sample(&self, interp: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        let n = xs.len();
        let width = self.width();
        let mut block = vec![0.0; BLOCK * width];
        for start in (0..n).step_by(BLOCK) {
            let end = (start + BLOCK).min(n);
            let m = end - start;
            let q = self.mapped(&xs[start..end], &ys[start..end], &zs[start..end]);
            self.grid.sample(
                interp,
                &q[0][..m],
                &q[1][..m],
                &q[2][..m],
                &mut block[..m * width],
            );
            for c in 0..width {
                out[c * n + start..c * n + end].copy_from_slice(&block[c * m..(c + 1) * m]);
            }
        }
    }

    /// The chain rule: d(value)/d(world) = d(value)/d(index) · d(index)/d(world).
    fn sample_gradient(&self, interp: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        let n = xs.len();
        let width = self.width();
        let mut block = vec![0.0; BLOCK * width * 3];
        for start in (0..n).step_by(BLOCK) {
            let end = (start + BLOCK).min(n);
            let m = end - start;
            let q = self.mapped(&xs[start..end], &ys[start..end], &zs[start..end]);
            let by_index = &mut block[..m * width * 3];
            self.grid
                .sample_gradient(interp, &q[0][..m], &q[1][..m], &q[2][..m], by_index);
            for i in 0..m {
                let p = DVec3::new(xs[start + i], ys[start + i], zs[start + i]);
                let jacobian = self.frustum.jacobian(p);
                for c in 0..width {
                    let g =
                        DVec3::from_array(std::array::from_fn(|a| by_index[(c * 3 + a) * m + i]));
                    // Row `a` of the Jacobian is the gradient of index coordinate `a`.
                    let world = jacobian.transpose() * g;
                    for j in 0..3 {
                        out[(c * 3 + j) * n + start + i] = world[j];
                    }
                }
            }
        }
    }

    fn bounds(&self) -> Aabb {
        self.frustum.bounds()
    }

    fn background(&self) -> Vec<f64> {
        self.grid.background()
    }

    /// The cells' size at the middle of the frustum, where central differences are taken.
    fn cell_size(&self) -> DVec3 {
        let middle = DVec3::from_array(self.frustum.cells().map(|n| 0.5 * n as f64));
        let at = self.frustum.index_to_world(middle);
        let step = |axis: usize| {
            let mut next = middle;
            next[axis] += 1.0;
            (self.frustum.index_to_world(next) - at).length()
        };
        DVec3::new(step(0), step(1), step(2))
    }

    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        self.grid.range(&self.region(region))
    }

    fn range_read(&self, region: &Aabb, interp: Interp) -> Vec<(f64, f64)> {
        self.grid.range_read(&self.region(region), interp)
    }

    fn range_held(&self, region: &Aabb, interp: Interp) -> Vec<(f64, f64)> {
        self.grid.range_held(&self.region(region), interp)
    }

    fn pending_inputs(&self) -> Vec<Arc<dyn GridSource>> {
        self.grid.pending_inputs()
    }

    fn solve(&self) -> Outcome<()> {
        self.grid.solve()
    }
}
