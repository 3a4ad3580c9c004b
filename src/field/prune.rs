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
//! The one key decision: a choice is decided only when the intervals separate strictly, meet
//! at a non-zero value, or meet at zero where neither operand can be `−0`. `max` of `+0` and
//! `−0` is not specified bit for bit, so a choice between values that may be zeros of either
//! sign is kept, and every pruned value stays identical to the unpruned tape's, not merely
//! equal. Which values can never be `−0` follows from a pass of simple rules (a constant `+0`,
//! `1 − √s`, `max(p, 0)`: the shapes of profiles and masks), so the maximum of many
//! `max(profile, 0)` terms does prune where only one of them reaches.

use crate::field::interval::Interval;
use crate::field::node::{BinOp, MathFn};
use crate::field::ssa::{Index, Inst, Ssa};

/// Whether every value of `a` is certainly at least every value of `b`, so that `max(a, b)`
/// is `a` bit for bit; `unsigned` says that neither can be `−0` (see the module notes).
fn at_least(a: Interval, b: Interval, unsigned: bool) -> bool {
    a.lo > b.hi || (a.lo == b.hi && (a.lo != 0.0 || unsigned))
}

/// For each instruction, whether its value is certainly never `−0` over the region whose
/// instruction intervals are `iv` (NaN is not `−0`; an interval that may hold NaN is the whole
/// line, so `lo > 0` and `hi < 0` exclude it).
fn never_negative_zero(ssa: &Ssa, iv: &[Interval]) -> Vec<bool> {
    let mut never: Vec<bool> = Vec::with_capacity(ssa.insts.len());
    for inst in &ssa.insts {
        let n = |i: &Index| never[*i as usize];
        let at = |i: &Index| iv[*i as usize];
        let value = match inst {
            Inst::Const(c) => !(*c == 0.0 && c.is_sign_negative()),
            Inst::Unary(MathFn::Abs | MathFn::Exp, _) => true,
            Inst::Unary(MathFn::Sqrt, [a]) => n(a),
            // A zero sum is −0 only when both terms are −0; `a − b` only when `a` is.
            Inst::Binary(BinOp::Add, [a, b]) => n(a) || n(b),
            Inst::Binary(BinOp::Sub, [a, _]) => n(a),
            // A product of non-negative factors, neither −0, is +0 or positive (underflow too).
            Inst::Binary(BinOp::Mul, [a, b]) => n(a) && n(b) && at(a).lo >= 0.0 && at(b).lo >= 0.0,
            Inst::Binary(BinOp::Max, [a, b]) => (n(a) && n(b)) || at(a).lo > 0.0 || at(b).lo > 0.0,
            Inst::Binary(BinOp::Min, [a, b]) => (n(a) && n(b)) || at(a).hi < 0.0 || at(b).hi < 0.0,
            Inst::Select([_, a, b]) => n(a) && n(b),
            _ => false,
        };
        never.push(value);
    }
    never
}

/// What a choice instruction reduces to over a region: the operand it certainly takes, if any.
fn decided(inst: &Inst, iv: &[Interval], never_negative_zero: &[bool]) -> Option<Index> {
    let at = |i: Index| iv[i as usize];
    let unsigned =
        |a: Index, b: Index| never_negative_zero[a as usize] && never_negative_zero[b as usize];
    match inst {
        Inst::Binary(BinOp::Max, [a, b]) => {
            if at_least(at(*a), at(*b), unsigned(*a, *b)) {
                Some(*a)
            } else if at_least(at(*b), at(*a), unsigned(*a, *b)) {
                Some(*b)
            } else {
                None
            }
        }
        Inst::Binary(BinOp::Min, [a, b]) => {
            if at_least(at(*b), at(*a), unsigned(*a, *b)) {
                Some(*a)
            } else if at_least(at(*a), at(*b), unsigned(*a, *b)) {
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
    let never = never_negative_zero(ssa, iv);
    choices
        .iter()
        .map(|&c| decided(&ssa.insts[c as usize], iv, &never).unwrap_or(Index::MAX))
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
