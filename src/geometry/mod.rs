//! Geometry: felt's `shape` (a triangle mesh) and the bridges between shapes and level sets.
//!
//! `marching_cubes` turns a level set (positive inside) into a closed, outward-oriented mesh
//! (`ls2shape`); `MeshDistance` turns a mesh back into a signed-distance field (`shape2ls`);
//! `pieces` splits a mesh into connected components; `load_mesh`/`save_mesh` read and write
//! OBJ and PLY; `attributes` holds per-vertex values (normals, texture coordinates, anything
//! named) and `transfer` carries them from one shape to another through a warp. The one key
//! decision: a `Mesh` is shared vertex positions, index triples and per-vertex attributes —
//! no half-edge structure, no per-corner values — so every file, every extraction and every
//! query agrees on one plain representation, and the properties that matter (closed,
//! oriented, its volume and Euler characteristic) are computed from it on demand rather than
//! trusted from a flag.

pub mod attributes;
mod bvh;
mod cases;
mod components;
mod distance;
mod io;
pub mod knives;
mod marching;
mod obj;
mod ply;
mod ply_header;
mod sphere;
pub mod transfer;
mod winding;

#[cfg(test)]
mod tests;

pub use components::{pieces, pieces_above};
pub use distance::MeshDistance;
pub use io::{load_mesh, save_mesh};
pub use marching::{DEFAULT_MESH_CELLS, default_mesh_domain, marching_cubes};
pub use obj::{parse_obj, write_obj};
pub use ply::{parse_ply, write_ply};
pub use sphere::uv_sphere;

pub use attributes::{Attribute, AttributeValue, Attributes};

use crate::base::failure::{Failure, Outcome};
use crate::space::Aabb;
use glam::DVec3;

/// A triangle mesh: vertex positions in world space and triangles as indices into them,
/// counter-clockwise seen from outside (so the right-hand normal points out of the solid).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Per-vertex values by name, each as long as `positions`.
    pub attributes: Attributes,
}

impl Mesh {
    /// A mesh of positions and triangles without attributes.
    pub fn new(positions: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Mesh {
        Mesh {
            positions,
            triangles,
            attributes: Attributes::new(),
        }
    }

    /// The attribute `name`, or a failure that lists the ones the shape has.
    pub fn attribute(&self, name: &str) -> Outcome<&Attribute> {
        self.attributes.get(name).ok_or_else(|| {
            let names: Vec<&str> = self.attributes.keys().map(|k| k.as_str()).collect();
            let has = if names.is_empty() {
                "it has no attributes".to_string()
            } else {
                format!("it has {}", names.join(", "))
            };
            Failure::new(format!(
                "the shape has no vertex attribute '{name}' ({has})"
            ))
        })
    }

    /// Sets an attribute, which must have one value per vertex.
    pub fn set_attribute(&mut self, name: &str, values: Attribute) -> Outcome<()> {
        if values.len() != self.positions.len() {
            return Err(Failure::new(format!(
                "attribute '{name}' needs one value per vertex: {} values for {} vertices",
                values.len(),
                self.positions.len()
            )));
        }
        values.check_finite(name)?;
        self.attributes.insert(name.to_string(), values);
        Ok(())
    }

    /// The box around all vertices; `None` for a mesh without vertices.
    pub fn bounds(&self) -> Option<Aabb> {
        let first = *self.positions.first()?;
        let mut bounds = Aabb::new(first, first);
        for p in &self.positions[1..] {
            bounds.min = bounds.min.min(*p);
            bounds.max = bounds.max.max(*p);
        }
        Some(bounds)
    }

    /// The three corners of every triangle whose indices are in range.
    fn corners(&self) -> impl Iterator<Item = [DVec3; 3]> + '_ {
        self.triangles.iter().filter_map(|t| {
            Some([
                *self.positions.get(t[0] as usize)?,
                *self.positions.get(t[1] as usize)?,
                *self.positions.get(t[2] as usize)?,
            ])
        })
    }

    /// Enclosed volume by the divergence theorem: the sum of the signed volumes of the
    /// tetrahedra joining each triangle to a reference point. Positive when the triangles face
    /// outward. For a closed mesh the reference point does not matter; the first vertex is used
    /// because it keeps the products small (and exact cancellation likely) far from the origin.
    pub fn volume(&self) -> f64 {
        let Some(&reference) = self.positions.first() else {
            return 0.0;
        };
        let sum: f64 = self
            .corners()
            .map(|[a, b, c]| (a - reference).dot((b - reference).cross(c - reference)))
            .sum();
        sum / 6.0
    }

    /// Total area of the triangles.
    pub fn area(&self) -> f64 {
        self.corners()
            .map(|[a, b, c]| 0.5 * (b - a).cross(c - a).length())
            .sum()
    }

    /// Is this the surface of a solid: every edge used by exactly two triangles, once in each
    /// direction? Topological (by index, not position). A triangle that repeats an index or
    /// points past the vertices makes the mesh open; a mesh without triangles is closed.
    pub fn is_closed(&self) -> bool {
        let n = self.positions.len();
        let mut edges = Vec::with_capacity(self.triangles.len() * 3);
        for t in &self.triangles {
            if t.iter().any(|&v| v as usize >= n) || t[0] == t[1] || t[1] == t[2] || t[2] == t[0] {
                return false;
            }
            edges.extend([(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]);
        }
        edges.sort_unstable();
        // Each directed edge once, and its reverse present: then every undirected edge is used
        // by exactly one triangle in each direction.
        if edges.windows(2).any(|w| w[0] == w[1]) {
            return false;
        }
        edges
            .iter()
            .all(|&(a, b)| edges.binary_search(&(b, a)).is_ok())
    }

    /// V − E + F over the vertices the triangles use (unused positions are not counted):
    /// 2 for a sphere, 0 for a torus, 2 − 2g for a closed surface of genus g.
    pub fn euler_characteristic(&self) -> i64 {
        let n = self.positions.len();
        let mut used = vec![false; n];
        let mut edges = Vec::with_capacity(self.triangles.len() * 3);
        let mut faces = 0i64;
        for t in &self.triangles {
            if t.iter().any(|&v| v as usize >= n) {
                continue;
            }
            faces += 1;
            for k in 0..3 {
                used[t[k] as usize] = true;
                let (a, b) = (t[k], t[(k + 1) % 3]);
                edges.push((a.min(b), a.max(b)));
            }
        }
        edges.sort_unstable();
        edges.dedup();
        let vertices = used.iter().filter(|&&u| u).count() as i64;
        vertices - edges.len() as i64 + faces
    }

    /// Checks what a file or a script may have got wrong: every index names a vertex, every
    /// position is finite, and there are no more vertices than `u32` indices can name.
    pub fn validate(&self) -> Outcome<()> {
        if self.positions.len() > u32::MAX as usize {
            return Err(Failure::new(format!(
                "the shape has {} vertices, more than the {} a shape can index",
                self.positions.len(),
                u32::MAX
            )));
        }
        if let Some((i, p)) = self
            .positions
            .iter()
            .enumerate()
            .find(|(_, p)| !p.is_finite())
        {
            return Err(Failure::new(format!(
                "vertex {i} of the shape is not finite: ({}, {}, {})",
                p.x, p.y, p.z
            )));
        }
        let n = self.positions.len();
        for (name, values) in &self.attributes {
            if values.len() != n {
                return Err(Failure::new(format!(
                    "attribute '{name}' has {} values for {n} vertices",
                    values.len()
                )));
            }
            values.check_finite(name)?;
        }
        if let Some((i, t)) = self
            .triangles
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&v| v as usize >= n))
        {
            return Err(Failure::new(format!(
                "triangle {i} of the shape refers to vertex {}, but the shape has only {n} vertices",
                t.iter().copied().max().unwrap_or(0)
            )));
        }
        Ok(())
    }
}
