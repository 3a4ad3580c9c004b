//! Advection: a field carried along a velocity, as a warp of space.
//!
//! `advect(F, U, dt)` is `F` at the back-traced point `x − ∫U dt` (one explicit step, or a
//! Runge–Kutta trace of order 2 to 4), built by substitution like `compose`, so it is exact,
//! differentiable and lazy. On grids that is first-order semi-Lagrangian advection, which
//! smears: every step interpolates. Two error-correcting schemes cancel most of that error
//! by tracing back and forth once more:
//! - **MacCormack** (Selle et al. 2008): `φ̂ = F∘B`, `φ̃ = φ̂∘B⁻`, result `φ̂ + (F − φ̃)/2`,
//!   where `B` is the back trace and `B⁻` the trace forwards;
//! - **BFECC** (Kim et al. 2005): `F' = F + (F − φ̃)/2`, result `F'∘B`.
//!
//! What they correct is the error of interpolating between cells, so they act where `F` is a
//! grid read (a cached density, a SELMA map); the intermediate `φ̂` (and BFECC's `F'`) are
//! sampled onto `F`'s own cells through a lazy cache, exactly as a grid solver stores them.
//! On a procedural `F` nothing is interpolated and every scheme is the plain back trace.
//!
//! The one key decision is the clamp. Both schemes overshoot near sharp features, so the
//! result is clamped to the smallest and largest of the eight samples of `F` around the
//! back-traced point, written as graph nodes (the cell centres are found with `floor` in the
//! grid's index space): the clamped scheme is still an ordinary field. A grid read that
//! extrapolates outside its box (a map) is clamped only where the back trace lands inside it,
//! so an affine map stays affine beyond the border.

use super::node::{self, NodeRef, Op};
use super::{Field, FieldKind};
use crate::base::failure::{Failure, Outcome};
use crate::space::{GridSource, Lattice};
use std::sync::Arc;

/// How `advect` moves values along the velocity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scheme {
    /// One back trace: first-order semi-Lagrangian on grids.
    SemiLagrangian,
    /// MacCormack with clamping.
    MacCormack,
    /// Back-and-forth error compensation and correction, with clamping.
    Bfecc,
}

impl Scheme {
    /// The scheme a script names.
    pub fn named(name: &str) -> Outcome<Scheme> {
        match name {
            "semilagrangian" => Ok(Scheme::SemiLagrangian),
            "maccormack" => Ok(Scheme::MacCormack),
            "bfecc" => Ok(Scheme::Bfecc),
            other => Err(Failure::new(format!(
                "advect scheme must be \"semilagrangian\", \"maccormack\" or \"bfecc\", found \"{other}\""
            ))),
        }
    }
}

/// The map `x ↦ x − ∫ u dt` over one step: one explicit step (order 1) or a Runge–Kutta
/// scheme of order 2 (midpoint), 3 (Kutta) or 4 (classic).
pub fn back_trace(u: &Field, dt: &Field, order: u32) -> Outcome<Field> {
    u.only_vector("the velocity of advect")?;
    dt.only_scalar("the time step of advect")?;
    let x = Field::identity();
    // Tracing backwards is tracing forwards along -u.
    let h = dt.neg();
    let u_at = |p: &Field| u.compose(p);
    let step = |p: &Field, k: &Field, s: f64| -> Outcome<Field> {
        p.add(&k.mul(&h.mul(&Field::constant_scalar(s))?)?)
    };
    Ok(match order {
        1 => step(&x, u, 1.0)?,
        2 => {
            let k2 = u_at(&step(&x, u, 0.5)?)?;
            step(&x, &k2, 1.0)?
        }
        3 => {
            let k1 = u.clone();
            let k2 = u_at(&step(&x, &k1, 0.5)?)?;
            let k3 = u_at(&step(&step(&x, &k1, -1.0)?, &k2, 2.0)?)?;
            let sum = k1.add(&k2.mul(&Field::constant_scalar(4.0))?)?.add(&k3)?;
            step(&x, &sum, 1.0 / 6.0)?
        }
        4 => {
            let k1 = u.clone();
            let k2 = u_at(&step(&x, &k1, 0.5)?)?;
            let k3 = u_at(&step(&x, &k2, 0.5)?)?;
            let k4 = u_at(&step(&x, &k3, 1.0)?)?;
            let two = Field::constant_scalar(2.0);
            let sum = k1.add(&k2.mul(&two)?)?.add(&k3.mul(&two)?)?.add(&k4)?;
            step(&x, &sum, 1.0 / 6.0)?
        }
        other => {
            return Err(Failure::new(format!(
                "advect order must be 1, 2, 3 or 4, found {other}"
            )));
        }
    })
}

/// `f` carried along `u` for time `dt` by one back trace of the given order.
pub fn advect(f: &Field, u: &Field, dt: &Field, order: u32) -> Outcome<Field> {
    f.compose(&back_trace(u, dt, order)?)
}

/// How an error-correcting scheme samples its intermediate fields onto the grid of the field
/// being advected: given a field and the grid it is read from, a field reading that field's
/// samples over the same cells (the interpreter makes a lazy cache).
pub type Resample<'a> = dyn Fn(&Field, &dyn GridSource) -> Outcome<Field> + 'a;

/// `advect` with a choice of scheme. The error-correcting schemes correct the error of
/// interpolating between cells, so they apply where `f` is read from a grid; there the
/// intermediate fields go through `resample` onto that grid, exactly as a grid solver stores
/// them. Elsewhere (a procedural `f`) there is no interpolation to correct and every scheme is
/// the plain back trace.
pub fn advect_with(
    f: &Field,
    u: &Field,
    dt: &Field,
    order: u32,
    scheme: Scheme,
    resample: &Resample<'_>,
) -> Outcome<Field> {
    let back = back_trace(u, dt, order)?;
    let Some(grid) = grid_read(f).filter(|_| scheme != Scheme::SemiLagrangian) else {
        return f.compose(&back);
    };
    let forward = back_trace(&u.neg(), dt, order)?;
    let half = Field::constant_scalar(0.5);
    let predicted = resample(&f.compose(&back)?, grid.as_ref())?;
    let returned = predicted.compose(&forward)?;
    let error = f.sub(&returned)?.mul(&half)?;
    let corrected = match scheme {
        Scheme::MacCormack => predicted.add(&error)?,
        _ => resample(&f.add(&error)?, grid.as_ref())?.compose(&back)?,
    };
    let corrected = match neighbour_limits(f, grid.as_ref(), &back) {
        Some(limits) => limits.clamp(&corrected),
        None => corrected,
    };
    // Where a trace leaves a grid that reads its background outside, the correction would
    // compare the value here with nothing and put back density the flow has carried out:
    // there the scheme falls back to the plain back trace (as Selle et al. do at boundaries).
    match grid.lattice() {
        Some(lattice) if !lattice.extrapolates => {
            let margin = |at: &Field| span_margin(&lattice, &index_coordinates(&lattice, at));
            let inside = node::binary(node::BinOp::Min, margin(&back), margin(&forward));
            Field::select(&Field::scalar(inside), &corrected, &predicted)
        }
        _ => Ok(corrected),
    }
}

/// The grid `f` reads, when `f` is exactly one read of a grid at the position (a `cacheread`).
fn grid_read(f: &Field) -> Option<Arc<dyn GridSource>> {
    let first = f.components().first()?;
    let Op::Output(kernel, _) = &first.op else {
        return None;
    };
    let Op::Kernel(read, args) = &kernel.op else {
        return None;
    };
    let grid = read.grid_read().filter(|r| r.is_value())?.grid();
    let reads_position = args
        .iter()
        .enumerate()
        .all(|(axis, a)| a.id == node::position(axis).id);
    let one_read =
        f.components().iter().enumerate().all(
            |(c, n)| matches!(&n.op, Op::Output(k, i) if k.id == kernel.id && *i as usize == c),
        );
    (reads_position && one_read && grid.width() == f.kind().width() && grid.lattice().is_some())
        .then(|| grid.clone())
}

/// Per component, the smallest and largest sample around the back-traced points, and where
/// the clamp applies.
struct Limits {
    low: Vec<NodeRef>,
    high: Vec<NodeRef>,
    /// `>= 0` where the clamp applies; `None`: everywhere.
    applies: Option<NodeRef>,
}

impl Limits {
    fn clamp(&self, value: &Field) -> Field {
        let clamped: Vec<NodeRef> = value
            .components()
            .iter()
            .enumerate()
            .map(|(c, v)| {
                let bounded = node::binary(
                    node::BinOp::Min,
                    node::binary(node::BinOp::Max, v.clone(), self.low[c].clone()),
                    self.high[c].clone(),
                );
                match &self.applies {
                    Some(inside) => node::select(inside.clone(), bounded, v.clone()),
                    None => bounded,
                }
            })
            .collect();
        Field::new(value.kind(), clamped)
    }
}

/// Index coordinates of the points `at` in a grid: `R^T (p − origin) / cell − ½`.
fn index_coordinates(lattice: &Lattice, at: &Field) -> Vec<NodeRef> {
    let at = at.components();
    let relative: Vec<NodeRef> = (0..3)
        .map(|i| node::sub(at[i].clone(), node::constant(lattice.origin[i])))
        .collect();
    (0..3)
        .map(|a| {
            let axis = lattice.rotation.col(a);
            let local =
                node::sum((0..3).map(|i| node::mul(node::constant(axis[i]), relative[i].clone())));
            node::sub(
                node::mul(local, node::constant(1.0 / lattice.cell[a])),
                node::constant(0.5),
            )
        })
        .collect()
}

/// `>= 0` where index coordinates lie within the span of cell centres on every axis: the
/// smallest over axes of `min(u, n − 1 − u)`.
fn span_margin(lattice: &Lattice, index: &[NodeRef]) -> NodeRef {
    (0..3)
        .map(|a| {
            let last = lattice.counts[a] as f64 - 1.0;
            node::binary(
                node::BinOp::Min,
                index[a].clone(),
                node::sub(node::constant(last), index[a].clone()),
            )
        })
        .reduce(|a, b| node::binary(node::BinOp::Min, a, b))
        .unwrap_or_else(|| node::constant(0.0))
}

/// The limits of the eight samples of `grid` (which `f` reads) around the points `at`: the
/// linear stencil's cells, found by `floor` in the grid's index space.
fn neighbour_limits(f: &Field, grid: &dyn GridSource, at: &Field) -> Option<Limits> {
    let lattice = grid.lattice()?;
    let index = index_coordinates(&lattice, at);
    // The cell at or below, kept so that the cell above exists.
    let below: Vec<NodeRef> = (0..3)
        .map(|a| {
            let top = lattice.counts[a].saturating_sub(2) as f64;
            node::binary(
                node::BinOp::Min,
                node::binary(
                    node::BinOp::Max,
                    node::unary(super::MathFn::Floor, index[a].clone()),
                    node::constant(0.0),
                ),
                node::constant(top),
            )
        })
        .collect();
    let width = f.kind().width();
    let mut low: Vec<Option<NodeRef>> = vec![None; width];
    let mut high: Vec<Option<NodeRef>> = vec![None; width];
    for corner in 0..8 {
        let offset = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
        if (0..3).any(|a| offset[a] == 1 && lattice.counts[a] < 2) {
            continue;
        }
        // World position of that cell's centre.
        let local: Vec<NodeRef> = (0..3)
            .map(|a| {
                node::mul(
                    node::add(below[a].clone(), node::constant(offset[a] as f64 + 0.5)),
                    node::constant(lattice.cell[a]),
                )
            })
            .collect();
        let centre: Vec<NodeRef> = (0..3)
            .map(|i| {
                let terms = (0..3).map(|a| {
                    node::mul(node::constant(lattice.rotation.col(a)[i]), local[a].clone())
                });
                node::add(node::constant(lattice.origin[i]), node::sum(terms))
            })
            .collect();
        let centre = Field::new(FieldKind::Vector, centre);
        let sample = f.compose(&centre).ok()?;
        for (c, v) in sample.components().iter().enumerate() {
            low[c] = Some(match low[c].take() {
                Some(l) => node::binary(node::BinOp::Min, l, v.clone()),
                None => v.clone(),
            });
            high[c] = Some(match high[c].take() {
                Some(h) => node::binary(node::BinOp::Max, h, v.clone()),
                None => v.clone(),
            });
        }
    }
    let applies = lattice.extrapolates.then(|| span_margin(&lattice, &index));
    Some(Limits {
        low: low.into_iter().collect::<Option<_>>()?,
        high: high.into_iter().collect::<Option<_>>()?,
        applies,
    })
}
