//! Conservative value ranges and supports of node graphs, by interval arithmetic.
//!
//! `ranges` evaluates every node once on a box of positions and returns an interval that
//! contains every value the roots take there (NaN-producing operations widen to the whole line).
//! `support` finds a box outside which a field is exactly zero: a structural pass first (a
//! product is zero where either factor is, a grid read of zero background is zero outside its
//! grid), then an octree search that discards boxes whose interval is exactly zero. The one key
//! decision: the search starts from ±1e5 units when the structure says nothing, keeps at most a
//! few thousand boxes per level, and stops refining when that budget would be exceeded, so it
//! always ends quickly with a bound that is conservative, if not always tight.

use crate::field::node::{BinOp, MathFn, NodeRef};
use crate::field::ssa::{Index, Inst, Ssa};
use crate::space::Aabb;
use glam::DVec3;
use std::sync::Arc;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    pub lo: f64,
    pub hi: f64,
}

pub(crate) const ALL: Interval = Interval {
    lo: f64::NEG_INFINITY,
    hi: f64::INFINITY,
};

impl Interval {
    pub fn new(lo: f64, hi: f64) -> Interval {
        if lo.is_nan() || hi.is_nan() || lo > hi {
            ALL
        } else {
            Interval { lo, hi }
        }
    }

    pub(crate) fn point(v: f64) -> Interval {
        Interval::new(v, v)
    }

    pub(crate) fn union(self, o: Interval) -> Interval {
        Interval::new(self.lo.min(o.lo), self.hi.max(o.hi))
    }

    pub fn is_zero(&self) -> bool {
        self.lo == 0.0 && self.hi == 0.0
    }

    fn mul(self, o: Interval) -> Interval {
        if self.is_zero() || o.is_zero() {
            return Interval::point(0.0);
        }
        let p = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        if p.iter().any(|v| v.is_nan()) {
            return ALL;
        }
        Interval::new(
            p.iter().cloned().fold(f64::INFINITY, f64::min),
            p.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
        )
    }

    /// `self / o`, from the quotients of the ends: each is rounded once, as the point
    /// division is, so the bounds are those of the values the tape computes. (A reciprocal
    /// times the dividend rounds twice and can land one unit in the last place inside.)
    fn div(self, o: Interval) -> Interval {
        if self.is_zero() {
            return Interval::point(0.0);
        }
        if !(o.lo > 0.0 || o.hi < 0.0) {
            return ALL;
        }
        let q = [
            self.lo / o.lo,
            self.lo / o.hi,
            self.hi / o.lo,
            self.hi / o.hi,
        ];
        Interval::spanning(&q)
    }

    /// The smallest interval holding `values`; everything if one is NaN.
    fn spanning(values: &[f64]) -> Interval {
        if values.iter().any(|v| v.is_nan()) {
            return ALL;
        }
        Interval::new(
            values.iter().copied().fold(f64::INFINITY, f64::min),
            values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    }

    fn monotone(self, f: impl Fn(f64) -> f64) -> Interval {
        Interval::new(f(self.lo), f(self.hi))
    }

    /// Wider by one unit in the last place at each non-zero finite end. The library's exp,
    /// ln, pow, sin and inverse trigonometric functions are accurate to within an ulp but not
    /// always correctly rounded, so a value inside the box may round one step past the value
    /// at its end; zeros (exp of -inf, ln 1, sin 0) are exact and stay.
    fn widened(self) -> Interval {
        let out = |v: f64, up: bool| match (v == 0.0 || !v.is_finite(), up) {
            (true, _) => v,
            (false, true) => v.next_up(),
            (false, false) => v.next_down(),
        };
        Interval::new(out(self.lo, false), out(self.hi, true))
    }

    fn clamped(self, lo: f64, hi: f64) -> Interval {
        Interval::new(self.lo.max(lo), self.hi.min(hi))
    }
}

/// Largest magnitude at which the narrow rule for sin and cos finds crests by arithmetic: the
/// crest `(k + 1/2)π` is then placed to within 1e-9, so its value is 1 to far below an ulp.
/// Farther out the crests computed in floating point drift from the true ones by whole
/// fractions of a period.
const NARROW_TRIG_REACH: f64 = 1048576.0;

fn unary(m: MathFn, a: Interval) -> Interval {
    match m {
        MathFn::Abs => {
            if a.lo >= 0.0 {
                a
            } else if a.hi <= 0.0 {
                Interval::new(-a.hi, -a.lo)
            } else {
                Interval::new(0.0, (-a.lo).max(a.hi))
            }
        }
        MathFn::Sqrt if a.lo >= 0.0 => a.monotone(f64::sqrt),
        MathFn::Exp => a.monotone(f64::exp).widened(),
        MathFn::Log if a.lo > 0.0 => a.monotone(f64::ln).widened(),
        MathFn::Sin | MathFn::Cos => {
            let reach = a.lo.abs().max(a.hi.abs());
            if a.hi - a.lo < 1.0 && reach < NARROW_TRIG_REACH {
                // Narrow: the extremes are at the ends or at a crest inside.
                let f = if m == MathFn::Sin { f64::sin } else { f64::cos };
                let mut r = Interval::new(f(a.lo).min(f(a.hi)), f(a.lo).max(f(a.hi)));
                let phase = if m == MathFn::Sin { 0.5 } else { 0.0 };
                let crest = |k: f64| (k + phase) * std::f64::consts::PI;
                let first = (a.lo / std::f64::consts::PI - phase).ceil();
                let mut k = first;
                while crest(k) <= a.hi {
                    r = r.union(Interval::point(f(crest(k))));
                    k += 1.0;
                }
                r.widened().clamped(-1.0, 1.0)
            } else {
                Interval::new(-1.0, 1.0)
            }
        }
        MathFn::Asin => a.clamped(-1.0, 1.0).monotone(f64::asin).widened(),
        MathFn::Acos => {
            let c = a.clamped(-1.0, 1.0);
            Interval::new(c.hi.acos(), c.lo.acos()).widened()
        }
        MathFn::Atan => a.monotone(f64::atan).widened(),
        MathFn::Floor => a.monotone(f64::floor),
        MathFn::Ceil => a.monotone(f64::ceil),
        MathFn::Fract => {
            if a.lo.floor() == a.hi.floor() && a.lo.is_finite() {
                Interval::new(a.lo - a.lo.floor(), a.hi - a.lo.floor())
            } else {
                Interval::new(0.0, 1.0)
            }
        }
        MathFn::Sign => a.monotone(|x| MathFn::Sign.apply(x)),
        MathFn::Step => a.monotone(|x| MathFn::Step.apply(x)),
        _ => ALL,
    }
}

fn binary(op: BinOp, a: Interval, b: Interval) -> Interval {
    match op {
        BinOp::Add => Interval::new(a.lo + b.lo, a.hi + b.hi),
        BinOp::Sub => Interval::new(a.lo - b.hi, a.hi - b.lo),
        BinOp::Mul => a.mul(b),
        BinOp::Div => a.div(b),
        BinOp::GuardedDiv => {
            let q = a.div(b);
            if b.lo <= 0.0 && b.hi >= 0.0 {
                // Zero is a possible value where the divisor vanishes.
                q.union(Interval::point(0.0))
            } else {
                q
            }
        }
        BinOp::Min => Interval::new(a.lo.min(b.lo), a.hi.min(b.hi)),
        BinOp::Max => Interval::new(a.lo.max(b.lo), a.hi.max(b.hi)),
        BinOp::Atan2 => Interval::point(std::f64::consts::PI)
            .widened()
            .union(Interval::point(-std::f64::consts::PI).widened()),
        BinOp::Pow => {
            if a.lo > 0.0 {
                // For x > 0, x^y is monotone in each argument, so its extremes over the box
                // are at the corners; `powf` there is what the tape computes.
                let corners = [
                    a.lo.powf(b.lo),
                    a.lo.powf(b.hi),
                    a.hi.powf(b.lo),
                    a.hi.powf(b.hi),
                ];
                Interval::spanning(&corners).widened()
            } else if b.lo == b.hi && b.lo.fract() == 0.0 && b.lo >= 0.0 {
                // A whole exponent, kept in floating point: its parity decides the shape
                // (an exponent of 2^31 or more does not fit an i32).
                let p = b.lo;
                let even = (p / 2.0).fract() == 0.0;
                let mut r = Interval::spanning(&[a.lo.powf(p), a.hi.powf(p)]);
                if even && a.lo < 0.0 && a.hi > 0.0 {
                    r = r.union(Interval::point(0.0));
                }
                r.widened()
            } else {
                ALL
            }
        }
    }
}

/// Intervals of `roots` over positions in `region`.
pub fn ranges(roots: &[NodeRef], region: &Aabb) -> Vec<Interval> {
    IntervalTape::new(roots).ranges(region)
}

/// A field's linear form ready for repeated interval evaluation: evaluating a box is one pass
/// over the instructions, each result stored at its instruction's index. Cache fills ask for
/// the range of every brick and the support search for thousands of boxes; neither should walk
/// and hash the graph each time.
#[derive(Clone, Debug)]
pub struct IntervalTape {
    ssa: Arc<Ssa>,
    /// For each kernel instruction, where its outputs' intervals start in the one list of all
    /// kernels' outputs, and how many it has; (0, 0) for other instructions. One list, sized
    /// once, rather than a list per kernel per region: fills ask for a range per brick.
    outputs_of: Vec<(u32, u32)>,
    kernel_outputs: usize,
}

impl IntervalTape {
    pub fn new(roots: &[NodeRef]) -> IntervalTape {
        IntervalTape::from_ssa(Arc::new(Ssa::new(roots)))
    }

    /// The tape of a linear form, sharing it.
    pub fn from_ssa(ssa: Arc<Ssa>) -> IntervalTape {
        let mut kernel_outputs = 0;
        let outputs_of = ssa
            .insts
            .iter()
            .map(|inst| match inst {
                Inst::Kernel(kernel, _) => {
                    let first = kernel_outputs as u32;
                    kernel_outputs += kernel.outputs();
                    (first, kernel.outputs() as u32)
                }
                _ => (0, 0),
            })
            .collect();
        IntervalTape {
            ssa,
            outputs_of,
            kernel_outputs,
        }
    }

    /// The linear form evaluated.
    pub fn ssa(&self) -> &Arc<Ssa> {
        &self.ssa
    }

    /// Intervals of the roots over positions in `region`.
    pub fn ranges(&self, region: &Aabb) -> Vec<Interval> {
        let iv = self.intervals(region);
        self.ssa.roots.iter().map(|&r| iv[r as usize]).collect()
    }

    /// Intervals of the roots over `region` as if every grid read held its outermost cells'
    /// values in the half-cell border (`GridSource::range_held`).
    pub fn ranges_held(&self, region: &Aabb) -> Vec<Interval> {
        let iv = self.intervals_of(region, true);
        self.ssa.roots.iter().map(|&r| iv[r as usize]).collect()
    }

    /// The interval of every instruction over positions in `region`, by instruction index
    /// (what `prune` decides choices by).
    pub fn intervals(&self, region: &Aabb) -> Vec<Interval> {
        self.intervals_of(region, false)
    }

    fn intervals_of(&self, region: &Aabb, held: bool) -> Vec<Interval> {
        let insts = &self.ssa.insts;
        let mut iv: Vec<Interval> = Vec::with_capacity(insts.len());
        let mut kernel_iv: Vec<Interval> = vec![ALL; self.kernel_outputs];
        for (i, inst) in insts.iter().enumerate() {
            let at = |k: Index| iv[k as usize];
            let r = match inst {
                Inst::Const(c) => Interval::point(*c),
                Inst::X => Interval::new(region.min.x, region.max.x),
                Inst::Y => Interval::new(region.min.y, region.max.y),
                Inst::Z => Interval::new(region.min.z, region.max.z),
                Inst::Unary(m, [a]) => unary(*m, at(*a)),
                Inst::Binary(op, [a, b]) => binary(*op, at(*a), at(*b)),
                Inst::Select([c, a, b]) => {
                    let c = at(*c);
                    if c.lo >= 0.0 {
                        at(*a)
                    } else if c.hi < 0.0 {
                        at(*b)
                    } else {
                        at(*a).union(at(*b))
                    }
                }
                Inst::Kernel(k, args) => {
                    debug_assert!(args.len() <= MOST_KERNEL_ARGS);
                    let mut arg_iv = [ALL; MOST_KERNEL_ARGS];
                    for (to, &a) in arg_iv.iter_mut().zip(args.iter()) {
                        *to = at(a);
                    }
                    let (first, count) = self.outputs_of[i];
                    let out = &mut kernel_iv[first as usize..(first + count) as usize];
                    k.ranges(&arg_iv[..args.len().min(MOST_KERNEL_ARGS)], held, out);
                    ALL
                }
                Inst::Output([k], index) => {
                    let (first, count) = self.outputs_of[*k as usize];
                    let index = *index as u32;
                    if index < count {
                        kernel_iv[(first + index) as usize]
                    } else {
                        ALL
                    }
                }
            };
            iv.push(r);
        }
        iv
    }
}

/// Most arguments a kernel takes (the pseudo-inverse's nine matrix entries).
const MOST_KERNEL_ARGS: usize = 9;

/// A box outside which every root is exactly zero, or `None` if no finite box was found.
pub fn support(roots: &[NodeRef]) -> Option<Aabb> {
    support_of(&IntervalTape::new(roots))
}

/// `support` of the field whose interval tape is `tape`.
pub fn support_of(tape: &IntervalTape) -> Option<Aabb> {
    let structural = structural_support(tape.ssa());
    let start = match structural {
        Some(b) if b.is_empty() => return Some(b),
        Some(b) if b.is_finite() => b,
        _ => Aabb::new(DVec3::splat(-1e5), DVec3::splat(1e5)),
    };
    let maybe_nonzero = |b: &Aabb| tape.ranges(b).iter().any(|r| !r.is_zero());
    if !maybe_nonzero(&start) {
        return Some(Aabb::new(DVec3::ZERO, DVec3::ZERO));
    }
    const BUDGET: usize = 4096;
    let mut boxes = vec![start];
    for _level in 0..40 {
        let mut next = Vec::with_capacity(boxes.len() * 8);
        for b in &boxes {
            let c = b.center();
            for octant in 0..8 {
                let pick = |bit: usize, axis: usize| {
                    if octant >> bit & 1 == 0 {
                        (b.min[axis], c[axis])
                    } else {
                        (c[axis], b.max[axis])
                    }
                };
                let (x, y, z) = (pick(0, 0), pick(1, 1), pick(2, 2));
                let child = Aabb::new(DVec3::new(x.0, y.0, z.0), DVec3::new(x.1, y.1, z.1));
                if maybe_nonzero(&child) {
                    next.push(child);
                }
            }
        }
        if next.len() > BUDGET {
            break;
        }
        let tight = union_of(&next);
        let size = tight.size().max_element();
        boxes = next;
        // Refining further only trims a shell thinner than 1/64 of the extent.
        if boxes[0].size().max_element() < size / 64.0 {
            break;
        }
    }
    let found = union_of(&boxes);
    if found.is_empty() || !found.is_finite() {
        None
    } else if structural.is_none() && reaches_edge(&found, &start) {
        // Nonzero up to the search's edge: the field may extend beyond it.
        None
    } else {
        Some(found)
    }
}

fn reaches_edge(found: &Aabb, start: &Aabb) -> bool {
    found.min.cmple(start.min).any() || found.max.cmpge(start.max).any()
}

fn union_of(boxes: &[Aabb]) -> Aabb {
    boxes.iter().fold(
        Aabb::new(DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |a, b| a.union(b),
    )
}

/// Supports known from the graph's shape alone. `None` means "everywhere".
fn structural_support(ssa: &Ssa) -> Option<Aabb> {
    let insts = &ssa.insts;
    let empty = Aabb::new(DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    let mut s: Vec<Option<Aabb>> = Vec::with_capacity(insts.len());
    let union = |a: Option<Aabb>, b: Option<Aabb>| match (a, b) {
        (Some(a), Some(b)) => Some(a.union(&b)),
        _ => None,
    };
    let is_position = |i: Index, axis: usize| {
        matches!(
            (&insts[i as usize], axis),
            (Inst::X, 0) | (Inst::Y, 1) | (Inst::Z, 2)
        )
    };
    for inst in insts {
        let get = |c: Index| s[c as usize];
        let r = match inst {
            Inst::Const(c) => (*c == 0.0).then_some(empty),
            Inst::X | Inst::Y | Inst::Z => None,
            Inst::Unary(m, [a]) => match m {
                MathFn::Abs
                | MathFn::Sqrt
                | MathFn::Sin
                | MathFn::Tan
                | MathFn::Asin
                | MathFn::Atan
                | MathFn::Sign => get(*a),
                _ => None,
            },
            Inst::Binary(op, [a, b]) => match op {
                BinOp::Mul => match (get(*a), get(*b)) {
                    (Some(x), Some(y)) => Some(x.intersection(&y)),
                    (Some(x), None) | (None, Some(x)) => Some(x),
                    (None, None) => None,
                },
                BinOp::Div | BinOp::GuardedDiv => get(*a),
                BinOp::Add | BinOp::Sub | BinOp::Min | BinOp::Max => union(get(*a), get(*b)),
                _ => None,
            },
            Inst::Select([_, a, b]) => union(get(*a), get(*b)),
            Inst::Kernel(..) => None,
            Inst::Output([k], i) => match &insts[*k as usize] {
                Inst::Kernel(k, args) => match k.grid_read() {
                    Some(read)
                        if read.is_value()
                            && (0..3).all(|a| is_position(args[a], a))
                            && read.grid().background().get(*i as usize) == Some(&0.0) =>
                    {
                        Some(read.grid().bounds())
                    }
                    _ => None,
                },
                _ => None,
            },
        };
        s.push(r);
    }
    ssa.roots
        .iter()
        .map(|&r| s[r as usize])
        .reduce(union)
        .flatten()
}
