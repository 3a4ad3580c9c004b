//! Wavefront OBJ: the `v`, `vt`, `vn` and `f` records, read and written.
//!
//! Reading keeps vertex positions (`v x y z`, extra colour or weight values ignored), texture
//! coordinates (`vt u v w`, as the `uv` attribute), normals (`vn`, as `N`) and faces (`f` with
//! `v`, `v/vt`, `v//vn` or `v/vt/vn` corners, negative indices counting back from the latest
//! record of their kind), splits polygons into fans of triangles, and ignores every other
//! record (groups, materials, lines). Attributes are per vertex: a vertex whose corners name
//! different texture coordinates or normals (a seam) becomes one vertex per distinct pair,
//! the first keeping its number and the others appended. The one key decision: the reader
//! trusts nothing — each number is checked as it is parsed and each index against the vertices
//! once the file is read (positive indices may name vertices defined later), and any problem is
//! a `Failure` that names the line, so a damaged file is reported, never half-loaded.
//! Writing prints each coordinate in the shortest form that reads back to the same `f64`, so a
//! written file loads to exactly the mesh that was saved (with `vt` and `vn` records, one per
//! vertex, when the shape has `uv` or `N`; other attributes have no place in OBJ).

use super::Mesh;
use super::attributes::{Attribute, NORMAL, TEXTURE};
use crate::base::failure::{Failure, Outcome};
use glam::DVec3;
use std::collections::HashMap;
use std::fmt::Write;

/// One face corner: vertex, texture coordinate and normal indices (zero-based).
type Corner = (u32, Option<u32>, Option<u32>);

/// Reads an OBJ file's triangles, texture coordinates and normals.
pub fn parse_obj(bytes: &[u8]) -> Outcome<Mesh> {
    let mut mesh = Mesh::default();
    let mut textures: Vec<DVec3> = Vec::new();
    let mut normals: Vec<DVec3> = Vec::new();
    // Corners of every triangle, and (first triangle of a face, its line) to name the line of
    // a bad positive index.
    let mut triangles: Vec<[Corner; 3]> = Vec::new();
    let mut faces: Vec<(usize, usize)> = Vec::new();
    let mut corners: Vec<Corner> = Vec::new();
    for (number, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = number + 1;
        let mut tokens = raw
            .split(|b| b.is_ascii_whitespace())
            .filter(|t| !t.is_empty());
        let Some(keyword) = tokens.next() else {
            continue;
        };
        match keyword {
            b"v" => mesh
                .positions
                .push(triple(&mut tokens, 3, "a vertex", line)?),
            b"vt" => textures.push(triple(&mut tokens, 1, "a texture coordinate", line)?),
            b"vn" => normals.push(triple(&mut tokens, 3, "a normal", line)?),
            b"f" => {
                corners.clear();
                let so_far = [mesh.positions.len(), textures.len(), normals.len()];
                for token in tokens {
                    corners.push(corner(token, so_far, line)?);
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
                faces.push((triangles.len(), line));
                for i in 1..corners.len() - 1 {
                    triangles.push([corners[0], corners[i], corners[i + 1]]);
                }
            }
            _ => {}
        }
    }
    let counts = [mesh.positions.len(), textures.len(), normals.len()];
    if counts[0] > u32::MAX as usize {
        return Err(Failure::new(format!(
            "the OBJ file has {} vertices, more than a shape can index",
            counts[0]
        )));
    }
    let out_of_range = |c: &Corner| {
        let [v, t, n] = [Some(c.0), c.1, c.2];
        [v, t, n]
            .iter()
            .zip(counts)
            .zip(["vertex", "texture coordinate", "normal"])
            .find_map(|((i, count), what)| {
                i.filter(|&i| i as usize >= count)
                    .map(|i| (i as usize + 1, count, what))
            })
    };
    for (index, triangle) in triangles.iter().enumerate() {
        if let Some((i, count, what)) = triangle.iter().find_map(out_of_range) {
            let face = faces.partition_point(|&(first, _)| first <= index) - 1;
            return Err(at(
                faces[face].1,
                format!("the face uses {what} {i}, but the file has only {count}"),
            ));
        }
    }
    let with_texture = triangles.iter().flatten().any(|c| c.1.is_some());
    let with_normal = triangles.iter().flatten().any(|c| c.2.is_some());
    if !with_texture && !with_normal {
        mesh.triangles = triangles.iter().map(|t| t.map(|c| c.0)).collect();
        return Ok(mesh);
    }
    split_seams(
        mesh,
        &triangles,
        &textures,
        &normals,
        with_texture,
        with_normal,
    )
}

/// Per-vertex `uv` and `N` from per-corner indices, one vertex per distinct (vertex, texture,
/// normal) triple.
fn split_seams(
    mut mesh: Mesh,
    triangles: &[[Corner; 3]],
    textures: &[DVec3],
    normals: &[DVec3],
    with_texture: bool,
    with_normal: bool,
) -> Outcome<Mesh> {
    let original = mesh.positions.len();
    let mut uv = vec![DVec3::ZERO; original];
    let mut n = vec![DVec3::ZERO; original];
    let mut first_use: Vec<Option<Corner>> = vec![None; original];
    let mut copies: HashMap<Corner, u32> = HashMap::new();
    let value = |list: &[DVec3], i: Option<u32>| i.map_or(DVec3::ZERO, |i| list[i as usize]);
    for triangle in triangles {
        let mut ids = [0u32; 3];
        for (id, &c) in ids.iter_mut().zip(triangle) {
            let v = c.0 as usize;
            // A corner that leaves out its texture coordinate or normal says nothing about
            // it, so it fits any use of the vertex; one that names different ones is a seam.
            let fits = |f: Corner| {
                (c.1.is_none() || f.1.is_none() || c.1 == f.1)
                    && (c.2.is_none() || f.2.is_none() || c.2 == f.2)
            };
            *id = match first_use[v] {
                None => {
                    first_use[v] = Some(c);
                    uv[v] = value(textures, c.1);
                    n[v] = value(normals, c.2);
                    c.0
                }
                Some(first) if fits(first) => {
                    let merged = (c.0, first.1.or(c.1), first.2.or(c.2));
                    uv[v] = value(textures, merged.1);
                    n[v] = value(normals, merged.2);
                    first_use[v] = Some(merged);
                    c.0
                }
                Some(_) => match copies.get(&c) {
                    Some(&copy) => copy,
                    None => {
                        let copy = u32::try_from(mesh.positions.len()).map_err(|_| {
                            Failure::new(
                                "the OBJ file's seams need more vertices than a shape can index",
                            )
                        })?;
                        mesh.positions.push(mesh.positions[v]);
                        uv.push(value(textures, c.1));
                        n.push(value(normals, c.2));
                        copies.insert(c, copy);
                        copy
                    }
                },
            };
        }
        mesh.triangles.push(ids);
    }
    if with_texture {
        mesh.set_attribute(TEXTURE, Attribute::Vector(uv))?;
    }
    if with_normal {
        mesh.set_attribute(NORMAL, Attribute::Vector(n))?;
    }
    Ok(mesh)
}

/// Up to three coordinates of a `v`, `vt` or `vn` record, at least `least` of them (missing
/// ones are zero).
fn triple<'t>(
    tokens: &mut impl Iterator<Item = &'t [u8]>,
    least: usize,
    what: &str,
    line: usize,
) -> Outcome<DVec3> {
    let mut p = [0.0; 3];
    for (axis, value) in p.iter_mut().enumerate() {
        match tokens.next() {
            Some(token) => *value = coordinate(token, line)?,
            None if axis >= least => break,
            None => {
                return Err(at(
                    line,
                    format!(
                        "{what} needs {} coordinate{}, found {axis}",
                        ["no", "one", "two", "three"][least],
                        if least == 1 { "" } else { "s" }
                    ),
                ));
            }
        }
    }
    Ok(DVec3::from_array(p))
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

/// The zero-based indices of a face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`, given the
/// number of vertices, texture coordinates and normals read so far (which negative indices
/// count back from).
fn corner(token: &[u8], so_far: [usize; 3], line: usize) -> Outcome<Corner> {
    let mut parts = token.split(|&b| b == b'/');
    let vertex = parts.next().unwrap_or(token);
    let v = index(vertex, token, so_far[0], "vertex", line)?;
    let mut optional = |count: usize, what: &str| -> Outcome<Option<u32>> {
        match parts.next() {
            Some(part) if !part.is_empty() => index(part, token, count, what, line).map(Some),
            _ => Ok(None),
        }
    };
    let t = optional(so_far[1], "texture coordinate")?;
    let n = optional(so_far[2], "normal")?;
    Ok((v, t, n))
}

/// One index of a corner; `corner` is the whole corner, for messages.
fn index(token: &[u8], corner: &[u8], so_far: usize, what: &str, line: usize) -> Outcome<u32> {
    let index: i64 = std::str::from_utf8(token)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| at(line, format!("'{}' is not a {what} index", text(corner))))?;
    let resolved = match index {
        0 => return Err(at(line, format!("{what} indices start at 1; found 0"))),
        i if i > 0 => i - 1,
        i => {
            let back = so_far as i64 + i;
            if back < 0 {
                return Err(at(
                    line,
                    format!("{what} index {i} reaches before the first of the {so_far} so far"),
                ));
            }
            back
        }
    };
    u32::try_from(resolved).map_err(|_| {
        at(
            line,
            format!("{what} index {index} is larger than a shape can hold"),
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
    let vectors = |name| match mesh.attributes.get(name) {
        Some(Attribute::Vector(v)) => Some(v),
        _ => None,
    };
    let (uv, normal) = (vectors(TEXTURE), vectors(NORMAL));
    for t in uv.into_iter().flatten() {
        let _ = writeln!(out, "vt {:?} {:?} {:?}", t.x, t.y, t.z);
    }
    for n in normal.into_iter().flatten() {
        let _ = writeln!(out, "vn {:?} {:?} {:?}", n.x, n.y, n.z);
    }
    for t in &mesh.triangles {
        let _ = write!(out, "f");
        for v in t {
            let i = v + 1;
            let _ = match (uv.is_some(), normal.is_some()) {
                (false, false) => write!(out, " {i}"),
                (true, false) => write!(out, " {i}/{i}"),
                (false, true) => write!(out, " {i}//{i}"),
                (true, true) => write!(out, " {i}/{i}/{i}"),
            };
        }
        let _ = writeln!(out);
    }
    Ok(out.into_bytes())
}
