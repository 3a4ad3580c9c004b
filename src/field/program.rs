//! Compilation of a node graph into a flat register program (a tape).
//!
//! The reachable nodes are put in dependency order and each becomes one instruction that works
//! on whole blocks of points: one register holds `BLOCK` values, one per point. Interpreting an
//! instruction therefore costs one dispatch per block, and its inner loop runs over contiguous
//! lanes that the compiler vectorises. The one key decision: registers are reused as soon as
//! the last reader of a value has run (linear scan over the tape), with the destination of an
//! instruction always distinct from its operands; that keeps the working set of a deep graph in
//! a few hundred kilobytes per thread, inside the cache, however many nodes it has.

use crate::field::node::{self, BinOp, Kernel, MathFn, NodeRef, Op};
use crate::field::noise::NoiseKind;
use crate::sample::{GridSource, Interp};
use std::collections::HashMap;
use std::sync::Arc;

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
    Select {
        dst: Reg,
        c: Reg,
        a: Reg,
        b: Reg,
    },
    Noise {
        kind: NoiseKind,
        seed: u32,
        at: [Reg; 3],
        outs: [Reg; 10],
    },
    Grid {
        grid: Arc<dyn GridSource>,
        interp: Interp,
        gradient: bool,
        at: [Reg; 3],
        outs: Vec<Reg>,
    },
    PseudoInverse {
        m: [Reg; 9],
        outs: [Reg; 9],
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
    /// The widest grid read (components × 3 for gradients), for scratch space.
    pub grid_scratch: usize,
    /// Number of graph nodes compiled (for summaries).
    pub nodes: usize,
}

impl Program {
    pub fn compile(roots: &[NodeRef]) -> Program {
        let order = node::postorder(roots);
        // Where each value is read for the last time (in tape order). Outputs of kernels are
        // "defined" at their kernel, so they are found through the kernel's users.
        let mut last_use: HashMap<u64, usize> = HashMap::new();
        let mut outputs_of: HashMap<u64, Vec<(usize, u64)>> = HashMap::new();
        for (i, n) in order.iter().enumerate() {
            match &n.op {
                Op::Output(k, index) => {
                    outputs_of
                        .entry(k.id)
                        .or_default()
                        .push((*index as usize, n.id));
                }
                _ => {
                    for c in n.children() {
                        last_use.insert(c.id, i);
                    }
                }
            }
        }
        for r in roots {
            last_use.insert(r.id, usize::MAX);
        }

        let mut reg_of: HashMap<u64, Reg> = HashMap::new();
        let mut constants = Vec::new();
        let mut registers: usize = 3;
        for n in &order {
            match &n.op {
                Op::X => {
                    reg_of.insert(n.id, 0);
                }
                Op::Y => {
                    reg_of.insert(n.id, 1);
                }
                Op::Z => {
                    reg_of.insert(n.id, 2);
                }
                Op::Const(c) => {
                    reg_of.insert(n.id, registers as Reg);
                    constants.push((registers as Reg, *c));
                    registers += 1;
                }
                _ => {}
            }
        }

        let mut free: Vec<Reg> = Vec::new();
        let mut allocate = |free: &mut Vec<Reg>| -> Reg {
            free.pop().unwrap_or_else(|| {
                registers += 1;
                (registers - 1) as Reg
            })
        };
        let mut instrs = Vec::new();
        let mut grid_scratch = 0;
        for (i, n) in order.iter().enumerate() {
            let instr = match &n.op {
                Op::X | Op::Y | Op::Z | Op::Const(_) | Op::Output(..) => continue,
                Op::Unary(f, a) => {
                    let a = reg_of[&a.id];
                    let dst = allocate(&mut free);
                    reg_of.insert(n.id, dst);
                    Instr::Unary { f: *f, dst, a }
                }
                Op::Binary(op, a, b) => {
                    let (a, b) = (reg_of[&a.id], reg_of[&b.id]);
                    let dst = allocate(&mut free);
                    reg_of.insert(n.id, dst);
                    Instr::Binary { op: *op, dst, a, b }
                }
                Op::Select(c, a, b) => {
                    let (c, a, b) = (reg_of[&c.id], reg_of[&a.id], reg_of[&b.id]);
                    let dst = allocate(&mut free);
                    reg_of.insert(n.id, dst);
                    Instr::Select { dst, c, a, b }
                }
                Op::Kernel(kernel, args) => {
                    let arg_regs: Vec<Reg> = args.iter().map(|a| reg_of[&a.id]).collect();
                    let mut outs = vec![UNUSED; kernel.outputs()];
                    for (index, out_id) in outputs_of.get(&n.id).into_iter().flatten() {
                        if *index < outs.len() {
                            let r = allocate(&mut free);
                            outs[*index] = r;
                            reg_of.insert(*out_id, r);
                        }
                    }
                    let at = || [arg_regs[0], arg_regs[1], arg_regs[2]];
                    match kernel {
                        Kernel::Noise { kind, seed } => Instr::Noise {
                            kind: *kind,
                            seed: *seed,
                            at: at(),
                            outs: outs.try_into().unwrap_or([UNUSED; 10]),
                        },
                        Kernel::GridValue { grid, interp, .. }
                        | Kernel::GridGradient { grid, interp } => {
                            let gradient = matches!(kernel, Kernel::GridGradient { .. });
                            grid_scratch = grid_scratch.max(kernel.outputs());
                            Instr::Grid {
                                grid: grid.clone(),
                                interp: *interp,
                                gradient,
                                at: at(),
                                outs,
                            }
                        }
                        Kernel::PseudoInverse => Instr::PseudoInverse {
                            m: std::array::from_fn(|k| arg_regs[k]),
                            outs: outs.try_into().unwrap_or([UNUSED; 9]),
                        },
                    }
                }
            };
            instrs.push(instr);
            // Operands whose last reader this was go back to the pool; inputs and constants
            // keep their registers. Freed only after the destination was taken, so a
            // destination never aliases an operand.
            let mut released: Vec<u64> = Vec::new();
            for c in n.children() {
                if last_use.get(&c.id) == Some(&i) && !released.contains(&c.id) {
                    released.push(c.id);
                }
            }
            for id in released {
                if let Some(&r) = reg_of.get(&id)
                    && r as usize >= 3
                    && !constants.iter().any(|(cr, _)| *cr == r)
                {
                    free.push(r);
                }
            }
            // Kernel outputs that nothing reads after the kernel are free at once.
            if let Op::Kernel(..) = &n.op {
                for (_, out_id) in outputs_of.get(&n.id).into_iter().flatten() {
                    if !last_use.contains_key(out_id)
                        && let Some(&r) = reg_of.get(out_id)
                    {
                        free.push(r);
                    }
                }
            }
        }
        let outputs: Vec<Reg> = roots.iter().map(|r| reg_of[&r.id]).collect();
        let emits = emit_schedule(&instrs, &outputs);
        Program {
            instrs,
            registers,
            constants,
            outputs,
            emits,
            grid_scratch,
            nodes: order.len(),
        }
    }
}

impl Instr {
    /// The registers this instruction writes.
    fn writes(&self) -> Vec<Reg> {
        match self {
            Instr::Unary { dst, .. } | Instr::Binary { dst, .. } | Instr::Select { dst, .. } => {
                vec![*dst]
            }
            Instr::Noise { outs, .. } => outs.to_vec(),
            Instr::Grid { outs, .. } => outs.clone(),
            Instr::PseudoInverse { outs, .. } => outs.to_vec(),
        }
    }
}

/// For each output, the last instruction writing its register: an output's register stays live
/// to the end of the tape, so that write is its final value.
fn emit_schedule(instrs: &[Instr], outputs: &[Reg]) -> Vec<(usize, usize)> {
    let mut last_write: HashMap<Reg, usize> = HashMap::new();
    for (k, instr) in instrs.iter().enumerate() {
        for r in instr.writes() {
            if r != UNUSED {
                last_write.insert(r, k);
            }
        }
    }
    let mut emits: Vec<(usize, usize)> = outputs
        .iter()
        .enumerate()
        .map(|(c, r)| (last_write.get(r).copied().unwrap_or(instrs.len()), c))
        .collect();
    emits.sort_unstable();
    emits
}
