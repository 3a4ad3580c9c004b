//! Fields: lazy, resolution-independent functions of space, as shared expression graphs.
//!
//! A [`Field`] is one, three or nine scalar nodes (scalar, vector, matrix; matrices row-major)
//! of the graph in `node`. Building a field never evaluates anything: operators, calculus and
//! warps only make nodes. Values are computed when an output asks — `probe`, `stats`, a cache
//! fill, a render — by compiling the reachable nodes into a register program (`program`) and
//! running it over blocks of points on all threads (`eval`).
//!
//! Decisions that shape everything downstream:
//! - `grad` is symbolic and exact (`calculus`), through noise (analytic derivatives) and warps;
//!   grid reads use the exact derivative of their interpolant, or central differences at the
//!   cell size when the read asks for them.
//! - `compose(F, X)` substitutes `X` for the position in `F`'s graph, so a composed field is an
//!   ordinary graph (differentiable, shareable, compiled into one program) and a chain of
//!   advections grows linearly, not exponentially.
//! - Precision: registers are `f64` everywhere; only noise in cache fills and renders runs in
//!   `f32` offsets from an `f64` block base (see `eval`).

mod advection;
mod calculus;
#[cfg(test)]
mod derivative_tests;
pub mod eval;
pub mod interval;
pub mod kernel;
pub mod linalg;
pub mod nacelle;
pub mod node;
pub mod noise;
#[cfg(test)]
mod op_tests;
pub mod program;
pub mod prune;
mod sampler;
pub mod shapes;
pub mod ssa;
mod substitution;
#[cfg(test)]
mod tests;

pub use advection::{Resample, Scheme, advect, advect_with};
pub use node::MathFn;
pub use sampler::{
    CompiledField, grids_read, prepare, probe, sample_points, stats, stats_with_count,
};

use crate::base::failure::{Failure, Outcome};
use crate::space::{GridDerivative, GridSource, Interp};
use glam::{DMat3, DVec3};
use node::{BinOp, NodeRef, Op};
use std::fmt;
use std::sync::Arc;

/// The kind of value a field has at each point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FieldKind {
    Scalar,
    Vector,
    Matrix,
}

impl FieldKind {
    pub fn width(self) -> usize {
        match self {
            FieldKind::Scalar => 1,
            FieldKind::Vector => 3,
            FieldKind::Matrix => 9,
        }
    }

    pub fn of_width(width: usize) -> Option<FieldKind> {
        match width {
            1 => Some(FieldKind::Scalar),
            3 => Some(FieldKind::Vector),
            9 => Some(FieldKind::Matrix),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            FieldKind::Scalar => "scalarfield",
            FieldKind::Vector => "vectorfield",
            FieldKind::Matrix => "matrixfield",
        }
    }
}

/// A plain value of a field at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FieldValue {
    Scalar(f64),
    Vector(DVec3),
    Matrix(DMat3),
}

/// A scalar, vector or matrix field.
#[derive(Clone)]
pub struct Field {
    kind: FieldKind,
    components: Arc<[NodeRef]>,
}

impl fmt::Debug for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{self}")
    }
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let nodes = node::postorder(&self.components).len();
        let plural = if nodes == 1 { "" } else { "s" };
        write!(f, "{} ({nodes} node{plural})", self.kind.name())
    }
}

impl Field {
    fn new(kind: FieldKind, components: Vec<NodeRef>) -> Field {
        debug_assert_eq!(components.len(), kind.width());
        Field {
            kind,
            components: components.into(),
        }
    }

    pub fn scalar(n: NodeRef) -> Field {
        Field::new(FieldKind::Scalar, vec![n])
    }

    fn vector(v: [NodeRef; 3]) -> Field {
        Field::new(FieldKind::Vector, v.to_vec())
    }

    fn matrix(m: [NodeRef; 9]) -> Field {
        Field::new(FieldKind::Matrix, m.to_vec())
    }

    pub fn kind(&self) -> FieldKind {
        self.kind
    }

    /// The scalar nodes, row-major for matrices.
    pub fn components(&self) -> &[NodeRef] {
        &self.components
    }

    /// Whether two fields are the same graph (hash-consing makes equal expressions identical).
    pub fn same_as(&self, other: &Field) -> bool {
        self.kind == other.kind
            && self
                .components
                .iter()
                .zip(other.components.iter())
                .all(|(a, b)| a.id == b.id)
    }

    /// The position `x` itself.
    pub fn identity() -> Field {
        Field::vector(std::array::from_fn(node::position))
    }

    pub fn constant_scalar(c: f64) -> Field {
        Field::scalar(node::constant(c))
    }

    pub fn constant_vector(v: DVec3) -> Field {
        Field::vector(std::array::from_fn(|i| node::constant(v[i])))
    }

    pub fn constant_matrix(m: DMat3) -> Field {
        // glam stores columns; fields are row-major.
        Field::matrix(std::array::from_fn(|i| node::constant(m.col(i % 3)[i / 3])))
    }

    /// A field that reads a grid trilinearly, with the interpolant's own derivatives: how
    /// every lazily filled grid (`shape2ls`, `clouddensity`, `pointfield`) is read.
    pub fn from_linear_grid(grid: Arc<dyn GridSource>) -> Outcome<Field> {
        Field::from_grid(grid, Interp::Linear, GridDerivative::Interpolant)
    }

    /// A field that reads a grid (a cache, a file, an FFT result).
    pub fn from_grid(
        grid: Arc<dyn GridSource>,
        interp: Interp,
        derivative: GridDerivative,
    ) -> Outcome<Field> {
        let kind = FieldKind::of_width(grid.width()).ok_or_else(|| {
            Failure::new(format!(
                "a grid of {} components is not a field",
                grid.width()
            ))
        })?;
        let kernel = node::mk(Op::Kernel(
            Arc::new(kernel::grid_read::GridRead::new(
                grid,
                interp,
                kernel::grid_read::Reading::Value(derivative),
            )),
            (0..3).map(node::position).collect(),
        ));
        Ok(Field::new(
            kind,
            (0..kind.width())
                .map(|c| node::output_of(&kernel, c))
                .collect(),
        ))
    }

    /// Noise of `kind` and `seed` at the position (lattice spacing 1). With `derivatives`, the
    /// result is the vectorfield of its exact gradient instead.
    pub fn noise(kind: noise::NoiseKind, seed: u32) -> Field {
        Field::scalar(node::kernel_output(
            Arc::new(kernel::noise::Noise { kind, seed }),
            (0..3).map(node::position).collect(),
            0,
        ))
    }

    /// The constant value, if the field does not depend on the position.
    pub fn as_constant(&self) -> Option<FieldValue> {
        let values: Option<Vec<f64>> = self.components.iter().map(|c| c.constant()).collect();
        let v = values?;
        Some(match self.kind {
            FieldKind::Scalar => FieldValue::Scalar(v[0]),
            FieldKind::Vector => FieldValue::Vector(DVec3::new(v[0], v[1], v[2])),
            FieldKind::Matrix => FieldValue::Matrix(DMat3::from_cols_array(&[
                v[0], v[3], v[6], v[1], v[4], v[7], v[2], v[5], v[8],
            ])),
        })
    }

    fn only_scalar(&self, what: &str) -> Outcome<&NodeRef> {
        match self.kind {
            FieldKind::Scalar => Ok(&self.components[0]),
            other => Err(Failure::new(format!(
                "{what} needs a scalarfield, found a {}",
                other.name()
            ))),
        }
    }

    fn only_vector(&self, what: &str) -> Outcome<&[NodeRef]> {
        match self.kind {
            FieldKind::Vector => Ok(&self.components),
            other => Err(Failure::new(format!(
                "{what} needs a vectorfield, found a {}",
                other.name()
            ))),
        }
    }

    fn only_matrix(&self, what: &str) -> Outcome<&[NodeRef]> {
        match self.kind {
            FieldKind::Matrix => Ok(&self.components),
            other => Err(Failure::new(format!(
                "{what} needs a matrixfield, found a {}",
                other.name()
            ))),
        }
    }

    fn map(&self, f: impl Fn(&NodeRef) -> NodeRef) -> Field {
        Field::new(self.kind, self.components.iter().map(f).collect())
    }

    fn zip(&self, other: &Field, f: impl Fn(&NodeRef, &NodeRef) -> NodeRef) -> Field {
        Field::new(
            self.kind,
            self.components
                .iter()
                .zip(other.components.iter())
                .map(|(a, b)| f(a, b))
                .collect(),
        )
    }

    /// Component `i` (0, 1, 2) of a vectorfield, or row `i` of a matrixfield.
    pub fn component(&self, i: usize) -> Outcome<Field> {
        match self.kind {
            FieldKind::Vector if i < 3 => Ok(Field::scalar(self.components[i].clone())),
            FieldKind::Matrix if i < 3 => Ok(Field::vector(std::array::from_fn(|c| {
                self.components[i * 3 + c].clone()
            }))),
            _ => Err(Failure::new(format!(
                "a {} has no component {i}",
                self.kind.name()
            ))),
        }
    }

    pub fn neg(&self) -> Field {
        self.map(|c| node::neg(c.clone()))
    }

    pub fn add(&self, other: &Field) -> Outcome<Field> {
        self.same_kind(other, "+")?;
        Ok(self.zip(other, |a, b| node::add(a.clone(), b.clone())))
    }

    pub fn sub(&self, other: &Field) -> Outcome<Field> {
        self.same_kind(other, "-")?;
        Ok(self.zip(other, |a, b| node::sub(a.clone(), b.clone())))
    }

    fn same_kind(&self, other: &Field, op: &str) -> Outcome<()> {
        if self.kind != other.kind {
            return Err(Failure::new(format!(
                "cannot apply `{op}` to a {} and a {}",
                self.kind.name(),
                other.kind.name()
            )));
        }
        Ok(())
    }

    /// The products (docs/language.md, "Operators"): scaling, dot product, matrix–vector and
    /// matrix products.
    pub fn mul(&self, other: &Field) -> Outcome<Field> {
        use FieldKind::*;
        let (a, b) = (&self.components, &other.components);
        Ok(match (self.kind, other.kind) {
            (Scalar, _) => other.map(|c| node::mul(a[0].clone(), c.clone())),
            (_, Scalar) => self.map(|c| node::mul(c.clone(), b[0].clone())),
            (Vector, Vector) => Field::scalar(linalg::dot(a, b)),
            (Matrix, Vector) => Field::vector(linalg::mat_vec(a, b)),
            (Vector, Matrix) => Field::vector(linalg::mat_vec(&linalg::transpose(b), a)),
            (Matrix, Matrix) => Field::matrix(linalg::mat_mul(a, b)),
        })
    }

    /// Division by a scalar (IEEE where the divisor is zero).
    pub fn div(&self, other: &Field) -> Outcome<Field> {
        let d = other.only_scalar("the divisor of `/`")?.clone();
        Ok(self.map(|c| node::div(c.clone(), d.clone())))
    }

    pub fn pow(&self, other: &Field) -> Outcome<Field> {
        Field::pow_field(self, other)
    }

    pub fn pow_field(a: &Field, b: &Field) -> Outcome<Field> {
        Field::scalar_binary(a, b, BinOp::Pow, "pow")
    }

    pub fn atan2(a: &Field, b: &Field) -> Outcome<Field> {
        Field::scalar_binary(a, b, BinOp::Atan2, "atan2")
    }

    pub fn min(a: &Field, b: &Field) -> Outcome<Field> {
        Field::scalar_binary(a, b, BinOp::Min, "min")
    }

    pub fn max(a: &Field, b: &Field) -> Outcome<Field> {
        Field::scalar_binary(a, b, BinOp::Max, "max")
    }

    fn scalar_binary(a: &Field, b: &Field, op: BinOp, what: &str) -> Outcome<Field> {
        let (x, y) = (a.only_scalar(what)?, b.only_scalar(what)?);
        Ok(Field::scalar(node::binary(op, x.clone(), y.clone())))
    }

    pub fn clamp(x: &Field, lo: &Field, hi: &Field) -> Outcome<Field> {
        Field::min(&Field::max(x, lo)?, hi)
    }

    /// 0 below `e0`, 1 above `e1`, `3t² − 2t³` between.
    pub fn smoothstep(e0: &Field, e1: &Field, x: &Field) -> Outcome<Field> {
        let t = x.sub(e0)?.div(&e1.sub(e0)?)?;
        let t = Field::clamp(
            &t,
            &Field::constant_scalar(0.0),
            &Field::constant_scalar(1.0),
        )?;
        let tt = t.mul(&t)?;
        let shape = Field::constant_scalar(3.0).sub(&t.mul(&Field::constant_scalar(2.0))?)?;
        tt.mul(&shape)
    }

    pub fn math(&self, f: MathFn) -> Outcome<Field> {
        let a = self.only_scalar(&format!("{f:?}").to_lowercase())?;
        Ok(Field::scalar(node::unary(f, a.clone())))
    }

    /// A unary function applied to every component.
    pub fn math_each(&self, f: MathFn) -> Outcome<Field> {
        Ok(self.map(|c| node::unary(f, c.clone())))
    }

    /// Division by a scalar that gives 0 where the divisor is 0 (for limits taken as zero).
    pub fn guarded_div(&self, other: &Field) -> Outcome<Field> {
        let d = other.only_scalar("the divisor")?.clone();
        Ok(self.map(|c| node::guarded_div(c.clone(), d.clone())))
    }

    /// 1 where the field is >= 0, else 0.
    pub fn mask(&self) -> Outcome<Field> {
        self.math(MathFn::Step)
    }

    /// `a` where `c >= 0`, else `b`.
    pub fn select(c: &Field, a: &Field, b: &Field) -> Outcome<Field> {
        let c = c.only_scalar("the condition of select")?.clone();
        a.same_kind(b, "select")?;
        Ok(a.zip(b, |x, y| node::select(c.clone(), x.clone(), y.clone())))
    }

    pub fn vector_from(x: &Field, y: &Field, z: &Field) -> Outcome<Field> {
        let c = [x, y, z].map(|f| f.only_scalar("a vectorfield component").cloned());
        let [a, b, c] = c;
        Ok(Field::vector([a?, b?, c?]))
    }

    pub fn matrix_from_rows(r0: &Field, r1: &Field, r2: &Field) -> Outcome<Field> {
        let mut m = Vec::with_capacity(9);
        for r in [r0, r1, r2] {
            m.extend_from_slice(r.only_vector("a matrixfield row")?);
        }
        Ok(Field::new(FieldKind::Matrix, m))
    }

    pub fn length(&self) -> Outcome<Field> {
        let v = self.only_vector("length")?;
        Ok(Field::scalar(node::unary(MathFn::Sqrt, linalg::dot(v, v))))
    }

    /// `v / |v|`, and zero where `v` is zero.
    pub fn normalize(&self) -> Outcome<Field> {
        let len = self.length()?.components[0].clone();
        Ok(self.map(|c| node::guarded_div(c.clone(), len.clone())))
    }

    pub fn cross(&self, other: &Field) -> Outcome<Field> {
        let (a, b) = (self.only_vector("cross")?, other.only_vector("cross")?);
        Ok(Field::vector(linalg::cross(a, b)))
    }

    /// The matrix with rows `a_i b`.
    pub fn outer(&self, other: &Field) -> Outcome<Field> {
        let (a, b) = (self.only_vector("outer")?, other.only_vector("outer")?);
        Ok(Field::matrix(std::array::from_fn(|i| {
            node::mul(a[i / 3].clone(), b[i % 3].clone())
        })))
    }

    pub fn transpose(&self) -> Outcome<Field> {
        Ok(Field::matrix(linalg::transpose(
            self.only_matrix("transpose")?,
        )))
    }

    pub fn det(&self) -> Outcome<Field> {
        Ok(Field::scalar(linalg::det(self.only_matrix("det")?)))
    }

    pub fn trace(&self) -> Outcome<Field> {
        Ok(Field::scalar(linalg::trace(self.only_matrix("trace")?)))
    }

    /// The inverse where the matrix is regular, the pseudo-inverse where it is singular.
    pub fn inverse(&self) -> Outcome<Field> {
        let m = self.only_matrix("inverse")?;
        let kernel = node::mk(Op::Kernel(
            Arc::new(kernel::pseudo_inverse::PseudoInverse),
            m.to_vec(),
        ));
        Ok(Field::matrix(std::array::from_fn(|i| {
            node::output_of(&kernel, i)
        })))
    }

    /// The field evaluated at the points `at(x)`.
    pub fn compose(&self, at: &Field) -> Outcome<Field> {
        let p = at.only_vector("the warp of compose")?;
        let p: [NodeRef; 3] = std::array::from_fn(|i| p[i].clone());
        Ok(Field::new(
            self.kind,
            substitution::substitute(&self.components, &p),
        ))
    }
}

/// `grad` of a scalarfield (a vectorfield) or of a vectorfield (the Jacobian, `J[i][j] = dv_i/dx_j`).
pub fn grad(f: &Field) -> Outcome<Field> {
    match f.kind {
        FieldKind::Scalar => {
            let g = calculus::gradients(&f.components)?;
            Ok(Field::vector(g[0].clone()))
        }
        FieldKind::Vector => {
            let g = calculus::gradients(&f.components)?;
            Ok(Field::matrix(std::array::from_fn(|i| {
                g[i / 3][i % 3].clone()
            })))
        }
        FieldKind::Matrix => Err(Failure::new(
            "grad takes a scalarfield or a vectorfield, found a matrixfield",
        )),
    }
}

/// The trace of the Jacobian, built from its diagonal alone (`calculus::divergence`).
pub fn div(v: &Field) -> Outcome<Field> {
    let v = Field::vector_checked(v, "div")?;
    Ok(Field::scalar(calculus::divergence(&v.components)?))
}

pub fn curl(v: &Field) -> Outcome<Field> {
    let j = grad(&Field::vector_checked(v, "curl")?)?;
    let d = |i: usize, k: usize| j.components[i * 3 + k].clone();
    Ok(Field::vector([
        node::sub(d(2, 1), d(1, 2)),
        node::sub(d(0, 2), d(2, 0)),
        node::sub(d(1, 0), d(0, 1)),
    ]))
}

/// Sum of second derivatives; componentwise for a vectorfield.
pub fn laplacian(f: &Field) -> Outcome<Field> {
    match f.kind {
        FieldKind::Scalar => {
            // The divergence of the gradient: the first pass answers for the budget of both.
            let g = calculus::gradients_then_divergence(&f.components)?;
            Ok(Field::scalar(calculus::divergence(&g[0])?))
        }
        FieldKind::Vector => {
            let parts: Outcome<Vec<NodeRef>> = (0..3)
                .map(|i| Ok(laplacian(&f.component(i)?)?.components[0].clone()))
                .collect();
            Ok(Field::new(FieldKind::Vector, parts?))
        }
        FieldKind::Matrix => Err(Failure::new(
            "laplacian takes a scalarfield or a vectorfield, found a matrixfield",
        )),
    }
}

impl Field {
    fn vector_checked(v: &Field, what: &str) -> Outcome<Field> {
        v.only_vector(what)?;
        Ok(v.clone())
    }
}

pub fn compose(f: &Field, at: &Field) -> Outcome<Field> {
    f.compose(at)
}

/// `f(x - offset)`.
pub fn translate(f: &Field, offset: DVec3) -> Outcome<Field> {
    let at = Field::vector(calculus::shifted_position(offset));
    f.compose(&at)
}

/// `f` turned by `angle` radians about `axis` through the origin: `f(R⁻¹ x)`.
pub fn rotate(f: &Field, axis: DVec3, angle: f64) -> Outcome<Field> {
    if !(axis.is_finite() && axis.length() > 0.0 && angle.is_finite()) {
        return Err(Failure::new(format!(
            "rotate needs a finite non-zero axis and a finite angle, found {axis} and {angle}"
        )));
    }
    let inverse = DMat3::from_axis_angle(axis.normalize(), -angle);
    f.compose(&Field::constant_matrix(inverse).mul(&Field::identity())?)
}

/// `f` stretched by `factor` about the origin: `f(x / factor)`.
pub fn scale(f: &Field, factor: DVec3) -> Outcome<Field> {
    if !(factor.is_finite() && factor.cmpne(DVec3::ZERO).all()) {
        return Err(Failure::new(format!(
            "scale factors must be finite and non-zero, found {factor}"
        )));
    }
    let at = Field::vector(std::array::from_fn(|i| {
        node::div(node::position(i), node::constant(factor[i]))
    }));
    f.compose(&at)
}
