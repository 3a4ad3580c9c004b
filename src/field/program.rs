//! Compilation of a node graph into a flat register program (a tape).
//!
//! The reachable nodes are put in dependency order and each becomes one instruction that works
//! on whole blocks of points: one register holds `BLOCK` values, one per point. Interpreting an
//! instruction therefore costs one dispatch per block, and its inner loop runs over contiguous
//! lanes that the compiler vectorises. The one key decision: registers are reused as soon as
//! the last reader of a value has run (linear scan over the tape), with the destination of an
//! instruction always distinct from its operands; that keeps the working set of a deep graph in
//! a few hundred kilobytes per thread, inside the cache, however many nodes it has.

use crate::field::node::{BinOp, Kernel, MathFn, NodeRef};
use crate::field::ssa::{Index, Inst, Ssa};

/// A register index.
pub type Reg = u32;

/// Marks an output of a kernel that no instruction reads.
pub const UNUSED: Reg = Reg::MAX;

#[derive(Clone, Debug)]
pub enum Instr {
    Unary {
        f: MathFn,
        dst: Reg,
        a: Reg,
    },
    Binary {
        op: BinOp,
        dst: Reg,
        a: Reg,
        b: Reg,
    },
    /// `a op k` (or `k op a` when `constant_first`) with a constant `k`: read as one value
    /// rather than a register of `BLOCK` copies, which halves what the instruction reads and
    /// keeps constants out of the cache.
    BinaryConstant {
        op: BinOp,
        dst: Reg,
        a: Reg,
        k: f64,
        constant_first: bool,
    },
    Select {
        dst: Reg,
        c: Reg,
        a: Reg,
        b: Reg,
    },
    /// A kernel (`field::kernel`) run on the whole block: one dispatch per block, its own
    /// loops inside. `outs[o]` is `UNUSED` where no instruction reads output `o`.
    Kernel {
        kernel: Kernel,
        args: Vec<Reg>,
        outs: Vec<Reg>,
    },
    /// The sine and cosine of one register, which one library call gives together.
    SinCos {
        a: Reg,
        sin: Reg,
        cos: Reg,
    },
}

/// A compiled field: registers 0, 1, 2 hold the point's x, y, z; `constants` are filled once
/// per evaluator; `outputs` name the registers holding the result components after a run.
#[derive(Clone, Debug)]
pub struct Program {
    pub instrs: Vec<Instr>,
    pub registers: usize,
    pub constants: Vec<(Reg, f64)>,
    pub outputs: Vec<Reg>,
    /// `(instruction, output)`: output components in the order their values become final,
    /// by the index of the instruction after which they are; `instrs.len()` for outputs that
    /// no instruction writes (coordinates and constants). Lets results be stored while later
    /// instructions still compute, instead of in one copy after the whole tape.
    pub emits: Vec<(usize, usize)>,
    /// The most scratch rows a kernel needs (`FieldKernel::scratch_rows`).
    pub scratch_rows: usize,
    /// Number of graph nodes compiled (for summaries).
    pub nodes: usize,
}

impl Program {
    pub fn compile(roots: &[NodeRef]) -> Program {
        Program::from_ssa(&Ssa::new(roots))
    }

    /// The register program of a linear form.
    pub fn from_ssa(ssa: &Ssa) -> Program {
        let insts = &ssa.insts;
        let count = insts.len();
        // Where each value is read for the last time (in tape order; `None`: never read).
        // Outputs of kernels are "defined" at their kernel, so they are found through the
        // kernel's users.
        let mut last_use: Vec<Option<usize>> = vec![None; count];
        let mut outputs_of: Vec<Vec<(usize, Index)>> = vec![Vec::new(); count];
        for (i, inst) in insts.iter().enumerate() {
            match inst {
                Inst::Output([k], index) => {
                    outputs_of[*k as usize].push((*index as usize, i as Index));
                }
                _ => {
                    for &c in inst.operands() {
                        last_use[c as usize] = Some(i);
                    }
                }
            }
        }
        for &r in &ssa.roots {
            last_use[r as usize] = Some(usize::MAX);
        }

        let mut reg_of: Vec<Option<Reg>> = vec![None; count];
        let mut constants = Vec::new();
        let mut registers: usize = 3;
        for (i, inst) in insts.iter().enumerate() {
            match inst {
                Inst::X => reg_of[i] = Some(0),
                Inst::Y => reg_of[i] = Some(1),
                Inst::Z => reg_of[i] = Some(2),
                Inst::Const(c) => {
                    reg_of[i] = Some(registers as Reg);
                    constants.push((registers as Reg, *c));
                    registers += 1;
                }
                _ => {}
            }
        }
        // Inputs and constants hold registers 0 .. first_temporary for the whole tape.
        let first_temporary = registers;

        let mut free: Vec<Reg> = Vec::new();
        let mut allocate = |free: &mut Vec<Reg>| -> Reg {
            free.pop().unwrap_or_else(|| {
                registers += 1;
                (registers - 1) as Reg
            })
        };
        let reg = |reg_of: &[Option<Reg>], i: Index| -> Reg {
            reg_of[i as usize].expect("operands are computed before their users")
        };
        let mut instrs = Vec::new();
        let mut scratch_rows = 0;
        let mut released: Vec<Index> = Vec::new();
        let partner = sin_cos_pairs(insts);
        for (i, inst) in insts.iter().enumerate() {
            let instr = match inst {
                Inst::X | Inst::Y | Inst::Z | Inst::Const(_) | Inst::Output(..) => continue,
                // The second of a sine and cosine pair was computed with the first.
                Inst::Unary(_, _) if partner[i].is_some_and(|p| (p as usize) < i) => None,
                Inst::Unary(f, [a]) if partner[i].is_some() => {
                    let a = reg(&reg_of, *a);
                    let (mine, theirs) = (allocate(&mut free), allocate(&mut free));
                    reg_of[i] = Some(mine);
                    reg_of[partner[i].expect("paired") as usize] = Some(theirs);
                    let (sin, cos) = match f {
                        MathFn::Sin => (mine, theirs),
                        _ => (theirs, mine),
                    };
                    Some(Instr::SinCos { a, sin, cos })
                }
                Inst::Unary(f, [a]) => {
                    let a = reg(&reg_of, *a);
                    let dst = allocate(&mut free);
                    reg_of[i] = Some(dst);
                    Some(Instr::Unary { f: *f, dst, a })
                }
                Inst::Binary(op, [a, b]) => {
                    let constant = |k: Index| match insts[k as usize] {
                        Inst::Const(c) => Some(c),
                        _ => None,
                    };
                    let (ra, rb) = (reg(&reg_of, *a), reg(&reg_of, *b));
                    let dst = allocate(&mut free);
                    reg_of[i] = Some(dst);
                    Some(match (constant(*a), constant(*b)) {
                        (None, Some(k)) => Instr::BinaryConstant {
                            op: *op,
                            dst,
                            a: ra,
                            k,
                            constant_first: false,
                        },
                        (Some(k), None) => Instr::BinaryConstant {
                            op: *op,
                            dst,
                            a: rb,
                            k,
                            constant_first: true,
                        },
                        _ => Instr::Binary {
                            op: *op,
                            dst,
                            a: ra,
                            b: rb,
                        },
                    })
                }
                Inst::Select([c, a, b]) => {
                    let (c, a, b) = (reg(&reg_of, *c), reg(&reg_of, *a), reg(&reg_of, *b));
                    let dst = allocate(&mut free);
                    reg_of[i] = Some(dst);
                    Some(Instr::Select { dst, c, a, b })
                }
                Inst::Kernel(kernel, args) => {
                    let arg_regs: Vec<Reg> = args.iter().map(|&a| reg(&reg_of, a)).collect();
                    let mut outs = vec![UNUSED; kernel.outputs()];
                    for &(index, out) in &outputs_of[i] {
                        if index < outs.len() {
                            let r = allocate(&mut free);
                            outs[index] = r;
                            reg_of[out as usize] = Some(r);
                        }
                    }
                    scratch_rows = scratch_rows.max(kernel.scratch_rows());
                    Some(Instr::Kernel {
                        kernel: kernel.clone(),
                        args: arg_regs,
                        outs,
                    })
                }
            };
            instrs.extend(instr);
            // Operands whose last reader this was go back to the pool; inputs and constants
            // keep their registers. Freed only after the destination was taken, so a
            // destination never aliases an operand.
            released.clear();
            for &c in inst.operands() {
                if last_use[c as usize] == Some(i) && !released.contains(&c) {
                    released.push(c);
                }
            }
            for &c in &released {
                if let Some(r) = reg_of[c as usize]
                    && r as usize >= first_temporary
                {
                    free.push(r);
                }
            }
            // Kernel outputs that nothing reads after the kernel are free at once.
            if let Inst::Kernel(..) = inst {
                for &(_, out) in &outputs_of[i] {
                    if last_use[out as usize].is_none()
                        && let Some(r) = reg_of[out as usize]
                    {
                        free.push(r);
                    }
                }
            }
        }
        let outputs: Vec<Reg> = ssa.roots.iter().map(|&r| reg(&reg_of, r)).collect();
        let emits = emit_schedule(&instrs, &outputs, registers);
        Program {
            instrs,
            registers,
            constants,
            outputs,
            emits,
            scratch_rows,
            nodes: count,
        }
    }
}

/// For each instruction, the other of a sine and a cosine of the same value, when the tape
/// has both (hash-consing leaves at most one of each per operand).
fn sin_cos_pairs(insts: &[Inst]) -> Vec<Option<Index>> {
    let mut partner = vec![None; insts.len()];
    let mut sine_of: Vec<Option<Index>> = vec![None; insts.len()];
    for (i, inst) in insts.iter().enumerate() {
        if let Inst::Unary(MathFn::Sin, [a]) = inst {
            sine_of[*a as usize] = Some(i as Index);
        }
    }
    for (j, inst) in insts.iter().enumerate() {
        if let Inst::Unary(MathFn::Cos, [a]) = inst
            && let Some(i) = sine_of[*a as usize]
        {
            partner[i as usize] = Some(j as Index);
            partner[j] = Some(i);
        }
    }
    partner
}

impl Instr {
    /// The registers this instruction writes.
    fn writes(&self) -> Vec<Reg> {
        match self {
            Instr::Unary { dst, .. }
            | Instr::Binary { dst, .. }
            | Instr::BinaryConstant { dst, .. }
            | Instr::Select { dst, .. } => {
                vec![*dst]
            }
            Instr::Kernel { outs, .. } => outs.clone(),
            Instr::SinCos { sin, cos, .. } => vec![*sin, *cos],
        }
    }
}

/// For each output, the last instruction writing its register: an output's register stays live
/// to the end of the tape, so that write is its final value.
fn emit_schedule(instrs: &[Instr], outputs: &[Reg], registers: usize) -> Vec<(usize, usize)> {
    let mut last_write: Vec<Option<usize>> = vec![None; registers];
    for (k, instr) in instrs.iter().enumerate() {
        for r in instr.writes() {
            if r != UNUSED {
                last_write[r as usize] = Some(k);
            }
        }
    }
    let mut emits: Vec<(usize, usize)> = outputs
        .iter()
        .enumerate()
        .map(|(c, &r)| (last_write[r as usize].unwrap_or(instrs.len()), c))
        .collect();
    emits.sort_unstable();
    emits
}
