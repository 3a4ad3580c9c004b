//! Geometry: triangle meshes, the `shape` values of scripts.

use glam::DVec3;

/// A triangle mesh: positions and triangles of indices into them, counter-clockwise seen from
/// outside.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
}
