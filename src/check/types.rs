//! The static types of felt and the rules that relate them: which values convert implicitly
//! (`int → float`, plain → constant field), and what each operator yields (docs/language.md,
//! "Operators").
//! The checker and the interpreter both use these rules, so a script that checks is a script
//! whose every operation the interpreter knows how to perform.

use crate::syntax::ast::{BaseType, BinaryOp, TypeExpr, UnaryOp};
use std::fmt;

#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Type {
    Int,
    Float,
    Bool,
    Str,
    Vector,
    Matrix,
    ScalarField,
    VectorField,
    MatrixField,
    Domain,
    ScalarCache,
    VectorCache,
    MatrixCache,
    Shape,
    Particles,
    Camera,
    Light,
    CloudSim,
    Void,
    Array(Box<Type>),
    /// The empty array literal `{}`, which fits any array type.
    EmptyArray,
    /// The type of an expression that already produced an error; fits anywhere, so that one
    /// mistake is reported once.
    Error,
}

impl Type {
    pub fn from_base(base: BaseType) -> Type {
        match base {
            BaseType::Int => Type::Int,
            BaseType::Float => Type::Float,
            BaseType::Bool => Type::Bool,
            BaseType::String => Type::Str,
            BaseType::Vector => Type::Vector,
            BaseType::Matrix => Type::Matrix,
            BaseType::ScalarField => Type::ScalarField,
            BaseType::VectorField => Type::VectorField,
            BaseType::MatrixField => Type::MatrixField,
            BaseType::Domain => Type::Domain,
            BaseType::ScalarCache => Type::ScalarCache,
            BaseType::VectorCache => Type::VectorCache,
            BaseType::MatrixCache => Type::MatrixCache,
            BaseType::Shape => Type::Shape,
            BaseType::Particles => Type::Particles,
            BaseType::Camera => Type::Camera,
            BaseType::Light => Type::Light,
            BaseType::CloudSim => Type::CloudSim,
            BaseType::Void => Type::Void,
        }
    }

    pub fn from_expr(ty: &TypeExpr) -> Type {
        let mut t = Type::from_base(ty.base);
        for _ in 0..ty.array_depth {
            t = Type::Array(Box::new(t));
        }
        t
    }

    pub fn array_of(elem: Type) -> Type {
        Type::Array(Box::new(elem))
    }

    pub fn is_error(&self) -> bool {
        matches!(self, Type::Error)
    }

    pub fn is_field(&self) -> bool {
        matches!(
            self,
            Type::ScalarField | Type::VectorField | Type::MatrixField
        )
    }

    pub fn is_number(&self) -> bool {
        matches!(self, Type::Int | Type::Float)
    }

    /// Shape of a value that arithmetic works on: scalar, vector or matrix, plain or field.
    pub fn shape(&self) -> Option<(Shape, bool)> {
        Some(match self {
            Type::Int | Type::Float => (Shape::Scalar, false),
            Type::Vector => (Shape::Vector, false),
            Type::Matrix => (Shape::Matrix, false),
            Type::ScalarField => (Shape::Scalar, true),
            Type::VectorField => (Shape::Vector, true),
            Type::MatrixField => (Shape::Matrix, true),
            _ => return None,
        })
    }

    /// The field type matching a shape.
    pub fn field_of(shape: Shape) -> Type {
        match shape {
            Shape::Scalar => Type::ScalarField,
            Shape::Vector => Type::VectorField,
            Shape::Matrix => Type::MatrixField,
        }
    }

    /// The plain type matching a shape.
    pub fn plain_of(shape: Shape) -> Type {
        match shape {
            Shape::Scalar => Type::Float,
            Shape::Vector => Type::Vector,
            Shape::Matrix => Type::Matrix,
        }
    }

    /// The cache type that stores fields of this shape, and back.
    pub fn cache_shape(&self) -> Option<Shape> {
        match self {
            Type::ScalarCache => Some(Shape::Scalar),
            Type::VectorCache => Some(Shape::Vector),
            Type::MatrixCache => Some(Shape::Matrix),
            _ => None,
        }
    }

    /// Can a value of type `self` be used where `target` is expected?
    pub fn converts_to(&self, target: &Type) -> bool {
        if self == target || self.is_error() || target.is_error() {
            return true;
        }
        match (self, target) {
            (Type::Int, Type::Float) => true,
            (Type::Int | Type::Float, Type::ScalarField) => true,
            (Type::Vector, Type::VectorField) => true,
            (Type::Matrix, Type::MatrixField) => true,
            (Type::EmptyArray, Type::Array(_)) => true,
            (Type::Array(a), Type::Array(b)) => a.converts_to(b),
            _ => false,
        }
    }

    /// The default value description used in messages about declarations.
    pub fn has_default(&self) -> bool {
        !matches!(
            self,
            Type::Domain
                | Type::ScalarCache
                | Type::VectorCache
                | Type::MatrixCache
                | Type::Camera
                | Type::Light
                | Type::CloudSim
                | Type::Void
        )
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Shape {
    Scalar,
    Vector,
    Matrix,
}

impl fmt::Display for Type {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self {
            Type::Int => "int",
            Type::Float => "float",
            Type::Bool => "bool",
            Type::Str => "string",
            Type::Vector => "vector",
            Type::Matrix => "matrix",
            Type::ScalarField => "scalarfield",
            Type::VectorField => "vectorfield",
            Type::MatrixField => "matrixfield",
            Type::Domain => "domain",
            Type::ScalarCache => "scalarcache",
            Type::VectorCache => "vectorcache",
            Type::MatrixCache => "matrixcache",
            Type::Shape => "shape",
            Type::Particles => "particles",
            Type::Camera => "camera",
            Type::Light => "light",
            Type::CloudSim => "cloudsim",
            Type::Void => "void",
            Type::Array(elem) => return write!(f, "{elem}[]"),
            Type::EmptyArray => "empty array",
            Type::Error => "<error>",
        };
        f.write_str(name)
    }
}

/// The common type of two values meeting in an array literal or a conditional: the one the
/// other converts to, if any.
pub fn unify(a: &Type, b: &Type) -> Option<Type> {
    if a.converts_to(b) {
        Some(b.clone())
    } else if b.converts_to(a) {
        Some(a.clone())
    } else {
        None
    }
}

/// The result type of a binary operator, or a message saying why the operands do not fit.
pub fn binary_result(op: BinaryOp, left: &Type, right: &Type) -> Result<Type, String> {
    use BinaryOp::*;
    if left.is_error() || right.is_error() {
        return Ok(Type::Error);
    }
    let mismatch = || {
        format!(
            "operator `{}` is not defined for {} and {}",
            op.symbol(),
            left,
            right
        )
    };
    match op {
        And | Or => {
            if *left == Type::Bool && *right == Type::Bool {
                Ok(Type::Bool)
            } else {
                Err(format!(
                    "operator `{}` needs two bools, found {} and {}",
                    op.symbol(),
                    left,
                    right
                ))
            }
        }
        Eq | Ne => {
            let comparable = (left.is_number() && right.is_number())
                || (left == right
                    && matches!(left, Type::Bool | Type::Str | Type::Vector | Type::Matrix));
            if comparable {
                Ok(Type::Bool)
            } else if left.is_field() || right.is_field() {
                Err(field_comparison(op))
            } else {
                Err(mismatch())
            }
        }
        Lt | Le | Gt | Ge => {
            if left.is_number() && right.is_number() {
                Ok(Type::Bool)
            } else if left.is_field() || right.is_field() {
                Err(field_comparison(op))
            } else {
                Err(mismatch())
            }
        }
        Add if *left == Type::Str && *right == Type::Str => Ok(Type::Str),
        Rem => match (left, right) {
            (Type::Int, Type::Int) => Ok(Type::Int),
            (l, r) if l.is_number() && r.is_number() => Ok(Type::Float),
            _ => Err(mismatch()),
        },
        Add | Sub | Mul | Div | Pow => {
            let ((ls, lf), (rs, rf)) = match (left.shape(), right.shape()) {
                (Some(l), Some(r)) => (l, r),
                _ => return Err(mismatch()),
            };
            if matches!(op, Add | Sub | Mul | Div) && *left == Type::Int && *right == Type::Int {
                return Ok(Type::Int);
            }
            let shape =
                arithmetic_shape(op, ls, rs).ok_or_else(|| arithmetic_message(op, left, right))?;
            Ok(if lf || rf {
                Type::field_of(shape)
            } else {
                Type::plain_of(shape)
            })
        }
    }
}

fn field_comparison(op: BinaryOp) -> String {
    format!(
        "operator `{}` compares plain numbers; fields have a value at every point",
        op.symbol()
    )
}

/// docs/language.md "Operators": the shape of `l op r`.
pub fn arithmetic_shape(op: BinaryOp, l: Shape, r: Shape) -> Option<Shape> {
    use Shape::*;
    match op {
        BinaryOp::Add | BinaryOp::Sub => (l == r).then_some(l),
        BinaryOp::Mul => Some(match (l, r) {
            (Scalar, s) | (s, Scalar) => s,
            (Vector, Vector) => Scalar,
            (Matrix, Vector) | (Vector, Matrix) => Vector,
            (Matrix, Matrix) => Matrix,
        }),
        BinaryOp::Div => (r == Scalar).then_some(l),
        BinaryOp::Pow => (l == Scalar && r == Scalar).then_some(Scalar),
        _ => None,
    }
}

fn arithmetic_message(op: BinaryOp, left: &Type, right: &Type) -> String {
    match op {
        BinaryOp::Add | BinaryOp::Sub => format!(
            "cannot {} {} and {}: both sides must be the same kind (scalar, vector or matrix)",
            if op == BinaryOp::Add {
                "add"
            } else {
                "subtract"
            },
            left,
            right
        ),
        BinaryOp::Div => format!("cannot divide {left} by {right}: the divisor must be a scalar"),
        BinaryOp::Pow => format!("`^` raises a scalar to a scalar power, found {left} ^ {right}"),
        _ => format!(
            "operator `{}` is not defined for {} and {}",
            op.symbol(),
            left,
            right
        ),
    }
}

/// The result type of a unary operator.
pub fn unary_result(op: UnaryOp, operand: &Type) -> Result<Type, String> {
    if operand.is_error() {
        return Ok(Type::Error);
    }
    match op {
        UnaryOp::Not if *operand == Type::Bool => Ok(Type::Bool),
        UnaryOp::Not => Err(format!("`!` needs a bool, found {operand}")),
        UnaryOp::Neg | UnaryOp::Plus if operand.shape().is_some() => Ok(operand.clone()),
        _ => Err(format!("cannot negate a {operand}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn operator_table_follows_the_language() {
        use BinaryOp::*;
        assert_eq!(
            binary_result(Mul, &Type::Vector, &Type::Vector),
            Ok(Type::Float)
        );
        assert_eq!(
            binary_result(Mul, &Type::VectorField, &Type::VectorField),
            Ok(Type::ScalarField)
        );
        assert_eq!(
            binary_result(Mul, &Type::MatrixField, &Type::VectorField),
            Ok(Type::VectorField)
        );
        assert_eq!(
            binary_result(Mul, &Type::Vector, &Type::Matrix),
            Ok(Type::Vector)
        );
        assert_eq!(
            binary_result(Add, &Type::Float, &Type::ScalarField),
            Ok(Type::ScalarField)
        );
        assert_eq!(binary_result(Div, &Type::Int, &Type::Int), Ok(Type::Int));
        assert_eq!(binary_result(Pow, &Type::Int, &Type::Int), Ok(Type::Float));
        assert!(binary_result(Add, &Type::Vector, &Type::Float).is_err());
        assert!(binary_result(Add, &Type::ScalarField, &Type::VectorField).is_err());
        assert!(binary_result(Div, &Type::Float, &Type::Vector).is_err());
        assert!(binary_result(Lt, &Type::ScalarField, &Type::Float).is_err());
    }

    #[test]
    fn conversions_are_the_documented_ones() {
        assert!(Type::Int.converts_to(&Type::Float));
        assert!(Type::Float.converts_to(&Type::ScalarField));
        assert!(Type::Vector.converts_to(&Type::VectorField));
        assert!(!Type::Float.converts_to(&Type::Int));
        assert!(!Type::ScalarField.converts_to(&Type::Float));
        assert!(Type::array_of(Type::Int).converts_to(&Type::array_of(Type::Float)));
        assert!(Type::EmptyArray.converts_to(&Type::array_of(Type::Shape)));
    }
}
