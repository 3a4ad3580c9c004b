//! Shape attribute builtins (FELT chapter 4.3): read and set per-vertex attributes, warp a
//! shape through a vectorfield, transfer an attribute from a reference shape through a warp.
//!
//! Vector and float attributes are read by two builtins (`pointattr`, `pointattrfloat`)
//! because a builtin's result type is fixed by its signature, and the checker must know
//! whether a script holds a `vector[]` or a `float[]`. The one key decision: every builtin
//! here returns a new shape and leaves its argument as it was, like every other felt value.

use crate::base::failure::{Failure, Outcome};
use crate::check::types::Type;
use crate::field::{Field, FieldKind, grad, sample_points};
use crate::geometry::attributes::{NORMAL, POSITION};
use crate::geometry::transfer::{Surface, transfer};
use crate::geometry::{Attribute, AttributeValue, Mesh, uv_sphere};
use crate::grid::cache::Cache;
use crate::interp::registry::{Args, Registry};
use crate::interp::value::Value;
use crate::space::{FieldSampler, FnField, GridSource};
use glam::{DMat3, DVec3};
use std::rc::Rc;
use std::sync::Arc;

pub fn register(r: &mut Registry) {
    r.add(
        "geometry",
        &[
            "pointattr(shape s, string name) -> vector[]",
            "pointattr(shape s, string name, domain d) -> vectorfield",
        ],
        "a vector attribute of a shape's vertices (\"P\" for positions, \"N\" normals, \"uv\" \
         texture coordinates) as an array, or, with a domain, as a field: at each cell centre the \
         value interpolated at the closest point of the surface",
        |interp, a| read_attribute(interp, &a, FieldKind::Vector),
    );
    r.add(
        "geometry",
        &[
            "pointattrfloat(shape s, string name) -> float[]",
            "pointattrfloat(shape s, string name, domain d) -> scalarfield",
        ],
        "a float attribute of a shape's vertices as an array, or, with a domain, as a field read \
         at the closest point of the surface",
        |interp, a| read_attribute(interp, &a, FieldKind::Scalar),
    );
    r.add(
        "geometry",
        &[
            "setpointattr(shape s, string name, vector[] values) -> shape",
            "setpointattr(shape s, string name, float[] values) -> shape",
            "setpointattr(shape s, string name, vectorfield values) -> shape",
            "setpointattr(shape s, string name, scalarfield values) -> shape",
        ],
        "the shape with attribute `name` set, one value per vertex, or a field evaluated at each \
         vertex (\"P\" moves the vertices)",
        |_, a| {
            let mesh = shape(&a)?;
            let name = a.string("name")?;
            let values = match a.get("values")? {
                Value::Array(items, _) => array_attribute(items)?,
                field => field_at_vertices(&field.as_field()?, &mesh.positions)?,
            };
            Ok(shape_value(with_attribute(mesh, name, values)?))
        },
    );
    r.add(
        "geometry",
        &["pointattrs(shape s) -> string[]"],
        "the names of a shape's vertex attributes, in alphabetical order",
        |_, a| {
            let names = shape(&a)?
                .attributes
                .keys()
                .map(|k| Value::string(k))
                .collect();
            Ok(Value::array(names, Type::Str))
        },
    );
    r.add(
        "geometry",
        &["warpshape(shape s, vectorfield X) -> shape"],
        "the shape with every vertex moved to X(vertex); normals follow the warp's exact \
         Jacobian (inverse transpose), other attributes stay with their vertices",
        |_, a| Ok(shape_value(warp(shape(&a)?, &a.get("X")?.as_field()?)?)),
    );
    r.add(
        "geometry",
        &["transferattr(shape object, shape reference, vectorfield X, string name) -> shape"],
        "the object with attribute `name` read from the reference: each object vertex is mapped \
         through X and takes the reference's value interpolated barycentrically at the closest \
         point of the closest reference triangle",
        |_, a| {
            let object = shape_named(&a, "object")?;
            let reference = shape_named(&a, "reference")?;
            let name = a.string("name")?;
            let mapped = points(&sample_points(&a.get("X")?.as_field()?, &object.positions)?);
            Ok(shape_value(transfer(object, reference, &mapped, name)?))
        },
    );
    r.add(
        "geometry",
        &["uvsphere(vector center, float radius, int rings, int segments) -> shape"],
        "a sphere meshed in latitude bands with texture coordinates uv (u around, v from south to \
         north pole) and normals N; the seam and the poles have their own vertices",
        |_, a| {
            let count = |key: &str| -> Outcome<usize> {
                let n = a.int(key)?;
                usize::try_from(n)
                    .map_err(|_| Failure::new(format!("{key} must be positive, found {n}")))
            };
            Ok(shape_value(uv_sphere(
                a.get("center")?.as_vector()?,
                a.float("radius")?,
                count("rings")?,
                count("segments")?,
            )?))
        },
    );
}

fn shape_value(mesh: Mesh) -> Value {
    Value::Shape(Rc::new(mesh))
}

fn shape(a: &Args) -> Outcome<&Mesh> {
    shape_named(a, "s")
}

fn shape_named<'a>(a: &'a Args, key: &str) -> Outcome<&'a Mesh> {
    match a.get(key)? {
        Value::Shape(mesh) => Ok(mesh),
        other => Err(Failure::new(format!(
            "expected a shape, found {}",
            other.type_of()
        ))),
    }
}

fn read_attribute(
    interp: &mut crate::interp::Interpreter,
    a: &Args,
    kind: FieldKind,
) -> Outcome<Value> {
    let mesh = shape(a)?;
    let name = a.string("name")?;
    let positions;
    let values = if name == POSITION {
        positions = Attribute::Vector(mesh.positions.clone());
        &positions
    } else {
        mesh.attribute(name)?
    };
    let wanted = if kind == FieldKind::Vector {
        "vector"
    } else {
        "float"
    };
    if values.kind() != wanted {
        let other = if kind == FieldKind::Vector {
            "pointattrfloat"
        } else {
            "pointattr"
        };
        return Err(Failure::new(format!(
            "attribute '{name}' is a {} attribute, not a {wanted} one",
            values.kind()
        ))
        .with_help(format!("read it with {other}")));
    }
    let Some(Value::Domain(domain)) = a.opt("d") else {
        crate::interp::elements::check_array(values.len(), 0, "pointattr's array")?;
        return Ok(match values {
            Attribute::Float(v) => {
                Value::array(v.iter().map(|&x| Value::Float(x)).collect(), Type::Float)
            }
            Attribute::Vector(v) => {
                Value::array(v.iter().map(|&x| Value::Vector(x)).collect(), Type::Vector)
            }
        });
    };
    if domain.resolution.is_none() {
        return Err(Failure::new(
            "an attribute field needs a domain with a cell size",
        ));
    }
    let surface = Arc::new(Surface::new(Arc::new(mesh.clone()))?);
    let values = values.clone();
    let width = kind.width();
    let sampler: Arc<dyn FieldSampler> = Arc::new(FnField::new(width, move |p, out| match surface
        .read_one(&values, p, 0, &mut Vec::new())
        .0
    {
        AttributeValue::Float(x) => out[0] = x,
        AttributeValue::Vector(v) => out.copy_from_slice(&v.to_array()),
    }));
    let label = format!(
        "{} '{name}' at {}",
        if kind == FieldKind::Vector {
            "pointattr"
        } else {
            "pointattrfloat"
        },
        interp.location(interp.call_span)
    );
    let cache = Cache::from_field((**domain).clone(), width, sampler, vec![0.0; width], label)?;
    let grid: Arc<dyn GridSource> = Arc::new(cache);
    Ok(Value::Field(Field::from_linear_grid(grid)?))
}

fn array_attribute(items: &[Value]) -> Outcome<Attribute> {
    match items.first() {
        Some(Value::Float(_)) | Some(Value::Int(_)) => Ok(Attribute::Float(
            items.iter().map(|v| v.as_float()).collect::<Outcome<_>>()?,
        )),
        _ => Ok(Attribute::Vector(
            items
                .iter()
                .map(|v| v.as_vector())
                .collect::<Outcome<_>>()?,
        )),
    }
}

fn field_at_vertices(field: &Field, positions: &[DVec3]) -> Outcome<Attribute> {
    let values = sample_points(field, positions)?;
    match field.kind() {
        FieldKind::Scalar => Ok(Attribute::Float(values)),
        FieldKind::Vector => Ok(Attribute::Vector(points(&values))),
        FieldKind::Matrix => Err(Failure::new(
            "a vertex attribute is a float or a vector, not a matrix",
        )),
    }
}

fn points(values: &[f64]) -> Vec<DVec3> {
    values
        .chunks_exact(3)
        .map(|c| DVec3::new(c[0], c[1], c[2]))
        .collect()
}

fn with_attribute(mesh: &Mesh, name: &str, values: Attribute) -> Outcome<Mesh> {
    let mut out = mesh.clone();
    if name == POSITION {
        let Attribute::Vector(p) = values else {
            return Err(Failure::new("positions \"P\" are vectors, not floats"));
        };
        if p.len() != out.positions.len() {
            return Err(Failure::new(format!(
                "\"P\" needs one position per vertex: {} values for {} vertices",
                p.len(),
                out.positions.len()
            )));
        }
        out.positions = p;
        out.validate()?;
    } else {
        if name.is_empty() {
            return Err(Failure::new("an attribute needs a name"));
        }
        out.set_attribute(name, values)?;
    }
    Ok(out)
}

fn warp(mesh: &Mesh, x: &Field) -> Outcome<Mesh> {
    let mut out = mesh.clone();
    out.positions = points(&sample_points(x, &mesh.positions)?);
    out.validate()
        .map_err(|f| Failure::new(format!("the warped shape is broken: {}", f.message)))?;
    if let Some(Attribute::Vector(normals)) = mesh.attributes.get(NORMAL) {
        let jacobian = sample_points(&grad(x)?, &mesh.positions)?;
        let warped = normals
            .iter()
            .zip(jacobian.chunks_exact(9))
            .map(|(n, j)| {
                // Normals transform with the inverse transpose; the cofactor matrix is that
                // times the determinant, so it needs no division and only its sign matters.
                let rows = [0, 3, 6].map(|r| DVec3::new(j[r], j[r + 1], j[r + 2]));
                let cofactor = DMat3::from_cols(
                    rows[1].cross(rows[2]),
                    rows[2].cross(rows[0]),
                    rows[0].cross(rows[1]),
                )
                .transpose();
                let det = rows[0].dot(rows[1].cross(rows[2]));
                (det.signum() * (cofactor * *n)).normalize_or_zero()
            })
            .collect();
        out.set_attribute(NORMAL, Attribute::Vector(warped))?;
    }
    Ok(out)
}
