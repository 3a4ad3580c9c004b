//! Particle files: PLY (ASCII, binary little and big endian) and CSV with a header row.
//!
//! The key decision: every numeric property of PLY's `vertex` element (or every CSV column)
//! becomes an attribute, so nothing a file carries is lost, and vectors are recognised by
//! name: `x y z` is the position, `nx ny nz` the attribute `N`, and `name_x name_y name_z`
//! the vector attribute `name`; anything else is a float. Writing uses the same names, so a
//! saved set reads back with the same attributes. Binary PLY is written little endian with
//! `float` properties (the storage precision), ASCII and CSV with shortest round-trip
//! decimals, so all three read back bit for bit. Before any point is read, the declared count
//! is checked against what the file can hold, so a lying header is a diagnostic, never a
//! giant allocation.

use super::{Particles, Values, check_name};
use crate::base::failure::{Failure, Outcome};

#[derive(Clone, Copy, Debug, PartialEq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// The byte sizes of PLY's scalar types, and whether they are floating point.
fn scalar_size(name: &str) -> Option<(usize, bool, bool)> {
    // (size, float, signed)
    Some(match name {
        "char" | "int8" => (1, false, true),
        "uchar" | "uint8" => (1, false, false),
        "short" | "int16" => (2, false, true),
        "ushort" | "uint16" => (2, false, false),
        "int" | "int32" => (4, false, true),
        "uint" | "uint32" => (4, false, false),
        "float" | "float32" => (4, true, true),
        "double" | "float64" => (8, true, true),
        _ => return None,
    })
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    size: usize,
    float: bool,
    signed: bool,
}

/// How columns (in file order) map onto attributes.
struct Layout {
    /// (attribute name, column of each component; one column for floats).
    attributes: Vec<(String, Vec<usize>)>,
    position: [usize; 3],
}

/// The layout of `columns` (CSV columns or PLY properties: `plural` names them) in the file
/// `what` names. A name given twice is refused: which of the two is meant cannot be known,
/// and keeping either would silently drop the other's values.
fn layout(columns: &[String], what: &str, plural: &str) -> Outcome<Layout> {
    for (later, name) in columns.iter().enumerate() {
        if let Some(first) = columns[..later].iter().position(|c| c == name) {
            return Err(Failure::new(format!(
                "{what} has two {plural} named \"{name}\" ({plural} {} and {})",
                first + 1,
                later + 1
            ))
            .with_help("rename or remove one of them: every name becomes one attribute"));
        }
    }
    let find = |n: &str| columns.iter().position(|c| c == n);
    let (Some(x), Some(y), Some(z)) = (find("x"), find("y"), find("z")) else {
        return Err(Failure::new(format!("{what} has no x, y and z columns"))
            .with_help("particle files need the position as columns named x, y and z"));
    };
    let mut used = vec![false; columns.len()];
    for i in [x, y, z] {
        used[i] = true;
    }
    let mut attributes = Vec::new();
    for (i, c) in columns.iter().enumerate() {
        if used[i] {
            continue;
        }
        let base = if c == "nx" {
            Some(("N".to_string(), ["nx", "ny", "nz"].map(String::from)))
        } else {
            c.strip_suffix("_x")
                .map(|b| (b.to_string(), ["_x", "_y", "_z"].map(|s| format!("{b}{s}"))))
        };
        if let Some((name, parts)) = base {
            let at: Vec<Option<usize>> = parts.iter().map(|p| find(p)).collect();
            if let [Some(a), Some(b), Some(c)] = at[..]
                && !used[b]
                && !used[c]
            {
                used[a] = true;
                used[b] = true;
                used[c] = true;
                attributes.push((name, vec![a, b, c]));
                continue;
            }
        }
        used[i] = true;
        attributes.push((c.clone(), vec![i]));
    }
    for (name, _) in &attributes {
        check_name(name).map_err(|e| Failure::new(format!("{what}: {}", e.message)))?;
    }
    Ok(Layout {
        attributes,
        position: [x, y, z],
    })
}

/// Builds the set from rows of column values, `row(i, out)` filling row `i`.
fn assemble(
    layout: &Layout,
    columns: usize,
    count: usize,
    mut row: impl FnMut(usize, &mut [f64]) -> Outcome<()>,
) -> Outcome<Particles> {
    let widths: Vec<usize> = layout.attributes.iter().map(|(_, c)| c.len()).collect();
    super::check_memory(count, &widths, "reading particles")?;
    let mut positions = Vec::with_capacity(count);
    let mut values: Vec<Values> = widths
        .iter()
        .map(|&w| {
            if w == 1 {
                Values::Float(Vec::with_capacity(count))
            } else {
                Values::Vector(Vec::with_capacity(count))
            }
        })
        .collect();
    let mut buffer = vec![0.0; columns];
    for i in 0..count {
        row(i, &mut buffer)?;
        let p = layout.position.map(|c| buffer[c] as f32);
        positions.push(p);
        for ((_, cols), v) in layout.attributes.iter().zip(values.iter_mut()) {
            match v {
                Values::Float(f) => f.push(buffer[cols[0]] as f32),
                Values::Vector(f) => f.push([
                    buffer[cols[0]] as f32,
                    buffer[cols[1]] as f32,
                    buffer[cols[2]] as f32,
                ]),
            }
        }
    }
    let mut set = Particles::new(positions);
    for ((name, _), v) in layout.attributes.iter().zip(values) {
        set.set(name, v)?;
    }
    Ok(set)
}

/// Reads a particle file, PLY or CSV by its contents (`ply` magic) or name.
pub fn read(bytes: &[u8], name: &str) -> Outcome<Particles> {
    if bytes.starts_with(b"ply") {
        read_ply(bytes)
    } else if name.to_ascii_lowercase().ends_with(".csv") {
        read_csv(bytes)
    } else {
        Err(Failure::new(format!(
            "'{name}' is neither a PLY file nor a .csv file"
        )))
    }
}

fn read_ply(bytes: &[u8]) -> Outcome<Particles> {
    let (format, count, properties, other_before, body) = ply_header(bytes)?;
    if other_before {
        return Err(Failure::new(
            "this PLY file has elements before \"vertex\"; felt reads particle files whose first element is vertex",
        ));
    }
    let columns: Vec<String> = properties.iter().map(|p| p.name.clone()).collect();
    let layout = layout(&columns, "this PLY file", "vertex properties")?;
    let data = &bytes[body..];
    match format {
        Format::Ascii => {
            let text = std::str::from_utf8(data)
                .map_err(|_| Failure::new("the body of this ASCII PLY file is not text"))?;
            let mut tokens = text.split_ascii_whitespace();
            let available = text.len() / 2 + 1;
            if count.saturating_mul(properties.len()) > available {
                return Err(Failure::new(format!(
                    "this PLY file declares {count} vertices but holds far fewer"
                )));
            }
            assemble(&layout, columns.len(), count, |i, row| {
                for (c, slot) in row.iter_mut().enumerate() {
                    let token = tokens.next().ok_or_else(|| {
                        Failure::new(format!("this PLY file ends inside vertex {i}"))
                    })?;
                    *slot = token.parse::<f64>().map_err(|_| {
                        Failure::new(format!(
                            "vertex {i}, property \"{}\": \"{token}\" is not a number",
                            columns[c]
                        ))
                    })?;
                }
                Ok(())
            })
        }
        Format::Little | Format::Big => {
            let stride: usize = properties.iter().map(|p| p.size).sum();
            if count.saturating_mul(stride) > data.len() {
                return Err(Failure::new(format!(
                    "this PLY file declares {count} vertices of {stride} bytes but holds only {} bytes",
                    data.len()
                )));
            }
            assemble(&layout, columns.len(), count, |i, row| {
                let mut at = i * stride;
                for (p, slot) in properties.iter().zip(row.iter_mut()) {
                    *slot = binary_scalar(&data[at..at + p.size], p, format == Format::Big);
                    at += p.size;
                }
                Ok(())
            })
        }
    }
}

fn binary_scalar(b: &[u8], p: &Property, big: bool) -> f64 {
    let mut raw = [0u8; 8];
    raw[..p.size].copy_from_slice(b);
    if big {
        raw[..p.size].reverse();
    }
    let bits = u64::from_le_bytes(raw);
    match (p.size, p.float, p.signed) {
        (4, true, _) => f32::from_bits(bits as u32) as f64,
        (8, true, _) => f64::from_bits(bits),
        (1, false, true) => bits as u8 as i8 as f64,
        (2, false, true) => bits as u16 as i16 as f64,
        (4, false, true) => bits as u32 as i32 as f64,
        _ => bits as f64,
    }
}

type Header = (Format, usize, Vec<Property>, bool, usize);

fn ply_header(bytes: &[u8]) -> Outcome<Header> {
    let end = find(bytes, b"end_header")
        .ok_or_else(|| Failure::new("this PLY file has no end_header line"))?;
    let mut body = end + b"end_header".len();
    if bytes.get(body) == Some(&b'\r') {
        body += 1;
    }
    if bytes.get(body) == Some(&b'\n') {
        body += 1;
    }
    let header = std::str::from_utf8(&bytes[..end])
        .map_err(|_| Failure::new("this PLY header is not text"))?;
    let mut format = None;
    let mut count = None;
    let mut properties = Vec::new();
    let mut in_vertex = false;
    let mut other_before = false;
    for (n, line) in header.lines().enumerate() {
        let words: Vec<&str> = line.split_ascii_whitespace().collect();
        let bad = |m: &str| Failure::new(format!("PLY header line {}: {m}", n + 1));
        match words.as_slice() {
            ["format", f, _] => {
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    other => return Err(bad(&format!("unknown format \"{other}\""))),
                })
            }
            ["element", name, n] => {
                let n: usize = n
                    .parse()
                    .map_err(|_| bad("the count is not a whole number"))?;
                if *name == "vertex" {
                    if count.is_some() {
                        return Err(bad("a second vertex element"));
                    }
                    count = Some(n);
                    in_vertex = true;
                } else {
                    if count.is_none() {
                        other_before = true;
                    }
                    in_vertex = false;
                }
            }
            ["property", "list", ..] if in_vertex => {
                return Err(bad("vertex list properties are not particle attributes"));
            }
            ["property", ty, name] if in_vertex => {
                let (size, float, signed) =
                    scalar_size(ty).ok_or_else(|| bad(&format!("unknown type \"{ty}\"")))?;
                properties.push(Property {
                    name: name.to_string(),
                    size,
                    float,
                    signed,
                });
            }
            _ => {}
        }
    }
    let format = format.ok_or_else(|| Failure::new("this PLY header has no format line"))?;
    let count = count.ok_or_else(|| Failure::new("this PLY file has no vertex element"))?;
    Ok((format, count, properties, other_before, body))
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

fn read_csv(bytes: &[u8]) -> Outcome<Particles> {
    let text =
        std::str::from_utf8(bytes).map_err(|_| Failure::new("this CSV file is not UTF-8 text"))?;
    // Spreadsheets often start UTF-8 CSV with a byte-order mark; it is not part of the header.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines
        .next()
        .ok_or_else(|| Failure::new("this CSV file is empty"))?;
    let columns: Vec<String> = header.split(',').map(|c| c.trim().to_string()).collect();
    let layout = layout(&columns, "this CSV file", "columns")?;
    let rows: Vec<(usize, &str)> = lines.collect();
    assemble(&layout, columns.len(), rows.len(), |i, row| {
        let (line, text) = rows[i];
        let cells: Vec<&str> = text.split(',').map(str::trim).collect();
        if cells.len() != columns.len() {
            return Err(Failure::new(format!(
                "CSV line {}: {} values for {} columns",
                line + 1,
                cells.len(),
                columns.len()
            )));
        }
        for (c, (slot, cell)) in row.iter_mut().zip(cells).enumerate() {
            *slot = cell.parse::<f64>().map_err(|_| {
                Failure::new(format!(
                    "CSV line {}, column \"{}\": \"{cell}\" is not a number",
                    line + 1,
                    columns[c]
                ))
            })?;
        }
        Ok(())
    })
}

/// Column names and, per point, its values, in file order.
fn columns(set: &Particles) -> Vec<(String, &Values)> {
    let mut out = Vec::new();
    for a in &set.attributes {
        out.push((a.name.clone(), &a.values));
    }
    out
}

fn column_names(set: &Particles) -> Vec<String> {
    let mut names: Vec<String> = ["x", "y", "z"].map(String::from).to_vec();
    for (name, values) in columns(set) {
        match values {
            Values::Float(_) => names.push(name),
            Values::Vector(_) if name == "N" => names.extend(["nx", "ny", "nz"].map(String::from)),
            Values::Vector(_) => names.extend(["x", "y", "z"].map(|s| format!("{name}_{s}"))),
        }
    }
    names
}

/// Row `i`'s values in column order.
fn row(set: &Particles, i: usize, out: &mut Vec<f32>) {
    out.clear();
    out.extend_from_slice(&set.positions[i]);
    for a in &set.attributes {
        match &a.values {
            Values::Float(v) => out.push(v[i]),
            Values::Vector(v) => out.extend_from_slice(&v[i]),
        }
    }
}

/// The file format a path asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FileKind {
    PlyBinary,
    PlyAscii,
    Csv,
}

/// The bytes of a particle file.
pub fn write(set: &Particles, kind: FileKind) -> Outcome<Vec<u8>> {
    set.check_finite("saving particles")?;
    let names = column_names(set);
    let mut out = Vec::new();
    let mut values = Vec::with_capacity(names.len());
    match kind {
        FileKind::Csv => {
            out.extend_from_slice(names.join(",").as_bytes());
            out.push(b'\n');
            for i in 0..set.len() {
                row(set, i, &mut values);
                let cells: Vec<String> = values.iter().map(|v| format!("{v:?}")).collect();
                out.extend_from_slice(cells.join(",").as_bytes());
                out.push(b'\n');
            }
        }
        FileKind::PlyAscii | FileKind::PlyBinary => {
            let format = if kind == FileKind::PlyAscii {
                "ascii"
            } else {
                "binary_little_endian"
            };
            let mut header = format!(
                "ply\nformat {format} 1.0\ncomment written by felt\nelement vertex {}\n",
                set.len()
            );
            for n in &names {
                header.push_str(&format!("property float {n}\n"));
            }
            header.push_str("end_header\n");
            out.extend_from_slice(header.as_bytes());
            for i in 0..set.len() {
                row(set, i, &mut values);
                if kind == FileKind::PlyAscii {
                    let cells: Vec<String> = values.iter().map(|v| format!("{v:?}")).collect();
                    out.extend_from_slice(cells.join(" ").as_bytes());
                    out.push(b'\n');
                } else {
                    for v in &values {
                        out.extend_from_slice(&v.to_le_bytes());
                    }
                }
            }
        }
    }
    Ok(out)
}
