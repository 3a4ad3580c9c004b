//! Pruning: a field's linear form specialised to one region of space.
//!
//! Over a small box most choices in a field are already made. The maximum of twenty-six
//! ellipsoid profiles is, in a brick that only one of them reaches, that one profile; a
//! `select` whose condition keeps one sign over the box is one of its branches. Interval
//! evaluation over the box says which: `max(a, b)` is `a` wherever `a`'s lowest value is above
//! `b`'s highest. Dropping the branch that cannot win, and everything only it reads, leaves a
//! shorter tape that gives the same values at every point of the box (in the manner of
//! Fidget's tape simplification).
//!
//! The one key decision: a choice is decided only when the intervals separate strictly, or
//! meet at a non-zero value. Two values meeting at zero may be `+0` and `−0`, and `max` of
//! those is not specified bit for bit, so keeping the choice there keeps every pruned value
//! identical to the unpruned tape's, not merely equal.

use crate::field::interval::Interval;
use crate::field::node::BinOp;
use crate::field::ssa::{Index, Inst, Ssa};

/// Whether every value of `a` is certainly at least every value of `b` (see the module notes
/// on zero).
fn at_least(a: Interval, b: Interval) -> bool {
    a.lo > b.hi || (a.lo == b.hi && a.lo != 0.0)
}

/// What a choice instruction reduces to over a region: the operand it certainly takes, if any.
fn decided(inst: &Inst, iv: &[Interval]) -> Option<Index> {
    let at = |i: Index| iv[i as usize];
    match inst {
        Inst::Binary(BinOp::Max, [a, b]) => {
            if at_least(at(*a), at(*b)) {
                Some(*a)
            } else if at_least(at(*b), at(*a)) {
                Some(*b)
            } else {
                None
            }
        }
        Inst::Binary(BinOp::Min, [a, b]) => {
            if at_least(at(*b), at(*a)) {
                Some(*a)
            } else if at_least(at(*a), at(*b)) {
                Some(*b)
            } else {
                None
            }
        }
        // The tape takes `a` where `c >= 0`; a NaN condition takes `b`, and an interval that
        // may hold NaN is never entirely non-negative.
        Inst::Select([c, a, b]) => {
            let c = at(*c);
            if c.lo >= 0.0 {
                Some(*a)
            } else if c.hi < 0.0 {
                Some(*b)
            } else {
                None
            }
        }
        _ => None,
    }
}

/// The choice instructions of `ssa` (max, min and select), in tape order: the only places a
/// region can shorten the tape.
pub fn choices(ssa: &Ssa) -> Vec<Index> {
    ssa.insts
        .iter()
        .enumerate()
        .filter(|(_, inst)| {
            matches!(
                inst,
                Inst::Binary(BinOp::Max | BinOp::Min, _) | Inst::Select(_)
            )
        })
        .map(|(i, _)| i as Index)
        .collect()
}

/// For each choice of `choices`, the operand it takes over the region whose instruction
/// intervals are `iv` (`Index::MAX` where the region does not decide it).
pub fn decisions(ssa: &Ssa, choices: &[Index], iv: &[Interval]) -> Vec<Index> {
    choices
        .iter()
        .map(|&c| decided(&ssa.insts[c as usize], iv).unwrap_or(Index::MAX))
        .collect()
}

/// The tape with each decided choice replaced by the operand it takes, and only what the roots
/// still read kept; `None` when no choice is decided (the tape is already as short as the
/// region allows).
pub fn pruned(ssa: &Ssa, choices: &[Index], decisions: &[Index]) -> Option<Ssa> {
    if decisions.iter().all(|&d| d == Index::MAX) {
        return None;
    }
    let count = ssa.insts.len();
    // Each instruction's stand-in: itself, or the operand a decided choice takes (which comes
    // earlier, so its own stand-in is already known).
    let mut stand_in: Vec<Index> = (0..count as Index).collect();
    for (&c, &d) in choices.iter().zip(decisions) {
        if d != Index::MAX {
            stand_in[c as usize] = stand_in[d as usize];
        }
    }
    // What the roots still read, walking the tape backwards.
    let mut live = vec![false; count];
    for &r in &ssa.roots {
        live[stand_in[r as usize] as usize] = true;
    }
    for i in (0..count).rev() {
        if live[i] && stand_in[i] as usize == i {
            for &operand in ssa.insts[i].operands() {
                live[stand_in[operand as usize] as usize] = true;
            }
        }
    }
    // The kept instructions, in their order, operands renumbered.
    let mut position = vec![Index::MAX; count];
    let mut insts = Vec::with_capacity(live.iter().filter(|&&l| l).count());
    for i in 0..count {
        if !live[i] || stand_in[i] as usize != i {
            continue;
        }
        let at = |operand: Index| position[stand_in[operand as usize] as usize];
        let inst = match &ssa.insts[i] {
            Inst::Const(c) => Inst::Const(*c),
            Inst::X => Inst::X,
            Inst::Y => Inst::Y,
            Inst::Z => Inst::Z,
            Inst::Unary(m, [a]) => Inst::Unary(*m, [at(*a)]),
            Inst::Binary(op, [a, b]) => Inst::Binary(*op, [at(*a), at(*b)]),
            Inst::Select([c, a, b]) => Inst::Select([at(*c), at(*a), at(*b)]),
            Inst::Kernel(k, args) => Inst::Kernel(k.clone(), args.iter().map(|&a| at(a)).collect()),
            Inst::Output([k], index) => Inst::Output([at(*k)], *index),
        };
        position[i] = insts.len() as Index;
        insts.push(inst);
    }
    let roots = ssa
        .roots
        .iter()
        .map(|&r| position[stand_in[r as usize] as usize])
        .collect();
    Some(Ssa { insts, roots })
}
