//! Stanford PLY: vertex positions, vertex attributes and polygon faces, in ASCII and both
//! binary byte orders.
//!
//! Reading parses the header into elements and typed properties, then reads every element in
//! order, keeping the `x`, `y`, `z` of `vertex` (any numeric type), every other scalar vertex
//! property as an attribute, and the index list of `face` (`vertex_indices` or
//! `vertex_index`, any integer types), fanning polygons into triangles, and stepping over
//! everything else. `nx ny nz` become the normal `N`; `s t`, `u v` or `texture_u texture_v`
//! the texture coordinates `uv`; `name_x name_y name_z` a vector attribute `name`; any other
//! property a float attribute of its own name. The one key decision: before a single
//! element is read, its declared count is checked against what the rest of the file can hold
//! (each element needs at least the bytes of its fixed-size properties, or one token per
//! property in ASCII), and so is every list length; a lying header is a `Failure` naming the
//! header line or byte offset, never a huge allocation. Writing produces binary little endian
//! with double coordinates and attributes under the same names, so a saved mesh reads back
//! exactly.

use super::Mesh;
use super::attributes::{Attribute, NORMAL, TEXTURE};
use super::ply_header::{
    Element, Format, Kind, Scalar, body_first_line, header_error, parse_header,
};
use crate::base::failure::{Failure, Outcome};
use glam::DVec3;

/// Reads a PLY file's triangles.
pub fn parse_ply(bytes: &[u8]) -> Outcome<Mesh> {
    let (format, elements, body) = parse_header(bytes)?;
    let mut source = match format {
        Format::Ascii => Source::Ascii(Tokens::new(&bytes[body..], body_first_line(bytes, body))),
        _ => Source::Binary(Cursor {
            bytes,
            at: body,
            big: format == Format::Big,
        }),
    };
    let mut mesh = Mesh::default();
    let mut vertex_count: Option<u64> = None;
    let mut corners: Vec<f64> = Vec::new();
    for element in &elements {
        let least = element.least_size(format);
        if least == 0 {
            continue;
        }
        let room = source.remaining() / least;
        if element.count > room as u64 {
            return Err(header_error(
                element.line,
                format!(
                    "{} '{}' elements are declared, but the file has room for at most {room}",
                    element.count, element.name
                ),
            ));
        }
        match element.name.as_str() {
            "vertex" if vertex_count.is_none() => {
                if element.count > u32::MAX as u64 {
                    return Err(header_error(
                        element.line,
                        "too many vertices for a shape".into(),
                    ));
                }
                vertex_count = Some(element.count);
                read_vertices(&mut source, element, &mut mesh)?;
            }
            "face" => read_faces(&mut source, element, &mut mesh, &mut corners)?,
            _ => {
                for _ in 0..element.count {
                    for property in &element.properties {
                        skip(&mut source, &property.kind, &mut corners)?;
                    }
                }
            }
        }
    }
    let count = mesh.positions.len();
    if let Some(t) = mesh
        .triangles
        .iter()
        .find(|t| t.iter().any(|&v| v as usize >= count))
    {
        return Err(Failure::new(format!(
            "PLY face uses vertex {}, but the file has only {count} vertices",
            t.iter().copied().max().unwrap_or(0)
        )));
    }
    Ok(mesh)
}

/// Where a vertex property's values go.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Slot {
    Position(usize),
    /// Component `1` of vector attribute `0` (an index into the vector names).
    Vector(usize, usize),
    Float(usize),
    Skip,
}

/// The vector attributes PLY spells as three properties, and how.
const VECTOR_SPELLINGS: &[(&str, [&str; 3])] = &[
    (NORMAL, ["nx", "ny", "nz"]),
    (TEXTURE, ["s", "t", "texture_w"]),
    (TEXTURE, ["u", "v", "texture_w"]),
    (TEXTURE, ["texture_u", "texture_v", "texture_w"]),
    (TEXTURE, ["texture_s", "texture_t", "texture_w"]),
];

/// What each vertex property feeds, and the names of the vector and float attributes.
fn vertex_slots(element: &Element) -> Outcome<(Vec<Slot>, Vec<String>, Vec<String>)> {
    let scalar = |name: &str| {
        element
            .properties
            .iter()
            .position(|p| p.name == name && matches!(p.kind, Kind::Scalar(_)))
    };
    let (Some(x), Some(y), Some(z)) = (scalar("x"), scalar("y"), scalar("z")) else {
        return Err(header_error(
            element.line,
            "the vertex element needs x, y and z properties".into(),
        ));
    };
    let mut slots = vec![Slot::Skip; element.properties.len()];
    for (axis, index) in [x, y, z].into_iter().enumerate() {
        slots[index] = Slot::Position(axis);
    }
    let mut vectors: Vec<String> = Vec::new();
    let mut claim = |slots: &mut Vec<Slot>, name: String, indices: [Option<usize>; 3]| {
        if indices[..2]
            .iter()
            .any(|i| i.is_none_or(|i| slots[i] != Slot::Skip))
            || vectors.contains(&name)
        {
            return;
        }
        for (axis, index) in indices.into_iter().enumerate() {
            if let Some(index) = index.filter(|&i| slots[i] == Slot::Skip) {
                slots[index] = Slot::Vector(vectors.len(), axis);
            }
        }
        vectors.push(name);
    };
    for (name, spelling) in VECTOR_SPELLINGS {
        let indices = spelling.map(scalar);
        // Normals need all three components; texture coordinates two.
        if *name == NORMAL && indices[2].is_none() {
            continue;
        }
        claim(&mut slots, name.to_string(), indices);
    }
    for property in &element.properties {
        if let Some(stem) = property.name.strip_suffix("_x") {
            let indices = ["_x", "_y", "_z"].map(|axis| scalar(&format!("{stem}{axis}")));
            if indices.iter().all(|i| i.is_some()) {
                claim(&mut slots, stem.to_string(), indices);
            }
        }
    }
    let mut floats = Vec::new();
    for (slot, property) in slots.iter_mut().zip(&element.properties) {
        if *slot == Slot::Skip && matches!(property.kind, Kind::Scalar(_)) {
            *slot = Slot::Float(floats.len());
            floats.push(property.name.clone());
        }
    }
    Ok((slots, vectors, floats))
}

fn read_vertices(source: &mut Source, element: &Element, mesh: &mut Mesh) -> Outcome<()> {
    let (slots, vector_names, float_names) = vertex_slots(element)?;
    let count = element.count as usize;
    mesh.positions.reserve(count);
    let mut vectors = vec![Vec::with_capacity(count); vector_names.len()];
    let mut floats = vec![Vec::with_capacity(count); float_names.len()];
    let mut skipped = Vec::new();
    for _ in 0..element.count {
        let mut p = DVec3::ZERO;
        for v in vectors.iter_mut() {
            v.push(DVec3::ZERO);
        }
        for (property, slot) in element.properties.iter().zip(&slots) {
            let Kind::Scalar(scalar) = property.kind else {
                skip(source, &property.kind, &mut skipped)?;
                continue;
            };
            let value = source.scalar(scalar)?;
            if !value.is_finite() {
                return Err(source.error(format!(
                    "vertex property '{}' is {value}, not a finite number",
                    property.name
                )));
            }
            match *slot {
                Slot::Position(axis) => p[axis] = value,
                Slot::Vector(index, axis) => {
                    vectors[index].last_mut().expect("pushed above")[axis] = value
                }
                Slot::Float(index) => floats[index].push(value),
                Slot::Skip => {}
            }
        }
        mesh.positions.push(p);
    }
    for (name, values) in vector_names.into_iter().zip(vectors) {
        mesh.attributes.insert(name, Attribute::Vector(values));
    }
    for (name, values) in float_names.into_iter().zip(floats) {
        mesh.attributes.insert(name, Attribute::Float(values));
    }
    Ok(())
}

fn read_faces(
    source: &mut Source,
    element: &Element,
    mesh: &mut Mesh,
    corners: &mut Vec<f64>,
) -> Outcome<()> {
    let Some(indices) = element.properties.iter().position(|p| {
        (p.name == "vertex_indices" || p.name == "vertex_index")
            && matches!(p.kind, Kind::List { .. })
    }) else {
        return Err(header_error(
            element.line,
            "the face element needs a vertex_indices list".into(),
        ));
    };
    if let Kind::List { item, .. } = element.properties[indices].kind
        && !item.is_integer()
    {
        return Err(header_error(
            element.line,
            "face vertex indices must be integers".into(),
        ));
    }
    for _ in 0..element.count {
        for (index, property) in element.properties.iter().enumerate() {
            skip(source, &property.kind, corners)?;
            if index != indices {
                continue;
            }
            if corners.len() < 3 {
                return Err(source.error(format!(
                    "a face needs at least three vertices, found {}",
                    corners.len()
                )));
            }
            let mut ids = [0u32; 3];
            for (k, &c) in corners.iter().enumerate() {
                if !(c >= 0.0 && c <= u32::MAX as f64) {
                    return Err(source.error(format!("face vertex index {c} is out of range")));
                }
                let id = c as u32;
                match k {
                    0 | 1 => ids[k] = id,
                    _ => {
                        ids[2] = id;
                        mesh.triangles.push(ids);
                        ids[1] = id;
                    }
                }
            }
        }
    }
    Ok(())
}

/// Reads one property; a list's items are left in `items`.
fn skip(source: &mut Source, kind: &Kind, items: &mut Vec<f64>) -> Outcome<()> {
    items.clear();
    match *kind {
        Kind::Scalar(s) => {
            source.scalar(s)?;
        }
        Kind::List { count, item } => {
            let n = source.scalar(count)?;
            let least = match source {
                Source::Ascii(_) => 1,
                Source::Binary(_) => item.size(),
            };
            if n < 0.0 || n > (source.remaining() / least) as f64 {
                return Err(source.error(format!("a list length of {n} does not fit in the file")));
            }
            for _ in 0..n as usize {
                items.push(source.scalar(item)?);
            }
        }
    }
    Ok(())
}

enum Source<'a> {
    Ascii(Tokens<'a>),
    Binary(Cursor<'a>),
}

impl Source<'_> {
    /// Bytes left (binary) or an upper bound on the tokens left (ASCII).
    fn remaining(&self) -> usize {
        match self {
            Source::Ascii(t) => t.bytes.len() - t.at,
            Source::Binary(c) => c.bytes.len() - c.at,
        }
    }

    fn scalar(&mut self, scalar: Scalar) -> Outcome<f64> {
        match self {
            Source::Ascii(t) => t.scalar(scalar),
            Source::Binary(c) => c.scalar(scalar),
        }
    }

    fn error(&self, message: String) -> Failure {
        match self {
            Source::Ascii(t) => Failure::new(format!("PLY line {}: {message}", t.line)),
            Source::Binary(c) => Failure::new(format!("PLY byte {}: {message}", c.at)),
        }
    }
}

struct Tokens<'a> {
    bytes: &'a [u8],
    at: usize,
    line: usize,
}

impl<'a> Tokens<'a> {
    fn new(bytes: &'a [u8], line: usize) -> Tokens<'a> {
        Tokens { bytes, at: 0, line }
    }

    fn next(&mut self) -> Option<&'a [u8]> {
        while self.at < self.bytes.len() && self.bytes[self.at].is_ascii_whitespace() {
            if self.bytes[self.at] == b'\n' {
                self.line += 1;
            }
            self.at += 1;
        }
        let start = self.at;
        while self.at < self.bytes.len() && !self.bytes[self.at].is_ascii_whitespace() {
            self.at += 1;
        }
        (self.at > start).then(|| &self.bytes[start..self.at])
    }

    fn scalar(&mut self, scalar: Scalar) -> Outcome<f64> {
        let line = self.line;
        let Some(token) = self.next() else {
            return Err(Failure::new(format!(
                "PLY line {line}: the file ends early"
            )));
        };
        let text = std::str::from_utf8(token).unwrap_or("");
        let value = if scalar.is_integer() {
            text.parse::<i64>().ok().map(|v| v as f64)
        } else {
            text.parse::<f64>().ok()
        };
        value.ok_or_else(|| {
            Failure::new(format!(
                "PLY line {}: '{}' is not a number of type {scalar:?}",
                self.line,
                String::from_utf8_lossy(token)
            ))
        })
    }
}

struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
    big: bool,
}

impl Cursor<'_> {
    fn take<const N: usize>(&mut self) -> Outcome<[u8; N]> {
        let Some(slice) = self.bytes.get(self.at..self.at + N) else {
            return Err(Failure::new(format!(
                "PLY byte {}: the file ends early",
                self.at
            )));
        };
        let mut word = [0u8; N];
        word.copy_from_slice(slice);
        if self.big {
            word.reverse();
        }
        self.at += N;
        Ok(word)
    }

    fn scalar(&mut self, scalar: Scalar) -> Outcome<f64> {
        Ok(match scalar {
            Scalar::I8 => i8::from_le_bytes(self.take()?) as f64,
            Scalar::U8 => u8::from_le_bytes(self.take()?) as f64,
            Scalar::I16 => i16::from_le_bytes(self.take()?) as f64,
            Scalar::U16 => u16::from_le_bytes(self.take()?) as f64,
            Scalar::I32 => i32::from_le_bytes(self.take()?) as f64,
            Scalar::U32 => u32::from_le_bytes(self.take()?) as f64,
            Scalar::F32 => f32::from_le_bytes(self.take()?) as f64,
            Scalar::F64 => f64::from_le_bytes(self.take()?),
        })
    }
}

/// The mesh as binary little-endian PLY with double coordinates and attributes and uint
/// indices.
pub fn write_ply(mesh: &Mesh) -> Outcome<Vec<u8>> {
    mesh.validate()?;
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by felt\n\
         element vertex {}\nproperty double x\nproperty double y\nproperty double z\n",
        mesh.positions.len()
    );
    for (name, values) in &mesh.attributes {
        let names: Vec<String> = match (name.as_str(), values) {
            (NORMAL, Attribute::Vector(_)) => ["nx", "ny", "nz"].map(String::from).to_vec(),
            (TEXTURE, Attribute::Vector(_)) => ["s", "t", "texture_w"].map(String::from).to_vec(),
            (_, Attribute::Vector(_)) => ["_x", "_y", "_z"].map(|a| format!("{name}{a}")).to_vec(),
            (_, Attribute::Float(_)) => vec![name.clone()],
        };
        for property in names {
            if property.is_empty() || property.contains(|c: char| c.is_ascii_whitespace()) {
                return Err(Failure::new(format!(
                    "attribute name '{name}' cannot be a PLY property name"
                ))
                .with_help("PLY property names are single words"));
            }
            header.push_str(&format!("property double {property}\n"));
        }
    }
    header.push_str(&format!(
        "element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        mesh.triangles.len()
    ));
    let per_vertex = 24
        + mesh
            .attributes
            .values()
            .map(|a| match a {
                Attribute::Float(_) => 8,
                Attribute::Vector(_) => 24,
            })
            .sum::<usize>();
    let mut out = Vec::with_capacity(
        header.len() + mesh.positions.len() * per_vertex + mesh.triangles.len() * 13,
    );
    out.extend_from_slice(header.as_bytes());
    for (i, p) in mesh.positions.iter().enumerate() {
        for c in [p.x, p.y, p.z] {
            out.extend_from_slice(&c.to_le_bytes());
        }
        for values in mesh.attributes.values() {
            match values {
                Attribute::Float(v) => out.extend_from_slice(&v[i].to_le_bytes()),
                Attribute::Vector(v) => {
                    for c in v[i].to_array() {
                        out.extend_from_slice(&c.to_le_bytes());
                    }
                }
            }
        }
    }
    for t in &mesh.triangles {
        out.push(3);
        for v in t {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(out)
}
