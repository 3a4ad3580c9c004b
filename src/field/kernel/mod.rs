//! Field kernels: the operations with several outputs that are cheaper computed together per
//! block (a noise value with its gradient and Hessian, every component of a grid read, a 3×3
//! pseudo-inverse). Each is one type implementing [`FieldKernel`], in its own file here; the
//! graph holds it as an `Arc<dyn FieldKernel>` in `Op::Kernel`, the tape as one
//! `Instr::Kernel`, and every pass (hash-consing, evaluation, differentiation, intervals) asks
//! the trait rather than matching kinds.
//!
//! The one key decision: dispatch is once per kernel per block, never per point. `run` gets the
//! whole block's registers and does its own inner loops, so the noise block loops (generic,
//! monomorphised, AVX2 builds chosen at run time) stay what they were behind one virtual call
//! per block. A kernel's identity for hash-consing is derived: each kernel is a plain struct
//! deriving `Hash` and `Eq`, compared through `Any` (see [`KernelIdentity`]).
//!
//! A new kernel touches its own file here (the struct and its `FieldKernel` impl), one
//! `pub mod` line below, and the code that makes its node: a `Field` constructor in
//! `field/mod.rs`, called by its builtin (which, like any builtin, has its registry row and
//! its entry in `docs/language.md`). Nothing else names kernels: hash-consing, the tape,
//! the evaluator, derivatives and intervals all go through the trait.

mod central;
pub mod grid_read;
pub mod noise;
pub mod pseudo_inverse;
#[cfg(test)]
mod tests;

pub use central::Central;
use grid_read::GridRead;

use crate::base::failure::Outcome;
use crate::field::eval::Precision;
use crate::field::interval::{ALL, Interval};
use crate::field::node::{self, NodeRef};
use crate::field::program::{Reg, UNUSED};
use crate::space::BLOCK;
use std::any::{Any, TypeId};
use std::fmt;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

/// A kernel as the graph and the tape hold it.
pub type Kernel = Arc<dyn FieldKernel>;

/// One operation with several outputs. Children of its node are its arguments (for most, the
/// lookup position x, y, z); `Output` nodes pick its outputs.
pub trait FieldKernel: KernelIdentity + Send + Sync + 'static {
    /// How many outputs it has.
    fn outputs(&self) -> usize;

    /// What it is, for graph dumps and diagnostics ("noise Perlin seed 3").
    fn describe(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result;

    /// Computes one block: reads the argument registers `args`, writes each output `o` to
    /// register `outs[o]`, skipping those that are [`UNUSED`].
    fn run(&self, block: &mut KernelBlock<'_>, args: &[Reg], outs: &[Reg]);

    /// Rows of `BLOCK` values of `KernelScratch::grid_out` that `run` needs.
    fn scratch_rows(&self) -> usize {
        0
    }

    /// Derivatives of every output along the pass's axes (`at.chain`), one list per output.
    /// By default central differences of the kernel itself, `difference_step` apart.
    fn derivative(&self, at: &KernelAt<'_>) -> Outcome<Vec<Vec<NodeRef>>> {
        let central = Central::new(at.kernel, at.args, self.difference_step());
        Ok((0..self.outputs())
            .map(|o| at.chain(&|k| central.partial(o, k)))
            .collect())
    }

    /// Distance between the samples of the default central difference, in the units of the
    /// arguments.
    fn difference_step(&self) -> f64 {
        1e-3
    }

    /// Conservative intervals of the outputs over argument intervals `args`, into `out` (one
    /// per output); grid reads as held reads when `held` (`GridSource::range_held`). By
    /// default every output may be anything.
    fn ranges(&self, args: &[Interval], held: bool, out: &mut [Interval]) {
        let _ = (args, held);
        out.fill(ALL);
    }

    /// The grid read this kernel is, for the passes that treat reads of grids specially
    /// (a plain cache read's own cells, the grids a field depends on, supports).
    fn grid_read(&self) -> Option<&GridRead> {
        None
    }
}

/// The identity of a kernel, derived from its `Hash` and `Eq`: given to every kernel type
/// that has them, so no kernel packs a key by hand.
pub trait KernelIdentity {
    /// A hash of the kernel's type and fields, stable within one build.
    fn identity_hash(&self) -> u64;
    /// Whether `other` is the same kernel: the same type with equal fields.
    fn same_as(&self, other: &dyn Any) -> bool;
    fn as_any(&self) -> &dyn Any;
}

impl<T: FieldKernel + Hash + Eq> KernelIdentity for T {
    fn identity_hash(&self) -> u64 {
        // SipHash with fixed keys: the same value on every run, so node identities (and with
        // them the order of commutative operands) never depend on a random seed.
        let mut hasher = std::hash::DefaultHasher::new();
        TypeId::of::<T>().hash(&mut hasher);
        self.hash(&mut hasher);
        hasher.finish()
    }

    fn same_as(&self, other: &dyn Any) -> bool {
        other.downcast_ref::<T>() == Some(self)
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

impl dyn FieldKernel {
    /// Whether two kernels are the same operation.
    pub fn same(&self, other: &dyn FieldKernel) -> bool {
        self.same_as(other.as_any())
    }
}

impl fmt::Debug for dyn FieldKernel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.describe(f)
    }
}

/// The kernels' working space in an evaluator, kept between blocks.
pub struct KernelScratch {
    /// Grid reads write all components here first, component-major (`scratch_rows` rows).
    pub grid_out: Vec<f64>,
    /// `f32` noise inputs (offsets from the block base) and outputs.
    pub noise_in: [Vec<f32>; 3],
    pub noise_out: Vec<f32>,
    pub noise_out64: Vec<f64>,
}

/// Outputs a noise kernel writes per point (value and derivatives), the noise buffers' rows.
pub const NOISE_OUTPUTS: usize = 10;

impl KernelScratch {
    /// Scratch for kernels needing at most `rows` rows of `grid_out`.
    pub fn new(rows: usize) -> KernelScratch {
        KernelScratch {
            grid_out: vec![0.0; rows.max(1) * BLOCK],
            noise_in: [vec![0.0; BLOCK], vec![0.0; BLOCK], vec![0.0; BLOCK]],
            noise_out: vec![0.0; NOISE_OUTPUTS * BLOCK],
            noise_out64: vec![0.0; NOISE_OUTPUTS * BLOCK],
        }
    }

    /// Grows `grid_out` to `rows` rows if it is smaller.
    pub fn reserve(&mut self, rows: usize) {
        let wanted = rows.max(1) * BLOCK;
        if self.grid_out.len() < wanted {
            self.grid_out.resize(wanted, 0.0);
        }
    }

    /// Bytes a scratch for `rows` rows holds, as `new` allocates it.
    pub fn bytes(rows: usize) -> usize {
        let f64s = (rows.max(1) + NOISE_OUTPUTS) * BLOCK;
        let f32s = (3 + NOISE_OUTPUTS) * BLOCK;
        f64s * std::mem::size_of::<f64>() + f32s * std::mem::size_of::<f32>()
    }
}

/// One block as a kernel sees it: the register file (`BLOCK` values per register, the first
/// `n` live) and the scratch space.
pub struct KernelBlock<'a> {
    pub regs: &'a mut [f64],
    pub scratch: &'a mut KernelScratch,
    pub n: usize,
    pub precision: Precision,
}

impl KernelBlock<'_> {
    /// The `n` live values of register `r` in `regs` (a free function of the registers, so
    /// the scratch can be written while rows are read).
    pub fn row(regs: &[f64], r: Reg, n: usize) -> &[f64] {
        let start = r as usize * BLOCK;
        &regs[start..start + n]
    }

    /// Copies row `o` of `rows` (component-major, `n` values each) into register `outs[o]`,
    /// for every output some instruction reads.
    pub fn store_rows(regs: &mut [f64], outs: &[Reg], rows: &[f64], n: usize) {
        for (o, &r) in outs.iter().enumerate() {
            if r != UNUSED {
                let r = r as usize * BLOCK;
                regs[r..r + n].copy_from_slice(&rows[o * n..(o + 1) * n]);
            }
        }
    }
}

/// A kernel node as a derivative pass sees it.
pub struct KernelAt<'a> {
    pub kernel: &'a Kernel,
    /// The kernel's node (its outputs are `node::output_of(node, o)`).
    pub node: &'a NodeRef,
    pub args: &'a [NodeRef],
    /// `d_args[k][j]`: argument `k` differentiated along the pass's `j`-th axis.
    pub d_args: Vec<&'a [NodeRef]>,
    /// How many axes the pass differentiates along.
    pub axes: usize,
}

impl KernelAt<'_> {
    /// Output `o` of the kernel node.
    pub fn output(&self, o: usize) -> NodeRef {
        node::output_of(self.node, o)
    }

    /// The chain rule along each of the pass's axes: `d out / d x_j = sum_k partial(k) ·
    /// d arg_k / d x_j`, with `partial(k)` the derivative of the output by argument `k`.
    pub fn chain(&self, partial: &dyn Fn(usize) -> NodeRef) -> Vec<NodeRef> {
        (0..self.axes)
            .map(|j| {
                node::sum(
                    (0..self.args.len()).map(|k| node::mul(partial(k), self.d_args[k][j].clone())),
                )
            })
            .collect()
    }
}
