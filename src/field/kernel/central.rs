//! Central differences of a kernel: the derivative of last resort, for outputs that have no
//! exact one (a noise Hessian's derivatives, the second derivative of a grid read, a read
//! that asks for differences).
//!
//! The one key decision: a shifted argument that is already some node plus a constant gets
//! the constants summed, so differences of differences land on shared points (`x + h - h` is
//! `x` again) and nested derivatives stay polynomial in size.

use crate::field::kernel::Kernel;
use crate::field::node::{self, BinOp, NodeRef, Op};

/// A kernel evaluated at ±h along each of its arguments.
pub struct Central {
    plus: Vec<NodeRef>,
    minus: Vec<NodeRef>,
    h: f64,
}

impl Central {
    pub fn new(kernel: &Kernel, args: &[NodeRef], h: f64) -> Central {
        Central {
            plus: (0..args.len())
                .map(|k| shifted_kernel(kernel, args, k, h))
                .collect(),
            minus: (0..args.len())
                .map(|k| shifted_kernel(kernel, args, k, -h))
                .collect(),
            h,
        }
    }

    /// d(output) / d(argument `arg`) by the central difference.
    pub fn partial(&self, output: usize, arg: usize) -> NodeRef {
        node::mul(
            node::constant(0.5 / self.h),
            node::sub(
                node::output_of(&self.plus[arg], output),
                node::output_of(&self.minus[arg], output),
            ),
        )
    }
}

/// The same kernel with argument `axis` moved by `offset`.
fn shifted_kernel(kernel: &Kernel, args: &[NodeRef], axis: usize, offset: f64) -> NodeRef {
    let mut moved = args.to_vec();
    let arg = &args[axis];
    moved[axis] = match &arg.op {
        Op::Binary(BinOp::Add, a, b) if b.constant().is_some() && a.constant().is_none() => {
            let total = b.constant().unwrap_or(0.0) + offset;
            node::add(a.clone(), node::constant(total))
        }
        Op::Binary(BinOp::Add, a, b) if a.constant().is_some() && b.constant().is_none() => {
            let total = a.constant().unwrap_or(0.0) + offset;
            node::add(b.clone(), node::constant(total))
        }
        _ => node::add(arg.clone(), node::constant(offset)),
    };
    node::mk(Op::Kernel(kernel.clone(), moved))
}
