//! A mesh as a level set: the signed distance to its triangles, positive inside (`shape2ls`).
//!
//! The magnitude is the exact distance to the nearest triangle, found through a BVH; the sign
//! comes from the generalised winding number (inside where it exceeds ½), so meshes with small
//! holes, overlaps or stray faces still have a sensible inside. The one key decision: the two
//! halves are separate queries on one tree, and points outside the mesh's bounding box are
//! outside without asking the winding number, which both saves the costlier query where most
//! samples of a domain lie and makes `range` provably conservative there. Within a block each
//! point starts its nearest-triangle search from its predecessor's answer, which the grid
//! order of cache fills makes a tight bound. And when the mesh is closed (after welding equal
//! positions) its winding number is an integer that changes only across the surface, so a
//! point closer to its predecessor than the predecessor is to the surface shares its sign:
//! a grid fill asks the winding number only within about a cell of the surface.

use super::Mesh;
use super::bvh::Bvh;
use super::components::welded;
use super::winding::{Moments, moments, winding_number};
use crate::base::failure::{Failure, Outcome};
use crate::space::{Aabb, BlockEval, FieldSampler};
use glam::DVec3;

/// The signed distance to a mesh, positive inside; a scalar `FieldSampler`.
pub struct MeshDistance {
    bvh: Bvh,
    moments: Vec<Moments>,
    bounds: Aabb,
    /// Every edge (after welding) has a twin in the opposite direction.
    closed: bool,
}

impl std::fmt::Debug for MeshDistance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "MeshDistance({} triangles over {:?})",
            self.bvh.triangles.len(),
            self.bounds
        )
    }
}

impl MeshDistance {
    /// Builds the tree and its winding-number moments once; queries are then read-only.
    pub fn new(mesh: &Mesh) -> Outcome<MeshDistance> {
        mesh.validate()?;
        if mesh.triangles.is_empty() {
            return Err(Failure::new(
                "the shape has no triangles, so it has no distance to measure",
            ));
        }
        let triangles: Vec<[DVec3; 3]> = mesh
            .triangles
            .iter()
            .map(|t| t.map(|v| mesh.positions[v as usize]))
            .collect();
        let bvh = Bvh::new(triangles);
        let moments = moments(&bvh);
        let root = bvh.nodes[0];
        let first = welded(&mesh.positions);
        let closed = Mesh::new(
            mesh.positions.clone(),
            mesh.triangles
                .iter()
                .map(|t| t.map(|v| first[v as usize]))
                .collect(),
        )
        .is_closed();
        Ok(MeshDistance {
            bvh,
            moments,
            bounds: Aabb::new(root.min, root.max),
            closed,
        })
    }

    /// The signed distance at one point (for inspection; fields go through `evaluator`).
    pub fn distance(&self, p: DVec3) -> f64 {
        let mut query = Query::new(self);
        query.signed_distance(p)
    }

    /// The winding number of the mesh about `p`: 1 inside, 0 outside a closed mesh.
    pub fn winding_number(&self, p: DVec3) -> f64 {
        winding_number(&self.bvh, &self.moments, p, &mut Vec::new())
    }
}

/// One thread's query state: a traversal stack, the last nearest triangle, and the last point
/// with its distance and side.
struct Query<'a> {
    mesh: &'a MeshDistance,
    stack: Vec<u32>,
    /// Nodes still to visit in the nearest-triangle search, with their box distances.
    pending: Vec<(u32, f64)>,
    hint: usize,
    last: Option<(DVec3, f64, bool)>,
    scratch: Vec<f64>,
}

impl Query<'_> {
    fn new(mesh: &MeshDistance) -> Query<'_> {
        Query {
            mesh,
            stack: Vec::with_capacity(64),
            pending: Vec::with_capacity(64),
            hint: 0,
            last: None,
            scratch: Vec::new(),
        }
    }

    fn signed_distance(&mut self, p: DVec3) -> f64 {
        let (d2, nearest) = self.mesh.bvh.nearest(p, self.hint, &mut self.pending);
        self.hint = nearest;
        let distance = d2.sqrt();
        let inside = match self.last {
            _ if !self.mesh.bounds.contains(p) => false,
            // The ball about the last point reaching to the surface holds no surface.
            // (Shrunk by far more than rounding, so that the sign never depends on which
            // point came before.)
            Some((q, d, side)) if self.mesh.closed && (p - q).length() < d * (1.0 - 1e-6) => side,
            _ => winding_number(&self.mesh.bvh, &self.mesh.moments, p, &mut self.stack) > 0.5,
        };
        self.last = Some((p, distance, inside));
        if inside { distance } else { -distance }
    }
}

impl BlockEval for Query<'_> {
    fn eval_f32(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f32]) {
        let mut scratch = std::mem::take(&mut self.scratch);
        scratch.resize(xs.len(), 0.0);
        self.eval_f64(xs, ys, zs, &mut scratch);
        for (o, v) in out.iter_mut().zip(&scratch) {
            *o = *v as f32;
        }
        self.scratch = scratch;
    }

    fn eval_f64(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        for i in 0..xs.len() {
            out[i] = self.signed_distance(DVec3::new(xs[i], ys[i], zs[i]));
        }
    }
}

impl FieldSampler for MeshDistance {
    fn width(&self) -> usize {
        1
    }

    fn evaluator(&self) -> Box<dyn BlockEval + '_> {
        Box::new(Query::new(self))
    }

    /// A distance is nonzero almost everywhere: there is no box outside which it vanishes.
    fn bounds(&self) -> Option<Aabb> {
        None
    }

    /// Every point is at most as far from the mesh as from the farthest point of its box, and
    /// at least as far as from the box itself; outside the box the sign is negative.
    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        if region.is_empty() {
            return vec![(0.0, 0.0)];
        }
        let b = &self.bounds;
        let gap = (b.min - region.max)
            .max(region.min - b.max)
            .max(DVec3::ZERO);
        let span = (region.max - b.min).abs().max((b.max - region.min).abs());
        let nearest = gap.length();
        let farthest = span.length();
        if region.intersection(b).is_empty() {
            vec![(-farthest, -nearest)]
        } else {
            vec![(-farthest, farthest)]
        }
    }
}
