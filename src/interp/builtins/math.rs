//! Math builtins (docs/language.md, Fields): each has a plain form computed at once and a field form
//! that builds a node. The plain form comes first in every entry so that `sin(1.0)` stays a
//! float; a field anywhere among the arguments selects the field form.

use crate::base::failure::{Failure, Outcome};
use crate::field::{Field, MathFn};
use crate::interp::Interpreter;
use crate::interp::registry::{Args, Registry};
use crate::interp::value::Value;
use glam::{DMat3, DVec3};

/// Registers `name(float) -> float` and `name(scalarfield) -> scalarfield`.
macro_rules! unary {
    ($r:expr, $name:literal, $doc:literal, $plain:expr, $function:expr) => {{
        fn run(_: &mut Interpreter, args: Args) -> Outcome<Value> {
            match args.get("x")? {
                Value::Field(f) => Ok(Value::Field(f.math($function)?)),
                v => {
                    let plain: fn(f64) -> f64 = $plain;
                    Ok(Value::Float(plain(v.as_float()?)))
                }
            }
        }
        $r.add(
            "math",
            &[
                concat!($name, "(float x) -> float"),
                concat!($name, "(scalarfield x) -> scalarfield"),
            ],
            $doc,
            run,
        );
    }};
}

pub fn register(r: &mut Registry) {
    unary!(r, "abs", "absolute value", f64::abs, MathFn::Abs);
    unary!(
        r,
        "sqrt",
        "square root (NaN below zero, as IEEE)",
        f64::sqrt,
        MathFn::Sqrt
    );
    unary!(r, "exp", "e to the power x", f64::exp, MathFn::Exp);
    unary!(r, "log", "natural logarithm", f64::ln, MathFn::Log);
    unary!(r, "sin", "sine (radians)", f64::sin, MathFn::Sin);
    unary!(r, "cos", "cosine (radians)", f64::cos, MathFn::Cos);
    unary!(r, "tan", "tangent (radians)", f64::tan, MathFn::Tan);
    unary!(r, "asin", "arc sine", f64::asin, MathFn::Asin);
    unary!(r, "acos", "arc cosine", f64::acos, MathFn::Acos);
    unary!(r, "atan", "arc tangent", f64::atan, MathFn::Atan);
    unary!(
        r,
        "floor",
        "largest integer not above x",
        f64::floor,
        MathFn::Floor
    );
    unary!(
        r,
        "ceil",
        "smallest integer not below x",
        f64::ceil,
        MathFn::Ceil
    );
    unary!(r, "fract", "x - floor(x)", |x| x - x.floor(), MathFn::Fract);
    unary!(
        r,
        "sign",
        "-1, 0 or 1 by the sign of x",
        |x| if x > 0.0 {
            1.0
        } else if x < 0.0 {
            -1.0
        } else {
            0.0
        },
        MathFn::Sign
    );

    r.add(
        "math",
        &[
            "atan2(float y, float x) -> float",
            "atan2(scalarfield y, scalarfield x) -> scalarfield",
        ],
        "angle of the point (x, y) from the x axis, in (-pi, pi]",
        |_, a| binary(&a, ["y", "x"], f64::atan2, Field::atan2),
    );
    r.add(
        "math",
        &[
            "pow(float a, float b) -> float",
            "pow(scalarfield a, scalarfield b) -> scalarfield",
        ],
        "a to the power b (the same as a ^ b)",
        |_, a| binary(&a, ["a", "b"], f64::powf, Field::pow_field),
    );
    r.add(
        "math",
        &[
            "min(int a, int b) -> int",
            "min(float a, float b) -> float",
            "min(scalarfield a, scalarfield b) -> scalarfield",
        ],
        "the smaller of a and b",
        |_, a| match (a.get("a")?, a.get("b")?) {
            (Value::Int(x), Value::Int(y)) => Ok(Value::Int(*x.min(y))),
            _ => binary(&a, ["a", "b"], f64::min, Field::min),
        },
    );
    r.add(
        "math",
        &[
            "max(int a, int b) -> int",
            "max(float a, float b) -> float",
            "max(scalarfield a, scalarfield b) -> scalarfield",
        ],
        "the larger of a and b",
        |_, a| match (a.get("a")?, a.get("b")?) {
            (Value::Int(x), Value::Int(y)) => Ok(Value::Int(*x.max(y))),
            _ => binary(&a, ["a", "b"], f64::max, Field::max),
        },
    );
    r.add(
        "math",
        &[
            "clamp(float x, float lo, float hi) -> float",
            "clamp(scalarfield x, scalarfield lo, scalarfield hi) -> scalarfield",
        ],
        "x limited to [lo, hi]",
        |_, a| {
            ternary(
                &a,
                ["x", "lo", "hi"],
                |x, lo, hi| x.max(lo).min(hi),
                Field::clamp,
            )
        },
    );
    r.add(
        "math",
        &[
            "smoothstep(float e0, float e1, float x) -> float",
            "smoothstep(scalarfield e0, scalarfield e1, scalarfield x) -> scalarfield",
        ],
        "0 below e0, 1 above e1, the cubic 3t^2 - 2t^3 between",
        |_, a| ternary(&a, ["e0", "e1", "x"], smoothstep, Field::smoothstep),
    );
    r.add(
        "math",
        &[
            "lerp(float a, float b, float t) -> float",
            "lerp(vector a, vector b, float t) -> vector",
            "lerp(scalarfield a, scalarfield b, scalarfield t) -> scalarfield",
            "lerp(vectorfield a, vectorfield b, scalarfield t) -> vectorfield",
        ],
        "a + (b - a) t",
        lerp,
    );
    r.add(
        "math",
        &[
            "length(vector v) -> float",
            "length(vectorfield v) -> scalarfield",
        ],
        "Euclidean length",
        |_, a| match a.get("v")? {
            Value::Field(f) => Ok(Value::Field(f.length()?)),
            v => Ok(Value::Float(v.as_vector()?.length())),
        },
    );
    r.add(
        "math",
        &[
            "normalize(vector v) -> vector",
            "normalize(vectorfield v) -> vectorfield",
        ],
        "v / |v|, and the zero vector for a zero vector",
        |_, a| match a.get("v")? {
            Value::Field(f) => Ok(Value::Field(f.normalize()?)),
            v => Ok(Value::Vector(v.as_vector()?.normalize_or_zero())),
        },
    );
    r.add(
        "math",
        &[
            "dot(vector a, vector b) -> float",
            "dot(vectorfield a, vectorfield b) -> scalarfield",
        ],
        "inner product (the same as a * b)",
        |_, a| match (a.get("a")?, a.get("b")?) {
            (Value::Vector(x), Value::Vector(y)) => Ok(Value::Float(x.dot(*y))),
            (x, y) => Ok(Value::Field(x.as_field()?.mul(&y.as_field()?)?)),
        },
    );
    r.add(
        "math",
        &[
            "cross(vector a, vector b) -> vector",
            "cross(vectorfield a, vectorfield b) -> vectorfield",
        ],
        "cross product",
        |_, a| match (a.get("a")?, a.get("b")?) {
            (Value::Vector(x), Value::Vector(y)) => Ok(Value::Vector(x.cross(*y))),
            (x, y) => Ok(Value::Field(x.as_field()?.cross(&y.as_field()?)?)),
        },
    );
    r.add(
        "math",
        &[
            "outer(vector a, vector b) -> matrix",
            "outer(vectorfield a, vectorfield b) -> matrixfield",
        ],
        "outer product: the matrix with rows a_i b",
        |_, a| match (a.get("a")?, a.get("b")?) {
            (Value::Vector(x), Value::Vector(y)) => Ok(Value::Matrix(outer(*x, *y))),
            (x, y) => Ok(Value::Field(x.as_field()?.outer(&y.as_field()?)?)),
        },
    );
    r.add(
        "math",
        &[
            "transpose(matrix m) -> matrix",
            "transpose(matrixfield m) -> matrixfield",
        ],
        "rows and columns exchanged",
        |_, a| match a.get("m")? {
            Value::Field(f) => Ok(Value::Field(f.transpose()?)),
            v => Ok(Value::Matrix(v.as_matrix()?.transpose())),
        },
    );
    r.add(
        "math",
        &[
            "det(matrix m) -> float",
            "det(matrixfield m) -> scalarfield",
        ],
        "determinant",
        |_, a| match a.get("m")? {
            Value::Field(f) => Ok(Value::Field(f.det()?)),
            v => Ok(Value::Float(v.as_matrix()?.determinant())),
        },
    );
    r.add(
        "math",
        &[
            "trace(matrix m) -> float",
            "trace(matrixfield m) -> scalarfield",
        ],
        "sum of the diagonal",
        |_, a| match a.get("m")? {
            Value::Field(f) => Ok(Value::Field(f.trace()?)),
            v => {
                let m = v.as_matrix()?;
                Ok(Value::Float(m.x_axis.x + m.y_axis.y + m.z_axis.z))
            }
        },
    );
    r.add(
        "math",
        &["inverse(matrix m) -> matrix", "inverse(matrixfield m) -> matrixfield"],
        "matrix inverse; an error for a singular plain matrix, the pseudo-inverse where a matrixfield is singular",
        |_, a| match a.get("m")? {
            Value::Field(f) => Ok(Value::Field(f.inverse()?)),
            v => inverse(v.as_matrix()?).map(Value::Matrix),
        },
    );
    r.add(
        "math",
        &["vector(float x, float y, float z) -> vector"],
        "the vector (x, y, z)",
        |_, a| {
            Ok(Value::Vector(DVec3::new(
                a.float("x")?,
                a.float("y")?,
                a.float("z")?,
            )))
        },
    );
    r.add(
        "math",
        &["matrix(vector row0, vector row1, vector row2) -> matrix"],
        "the matrix with these rows",
        |_, a| {
            let rows = [
                a.get("row0")?.as_vector()?,
                a.get("row1")?.as_vector()?,
                a.get("row2")?.as_vector()?,
            ];
            Ok(Value::Matrix(crate::interp::value::matrix_from_rows(
                rows[0], rows[1], rows[2],
            )))
        },
    );
}

/// A builtin of two plain or field operands, the parameters `names`.
fn binary(
    a: &Args,
    names: [&str; 2],
    plain: fn(f64, f64) -> f64,
    field: fn(&Field, &Field) -> Outcome<Field>,
) -> Outcome<Value> {
    let (x, y) = (a.get(names[0])?, a.get(names[1])?);
    if matches!(x, Value::Field(_)) || matches!(y, Value::Field(_)) {
        return Ok(Value::Field(field(&x.as_field()?, &y.as_field()?)?));
    }
    Ok(Value::Float(plain(x.as_float()?, y.as_float()?)))
}

/// A builtin of three plain or field operands, the parameters `names`.
fn ternary(
    a: &Args,
    names: [&str; 3],
    plain: fn(f64, f64, f64) -> f64,
    field: fn(&Field, &Field, &Field) -> Outcome<Field>,
) -> Outcome<Value> {
    let (x, y, z) = (a.get(names[0])?, a.get(names[1])?, a.get(names[2])?);
    if [x, y, z].iter().any(|v| matches!(v, Value::Field(_))) {
        return Ok(Value::Field(field(
            &x.as_field()?,
            &y.as_field()?,
            &z.as_field()?,
        )?));
    }
    Ok(Value::Float(plain(
        x.as_float()?,
        y.as_float()?,
        z.as_float()?,
    )))
}

fn smoothstep(e0: f64, e1: f64, x: f64) -> f64 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn lerp(_: &mut Interpreter, a: Args) -> Outcome<Value> {
    let (x, y, t) = (a.get("a")?, a.get("b")?, a.get("t")?);
    match (x, y, t) {
        (Value::Vector(p), Value::Vector(q), t) if !matches!(t, Value::Field(_)) => {
            Ok(Value::Vector(*p + (*q - *p) * t.as_float()?))
        }
        _ if [x, y, t].iter().any(|v| matches!(v, Value::Field(_))) => {
            let (p, q, t) = (x.as_field()?, y.as_field()?, t.as_field()?);
            Ok(Value::Field(p.add(&q.sub(&p)?.mul(&t)?)?))
        }
        _ => {
            let (p, q, t) = (x.as_float()?, y.as_float()?, t.as_float()?);
            Ok(Value::Float(p + (q - p) * t))
        }
    }
}

pub fn outer(a: DVec3, b: DVec3) -> DMat3 {
    crate::interp::value::matrix_from_rows(a.x * b, a.y * b, a.z * b)
}

/// The inverse of a plain matrix; a singular one (relative to its scale) is an error, because a
/// script that inverts a singular matrix has almost certainly built the wrong matrix.
fn inverse(m: DMat3) -> Outcome<DMat3> {
    let det = m.determinant();
    let scale = m.x_axis.length() * m.y_axis.length() * m.z_axis.length();
    if !det.is_finite() || det.abs() <= 1e-12 * scale || scale == 0.0 {
        return Err(Failure::new(format!(
            "cannot invert a singular matrix (determinant {det})"
        ))
        .with_help("a matrix with linearly dependent rows has no inverse"));
    }
    Ok(m.inverse())
}
