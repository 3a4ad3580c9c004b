//! The operators (docs/language.md, "Operators") on runtime values. Plain values are computed
//! at once (ints with overflow and division-by-zero checks, floats by IEEE rules); as soon as a
//! field is involved, both sides become fields and the result is a new graph node.

use super::value::Value;
use crate::base::failure::{Failure, Outcome};
use crate::field::Field;
use crate::syntax::ast::{BinaryOp, UnaryOp};
use glam::{DMat3, DVec3};

pub fn unary(op: UnaryOp, v: Value) -> Outcome<Value> {
    Ok(match (op, v) {
        (UnaryOp::Plus, v) => v,
        (UnaryOp::Not, Value::Bool(b)) => Value::Bool(!b),
        (UnaryOp::Neg, Value::Int(i)) => Value::Int(i.checked_neg().ok_or_else(overflow)?),
        (UnaryOp::Neg, Value::Float(x)) => Value::Float(-x),
        (UnaryOp::Neg, Value::Vector(v)) => Value::Vector(-v),
        (UnaryOp::Neg, Value::Matrix(m)) => Value::Matrix(-m),
        (UnaryOp::Neg, Value::Field(f)) => Value::Field(f.neg()),
        (op, v) => {
            return Err(Failure::new(format!(
                "`{op:?}` is not defined for {}",
                v.type_of()
            )));
        }
    })
}

fn overflow() -> Failure {
    Failure::new("integer overflow").with_help("use float arithmetic for large values")
}

pub fn binary(op: BinaryOp, l: Value, r: Value) -> Outcome<Value> {
    use BinaryOp::*;
    if matches!(l, Value::Field(_)) || matches!(r, Value::Field(_)) {
        return field_binary(op, &l.as_field()?, &r.as_field()?).map(Value::Field);
    }
    Ok(match (op, l, r) {
        (Add, Value::Str(a), Value::Str(b)) => {
            let bytes = a.len() as f64 + b.len() as f64;
            crate::engine::budget::check(bytes, &format!("a string of {bytes} bytes"))?;
            Value::string(&format!("{a}{b}"))
        }
        (Eq, Value::Str(a), Value::Str(b)) => Value::Bool(a == b),
        (Ne, Value::Str(a), Value::Str(b)) => Value::Bool(a != b),
        (Eq, Value::Bool(a), Value::Bool(b)) => Value::Bool(a == b),
        (Ne, Value::Bool(a), Value::Bool(b)) => Value::Bool(a != b),
        (Eq, Value::Vector(a), Value::Vector(b)) => Value::Bool(a == b),
        (Ne, Value::Vector(a), Value::Vector(b)) => Value::Bool(a != b),
        (Eq, Value::Matrix(a), Value::Matrix(b)) => Value::Bool(a == b),
        (Ne, Value::Matrix(a), Value::Matrix(b)) => Value::Bool(a != b),
        (op, Value::Int(a), Value::Int(b)) => int_binary(op, a, b)?,
        (op, a @ (Value::Int(_) | Value::Float(_)), b @ (Value::Int(_) | Value::Float(_))) => {
            float_binary(op, a.as_float()?, b.as_float()?)?
        }
        (op, a, b) => linear_binary(op, a, b)?,
    })
}

fn int_binary(op: BinaryOp, a: i64, b: i64) -> Outcome<Value> {
    use BinaryOp::*;
    Ok(match op {
        Add => Value::Int(a.checked_add(b).ok_or_else(overflow)?),
        Sub => Value::Int(a.checked_sub(b).ok_or_else(overflow)?),
        Mul => Value::Int(a.checked_mul(b).ok_or_else(overflow)?),
        Div | Rem if b == 0 => {
            return Err(Failure::new("integer division by zero")
                .with_help("write one side as a float (e.g. 1.0) for IEEE division"));
        }
        // C semantics: truncation toward zero, remainder with the sign of the dividend.
        Div => Value::Int(a.checked_div(b).ok_or_else(overflow)?),
        Rem => Value::Int(a.checked_rem(b).ok_or_else(overflow)?),
        Pow => Value::Float((a as f64).powf(b as f64)),
        Eq => Value::Bool(a == b),
        Ne => Value::Bool(a != b),
        Lt => Value::Bool(a < b),
        Le => Value::Bool(a <= b),
        Gt => Value::Bool(a > b),
        Ge => Value::Bool(a >= b),
        And | Or => return Err(Failure::new("`&&` and `||` need bools")),
    })
}

fn float_binary(op: BinaryOp, a: f64, b: f64) -> Outcome<Value> {
    use BinaryOp::*;
    Ok(match op {
        Add => Value::Float(a + b),
        Sub => Value::Float(a - b),
        Mul => Value::Float(a * b),
        Div => Value::Float(a / b),
        Rem => Value::Float(a % b),
        Pow => Value::Float(a.powf(b)),
        Eq => Value::Bool(a == b),
        Ne => Value::Bool(a != b),
        Lt => Value::Bool(a < b),
        Le => Value::Bool(a <= b),
        Gt => Value::Bool(a > b),
        Ge => Value::Bool(a >= b),
        And | Or => return Err(Failure::new("`&&` and `||` need bools")),
    })
}

/// Vectors and matrices (plain): §4's table with glam doing the arithmetic.
fn linear_binary(op: BinaryOp, a: Value, b: Value) -> Outcome<Value> {
    use BinaryOp::*;
    let scalar = |v: &Value| v.as_float().ok();
    Ok(match (op, &a, &b) {
        (Add, Value::Vector(x), Value::Vector(y)) => Value::Vector(*x + *y),
        (Sub, Value::Vector(x), Value::Vector(y)) => Value::Vector(*x - *y),
        (Add, Value::Matrix(x), Value::Matrix(y)) => Value::Matrix(*x + *y),
        (Sub, Value::Matrix(x), Value::Matrix(y)) => Value::Matrix(*x - *y),
        (Mul, Value::Vector(x), Value::Vector(y)) => Value::Float(x.dot(*y)),
        (Mul, Value::Matrix(m), Value::Vector(v)) => Value::Vector(*m * *v),
        (Mul, Value::Vector(v), Value::Matrix(m)) => Value::Vector(m.transpose() * *v),
        (Mul, Value::Matrix(x), Value::Matrix(y)) => Value::Matrix(*x * *y),
        (Mul, Value::Vector(v), s) | (Mul, s, Value::Vector(v)) if scalar(s).is_some() => {
            Value::Vector(*v * scalar(s).unwrap_or_default())
        }
        (Mul, Value::Matrix(m), s) | (Mul, s, Value::Matrix(m)) if scalar(s).is_some() => {
            Value::Matrix(*m * scalar(s).unwrap_or_default())
        }
        (Div, Value::Vector(v), s) if scalar(s).is_some() => {
            Value::Vector(*v / scalar(s).unwrap_or_default())
        }
        (Div, Value::Matrix(m), s) if scalar(s).is_some() => {
            Value::Matrix(*m * (1.0 / scalar(s).unwrap_or_default()))
        }
        _ => {
            return Err(Failure::new(format!(
                "operator `{}` is not defined for {} and {}",
                op.symbol(),
                a.type_of(),
                b.type_of()
            )));
        }
    })
}

/// Fields: every arithmetic operator builds a node; comparisons are not defined on fields.
fn field_binary(op: BinaryOp, a: &Field, b: &Field) -> Outcome<Field> {
    use BinaryOp::*;
    match op {
        Add => a.add(b),
        Sub => a.sub(b),
        Mul => a.mul(b),
        Div => a.div(b),
        Pow => a.pow(b),
        _ => Err(Failure::new(format!(
            "operator `{}` compares plain numbers; fields have a value at every point",
            op.symbol()
        ))
        .with_help("use mask(f) or select(c, a, b) for pointwise choices")),
    }
}

/// `m` as rows, for messages and tests.
pub fn rows(m: DMat3) -> [DVec3; 3] {
    [m.row(0), m.row(1), m.row(2)]
}
