//! Runtime values. Plain values (numbers, vectors, matrices, strings, arrays) are ordinary
//! data with value semantics: arrays are shared until written (`Rc::make_mut`), so passing an
//! array to a function copies it only if the function changes it. Fields are handles to
//! immutable graph nodes, so copying one is free. A cache variable is the one thing with
//! identity: `cachewrite` replaces the *state* it holds, while fields already read from it keep
//! the state they were read from (docs/language.md "Domains and caches").

use super::elements::Elements;
use crate::base::failure::Failure;
use crate::check::types::{Shape, Type};
use crate::field::{Field, FieldKind};
use crate::geometry::Mesh;
use crate::grid::cache::Cache;
use crate::particles::Particles;
use crate::render::sky::Sky;
use crate::render::{Camera, Light};
use crate::space::domain::Domain;
use glam::{DMat3, DVec3};
use std::cell::RefCell;
use std::fmt;
use std::rc::Rc;
use std::sync::Arc;

#[derive(Clone, Debug)]
pub enum Value {
    Void,
    Int(i64),
    Float(f64),
    Bool(bool),
    Str(Rc<str>),
    Vector(DVec3),
    Matrix(DMat3),
    Field(Field),
    Domain(Rc<Domain>),
    Cache(Rc<CacheVar>),
    Shape(Rc<Mesh>),
    Camera(Rc<Camera>),
    Light(Rc<Light>),
    /// A sky (`envmap`, `physicalsky`): a `light` to the checker, given as `render`'s `sky`.
    Sky(crate::render::sky::Sky),
    /// Points with attributes; shared, never changed once made.
    Particles(Arc<Particles>),
    /// One state of a cloud automaton (`cloudca`, `cloudstep`).
    CloudSim(Rc<crate::interp::builtins::clouds::CloudVar>),
    /// Elements, holding their share of the memory budget, and the element type (needed
    /// for `{}` and for conversions).
    Array(Rc<Elements>, Type),
}

/// A cache variable: its domain and kind are fixed at declaration; `cachewrite` swaps the
/// state.
#[derive(Debug)]
pub struct CacheVar {
    pub shape: Shape,
    pub domain: Rc<Domain>,
    /// For a frustum cache, the frustum whose cells `domain` indexes (`frustumcache`).
    pub frustum: Option<Arc<crate::grid::frustum::Frustum>>,
    /// One value per component.
    pub background: Vec<f64>,
    pub state: RefCell<Option<Arc<Cache>>>,
}

impl Value {
    pub fn type_of(&self) -> Type {
        match self {
            Value::Void => Type::Void,
            Value::Int(_) => Type::Int,
            Value::Float(_) => Type::Float,
            Value::Bool(_) => Type::Bool,
            Value::Str(_) => Type::Str,
            Value::Vector(_) => Type::Vector,
            Value::Matrix(_) => Type::Matrix,
            Value::Field(f) => Type::field_of(shape_of_kind(f.kind())),
            Value::Domain(_) => Type::Domain,
            Value::Cache(c) => match c.shape {
                Shape::Scalar => Type::ScalarCache,
                Shape::Vector => Type::VectorCache,
                Shape::Matrix => Type::MatrixCache,
            },
            Value::Shape(_) => Type::Shape,
            Value::Camera(_) => Type::Camera,
            Value::Light(_) | Value::Sky(_) => Type::Light,
            Value::Particles(_) => Type::Particles,
            Value::CloudSim(_) => Type::CloudSim,
            Value::Array(_, elem) => Type::array_of(elem.clone()),
        }
    }

    pub fn string(s: &str) -> Value {
        Value::Str(Rc::from(s))
    }

    pub fn array(items: Vec<Value>, elem: Type) -> Value {
        Value::Array(Rc::new(Elements::new(items)), elem)
    }
}

impl Value {
    pub fn as_float(&self) -> Result<f64, Failure> {
        match self {
            Value::Float(x) => Ok(*x),
            Value::Int(i) => Ok(*i as f64),
            other => Err(Failure::new(format!(
                "expected a number, found {}",
                other.type_of()
            ))),
        }
    }

    pub fn as_int(&self) -> Result<i64, Failure> {
        match self {
            Value::Int(i) => Ok(*i),
            other => Err(Failure::new(format!(
                "expected an int, found {}",
                other.type_of()
            ))),
        }
    }

    pub fn as_bool(&self) -> Result<bool, Failure> {
        match self {
            Value::Bool(b) => Ok(*b),
            other => Err(Failure::new(format!(
                "expected a bool, found {}",
                other.type_of()
            ))),
        }
    }

    pub fn as_str(&self) -> Result<&str, Failure> {
        match self {
            Value::Str(s) => Ok(s),
            other => Err(Failure::new(format!(
                "expected a string, found {}",
                other.type_of()
            ))),
        }
    }

    pub fn as_vector(&self) -> Result<DVec3, Failure> {
        match self {
            Value::Vector(v) => Ok(*v),
            other => Err(Failure::new(format!(
                "expected a vector, found {}",
                other.type_of()
            ))),
        }
    }

    pub fn as_matrix(&self) -> Result<DMat3, Failure> {
        match self {
            Value::Matrix(m) => Ok(*m),
            other => Err(Failure::new(format!(
                "expected a matrix, found {}",
                other.type_of()
            ))),
        }
    }

    /// The value as a field: fields as they are, plain numbers/vectors/matrices as constants.
    pub fn as_field(&self) -> Result<Field, Failure> {
        match self {
            Value::Field(f) => Ok(f.clone()),
            Value::Int(i) => Ok(Field::constant_scalar(*i as f64)),
            Value::Float(x) => Ok(Field::constant_scalar(*x)),
            Value::Vector(v) => Ok(Field::constant_vector(*v)),
            Value::Matrix(m) => Ok(Field::constant_matrix(*m)),
            other => Err(Failure::new(format!(
                "expected a field, found {}",
                other.type_of()
            ))),
        }
    }

    pub fn as_array(&self) -> Result<&Rc<Elements>, Failure> {
        match self {
            Value::Array(items, _) => Ok(items),
            other => Err(Failure::new(format!(
                "expected an array, found {}",
                other.type_of()
            ))),
        }
    }

    /// Converts to `target` by the implicit conversions the checker allows.
    pub fn convert(self, target: &Type) -> Value {
        match (self, target) {
            (Value::Int(i), Type::Float) => Value::Float(i as f64),
            (Value::Int(i), Type::ScalarField) => Value::Field(Field::constant_scalar(i as f64)),
            (Value::Float(x), Type::ScalarField) => Value::Field(Field::constant_scalar(x)),
            (Value::Vector(v), Type::VectorField) => Value::Field(Field::constant_vector(v)),
            (Value::Matrix(m), Type::MatrixField) => Value::Field(Field::constant_matrix(m)),
            (Value::Array(items, elem), Type::Array(target_elem)) if elem != **target_elem => {
                let converted = items
                    .iter()
                    .map(|v| v.clone().convert(target_elem))
                    .collect();
                Value::array(converted, (**target_elem).clone())
            }
            (value, _) => value,
        }
    }

    /// The default value of a declared type without an initialiser, if it has one.
    pub fn default_of(ty: &Type) -> Option<Value> {
        Some(match ty {
            Type::Int => Value::Int(0),
            Type::Float => Value::Float(0.0),
            Type::Bool => Value::Bool(false),
            Type::Str => Value::string(""),
            Type::Vector => Value::Vector(DVec3::ZERO),
            Type::Matrix => Value::Matrix(DMat3::ZERO),
            Type::ScalarField => Value::Field(Field::constant_scalar(0.0)),
            Type::VectorField => Value::Field(Field::constant_vector(DVec3::ZERO)),
            Type::MatrixField => Value::Field(Field::constant_matrix(DMat3::ZERO)),
            Type::Shape => Value::Shape(Rc::new(Mesh::default())),
            Type::Array(elem) => Value::array(Vec::new(), (**elem).clone()),
            _ => return None,
        })
    }
}

pub fn shape_of_kind(kind: FieldKind) -> Shape {
    match kind {
        FieldKind::Scalar => Shape::Scalar,
        FieldKind::Vector => Shape::Vector,
        FieldKind::Matrix => Shape::Matrix,
    }
}

/// A matrix from its rows, as felt writes matrices.
pub fn matrix_from_rows(r0: DVec3, r1: DVec3, r2: DVec3) -> DMat3 {
    DMat3::from_cols(r0, r1, r2).transpose()
}

/// Writes a float in Rust's shortest round-trip form (`0.5`, `1e-7`, `3.0`).
pub fn format_float(x: f64) -> String {
    format!("{x:?}")
}

fn format_vector(v: DVec3) -> String {
    format!(
        "({}, {}, {})",
        format_float(v.x),
        format_float(v.y),
        format_float(v.z)
    )
}

impl fmt::Display for Value {
    /// The form `print` writes (docs/language.md, "Printing and formatting"). Strings are written
    /// as they are at the top level and quoted inside arrays, so `{"a", "b"}` stays readable.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Void => f.write_str("void"),
            Value::Int(i) => write!(f, "{i}"),
            Value::Float(x) => f.write_str(&format_float(*x)),
            Value::Bool(b) => write!(f, "{b}"),
            Value::Str(s) => f.write_str(s),
            Value::Vector(v) => f.write_str(&format_vector(*v)),
            Value::Matrix(m) => {
                let t = m.transpose();
                write!(
                    f,
                    "({}, {}, {})",
                    format_vector(t.x_axis),
                    format_vector(t.y_axis),
                    format_vector(t.z_axis)
                )
            }
            Value::Field(field) => write!(f, "{field}"),
            Value::Domain(d) => {
                write!(
                    f,
                    "domain(origin {}, lengths {}",
                    format_vector(d.origin),
                    format_vector(d.lengths)
                )?;
                if d.orientation != DVec3::ZERO {
                    write!(f, ", orientation {}", format_vector(d.orientation))?;
                }
                match d.resolution {
                    Some([nx, ny, nz]) => write!(f, ", {nx}x{ny}x{nz} cells)"),
                    None => f.write_str(")"),
                }
            }
            Value::Cache(c) => {
                let written = if c.state.borrow().is_some() {
                    "written"
                } else {
                    "empty"
                };
                let [nx, ny, nz] = c.domain.resolution.unwrap_or([0, 0, 0]);
                write!(f, "{} ({nx}x{ny}x{nz} cells, {written})", self.type_of())
            }
            Value::Shape(m) => write!(
                f,
                "shape ({} vertices, {} triangles)",
                m.positions.len(),
                m.triangles.len()
            ),
            Value::Camera(c) => {
                write!(
                    f,
                    "camera(eye {}, lookat {}, up {}",
                    format_vector(c.eye),
                    format_vector(c.lookat),
                    format_vector(c.up)
                )?;
                match c.ortho_width {
                    Some(w) => write!(f, ", ortho {})", format_float(w)),
                    None => write!(f, ", fov {})", format_float(c.fov_degrees)),
                }
            }
            Value::Light(light) => {
                let (kind, place, at, color, name) = match light.as_ref() {
                    Light::Distant(l) => ("distantlight", "dir", l.direction, l.color, &l.name),
                    Light::Point(l) => ("pointlight", "pos", l.position, l.color, &l.name),
                };
                write!(
                    f,
                    "{kind}({place} {}, color {}",
                    format_vector(at),
                    format_vector(color)
                )?;
                match name {
                    Some(name) => write!(f, ", name {name})"),
                    None => f.write_str(")"),
                }
            }
            Value::Sky(sky) => match sky {
                Sky::Uniform(radiance) => write!(f, "sky({})", format_vector(*radiance)),
                Sky::Environment(map) => write!(
                    f,
                    "envmap(\"{}\", intensity {}, rotate {})",
                    map.source,
                    format_float(map.intensity),
                    format_float(map.rotate)
                ),
                Sky::Physical(sky) => write!(
                    f,
                    "physicalsky(sun {}, turbidity {}, intensity {})",
                    format_vector(sky.sun_travel()),
                    format_float(sky.turbidity),
                    format_float(sky.intensity)
                ),
            },
            Value::Particles(p) => {
                let names: Vec<&str> = std::iter::once(crate::particles::POSITION)
                    .chain(p.attributes.iter().map(|a| a.name.as_str()))
                    .collect();
                write!(f, "particles ({} points: {})", p.len(), names.join(", "))
            }
            Value::CloudSim(c) => write!(f, "{}", c.state),
            Value::Array(items, _) => {
                f.write_str("{")?;
                for (i, item) in items.iter().enumerate() {
                    if i > 0 {
                        f.write_str(", ")?;
                    }
                    match item {
                        Value::Str(s) => write!(f, "{s:?}")?,
                        other => write!(f, "{other}")?,
                    }
                }
                f.write_str("}")
            }
        }
    }
}
