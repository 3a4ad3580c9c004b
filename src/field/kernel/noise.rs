//! The noise kernel: Perlin, simplex or Worley noise of one seed at a position, with its exact
//! gradient and Hessian. The three families differ only in a row of a table (their block
//! loops and bounds, in `field::noise`), so they are one kernel with a `NoiseKind`.
//!
//! The one key decision: the block is staged for the noise loops here, in a body compiled
//! twice (plainly and with AVX2, picked at run time like the tape loop), so that converting
//! the points to `f32` offsets and widening the results keep the vector width they had when
//! this code was inlined into the tape.

use crate::base::failure::Outcome;
use crate::field::eval::{Precision, avx2_available};
use crate::field::interval::{ALL, Interval};
use crate::field::kernel::{Central, FieldKernel, KernelAt, KernelBlock, NOISE_OUTPUTS};
use crate::field::node::NodeRef;
use crate::field::noise::{self, NoiseKind, NoiseOutput};
use crate::field::program::{Reg, UNUSED};
use crate::space::BLOCK;
use std::fmt;

/// Noise of `kind` and `seed` at the position given by its three arguments (lattice spacing
/// 1). Outputs: 0 value, 1..=3 gradient, 4..=9 Hessian in the order xx, yy, zz, xy, xz, yz.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Noise {
    pub kind: NoiseKind,
    pub seed: u32,
}

/// Lattice units between the samples of a noise Hessian's central difference.
const NOISE_STEP: f64 = 1e-3;

/// Hessian output index for the pair of axes (a, b).
fn hessian_output(a: usize, b: usize) -> usize {
    match (a.min(b), a.max(b)) {
        (0, 0) => 4,
        (1, 1) => 5,
        (2, 2) => 6,
        (0, 1) => 7,
        (0, 2) => 8,
        _ => 9,
    }
}

impl FieldKernel for Noise {
    fn outputs(&self) -> usize {
        NOISE_OUTPUTS
    }

    fn describe(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "noise {:?} seed {}", self.kind, self.seed)
    }

    fn run(&self, block: &mut KernelBlock<'_>, args: &[Reg], outs: &[Reg]) {
        let at = [args[0], args[1], args[2]];
        #[cfg(target_arch = "x86_64")]
        {
            if avx2_available() {
                // SAFETY: the processor supports AVX2 (checked above).
                unsafe { self.run_avx2(block, at, outs) };
                return;
            }
        }
        self.stage(block, at, outs);
    }

    /// Exact first and second derivatives; third and higher ones (needed by nested
    /// level-set projections such as procedural `cumulo`) are central differences of the
    /// exact Hessian, a thousandth of a lattice cell apart (relative error about 1e-6).
    fn derivative(&self, at: &KernelAt<'_>) -> Outcome<Vec<Vec<NodeRef>>> {
        let mut outs = Vec::with_capacity(NOISE_OUTPUTS);
        outs.push(at.chain(&|k| at.output(1 + k)));
        for a in 0..3 {
            outs.push(at.chain(&|k| at.output(hessian_output(a, k))));
        }
        let central = Central::new(at.kernel, at.args, NOISE_STEP);
        for o in 4..NOISE_OUTPUTS {
            outs.push(at.chain(&|k| central.partial(o, k)));
        }
        Ok(outs)
    }

    /// The family's certified bounds (`noise::value_range`, `noise::lipschitz`): the value,
    /// then the gradient's three components; the Hessian's six stay unbounded.
    fn ranges(&self, _args: &[Interval], _held: bool, out: &mut [Interval]) {
        let (lo, hi) = noise::value_range(self.kind);
        let slope = noise::lipschitz(self.kind);
        out[0] = Interval::new(lo, hi);
        out[1..4].fill(Interval::new(-slope, slope));
        out[4..].fill(ALL);
    }
}

impl Noise {
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn run_avx2(&self, block: &mut KernelBlock<'_>, at: [Reg; 3], outs: &[Reg]) {
        self.stage(block, at, outs)
    }

    #[inline(always)]
    fn stage(&self, block: &mut KernelBlock<'_>, at: [Reg; 3], outs: &[Reg]) {
        let (kind, seed, n) = (self.kind, self.seed, block.n);
        let wants_gradient = outs[1..4].iter().any(|&r| r != UNUSED);
        let wants_hessian = outs[4..].iter().any(|&r| r != UNUSED);
        let [x, y, z] = at.map(|r| r as usize * BLOCK);
        let scratch = &mut *block.scratch;
        match block.precision {
            Precision::Double => {
                let regs = &block.regs;
                let (xs, ys, zs) = (&regs[x..x + n], &regs[y..y + n], &regs[z..z + n]);
                let out = split_output(
                    &mut scratch.noise_out64[..NOISE_OUTPUTS * n],
                    n,
                    wants_gradient,
                    wants_hessian,
                );
                noise::eval_f64(kind, seed, xs, ys, zs, out);
                KernelBlock::store_rows(block.regs, outs, &scratch.noise_out64, n);
            }
            Precision::Single => {
                if n == 0 {
                    return;
                }
                let regs = &mut *block.regs;
                let base = [regs[x], regs[y], regs[z]];
                for (axis, start) in [x, y, z].into_iter().enumerate() {
                    // Zipped slices: no bounds checks, so the loop runs on vector lanes.
                    let offsets = &mut scratch.noise_in[axis][..n];
                    for (o, &p) in offsets.iter_mut().zip(&regs[start..start + n]) {
                        *o = (p - base[axis]) as f32;
                    }
                }
                let out = split_output(
                    &mut scratch.noise_out[..NOISE_OUTPUTS * n],
                    n,
                    wants_gradient,
                    wants_hessian,
                );
                let [ix, iy, iz] = &scratch.noise_in;
                noise::eval_f32(kind, seed, base, &ix[..n], &iy[..n], &iz[..n], out);
                for (k, &r) in outs.iter().enumerate() {
                    if r != UNUSED {
                        let r = r as usize * BLOCK;
                        let row = &scratch.noise_out[k * n..(k + 1) * n];
                        for (d, s) in regs[r..r + n].iter_mut().zip(row) {
                            *d = *s as f64;
                        }
                    }
                }
            }
        }
    }
}

/// Ten rows of `n` values (value, gradient, Hessian) as a noise output.
fn split_output<T>(rows: &mut [T], n: usize, gradient: bool, hessian: bool) -> NoiseOutput<'_, T> {
    let (value, rest) = rows.split_at_mut(n);
    let (g, h) = rest.split_at_mut(3 * n);
    let (g0, g) = g.split_at_mut(n);
    let (g1, g2) = g.split_at_mut(n);
    let (h0, h) = h.split_at_mut(n);
    let (h1, h) = h.split_at_mut(n);
    let (h2, h) = h.split_at_mut(n);
    let (h3, h) = h.split_at_mut(n);
    let (h4, h5) = h.split_at_mut(n);
    NoiseOutput {
        value,
        gradient: gradient.then_some([g0, g1, g2]),
        hessian: hessian.then_some([h0, h1, h2, h3, h4, h5]),
    }
}
