//! The inverse of a 3×3 matrix where it is regular, its Moore–Penrose pseudo-inverse where it
//! is singular (`inverse` of a matrixfield).
//!
//! The one key decision: the nine entries are one kernel, so the shared factorisation in
//! `linalg::pseudo_inverse` runs once per point for all nine outputs, and its derivative is
//! the exact `d(M⁻¹) = -M⁻¹ dM M⁻¹` in terms of those outputs rather than a difference.

use crate::base::failure::Outcome;
use crate::field::kernel::{FieldKernel, KernelAt, KernelBlock};
use crate::field::linalg::pseudo_inverse;
use crate::field::node::{self, NodeRef};
use crate::field::program::{Reg, UNUSED};
use crate::space::BLOCK;
use std::fmt;

/// Children: nine matrix entries, row-major. Outputs: the nine entries of the inverse, or of
/// the pseudo-inverse where the matrix is singular.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PseudoInverse;

impl FieldKernel for PseudoInverse {
    fn outputs(&self) -> usize {
        9
    }

    fn describe(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("pseudo-inverse")
    }

    fn run(&self, block: &mut KernelBlock<'_>, args: &[Reg], outs: &[Reg]) {
        let regs = &mut *block.regs;
        for i in 0..block.n {
            let entries: [f64; 9] = std::array::from_fn(|k| regs[args[k] as usize * BLOCK + i]);
            let inv = pseudo_inverse(entries);
            for (k, &r) in outs.iter().enumerate() {
                if r != UNUSED {
                    regs[r as usize * BLOCK + i] = inv[k];
                }
            }
        }
    }

    /// d(M⁻¹) = -M⁻¹ dM M⁻¹, exact where M is invertible.
    fn derivative(&self, at: &KernelAt<'_>) -> Outcome<Vec<Vec<NodeRef>>> {
        let inv: Vec<NodeRef> = (0..9).map(|i| at.output(i)).collect();
        Ok((0..9)
            .map(|o| {
                let (r, c) = (o / 3, o % 3);
                (0..at.axes)
                    .map(|j| {
                        let mut terms = Vec::new();
                        for a in 0..3 {
                            for b in 0..3 {
                                let dm = at.d_args[a * 3 + b][j].clone();
                                terms.push(node::mul(
                                    node::mul(inv[r * 3 + a].clone(), dm),
                                    inv[b * 3 + c].clone(),
                                ));
                            }
                        }
                        node::neg(node::sum(terms))
                    })
                    .collect()
            })
            .collect())
    }
}
