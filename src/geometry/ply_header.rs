//! The header of a Stanford PLY file: its format, and its elements with their typed
//! properties, read before any of the body so that the body's size can be checked against
//! what the header declares.

use crate::base::failure::{Failure, Outcome};

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Format {
    Ascii,
    Little,
    Big,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    pub(crate) fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    pub(crate) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    pub(crate) fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

#[derive(Clone, Debug)]
pub(crate) enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
pub(crate) struct Property {
    pub(crate) name: String,
    pub(crate) kind: Kind,
}

#[derive(Clone, Debug)]
pub(crate) struct Element {
    pub(crate) name: String,
    pub(crate) count: u64,
    pub(crate) properties: Vec<Property>,
    /// The header line that declared it, for messages.
    pub(crate) line: usize,
}

impl Element {
    /// The fewest bytes (binary) or tokens (ASCII) one element can occupy.
    pub(crate) fn least_size(&self, format: Format) -> usize {
        self.properties
            .iter()
            .map(|p| match (&p.kind, format) {
                (_, Format::Ascii) => 1,
                (Kind::Scalar(s), _) => s.size(),
                (Kind::List { count, .. }, _) => count.size(),
            })
            .sum()
    }
}

pub(crate) fn header_error(line: usize, message: String) -> Failure {
    Failure::new(format!("PLY header line {line}: {message}"))
}

/// The format, the elements, and where the body starts.
pub(crate) fn parse_header(bytes: &[u8]) -> Outcome<(Format, Vec<Element>, usize)> {
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut at = 0;
    let mut line = 0;
    loop {
        line += 1;
        let Some(length) = bytes[at..].iter().position(|&b| b == b'\n') else {
            return Err(Failure::new("the PLY header has no end_header line")
                .with_help("is this a PLY file?"));
        };
        let raw = &bytes[at..at + length];
        at += length + 1;
        let text = std::str::from_utf8(raw)
            .map_err(|_| header_error(line, "the header is not text".into()))?;
        let words: Vec<&str> = text.split_ascii_whitespace().collect();
        if line == 1 {
            if words != ["ply"] {
                return Err(Failure::new(
                    "this is not a PLY file: it does not start with 'ply'",
                ));
            }
            continue;
        }
        match words.as_slice() {
            [] => {}
            ["comment", ..] | ["obj_info", ..] => {}
            ["format", name, _version] => {
                format = Some(match *name {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    other => return Err(header_error(line, format!("unknown format '{other}'"))),
                });
            }
            ["element", name, count] => {
                let count = count.parse::<u64>().map_err(|_| {
                    header_error(
                        line,
                        format!("element count '{count}' is not a whole number"),
                    )
                })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                    line,
                });
            }
            ["property", "list", count, item, name] => {
                let (Some(count), Some(item)) = (Scalar::parse(count), Scalar::parse(item)) else {
                    return Err(header_error(line, format!("unknown type in '{text}'")));
                };
                if !count.is_integer() {
                    return Err(header_error(
                        line,
                        "a list's length must have an integer type".into(),
                    ));
                }
                add_property(&mut elements, line, name, Kind::List { count, item })?;
            }
            ["property", kind, name] => {
                let Some(scalar) = Scalar::parse(kind) else {
                    return Err(header_error(
                        line,
                        format!("unknown property type '{kind}'"),
                    ));
                };
                add_property(&mut elements, line, name, Kind::Scalar(scalar))?;
            }
            ["end_header"] => break,
            _ => return Err(header_error(line, format!("cannot read '{}'", text.trim()))),
        }
    }
    let Some(format) = format else {
        return Err(Failure::new("the PLY header does not say its format"));
    };
    Ok((format, elements, at))
}

pub(crate) fn add_property(
    elements: &mut [Element],
    line: usize,
    name: &str,
    kind: Kind,
) -> Outcome<()> {
    let Some(element) = elements.last_mut() else {
        return Err(header_error(
            line,
            "a property comes before any element".into(),
        ));
    };
    // Readers look properties up by name: a second one of a name would be silently ignored.
    if let Some(first) = element.properties.iter().position(|p| p.name == name) {
        return Err(header_error(
            line,
            format!(
                "element '{}' has two properties named '{name}' (properties {} and {})",
                element.name,
                first + 1,
                element.properties.len() + 1
            ),
        ));
    }
    element.properties.push(Property {
        name: name.to_string(),
        kind,
    });
    Ok(())
}

pub(crate) fn body_first_line(bytes: &[u8], body: usize) -> usize {
    bytes[..body].iter().filter(|&&b| b == b'\n').count() + 1
}
