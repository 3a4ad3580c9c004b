//! Attribute transfer (FELT chapter 4.3): each vertex of an object is mapped through a warp onto
//! a reference shape, and the reference's attribute is interpolated there.
//!
//! The one key decision: the value is read at the closest point of the closest reference
//! triangle (found through the same bounding-volume hierarchy as `shape2ls`), with the
//! barycentric weights of that point, so a warp that lands slightly off the reference surface
//! still reads the surface's own values, and a point on a triangle reads exactly the linear
//! interpolant of its corners.

use super::Mesh;
use super::attributes::{Attribute, AttributeValue};
use super::bvh::Bvh;
use crate::base::failure::{Failure, Outcome};
use glam::DVec3;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::Arc;

/// A reference surface prepared for closest-point reads.
pub struct Surface {
    mesh: Arc<Mesh>,
    bvh: Bvh,
}

impl Surface {
    /// Checks `mesh` can serve as a reference: it has triangles, finite values, and no edge is
    /// shared by more than two triangles (where the closest triangle would be ambiguous between
    /// sheets). Open edges are allowed: a reference may be a patch.
    pub fn new(mesh: Arc<Mesh>) -> Outcome<Surface> {
        mesh.validate()?;
        if mesh.triangles.is_empty() {
            return Err(Failure::new(
                "the reference shape has no triangles, so there is no surface to read from",
            ));
        }
        if let Some((a, b)) = non_manifold_edge(&mesh) {
            return Err(Failure::new(format!(
                "the reference shape is not a manifold: the edge from vertex {a} to vertex {b} \
                 is shared by more than two triangles"
            ))
            .with_help("split it into pieces with pieces(shape), or remesh it with ls2shape"));
        }
        let corners = mesh
            .triangles
            .iter()
            .map(|t| t.map(|v| mesh.positions[v as usize]))
            .collect();
        Ok(Surface {
            mesh,
            bvh: Bvh::new(corners),
        })
    }

    /// The attribute at the surface point closest to each of `points`. Every point is looked up
    /// on its own, so the result does not depend on the number of threads.
    pub fn read(&self, values: &Attribute, points: &[DVec3]) -> Vec<AttributeValue> {
        points
            .par_chunks(256)
            .flat_map_iter(|chunk| {
                let mut stack = Vec::new();
                let mut hint = 0;
                chunk
                    .iter()
                    .map(|&p| {
                        let (value, t) = self.read_one(values, p, hint, &mut stack);
                        hint = t;
                        value
                    })
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    /// The attribute at the surface point closest to `p`, and the triangle (in tree order) it
    /// lies on; `hint` is a triangle to start the search from.
    pub fn read_one(
        &self,
        values: &Attribute,
        p: DVec3,
        hint: usize,
        stack: &mut Vec<(u32, f64)>,
    ) -> (AttributeValue, usize) {
        let (_, t) = self.bvh.nearest(p, hint, stack);
        let weights = barycentric(p, &self.bvh.triangles[t]);
        let corners = self.mesh.triangles[self.bvh.order[t] as usize];
        (values.interpolate(corners, weights), t)
    }

    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }
}

/// `object` with attribute `name` read from `reference` at `mapped[i]` for vertex `i`.
pub fn transfer(object: &Mesh, reference: &Mesh, mapped: &[DVec3], name: &str) -> Outcome<Mesh> {
    let values = reference
        .attribute(name)
        .map_err(|f| Failure::new(format!("cannot transfer from the reference: {}", f.message)))?;
    let surface = Surface::new(Arc::new(reference.clone()))?;
    let read = surface.read(values, mapped);
    let mut out = object.clone();
    let mut transferred = match values {
        Attribute::Float(_) => Attribute::Float(Vec::with_capacity(read.len())),
        Attribute::Vector(_) => Attribute::Vector(Vec::with_capacity(read.len())),
    };
    for value in read {
        transferred.push(Some(value));
    }
    out.set_attribute(name, transferred)?;
    Ok(out)
}

/// Barycentric weights of the point of triangle `t` closest to `p` (Ericson, Real-Time Collision
/// Detection §5.1.5), summing to one. A triangle without area gives the weights of the
/// closest point on its longest edge.
pub fn barycentric(p: DVec3, t: &[DVec3; 3]) -> [f64; 3] {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let sum = va + vb + vc;
    if sum.is_nan() || sum <= 0.0 {
        return degenerate(p, t);
    }
    let (v, w) = (vb / sum, vc / sum);
    [1.0 - v - w, v, w]
}

/// Weights on the longest edge of a triangle without area.
fn degenerate(p: DVec3, t: &[DVec3; 3]) -> [f64; 3] {
    let edges = [(0, 1), (1, 2), (2, 0)];
    let (i, j) = edges
        .into_iter()
        .max_by(|&(a, b), &(c, d)| {
            t[a].distance_squared(t[b])
                .total_cmp(&t[c].distance_squared(t[d]))
        })
        .expect("three edges");
    let edge = t[j] - t[i];
    let length = edge.length_squared();
    let s = if length > 0.0 {
        ((p - t[i]).dot(edge) / length).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut weights = [0.0; 3];
    weights[i] = 1.0 - s;
    weights[j] += s;
    weights
}

/// An edge (by welded vertex positions) that more than two triangles share, if any.
fn non_manifold_edge(mesh: &Mesh) -> Option<(u32, u32)> {
    let first = super::components::welded(&mesh.positions);
    let mut uses: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.triangles.len() * 3);
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (first[t[k] as usize], first[t[(k + 1) % 3] as usize]);
            if a == b {
                continue;
            }
            let count = uses.entry((a.min(b), a.max(b))).or_insert(0);
            *count += 1;
            if *count > 2 {
                return Some((a.min(b), a.max(b)));
            }
        }
    }
    None
}
