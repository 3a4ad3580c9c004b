//! Particles: points with named float and vector attributes, the input and output of splats,
//! wisps and fractal flames.
//!
//! The one key decision: a particle set is a structure of arrays. Positions are one array of
//! `[f32; 3]`, and every attribute is its own array of `f32` or `[f32; 3]`, so a point costs
//! exactly what its attributes need (12 bytes for a bare position, 28 with a density and a
//! colour) and 80 million dots fit in a few GiB. Storage is `f32`, the precision of caches and
//! renders; positions far from the origin lose precision as `f32` does (a millimetre at 10 km).
//! Sets are immutable once built: `addattr` makes a new set that shares nothing it changes.
//!
//! Around that: `io` reads and writes PLY (ASCII and binary) and CSV, `scatter` fills a level
//! set, `splat` accumulates attributes into caches, `pointfield` turns an attribute into a
//! field, `wisp` and `flame` generate dots.

pub mod chaos;
pub mod evaluate;
pub mod flame;
pub mod flame_splat;
pub mod guide;
pub mod io;
pub mod pointfield;
pub mod random;
pub mod scatter;
pub mod splat;
mod splat_bins;
pub mod wisp;

#[cfg(test)]
mod flame_splat_tests;
#[cfg(test)]
mod splat_tests;
#[cfg(test)]
mod tests;

use crate::base::failure::{Failure, Outcome};

/// The values of one attribute, one per point.
#[derive(Clone, Debug, PartialEq)]
pub enum Values {
    Float(Vec<f32>),
    Vector(Vec<[f32; 3]>),
}

impl Values {
    pub fn len(&self) -> usize {
        match self {
            Values::Float(v) => v.len(),
            Values::Vector(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Components per point: 1 or 3.
    pub fn width(&self) -> usize {
        match self {
            Values::Float(_) => 1,
            Values::Vector(_) => 3,
        }
    }

    fn kind(&self) -> &'static str {
        match self {
            Values::Float(_) => "float",
            Values::Vector(_) => "vector",
        }
    }
}

/// A named attribute.
#[derive(Clone, Debug, PartialEq)]
pub struct Attribute {
    pub name: String,
    pub values: Values,
}

/// A set of points with attributes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Particles {
    pub positions: Vec<[f32; 3]>,
    pub attributes: Vec<Attribute>,
}

/// The position's name, as files and scripts write it.
pub const POSITION: &str = "P";

/// Bytes one point of these attribute widths takes (position included).
pub fn bytes_per_point(widths: &[usize]) -> usize {
    12 + widths.iter().map(|w| w * 4).sum::<usize>()
}

impl Particles {
    /// Points at `positions` without attributes.
    pub fn new(positions: Vec<[f32; 3]>) -> Particles {
        Particles {
            positions,
            attributes: Vec::new(),
        }
    }

    pub fn len(&self) -> usize {
        self.positions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Bytes held by the positions and attributes.
    pub fn bytes(&self) -> u64 {
        let widths: Vec<usize> = self.attributes.iter().map(|a| a.values.width()).collect();
        (bytes_per_point(&widths) * self.len()) as u64
    }

    pub fn attribute(&self, name: &str) -> Option<&Values> {
        self.attributes
            .iter()
            .find(|a| a.name == name)
            .map(|a| &a.values)
    }

    /// The attribute, or a failure naming the ones there are.
    pub fn require(&self, name: &str) -> Outcome<&Values> {
        self.attribute(name).ok_or_else(|| {
            let names: Vec<String> = std::iter::once(POSITION.to_string())
                .chain(self.attributes.iter().map(|a| a.name.clone()))
                .map(|n| format!("\"{n}\""))
                .collect();
            Failure::new(format!("these particles have no attribute \"{name}\""))
                .with_help(format!("their attributes are {}", names.join(", ")))
        })
    }

    /// A float attribute's values.
    pub fn floats(&self, name: &str) -> Outcome<&[f32]> {
        match self.require(name)? {
            Values::Float(v) => Ok(v),
            other => Err(Failure::new(format!(
                "attribute \"{name}\" is a {}, not a float",
                other.kind()
            ))),
        }
    }

    /// A vector attribute's values; `"P"` is the positions.
    pub fn vectors(&self, name: &str) -> Outcome<&[[f32; 3]]> {
        if name == POSITION {
            return Ok(&self.positions);
        }
        match self.require(name)? {
            Values::Vector(v) => Ok(v),
            other => Err(Failure::new(format!(
                "attribute \"{name}\" is a {}, not a vector",
                other.kind()
            ))),
        }
    }

    /// Sets (adds or replaces) an attribute; `"P"` replaces the positions.
    pub fn set(&mut self, name: &str, values: Values) -> Outcome<()> {
        check_name(name)?;
        if values.len() != self.len() {
            return Err(Failure::new(format!(
                "attribute \"{name}\" has {} values for {} points",
                values.len(),
                self.len()
            )));
        }
        if name == POSITION {
            return match values {
                Values::Vector(v) => {
                    self.positions = v;
                    Ok(())
                }
                Values::Float(_) => Err(Failure::new("the position \"P\" must be a vector")),
            };
        }
        match self.attributes.iter_mut().find(|a| a.name == name) {
            Some(a) => a.values = values,
            None => self.attributes.push(Attribute {
                name: name.to_string(),
                values,
            }),
        }
        Ok(())
    }

    /// The smallest box holding every point, if there are points.
    pub fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        let first = *self.positions.first()?;
        Some(self.positions.iter().fold((first, first), |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1]), lo[2].min(p[2])],
                [hi[0].max(p[0]), hi[1].max(p[1]), hi[2].max(p[2])],
            )
        }))
    }

    /// Whether every position and attribute value is finite (what a file or a generator must
    /// give before anything is splatted).
    pub fn first_nonfinite(&self) -> Option<(String, usize)> {
        let bad3 = |v: &[[f32; 3]]| v.iter().position(|p| !p.iter().all(|c| c.is_finite()));
        if let Some(i) = bad3(&self.positions) {
            return Some((POSITION.to_string(), i));
        }
        for a in &self.attributes {
            let at = match &a.values {
                Values::Float(v) => v.iter().position(|x| !x.is_finite()),
                Values::Vector(v) => bad3(v),
            };
            if let Some(i) = at {
                return Some((a.name.clone(), i));
            }
        }
        None
    }

    /// A failure when any value is NaN or infinite.
    pub fn check_finite(&self, what: &str) -> Outcome<()> {
        match self.first_nonfinite() {
            None => Ok(()),
            Some((name, i)) => Err(Failure::new(format!(
                "{what}: attribute \"{name}\" of point {i} is not a finite number"
            ))),
        }
    }
}

/// Attribute names are what files can carry: letters, digits and `_`, not starting with a digit.
pub fn check_name(name: &str) -> Outcome<()> {
    let ok = !name.is_empty()
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !name.starts_with(|c: char| c.is_ascii_digit());
    if ok {
        Ok(())
    } else {
        Err(Failure::new(format!("\"{name}\" is not an attribute name"))
            .with_help("use letters, digits and _, starting with a letter"))
    }
}

/// Checks the run's memory budget for `addattr`: a copy of `set` with an attribute of `width`
/// components added, made while the script still holds `set`, so both count, and so does the
/// attribute's own storage, twice when it is `gathered` from an array or a field first.
pub fn check_added_attribute(set: &Particles, width: usize, gathered: bool) -> Outcome<()> {
    let n = set.len();
    let attribute = (n * width * std::mem::size_of::<f32>()) as f64;
    let copies = if gathered { 2.0 } else { 1.0 };
    crate::engine::budget::check(
        2.0 * set.bytes() as f64 + copies * attribute,
        &format!("addattr's copy of {n} points with the attribute added"),
    )
}

/// Checks the run's memory budget for `points` points of these widths before allocating them.
pub fn check_memory(points: usize, widths: &[usize], what: &str) -> Outcome<()> {
    crate::engine::budget::check((points as f64) * bytes_per_point(widths) as f64, what)
}
