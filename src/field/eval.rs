//! Running a compiled program over blocks of points.
//!
//! Each thread owns an [`Evaluator`]: the register file (one `BLOCK`-wide row per register)
//! plus scratch space for kernels. A block is run by copying the points into registers 0–2 and
//! executing the tape once. The one key decision about precision: every register holds `f64`,
//! for every caller. Arithmetic in double precision costs little next to noise and grid reads,
//! and it keeps warps, level sets and long advection chains accurate far from the origin. The
//! only single-precision stage is noise when the caller asked for `f32` values (cache fills,
//! rendering): the noise kernels then take one `f64` base point per block and `f32` offsets
//! from it, so lattice lookups stay exact 1e5 units from the origin while eight points share
//! one AVX2 register. `probe` and `stats` use the double-precision noise reference.
//!
//! The tape loop is compiled twice, plainly and with AVX2 enabled, and the second is used when
//! the processor has it (checked once).

use crate::field::kernel::{KernelBlock, KernelScratch};
use crate::field::node::{BinOp, MathFn, sin_cos};
use crate::field::program::{Instr, Program, Reg};
use crate::space::BLOCK;
use std::sync::Arc;

/// Which noise kernels a run uses (registers are always `f64`).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Precision {
    /// Noise in `f32` offsets from an `f64` block base: for cache fills and rendering.
    Single,
    /// Noise in `f64` throughout: for probes, statistics and accuracy references.
    Double,
}

/// The program an evaluator runs: borrowed from its compiled field, or a pruned one it holds.
#[derive(Clone)]
pub enum ProgramRef<'p> {
    Borrowed(&'p Program),
    Shared(Arc<Program>),
}

impl ProgramRef<'_> {
    pub fn get(&self) -> &Program {
        match self {
            ProgramRef::Borrowed(p) => p,
            ProgramRef::Shared(p) => p,
        }
    }
}

/// What an evaluator holds while its own program is out, being run.
static NO_PROGRAM: Program = Program {
    instrs: Vec::new(),
    registers: 0,
    constants: Vec::new(),
    outputs: Vec::new(),
    emits: Vec::new(),
    scratch_rows: 0,
    nodes: 0,
};

pub struct Evaluator<'p> {
    /// The compiled field's own program, or one specialised to a region (`field::prune`).
    program: ProgramRef<'p>,
    regs: Vec<f64>,
    /// The kernels' working space.
    scratch: KernelScratch,
}

/// Bytes one evaluator of `program` holds: its registers, the grid kernels' scratch and the
/// noise buffers, as `Evaluator::new` allocates them. Every worker thread has its own, so a
/// compiled field charges the budget this figure per thread (`CompiledField::prepared`).
pub fn evaluator_bytes(program: &Program) -> usize {
    program.registers * BLOCK * std::mem::size_of::<f64>()
        + KernelScratch::bytes(program.scratch_rows)
}

impl<'p> Evaluator<'p> {
    pub fn new(program: &'p Program) -> Evaluator<'p> {
        let mut regs = vec![0.0; program.registers * BLOCK];
        for &(r, c) in &program.constants {
            regs[r as usize * BLOCK..(r as usize + 1) * BLOCK].fill(c);
        }
        Evaluator {
            program: ProgramRef::Borrowed(program),
            regs,
            scratch: KernelScratch::new(program.scratch_rows),
        }
    }

    /// Runs `program` from now on, keeping the scratch space: a program specialised to a region
    /// replaces the field's own for the points of that region.
    pub fn set_program(&mut self, handle: ProgramRef<'p>) {
        let program = handle.get();
        self.regs.resize(program.registers * BLOCK, 0.0);
        for &(r, c) in &program.constants {
            self.regs[r as usize * BLOCK..(r as usize + 1) * BLOCK].fill(c);
        }
        self.scratch.reserve(program.scratch_rows);
        self.program = handle;
    }

    /// The program being run.
    pub fn program(&self) -> &Program {
        self.program.get()
    }

    /// Runs the program on `xs.len() <= BLOCK` points; results stay in the output registers.
    pub fn run(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], precision: Precision) {
        self.run_emitting(xs, ys, zs, precision, |_, _| {});
    }

    /// Runs the program and hands each output component to `emit` (component, lanes) as soon
    /// as its value is final. Storing results while the rest of the tape still computes
    /// overlaps the stores with arithmetic; a copy after the whole tape would add its memory
    /// traffic to the time instead.
    pub fn run_emitting(
        &mut self,
        xs: &[f64],
        ys: &[f64],
        zs: &[f64],
        precision: Precision,
        mut emit: impl FnMut(usize, &[f64]),
    ) {
        let n = xs.len().min(ys.len()).min(zs.len()).min(BLOCK);
        self.regs[..n].copy_from_slice(&xs[..n]);
        self.regs[BLOCK..BLOCK + n].copy_from_slice(&ys[..n]);
        self.regs[2 * BLOCK..2 * BLOCK + n].copy_from_slice(&zs[..n]);
        #[cfg(target_arch = "x86_64")]
        {
            if avx2_available() {
                // SAFETY: the processor supports AVX2 (checked above).
                unsafe { self.run_avx2(n, precision, &mut emit) };
                return;
            }
        }
        self.run_tape(n, precision, &mut emit);
    }

    /// Component `c` of the result for the last run, `n` lanes.
    pub fn output(&self, c: usize, n: usize) -> &[f64] {
        let r = self.program.get().outputs[c] as usize;
        &self.regs[r * BLOCK..r * BLOCK + n]
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn run_avx2(
        &mut self,
        n: usize,
        precision: Precision,
        emit: &mut impl FnMut(usize, &[f64]),
    ) {
        self.run_tape(n, precision, emit)
    }

    /// Hands every output of `program` whose value became final after instruction `k` to
    /// `emit`.
    #[inline(always)]
    fn emit_after(
        &self,
        program: &Program,
        k: usize,
        next: &mut usize,
        n: usize,
        emit: &mut impl FnMut(usize, &[f64]),
    ) {
        while let Some(&(at, c)) = program.emits.get(*next) {
            if at != k {
                break;
            }
            let r = program.outputs[c] as usize;
            emit(c, &self.regs[r * BLOCK..r * BLOCK + n]);
            *next += 1;
        }
    }

    #[inline(always)]
    fn run_tape(&mut self, n: usize, precision: Precision, emit: &mut impl FnMut(usize, &[f64])) {
        // The program is taken out for the run, so the tape can be read while the evaluator's
        // scratch is written. Not a clone: threads running one shared program would bump its
        // reference count once per block, on one cache line they all write.
        let handle = std::mem::replace(&mut self.program, ProgramRef::Borrowed(&NO_PROGRAM));
        let program = handle.get();
        let mut next = 0;
        for (step, instr) in program.instrs.iter().enumerate() {
            match instr {
                Instr::Unary { f, dst, a } => unary(&mut self.regs, *f, *dst, *a, n),
                Instr::SinCos { a, sin, cos } => {
                    let (a, sin, cos) = (*a as usize, *sin as usize, *cos as usize);
                    for i in 0..n {
                        let (s, c) = sin_cos(self.regs[a * BLOCK + i]);
                        self.regs[sin * BLOCK + i] = s;
                        self.regs[cos * BLOCK + i] = c;
                    }
                }
                Instr::Binary { op, dst, a, b } => binary(&mut self.regs, *op, *dst, *a, *b, n),
                Instr::BinaryConstant {
                    op,
                    dst,
                    a,
                    k,
                    constant_first,
                } => binary_constant(&mut self.regs, *op, *dst, *a, *k, *constant_first, n),
                Instr::Select { dst, c, a, b } => {
                    let (d, [c, a, b]) = lanes(&mut self.regs, *dst, [*c, *a, *b], n);
                    for i in 0..n {
                        d[i] = if c[i] >= 0.0 { a[i] } else { b[i] };
                    }
                }
                Instr::Kernel { kernel, args, outs } => {
                    let mut block = KernelBlock {
                        regs: &mut self.regs,
                        scratch: &mut self.scratch,
                        n,
                        precision,
                    };
                    kernel.run(&mut block, args, outs);
                }
            }
            self.emit_after(program, step, &mut next, n, emit);
        }
        self.emit_after(program, program.instrs.len(), &mut next, n, emit);
        self.program = handle;
    }
}

/// The destination row and operand rows of one instruction. The register allocator never gives
/// an instruction a destination equal to one of its operands, which is what makes this sound.
#[inline(always)]
fn lanes<const K: usize>(
    regs: &mut [f64],
    dst: Reg,
    operands: [Reg; K],
    n: usize,
) -> (&mut [f64], [&[f64]; K]) {
    let dst = dst as usize;
    assert!(operands.iter().all(|&o| o as usize != dst) && (dst + 1) * BLOCK <= regs.len());
    assert!(
        operands
            .iter()
            .all(|&o| (o as usize + 1) * BLOCK <= regs.len())
            && n <= BLOCK
    );
    let base = regs.as_mut_ptr();
    // SAFETY: all rows are in bounds (asserted) and the destination row is disjoint from every
    // operand row, so the one mutable slice aliases none of the shared ones.
    unsafe {
        let d = std::slice::from_raw_parts_mut(base.add(dst * BLOCK), n);
        let ops = operands
            .map(|o| std::slice::from_raw_parts(base.add(o as usize * BLOCK) as *const f64, n));
        (d, ops)
    }
}

#[inline(always)]
fn map1(regs: &mut [f64], dst: Reg, a: Reg, n: usize, f: impl Fn(f64) -> f64) {
    let (d, [a]) = lanes(regs, dst, [a], n);
    for i in 0..n {
        d[i] = f(a[i]);
    }
}

#[inline(always)]
fn map2(regs: &mut [f64], dst: Reg, a: Reg, b: Reg, n: usize, f: impl Fn(f64, f64) -> f64) {
    let (d, [a, b]) = lanes(regs, dst, [a, b], n);
    for i in 0..n {
        d[i] = f(a[i], b[i]);
    }
}

#[inline(always)]
fn unary(regs: &mut [f64], f: MathFn, dst: Reg, a: Reg, n: usize) {
    match f {
        MathFn::Abs => map1(regs, dst, a, n, f64::abs),
        MathFn::Sqrt => map1(regs, dst, a, n, f64::sqrt),
        MathFn::Floor => map1(regs, dst, a, n, f64::floor),
        MathFn::Ceil => map1(regs, dst, a, n, f64::ceil),
        MathFn::Fract => map1(regs, dst, a, n, |x| x - x.floor()),
        MathFn::Step => map1(regs, dst, a, n, |x| if x >= 0.0 { 1.0 } else { 0.0 }),
        other => map1(regs, dst, a, n, |x| other.apply(x)),
    }
}

/// Calls `$apply!` with the closure computing `op` (one place for the tape's arithmetic of
/// every binary operation).
macro_rules! with_op {
    ($op:expr, $apply:ident) => {
        match $op {
            BinOp::Add => $apply!(|x: f64, y: f64| x + y),
            BinOp::Sub => $apply!(|x: f64, y: f64| x - y),
            BinOp::Mul => $apply!(|x: f64, y: f64| x * y),
            BinOp::Div => $apply!(|x: f64, y: f64| x / y),
            BinOp::GuardedDiv => $apply!(|x: f64, y: f64| {
                let q = x / y;
                if y == 0.0 { 0.0 } else { q }
            }),
            BinOp::Min => $apply!(f64::min),
            BinOp::Max => $apply!(f64::max),
            BinOp::Pow => $apply!(f64::powf),
            BinOp::Atan2 => $apply!(f64::atan2),
        }
    };
}

#[inline(always)]
fn binary(regs: &mut [f64], op: BinOp, dst: Reg, a: Reg, b: Reg, n: usize) {
    macro_rules! lanes_of_both {
        ($f:expr) => {
            map2(regs, dst, a, b, n, $f)
        };
    }
    with_op!(op, lanes_of_both)
}

/// `binary` with one operand a constant `k` (the first operand when `constant_first`).
#[inline(always)]
fn binary_constant(
    regs: &mut [f64],
    op: BinOp,
    dst: Reg,
    a: Reg,
    k: f64,
    constant_first: bool,
    n: usize,
) {
    macro_rules! with_constant {
        ($f:expr) => {
            if constant_first {
                map1(regs, dst, a, n, |x| $f(k, x))
            } else {
                map1(regs, dst, a, n, |x| $f(x, k))
            }
        };
    }
    with_op!(op, with_constant)
}

/// Whether the processor has AVX2 (checked once): the tape loop and the kernels' staging are
/// compiled for it too.
#[cfg(target_arch = "x86_64")]
pub(crate) fn avx2_available() -> bool {
    use std::sync::OnceLock;
    static AVAILABLE: OnceLock<bool> = OnceLock::new();
    *AVAILABLE.get_or_init(|| std::is_x86_feature_detected!("avx2"))
}

#[cfg(test)]
mod budget_tests {
    use super::*;
    use crate::field::Field;
    use crate::field::noise::NoiseKind;

    /// The figure a compiled field charges per thread is what an evaluator really allocates:
    /// each buffer's capacity times the size of its element.
    #[test]
    fn evaluator_bytes_are_what_an_evaluator_allocates() {
        let p = Field::identity();
        let noisy = Field::noise(NoiseKind::Perlin, 7);
        let roots: Vec<_> = [p.length().unwrap(), noisy]
            .iter()
            .flat_map(|f| f.components().to_vec())
            .collect();
        let program = Program::compile(&roots);
        assert!(program.registers > 3);
        let evaluator = Evaluator::new(&program);
        let held = |capacity: usize, element: usize| capacity * element;
        let allocated = held(evaluator.regs.capacity(), 8)
            + held(evaluator.scratch.grid_out.capacity(), 8)
            + evaluator
                .scratch
                .noise_in
                .iter()
                .map(|v| held(v.capacity(), 4))
                .sum::<usize>()
            + held(evaluator.scratch.noise_out.capacity(), 4)
            + held(evaluator.scratch.noise_out64.capacity(), 8);
        assert_eq!(evaluator_bytes(&program), allocated);
    }
}
