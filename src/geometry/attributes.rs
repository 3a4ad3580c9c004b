//! Per-vertex attributes of a shape: normals, texture coordinates and any named float or
//! vector values, one per vertex.
//!
//! The one key decision: every attribute is per vertex, never per face corner. A file whose
//! corners give one vertex different texture coordinates on either side of a seam is read
//! with that vertex split into one copy per distinct corner (see `obj`), so a triangle's three
//! corners always carry the values it interpolates between, and transfer, warping and
//! splitting into pieces only ever gather attributes by vertex index. Names follow the
//! conventions of the files felt reads: `N` for normals, `uv` for texture coordinates (a
//! vector `(u, v, w)`, `w` zero for flat maps); `P`, the position, is not an attribute but
//! reads and writes like one.

use crate::base::failure::{Failure, Outcome};
use glam::DVec3;
use std::collections::BTreeMap;

/// The normal attribute's name.
pub const NORMAL: &str = "N";
/// The texture-coordinate attribute's name.
pub const TEXTURE: &str = "uv";
/// The name under which positions read and write like an attribute.
pub const POSITION: &str = "P";

/// One value per vertex.
#[derive(Clone, Debug, PartialEq)]
pub enum Attribute {
    Float(Vec<f64>),
    Vector(Vec<DVec3>),
}

impl Attribute {
    pub fn len(&self) -> usize {
        match self {
            Attribute::Float(v) => v.len(),
            Attribute::Vector(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn kind(&self) -> &'static str {
        match self {
            Attribute::Float(_) => "float",
            Attribute::Vector(_) => "vector",
        }
    }

    /// The values of the vertices `indices`, in that order.
    pub fn gather(&self, indices: impl Iterator<Item = usize>) -> Attribute {
        match self {
            Attribute::Float(v) => Attribute::Float(indices.map(|i| v[i]).collect()),
            Attribute::Vector(v) => Attribute::Vector(indices.map(|i| v[i]).collect()),
        }
    }

    /// `Σ weights[k] · value[corners[k]]`: the value at a point of a triangle from its
    /// barycentric weights.
    pub fn interpolate(&self, corners: [u32; 3], weights: [f64; 3]) -> AttributeValue {
        match self {
            Attribute::Float(v) => {
                AttributeValue::Float((0..3).map(|k| weights[k] * v[corners[k] as usize]).sum())
            }
            Attribute::Vector(v) => {
                AttributeValue::Vector((0..3).map(|k| weights[k] * v[corners[k] as usize]).sum())
            }
        }
    }

    /// Appends one value (zero of the right kind when `value` is `None`).
    pub fn push(&mut self, value: Option<AttributeValue>) {
        match (self, value) {
            (Attribute::Float(v), Some(AttributeValue::Float(x))) => v.push(x),
            (Attribute::Vector(v), Some(AttributeValue::Vector(x))) => v.push(x),
            (Attribute::Float(v), _) => v.push(0.0),
            (Attribute::Vector(v), _) => v.push(DVec3::ZERO),
        }
    }

    /// Checks the values are finite, naming the attribute and the first bad vertex.
    pub fn check_finite(&self, name: &str) -> Outcome<()> {
        let bad = match self {
            Attribute::Float(v) => v.iter().position(|x| !x.is_finite()),
            Attribute::Vector(v) => v.iter().position(|x| !x.is_finite()),
        };
        match bad {
            Some(i) => Err(Failure::new(format!(
                "attribute '{name}' of vertex {i} is not finite"
            ))),
            None => Ok(()),
        }
    }
}

/// One vertex's value of an attribute.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AttributeValue {
    Float(f64),
    Vector(DVec3),
}

/// A shape's attributes by name, in name order (so files list them deterministically).
pub type Attributes = BTreeMap<String, Attribute>;
