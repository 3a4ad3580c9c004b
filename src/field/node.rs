//! Scalar expression nodes: the graph every field is made of, shared through a hash-consing table.
//!
//! The one key decision: fields are *scalarised* when they are built. A vectorfield is three
//! scalar nodes and a matrixfield nine, so every operator of the language (dot products,
//! matrix products, determinants, Jacobians) becomes a handful of scalar operations, and the
//! whole engine (simplification, differentiation, substitution, compilation, intervals) deals
//! with one small set of scalar operations. Operations with several outputs that are cheaper
//! computed together (a noise value with its gradient and Hessian, all components of a grid
//! read, a 3×3 pseudo-inverse) are *kernel* nodes whose outputs are picked by `Output` nodes.
//!
//! Every node is made through [`mk`], which folds constants, applies identities that are exact
//! for finite values (`a + 0`, `a * 1`, `a * 0`, `a - a`) and returns the existing node when the
//! same operation on the same children was made before, so a sub-expression written twice, in a
//! loop or in two function calls, is one node and is evaluated once per point.

mod intern;

use intern::intern;
use std::fmt;
use std::sync::Arc;

pub use crate::field::kernel::Kernel;
pub use intern::{
    IdHasher, check_beside_graphs, check_graph_memory, check_projected_growth, node_bytes,
    nodes_made, table_len,
};

/// A shared scalar node.
pub type NodeRef = Arc<Node>;

/// Unary scalar functions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MathFn {
    Abs,
    Sqrt,
    Exp,
    Log,
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Floor,
    Ceil,
    Fract,
    Sign,
    /// 1 where the argument is >= 0, else 0 (`mask`).
    Step,
}

/// `(x.sin(), x.cos())` in one call where the C library has `sincos`, which shares the
/// argument reduction of the two (glibc's gives the bits of its `sin` and `cos`).
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        unsafe extern "C" {
            fn sincos(x: f64, sin: *mut f64, cos: *mut f64);
        }
        let (mut s, mut c) = (0.0, 0.0);
        // SAFETY: glibc's libm, which std links, defines `sincos`; it writes the two
        // pointers, which point at live locals.
        unsafe { sincos(x, &mut s, &mut c) };
        (s, c)
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    {
        (x.sin(), x.cos())
    }
}

impl MathFn {
    pub fn apply(self, x: f64) -> f64 {
        match self {
            MathFn::Abs => x.abs(),
            MathFn::Sqrt => x.sqrt(),
            MathFn::Exp => x.exp(),
            MathFn::Log => x.ln(),
            MathFn::Sin => x.sin(),
            MathFn::Cos => x.cos(),
            MathFn::Tan => x.tan(),
            MathFn::Asin => x.asin(),
            MathFn::Acos => x.acos(),
            MathFn::Atan => x.atan(),
            MathFn::Floor => x.floor(),
            MathFn::Ceil => x.ceil(),
            MathFn::Fract => x - x.floor(),
            MathFn::Sign => {
                if x > 0.0 {
                    1.0
                } else if x < 0.0 {
                    -1.0
                } else {
                    0.0
                }
            }
            MathFn::Step => {
                if x >= 0.0 {
                    1.0
                } else {
                    0.0
                }
            }
        }
    }
}

/// Binary scalar operations.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BinOp {
    Add,
    Sub,
    Mul,
    /// IEEE division: `x / 0` is ±inf or NaN, as the user wrote it.
    Div,
    /// Division that gives 0 where the divisor is 0: used only by derivative rules and
    /// `normalize`, at points where the limit is taken to be 0 (the gradient of `|x|` at the
    /// origin, `normalize` of a zero vector).
    GuardedDiv,
    Pow,
    Atan2,
    Min,
    Max,
}

impl BinOp {
    pub fn apply(self, a: f64, b: f64) -> f64 {
        match self {
            BinOp::Add => a + b,
            BinOp::Sub => a - b,
            BinOp::Mul => a * b,
            BinOp::Div => a / b,
            BinOp::GuardedDiv => {
                if b == 0.0 {
                    0.0
                } else {
                    a / b
                }
            }
            BinOp::Pow => a.powf(b),
            BinOp::Atan2 => a.atan2(b),
            BinOp::Min => a.min(b),
            BinOp::Max => a.max(b),
        }
    }

    fn commutative(self) -> bool {
        matches!(self, BinOp::Add | BinOp::Mul | BinOp::Min | BinOp::Max)
    }
}

/// What a node computes. Children are other nodes.
#[derive(Clone, Debug)]
pub enum Op {
    Const(f64),
    /// The position's components.
    X,
    Y,
    Z,
    Unary(MathFn, NodeRef),
    Binary(BinOp, NodeRef, NodeRef),
    /// `a` where `c >= 0`, else `b`.
    Select(NodeRef, NodeRef, NodeRef),
    /// A multi-output operation (`field::kernel`); only reachable through `Output` nodes.
    Kernel(Kernel, Vec<NodeRef>),
    /// Output `index` of a kernel node.
    Output(NodeRef, u8),
}

/// One node of the graph. Nodes are immutable; identity is the `id`.
pub struct Node {
    pub id: u64,
    pub op: Op,
}

impl Node {
    pub fn children(&self) -> Vec<&NodeRef> {
        match &self.op {
            Op::Const(_) | Op::X | Op::Y | Op::Z => Vec::new(),
            Op::Unary(_, a) => vec![a],
            Op::Binary(_, a, b) => vec![a, b],
            Op::Select(c, a, b) => vec![c, a, b],
            Op::Kernel(_, args) => args.iter().collect(),
            Op::Output(k, _) => vec![k],
        }
    }

    pub fn constant(&self) -> Option<f64> {
        match self.op {
            Op::Const(c) => Some(c),
            _ => None,
        }
    }
}

/// Dropping a node drops its children, and theirs: done recursively, a chain of a few hundred
/// thousand nodes (a long gridless advection) would overflow the stack. Children whose last
/// owner is the node being dropped are taken apart here, on a heap stack, instead.
impl Drop for Node {
    fn drop(&mut self) {
        let mut stack = Vec::new();
        take_children(&mut self.op, &mut stack);
        while let Some(child) = stack.pop() {
            if let Some(mut node) = Arc::into_inner(child) {
                take_children(&mut node.op, &mut stack);
            }
        }
    }
}

/// Moves the children of `op` onto `stack`, leaving a childless operation behind.
fn take_children(op: &mut Op, stack: &mut Vec<NodeRef>) {
    match std::mem::replace(op, Op::Const(0.0)) {
        Op::Const(_) | Op::X | Op::Y | Op::Z => {}
        Op::Unary(_, a) => stack.push(a),
        Op::Binary(_, a, b) => stack.extend([a, b]),
        Op::Select(c, a, b) => stack.extend([c, a, b]),
        Op::Kernel(_, args) => stack.extend(args),
        Op::Output(k, _) => stack.push(k),
    }
}

impl fmt::Debug for Node {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "#{} ", self.id)?;
        match &self.op {
            Op::Const(c) => write!(f, "{c}"),
            Op::X => f.write_str("x"),
            Op::Y => f.write_str("y"),
            Op::Z => f.write_str("z"),
            Op::Unary(m, a) => write!(f, "{m:?}(#{})", a.id),
            Op::Binary(b, x, y) => write!(f, "{b:?}(#{}, #{})", x.id, y.id),
            Op::Select(c, a, b) => write!(f, "select(#{}, #{}, #{})", c.id, a.id, b.id),
            Op::Kernel(k, args) => {
                let ids: Vec<u64> = args.iter().map(|a| a.id).collect();
                write!(f, "{k:?}{ids:?}")
            }
            Op::Output(k, i) => write!(f, "#{}.{i}", k.id),
        }
    }
}

pub fn constant(c: f64) -> NodeRef {
    intern(Op::Const(c))
}

pub fn position(axis: usize) -> NodeRef {
    intern(match axis {
        0 => Op::X,
        1 => Op::Y,
        _ => Op::Z,
    })
}

/// The node for `op`, simplified and shared. All graph construction goes through here.
pub fn mk(op: Op) -> NodeRef {
    match op {
        Op::Unary(m, a) => unary(m, a),
        Op::Binary(b, x, y) => binary(b, x, y),
        Op::Select(c, a, b) => select(c, a, b),
        other => intern(other),
    }
}

pub fn unary(m: MathFn, a: NodeRef) -> NodeRef {
    if let Some(c) = a.constant() {
        return constant(m.apply(c));
    }
    // Idempotent functions of their own result.
    if let Op::Unary(inner, _) = &a.op {
        let idempotent = matches!(
            m,
            MathFn::Abs | MathFn::Floor | MathFn::Ceil | MathFn::Sign | MathFn::Step
        );
        if *inner == m && idempotent {
            return a;
        }
    }
    intern(Op::Unary(m, a))
}

pub fn neg(a: NodeRef) -> NodeRef {
    if let Some(c) = a.constant() {
        return constant(-c);
    }
    if let Op::Binary(BinOp::Mul, x, y) = &a.op
        && x.constant() == Some(-1.0)
    {
        return y.clone();
    }
    binary(BinOp::Mul, constant(-1.0), a)
}

pub fn binary(op: BinOp, a: NodeRef, b: NodeRef) -> NodeRef {
    let (ca, cb) = (a.constant(), b.constant());
    if let (Some(x), Some(y)) = (ca, cb) {
        return constant(op.apply(x, y));
    }
    match op {
        BinOp::Add => {
            if ca == Some(0.0) {
                return b;
            }
            if cb == Some(0.0) {
                return a;
            }
            // a + a = 2a exactly (doubling is exact in binary floating point).
            if a.id == b.id {
                return binary(BinOp::Mul, constant(2.0), a);
            }
        }
        BinOp::Sub => {
            if cb == Some(0.0) {
                return a;
            }
            if ca == Some(0.0) {
                return neg(b);
            }
            if a.id == b.id {
                return constant(0.0);
            }
        }
        BinOp::Mul => {
            // `0 * a` is 0 for every finite `a`: the engine's algebra assumes finite values,
            // which keeps derivative graphs free of the zeros of constant terms.
            if ca == Some(0.0) || cb == Some(0.0) {
                return constant(0.0);
            }
            if ca == Some(1.0) {
                return b;
            }
            if cb == Some(1.0) {
                return a;
            }
            if ca == Some(-1.0)
                && let Op::Binary(BinOp::Mul, x, y) = &b.op
                && x.constant() == Some(-1.0)
            {
                return y.clone();
            }
        }
        BinOp::Div | BinOp::GuardedDiv => {
            if cb == Some(1.0) {
                return a;
            }
            // (c·x) / (c·y) = x / y for a common power-of-two factor c (exact scaling), as in
            // the derivative of sqrt: (2x) / (2 sqrt(u)).
            if let (Op::Binary(BinOp::Mul, c1, x), Op::Binary(BinOp::Mul, c2, y)) = (&a.op, &b.op)
                && let (Some(k1), Some(k2)) = (c1.constant(), c2.constant())
                && k1 == k2
                && k1 != 0.0
                && k1.abs().log2().fract() == 0.0
            {
                return binary(op, x.clone(), y.clone());
            }
            if ca == Some(0.0) {
                return constant(0.0);
            }
            if let Some(c) = cb
                && c != 0.0
                && (c.abs().log2().fract() == 0.0)
            {
                // Division by a power of two is exact as a multiplication.
                return binary(BinOp::Mul, constant(1.0 / c), a);
            }
        }
        BinOp::Pow => {
            if cb == Some(1.0) {
                return a;
            }
            if cb == Some(0.0) {
                return constant(1.0);
            }
            if cb == Some(2.0) {
                return binary(BinOp::Mul, a.clone(), a);
            }
        }
        BinOp::Min | BinOp::Max => {
            if a.id == b.id {
                return a;
            }
        }
        BinOp::Atan2 => {}
    }
    // Canonical order for commutative operations, constants first, so that `a + b` and `b + a`
    // are the same node.
    let (a, b) = if op.commutative() && order_key(&b) < order_key(&a) {
        (b, a)
    } else {
        (a, b)
    };
    intern(Op::Binary(op, a, b))
}

fn order_key(n: &NodeRef) -> (bool, u64) {
    (n.constant().is_none(), n.id)
}

pub fn select(c: NodeRef, a: NodeRef, b: NodeRef) -> NodeRef {
    if let Some(v) = c.constant() {
        return if v >= 0.0 { a } else { b };
    }
    if a.id == b.id {
        return a;
    }
    intern(Op::Select(c, a, b))
}

/// Output `index` of a kernel with these arguments.
pub fn kernel_output(kernel: Kernel, args: Vec<NodeRef>, index: usize) -> NodeRef {
    let k = intern(Op::Kernel(kernel, args));
    intern(Op::Output(k, index as u8))
}

/// Output `index` of an existing kernel node.
pub fn output_of(kernel: &NodeRef, index: usize) -> NodeRef {
    intern(Op::Output(kernel.clone(), index as u8))
}

pub fn add(a: NodeRef, b: NodeRef) -> NodeRef {
    binary(BinOp::Add, a, b)
}

pub fn sub(a: NodeRef, b: NodeRef) -> NodeRef {
    binary(BinOp::Sub, a, b)
}

pub fn mul(a: NodeRef, b: NodeRef) -> NodeRef {
    binary(BinOp::Mul, a, b)
}

pub fn div(a: NodeRef, b: NodeRef) -> NodeRef {
    binary(BinOp::Div, a, b)
}

pub fn guarded_div(a: NodeRef, b: NodeRef) -> NodeRef {
    binary(BinOp::GuardedDiv, a, b)
}

/// Sum of many terms, added left to right.
pub fn sum(terms: impl IntoIterator<Item = NodeRef>) -> NodeRef {
    terms
        .into_iter()
        .reduce(add)
        .unwrap_or_else(|| constant(0.0))
}

/// All nodes reachable from `roots`, children before parents, each once. Iterative, so graphs
/// thousands of nodes deep (long advection chains) do not exhaust the stack.
pub fn postorder(roots: &[NodeRef]) -> Vec<NodeRef> {
    let mut seen = std::collections::HashSet::<u64, IdHasher>::default();
    let mut order = Vec::new();
    let mut stack: Vec<(NodeRef, bool)> = roots.iter().rev().map(|r| (r.clone(), false)).collect();
    while let Some((node, expanded)) = stack.pop() {
        if expanded {
            order.push(node);
            continue;
        }
        if !seen.insert(node.id) {
            continue;
        }
        stack.push((node.clone(), true));
        for child in node.children().into_iter().rev() {
            if !seen.contains(&child.id) {
                stack.push((child.clone(), false));
            }
        }
    }
    order
}
