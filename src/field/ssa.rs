//! The linear form of a field graph: one instruction per reachable node, in dependency order,
//! each naming its operands by dense index.
//!
//! The one key decision: a compiled field is flattened exactly once, into this list, and every
//! pass over it — the register program (`program`), the interval tape and the support search
//! (`interval`), the grids a field reads — is derived from the list, keeping what it knows per
//! node in vectors indexed by position instead of hash maps keyed by node id. The order is the
//! graph's post-order (children before parents, first-met first), the same order
//! `node::postorder` gives, so programs derived from it are the ones the engine always built.
//! Building it is iterative, so a graph hundreds of thousands of nodes deep needs no deep stack.

use crate::field::node::{BinOp, Kernel, MathFn, NodeRef, Op};
use std::collections::HashMap;

/// The position of an instruction in an [`Ssa`].
pub type Index = u32;

/// One instruction: a node's operation with its operands replaced by their indices.
#[derive(Clone, Debug)]
pub enum Inst {
    Const(f64),
    X,
    Y,
    Z,
    Unary(MathFn, [Index; 1]),
    Binary(BinOp, [Index; 2]),
    /// `a` where `c >= 0`, else `b`: operands `[c, a, b]`.
    Select([Index; 3]),
    /// A multi-output operation; its values are read through `Output` instructions.
    Kernel(Kernel, Vec<Index>),
    /// Output `index` of the kernel at operand 0.
    Output([Index; 1], u8),
}

impl Inst {
    /// The operands, in the order the node lists its children.
    pub fn operands(&self) -> &[Index] {
        match self {
            Inst::Const(_) | Inst::X | Inst::Y | Inst::Z => &[],
            Inst::Unary(_, a) | Inst::Output(a, _) => a,
            Inst::Binary(_, a) => a,
            Inst::Select(a) => a,
            Inst::Kernel(_, args) => args,
        }
    }
}

/// A field graph as one linear list of instructions.
#[derive(Clone, Debug)]
pub struct Ssa {
    pub insts: Vec<Inst>,
    /// The instructions whose values are the field's components.
    pub roots: Vec<Index>,
}

impl Ssa {
    /// The instructions reachable from `roots`, children before parents, each once.
    pub fn new(roots: &[NodeRef]) -> Ssa {
        // `None`: met, not yet placed (its children are being placed).
        let mut index: HashMap<u64, Option<Index>> = HashMap::new();
        let mut insts = Vec::new();
        let mut stack: Vec<(&NodeRef, bool)> = roots.iter().rev().map(|r| (r, false)).collect();
        while let Some((node, expanded)) = stack.pop() {
            if expanded {
                let at = |c: &NodeRef| index[&c.id].expect("children are placed first");
                let inst = match &node.op {
                    Op::Const(c) => Inst::Const(*c),
                    Op::X => Inst::X,
                    Op::Y => Inst::Y,
                    Op::Z => Inst::Z,
                    Op::Unary(m, a) => Inst::Unary(*m, [at(a)]),
                    Op::Binary(op, a, b) => Inst::Binary(*op, [at(a), at(b)]),
                    Op::Select(c, a, b) => Inst::Select([at(c), at(a), at(b)]),
                    Op::Kernel(k, args) => Inst::Kernel(k.clone(), args.iter().map(at).collect()),
                    Op::Output(k, i) => Inst::Output([at(k)], *i),
                };
                index.insert(node.id, Some(insts.len() as Index));
                insts.push(inst);
                continue;
            }
            if index.contains_key(&node.id) {
                continue;
            }
            index.insert(node.id, None);
            stack.push((node, true));
            for child in node.children().into_iter().rev() {
                if !index.contains_key(&child.id) {
                    stack.push((child, false));
                }
            }
        }
        let roots = roots
            .iter()
            .map(|r| index[&r.id].expect("roots are placed"))
            .collect();
        Ssa { insts, roots }
    }

    pub fn len(&self) -> usize {
        self.insts.len()
    }

    pub fn is_empty(&self) -> bool {
        self.insts.is_empty()
    }
}
