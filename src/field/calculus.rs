//! Symbolic differentiation over scalar node graphs.
//!
//! `derivatives` builds, for a set of roots, the nodes of their partial derivatives along x, y
//! and z, by forward-mode rules applied to every reachable node once (children first, so the
//! chain rule through a substituted warp falls out of the same rules). Substitution itself
//! (`compose`, `advect`, the warps) is in `substitution`: the composed field is an ordinary
//! graph, so differentiating it again is exact too.
//!
//! A pass differentiates along only the axes it is asked for: `divergence` (and so
//! `laplacian`, the divergence of the gradient) takes each component along its own axis
//! alone, so a tower of nested Laplacians never builds the six off-diagonal second
//! derivatives that the trace of the full Jacobian would drop.
//!
//! Two decisions: where a derivative has a removable 0/0 (the gradient of `sqrt(u)` where `u`
//! and its derivative vanish together, as for `|x|` at the origin), the rule uses the guarded
//! division, which gives 0 there instead of NaN. And each kernel differentiates itself
//! (`FieldKernel::derivative`): grid reads through the interpolant's exact gradient, noise
//! exactly to second order, both by central differences beyond (`field::kernel`).

use crate::base::failure::{Failure, Outcome};
use crate::field::kernel::KernelAt;
use crate::field::node::{self, BinOp, Kernel, MathFn, NodeRef, Op};
use glam::DVec3;
use std::collections::HashMap;

/// Partial derivatives `[d/dx, d/dy, d/dz]` of each root.
pub fn gradients(roots: &[NodeRef]) -> Outcome<Vec<[NodeRef; 3]>> {
    partials(roots, [0, 1, 2], Later::Nothing)
}

/// `gradients`, when the divergence of the result will follow (a `laplacian` is the
/// divergence of the gradient): the memory budget is checked against the growth of both, projected
/// from the rate of this pass (`node::check_projected_growth`), so a tower of derivatives
/// that cannot fit stops before its last level is half built.
pub fn gradients_then_divergence(roots: &[NodeRef]) -> Outcome<Vec<[NodeRef; 3]>> {
    partials(roots, [0, 1, 2], Later::Divergence)
}

/// `∂v₀/∂x + ∂v₁/∂y + ∂v₂/∂z`, differentiating each component only along its own axis: the
/// six off-diagonal terms of the Jacobian are never built. Each term is the node the full
/// Jacobian would hold, and the terms are added in the same order as its trace, so the value
/// is bit for bit that of `trace(grad(v))`. Nodes the components share are still taken
/// along every axis, so nested Laplacians of noise make half the nodes, not a third.
pub fn divergence(v: &[NodeRef]) -> Outcome<NodeRef> {
    let terms: Outcome<Vec<NodeRef>> = (0..3)
        .map(|axis| {
            let [term] =
                partials(std::slice::from_ref(&v[axis]), [axis], Later::Nothing)?[0].clone();
            Ok(term)
        })
        .collect();
    Ok(node::sum(terms?))
}

/// The passes that will follow a derivative pass over what it returns, for the projection of
/// its growth against the memory budget.
#[derive(Clone, Copy)]
enum Later {
    Nothing,
    Divergence,
}

/// Partial derivatives of each root along `axes` (0 x, 1 y, 2 z), in that order: the
/// forward-mode rules applied to every node reachable from the roots, along those axes only.
fn partials<const A: usize>(
    roots: &[NodeRef],
    axes: [usize; A],
    later: Later,
) -> Outcome<Vec<[NodeRef; A]>> {
    let order = node::postorder(roots);
    let mut d: IdMap<[NodeRef; A]> =
        IdMap::with_capacity_and_hasher(order.len(), Default::default());
    // Kernel nodes: the derivative of each output, per axis.
    let mut kernel_d: IdMap<Vec<[NodeRef; A]>> = IdMap::default();
    let zero = node::constant(0.0);
    let zeros = || std::array::from_fn(|_| zero.clone());
    let unit = |axis: usize| {
        std::array::from_fn(|j| node::constant(if axes[j] == axis { 1.0 } else { 0.0 }))
    };
    let made_before = node::nodes_made();
    for (i, n) in order.iter().enumerate() {
        // Derivatives of derivatives can grow a graph severalfold per level: stop at the
        // budget rather than when memory runs out, and as soon as the rate of growth shows
        // the pass will not fit rather than at its end.
        if i % 1024 == 0 {
            node::check_graph_memory()?;
            let made = node::nodes_made() - made_before;
            node::check_projected_growth(made, i, order.len(), matches!(later, Later::Divergence))?;
        }
        let grad: [NodeRef; A] = match &n.op {
            Op::Const(_) => zeros(),
            Op::X => unit(0),
            Op::Y => unit(1),
            Op::Z => unit(2),
            Op::Unary(m, a) => {
                let factor = unary_factor(*m, a);
                let da = &d[&a.id];
                std::array::from_fn(|j| match &factor {
                    Factor::Zero => zero.clone(),
                    Factor::One => da[j].clone(),
                    Factor::Times(f) => node::mul(f.clone(), da[j].clone()),
                    Factor::GuardedOver(f) => node::guarded_div(da[j].clone(), f.clone()),
                })
            }
            Op::Binary(b, x, y) => {
                let (dx, dy) = (&d[&x.id], &d[&y.id]);
                std::array::from_fn(|j| binary_rule(*b, n, x, y, &dx[j], &dy[j]))
            }
            Op::Select(c, a, b) => {
                let (da, db) = (&d[&a.id], &d[&b.id]);
                std::array::from_fn(|j| node::select(c.clone(), da[j].clone(), db[j].clone()))
            }
            Op::Kernel(kernel, args) => {
                let outs = kernel_rule(kernel, n, args, &d)?;
                kernel_d.insert(n.id, outs);
                // A kernel node has no value of its own; its outputs carry the derivatives.
                zeros()
            }
            Op::Output(k, i) => match kernel_d.get(&k.id).and_then(|v| v.get(*i as usize)) {
                Some(g) => g.clone(),
                None => return Err(third_derivative_error(k)),
            },
        };
        d.insert(n.id, grad);
    }
    Ok(roots.iter().map(|r| d[&r.id].clone()).collect())
}

/// Working maps keyed by node id: ids are small sequential integers, so a fast hasher
/// serves (nothing iterates these maps).
type IdMap<V> = HashMap<u64, V, node::IdHasher>;

fn third_derivative_error(k: &NodeRef) -> Failure {
    Failure::new(format!("cannot differentiate an output of {k:?}"))
}

enum Factor {
    Zero,
    One,
    Times(NodeRef),
    GuardedOver(NodeRef),
}

/// d f(a) = factor · da.
fn unary_factor(m: MathFn, a: &NodeRef) -> Factor {
    use node::{constant as k, mul, sub, unary};
    match m {
        MathFn::Abs => Factor::Times(unary(MathFn::Sign, a.clone())),
        MathFn::Sqrt => Factor::GuardedOver(mul(k(2.0), unary(MathFn::Sqrt, a.clone()))),
        MathFn::Exp => Factor::Times(unary(MathFn::Exp, a.clone())),
        MathFn::Log => Factor::GuardedOver(a.clone()),
        MathFn::Sin => Factor::Times(unary(MathFn::Cos, a.clone())),
        MathFn::Cos => Factor::Times(node::neg(unary(MathFn::Sin, a.clone()))),
        MathFn::Tan => {
            let t = unary(MathFn::Tan, a.clone());
            Factor::Times(node::add(k(1.0), mul(t.clone(), t)))
        }
        MathFn::Asin => {
            Factor::GuardedOver(unary(MathFn::Sqrt, sub(k(1.0), mul(a.clone(), a.clone()))))
        }
        MathFn::Acos => Factor::GuardedOver(node::neg(unary(
            MathFn::Sqrt,
            sub(k(1.0), mul(a.clone(), a.clone())),
        ))),
        MathFn::Atan => Factor::GuardedOver(node::add(k(1.0), mul(a.clone(), a.clone()))),
        MathFn::Fract => Factor::One,
        MathFn::Floor | MathFn::Ceil | MathFn::Sign | MathFn::Step => Factor::Zero,
    }
}

fn binary_rule(
    op: BinOp,
    n: &NodeRef,
    x: &NodeRef,
    y: &NodeRef,
    dx: &NodeRef,
    dy: &NodeRef,
) -> NodeRef {
    use node::{add, constant as k, guarded_div, mul, sub};
    match op {
        BinOp::Add => add(dx.clone(), dy.clone()),
        BinOp::Sub => sub(dx.clone(), dy.clone()),
        BinOp::Mul => add(mul(dx.clone(), y.clone()), mul(x.clone(), dy.clone())),
        // (x/y)' = x'/y - (x/y) y'/y: IEEE where y = 0, like the quotient itself.
        BinOp::Div => sub(
            node::div(dx.clone(), y.clone()),
            node::div(mul(n.clone(), dy.clone()), y.clone()),
        ),
        BinOp::GuardedDiv => sub(
            guarded_div(dx.clone(), y.clone()),
            guarded_div(mul(n.clone(), dy.clone()), y.clone()),
        ),
        BinOp::Pow => {
            // d(x^y) = y x^(y-1) dx + x^y ln(x) dy; the second term only when y varies.
            let first = match y.constant() {
                Some(c) => mul(
                    mul(k(c), node::binary(BinOp::Pow, x.clone(), k(c - 1.0))),
                    dx.clone(),
                ),
                None => mul(
                    mul(
                        y.clone(),
                        node::binary(BinOp::Pow, x.clone(), sub(y.clone(), k(1.0))),
                    ),
                    dx.clone(),
                ),
            };
            let second = mul(
                mul(n.clone(), node::unary(MathFn::Log, x.clone())),
                dy.clone(),
            );
            add(first, second)
        }
        BinOp::Atan2 => {
            // atan2(y, x) with y = x_, x = y_ here: (x dy - y dx) / (x² + y²), guarded at the origin.
            let (yy, xx) = (x, y);
            let (dyy, dxx) = (dx, dy);
            guarded_div(
                sub(mul(xx.clone(), dyy.clone()), mul(yy.clone(), dxx.clone())),
                add(mul(xx.clone(), xx.clone()), mul(yy.clone(), yy.clone())),
            )
        }
        // min picks x where x <= y; max picks x where x >= y.
        BinOp::Min => node::select(sub(y.clone(), x.clone()), dx.clone(), dy.clone()),
        BinOp::Max => node::select(sub(x.clone(), y.clone()), dx.clone(), dy.clone()),
    }
}

/// Derivatives of every output of a kernel node along the pass's axes, by the kernel's own
/// rule.
fn kernel_rule<const A: usize>(
    kernel: &Kernel,
    n: &NodeRef,
    args: &[NodeRef],
    d: &IdMap<[NodeRef; A]>,
) -> Outcome<Vec<[NodeRef; A]>> {
    let at = KernelAt {
        kernel,
        node: n,
        args,
        d_args: args.iter().map(|a| &d[&a.id][..]).collect(),
        axes: A,
    };
    let outs = kernel.derivative(&at)?;
    outs.into_iter()
        .map(|o| {
            <[NodeRef; A]>::try_from(o).map_err(|_| {
                Failure::new(format!(
                    "{kernel:?} gave derivatives along the wrong number of axes"
                ))
            })
        })
        .collect()
}

/// The position nodes shifted by a constant vector: `x - offset`.
pub fn shifted_position(offset: DVec3) -> [NodeRef; 3] {
    std::array::from_fn(|i| node::sub(node::position(i), node::constant(offset[i])))
}
