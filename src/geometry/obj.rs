//! Wavefront OBJ: the `v` and `f` records, read and written.
//!
//! Reading keeps vertex positions (`v x y z`, extra colour or weight values ignored) and faces
//! (`f` with `v`, `v/vt`, `v//vn` or `v/vt/vn` corners, negative indices counting back from
//! the latest vertex), splits polygons into fans of triangles, and ignores every other record
//! (normals, texture coordinates, groups, materials, lines). The one key decision: the reader
//! trusts nothing — each number is checked as it is parsed and each index against the vertices
//! once the file is read (positive indices may name vertices defined later), and any problem is
//! a `Failure` that names the line, so a damaged file is reported, never half-loaded.
//! Writing prints each coordinate in the shortest form that reads back to the same `f64`, so a
//! written file loads to exactly the mesh that was saved.

use super::Mesh;
use crate::failure::{Failure, Outcome};
use glam::DVec3;
use std::fmt::Write;

/// Reads an OBJ file's triangles.
pub fn parse_obj(bytes: &[u8]) -> Outcome<Mesh> {
    let mut mesh = Mesh::default();
    // (first triangle of a face, its line): to name the line of a bad positive index.
    let mut faces: Vec<(usize, usize)> = Vec::new();
    let mut corners: Vec<u32> = Vec::new();
    for (number, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = number + 1;
        let mut tokens = raw
            .split(|b| b.is_ascii_whitespace())
            .filter(|t| !t.is_empty());
        let Some(keyword) = tokens.next() else {
            continue;
        };
        match keyword {
            b"v" => {
                let mut p = [0.0; 3];
                for (axis, value) in p.iter_mut().enumerate() {
                    let Some(token) = tokens.next() else {
                        return Err(at(
                            line,
                            format!("a vertex needs three coordinates, found {axis}"),
                        ));
                    };
                    *value = coordinate(token, line)?;
                }
                mesh.positions.push(DVec3::from_array(p));
            }
            b"f" => {
                corners.clear();
                for token in tokens {
                    corners.push(corner(token, mesh.positions.len(), line)?);
                }
                if corners.len() < 3 {
                    return Err(at(
                        line,
                        format!(
                            "a face needs at least three corners, found {}",
                            corners.len()
                        ),
                    ));
                }
                faces.push((mesh.triangles.len(), line));
                for i in 1..corners.len() - 1 {
                    mesh.triangles
                        .push([corners[0], corners[i], corners[i + 1]]);
                }
            }
            _ => {}
        }
    }
    let count = mesh.positions.len();
    if count > u32::MAX as usize {
        return Err(Failure::new(format!(
            "the OBJ file has {count} vertices, more than a shape can index"
        )));
    }
    if let Some(bad) = mesh
        .triangles
        .iter()
        .position(|t| t.iter().any(|&v| v as usize >= count))
    {
        let face = faces.partition_point(|&(first, _)| first <= bad) - 1;
        let index = mesh.triangles[bad].iter().copied().max().unwrap_or(0) as usize + 1;
        return Err(at(
            faces[face].1,
            format!("the face uses vertex {index}, but the file has only {count} vertices"),
        ));
    }
    Ok(mesh)
}

fn at(line: usize, message: String) -> Failure {
    Failure::new(format!("OBJ line {line}: {message}"))
}

fn text(token: &[u8]) -> String {
    String::from_utf8_lossy(token).into_owned()
}

fn coordinate(token: &[u8], line: usize) -> Outcome<f64> {
    let value: f64 = std::str::from_utf8(token)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| at(line, format!("'{}' is not a number", text(token))))?;
    if !value.is_finite() {
        return Err(at(
            line,
            format!("vertex coordinate '{}' is not finite", text(token)),
        ));
    }
    Ok(value)
}

/// The zero-based vertex index of a face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`, given the
/// number of vertices read so far (which negative indices count back from).
fn corner(token: &[u8], vertices_so_far: usize, line: usize) -> Outcome<u32> {
    let vertex = token.split(|&b| b == b'/').next().unwrap_or(token);
    let index: i64 = std::str::from_utf8(vertex)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| at(line, format!("'{}' is not a vertex index", text(token))))?;
    let resolved = match index {
        0 => return Err(at(line, "vertex indices start at 1; found 0".into())),
        i if i > 0 => i - 1,
        i => {
            let back = vertices_so_far as i64 + i;
            if back < 0 {
                return Err(at(
                    line,
                    format!(
                        "vertex index {i} reaches before the first of the {vertices_so_far} vertices so far"
                    ),
                ));
            }
            back
        }
    };
    u32::try_from(resolved).map_err(|_| {
        at(
            line,
            format!("vertex index {index} is larger than a shape can hold"),
        )
    })
}

/// The mesh as OBJ text.
pub fn write_obj(mesh: &Mesh) -> Outcome<Vec<u8>> {
    mesh.validate()?;
    let mut out = String::with_capacity(mesh.positions.len() * 40 + mesh.triangles.len() * 24);
    let _ = writeln!(
        out,
        "# felt shape: {} vertices, {} triangles",
        mesh.positions.len(),
        mesh.triangles.len()
    );
    for p in &mesh.positions {
        // `{:?}` is the shortest text that parses back to the same f64.
        let _ = writeln!(out, "v {:?} {:?} {:?}", p.x, p.y, p.z);
    }
    for t in &mesh.triangles {
        let _ = writeln!(out, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    Ok(out.into_bytes())
}
