//! A texture-mapped sphere (`uvsphere`): the usual reference shape for attribute transfer.
//!
//! The one key decision: the seam and the poles carry their own vertices — the meridian at
//! `u = 0` is repeated at `u = 1`, and each pole is one vertex per segment, with the `u` of
//! the middle of its segment — so every triangle's corners hold the texture coordinates it should
//! interpolate between, and no triangle spans the jump from 1 back to 0.

use super::Mesh;
use super::attributes::{Attribute, NORMAL, TEXTURE};
use crate::base::failure::{Failure, Outcome};
use glam::DVec3;
use std::f64::consts::PI;

/// A sphere of `rings` bands from pole to pole (y up) and `segments` around, with `uv`
/// (`u` around from +x towards +z, `v` from 0 at the south pole to 1 at the north) and
/// outward unit normals `N`.
pub fn uv_sphere(center: DVec3, radius: f64, rings: usize, segments: usize) -> Outcome<Mesh> {
    if !(radius > 0.0 && radius.is_finite()) {
        return Err(Failure::new(format!(
            "a sphere needs a positive radius, found {radius}"
        )));
    }
    if !(2..=4096).contains(&rings) || !(3..=4096).contains(&segments) {
        return Err(Failure::new(format!(
            "a uv sphere needs 2 to 4096 rings and 3 to 4096 segments, found {rings} and {segments}"
        )));
    }
    // Vertices: the north pole once per segment, the rings between the poles with their seam
    // vertex repeated, the south pole once per segment.
    let columns = segments + 1;
    let interior = rings - 1;
    let count = 2 * segments + interior * columns;
    let mut positions = Vec::with_capacity(count);
    let mut normals = Vec::with_capacity(count);
    let mut uv = Vec::with_capacity(count);
    // Positions come from the segment index modulo the segments and the poles are exact, so
    // the seam's and the poles' copies are bit-identical and weld into a closed surface.
    let mut add = |normal: DVec3, u: f64, v: f64| {
        positions.push(center + radius * normal);
        normals.push(normal);
        uv.push(DVec3::new(u, v, 0.0));
    };
    let segment = |j: usize| j as f64 / segments as f64;
    // A pole vertex takes the u of its segment's middle, where its one triangle is.
    let middle = |j: usize| (j as f64 + 0.5) / segments as f64;
    for j in 0..segments {
        add(DVec3::Y, middle(j), 1.0);
    }
    for i in 1..rings {
        let theta = PI * i as f64 / rings as f64;
        for j in 0..=segments {
            let phi = 2.0 * PI * segment(j % segments);
            let normal = DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            add(normal, segment(j), 1.0 - i as f64 / rings as f64);
        }
    }
    for j in 0..segments {
        add(-DVec3::Y, middle(j), 0.0);
    }
    let north = |j: usize| j as u32;
    let ring = |i: usize, j: usize| (segments + (i - 1) * columns + j) as u32;
    let south = |j: usize| (segments + interior * columns + j) as u32;
    // Counter-clockwise seen from outside: the θ and φ tangents give an inward normal, so the
    // corners go along φ first.
    let mut triangles = Vec::with_capacity(2 * rings * segments);
    for j in 0..segments {
        triangles.push([north(j), ring(1, j + 1), ring(1, j)]);
        for i in 1..interior {
            triangles.push([ring(i, j), ring(i, j + 1), ring(i + 1, j)]);
            triangles.push([ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j)]);
        }
        triangles.push([ring(interior, j), ring(interior, j + 1), south(j)]);
    }
    let mut mesh = Mesh::new(positions, triangles);
    mesh.set_attribute(NORMAL, Attribute::Vector(normals))?;
    mesh.set_attribute(TEXTURE, Attribute::Vector(uv))?;
    Ok(mesh)
}
