//! Op-consistency tests: every math function, binary operation and kernel of the field engine
//! is defined three times — constant folding (`node`), the point tape (`eval`) and interval
//! ranges (`interval`) — and these tests check, op by op, that the three agree.
//!
//! The one key decision: the tables are written as exhaustive matches over the op enums
//! (`every_math_fn`, `every_bin_op`, `every_kernel_kind`), so a new node kind that is not added
//! here fails to compile instead of going untested. Inputs are seeded and deterministic; boxes
//! are drawn to straddle poles, zeros of divisors, integers, crests of sin and cos, and to sit
//! at huge magnitudes, and each box is sampled at its ends, at the special points inside it
//! and at random points between. A NaN point value is not checked against its interval: the
//! engine's algebra assumes finite values (it folds `0 · a` to 0), and an interval cannot
//! contain NaN.
//!
//! Precision, as stated by the engine (`eval`): every register is `f64`; only noise has an
//! `f32` path (offsets from an `f64` block base). So "f32 against f64" is checked as: a tape
//! without noise gives bit-identical values in both precisions, and noise in `f32` is within
//! the stated bounds of its `f64` reference.

use crate::field::eval::{Evaluator, Precision};
use crate::field::interval::{Interval, IntervalTape};
use crate::field::node::{self, BinOp, Kernel, MathFn, NodeRef};
use crate::field::noise::NoiseKind;
use crate::field::program::Program;
use crate::field::{CompiledField, Field};
use crate::grid::cache::{BRICK, Cache};
use crate::grid::domain::Domain;
use crate::sample::{Aabb, BLOCK, FieldSampler, GridDerivative, GridSource, Interp};
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::Arc;

/// Every math function; the match makes adding one without a test a compile error.
fn every_math_fn() -> Vec<MathFn> {
    let all = [
        MathFn::Abs,
        MathFn::Sqrt,
        MathFn::Exp,
        MathFn::Log,
        MathFn::Sin,
        MathFn::Cos,
        MathFn::Tan,
        MathFn::Asin,
        MathFn::Acos,
        MathFn::Atan,
        MathFn::Floor,
        MathFn::Ceil,
        MathFn::Fract,
        MathFn::Sign,
        MathFn::Step,
    ];
    for m in all {
        match m {
            MathFn::Abs
            | MathFn::Sqrt
            | MathFn::Exp
            | MathFn::Log
            | MathFn::Sin
            | MathFn::Cos
            | MathFn::Tan
            | MathFn::Asin
            | MathFn::Acos
            | MathFn::Atan
            | MathFn::Floor
            | MathFn::Ceil
            | MathFn::Fract
            | MathFn::Sign
            | MathFn::Step => {}
        }
    }
    all.to_vec()
}

/// Every binary operation; exhaustive as above.
fn every_bin_op() -> Vec<BinOp> {
    let all = [
        BinOp::Add,
        BinOp::Sub,
        BinOp::Mul,
        BinOp::Div,
        BinOp::GuardedDiv,
        BinOp::Pow,
        BinOp::Atan2,
        BinOp::Min,
        BinOp::Max,
    ];
    for op in all {
        match op {
            BinOp::Add
            | BinOp::Sub
            | BinOp::Mul
            | BinOp::Div
            | BinOp::GuardedDiv
            | BinOp::Pow
            | BinOp::Atan2
            | BinOp::Min
            | BinOp::Max => {}
        }
    }
    all.to_vec()
}

/// The kernels with a range rule narrower than "anything", and how they are covered here.
/// Exhaustive over `Kernel`, so a new kernel must say where its range is tested.
fn every_kernel_kind(k: &Kernel) -> &'static str {
    match k {
        Kernel::Noise { .. } => "noise_ranges_contain_both_precisions",
        Kernel::GridValue { .. } => "grid_read_ranges_contain_every_value",
        // Both default to "anything" (no rule to check).
        Kernel::GridGradient { .. } | Kernel::PseudoInverse => "range is everything",
    }
}

use crate::test_random::SplitMix as Rng;

/// Values of `roots` at `points`, root-major: `[root][point]`.
fn tape(roots: &[NodeRef], points: &[[f64; 3]], precision: Precision) -> Vec<Vec<f64>> {
    let program = Program::compile(roots);
    let mut evaluator = Evaluator::new(&program);
    let mut out = vec![Vec::with_capacity(points.len()); roots.len()];
    for block in points.chunks(BLOCK) {
        let axis = |a: usize| block.iter().map(|p| p[a]).collect::<Vec<f64>>();
        evaluator.run(&axis(0), &axis(1), &axis(2), precision);
        for (c, values) in out.iter_mut().enumerate() {
            values.extend_from_slice(evaluator.output(c, block.len()));
        }
    }
    out
}

/// Same value: equal bits, or both NaN (payloads may differ).
fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

const INF: f64 = f64::INFINITY;

/// Inputs where functions change behaviour: signed zeros, ±1, poles and crests, subnormals,
/// huge and infinite values, NaN.
const SPECIAL: [f64; 30] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    -0.5,
    2.0,
    -2.0,
    3.0,
    0.1,
    -2.5,
    7.25,
    FRAC_PI_2,
    -FRAC_PI_2,
    PI,
    1.0 - f64::EPSILON,
    1e-310,
    -1e-310,
    1e-5,
    1e10,
    -1e10,
    9.007_199_254_740_993e15,
    1e20,
    1e300,
    -1e300,
    f64::MAX,
    INF,
    -INF,
    f64::NAN,
    4.5e15,
];

#[test]
fn kernels_have_a_range_rule_or_none() {
    // The table names where each kernel's range is tested.
    let kernels = [
        Kernel::Noise {
            kind: NoiseKind::Perlin,
            seed: 0,
        },
        Kernel::PseudoInverse,
    ];
    for k in &kernels {
        assert!(!every_kernel_kind(k).is_empty());
    }
}

#[test]
fn folding_a_math_fn_gives_the_tape_value() {
    let x = node::position(0);
    for m in every_math_fn() {
        let values = tape(
            &[node::unary(m, x.clone())],
            &SPECIAL.map(|v| [v, 0.0, 0.0]),
            Precision::Double,
        );
        for (i, &v) in SPECIAL.iter().enumerate() {
            let folded = node::unary(m, node::constant(v)).constant().unwrap();
            assert!(
                same(folded, values[0][i]),
                "{m:?}({v:e}): folded {folded:e}, tape {:e}",
                values[0][i]
            );
        }
    }
}

#[test]
fn folding_a_binary_op_gives_the_tape_value() {
    let (x, y) = (node::position(0), node::position(1));
    let pairs: Vec<[f64; 3]> = SPECIAL
        .iter()
        .flat_map(|&a| SPECIAL.iter().map(move |&b| [a, b, 0.0]))
        .collect();
    for op in every_bin_op() {
        let values = tape(
            &[node::binary(op, x.clone(), y.clone())],
            &pairs,
            Precision::Double,
        );
        for (p, &v) in pairs.iter().zip(&values[0]) {
            let folded = node::binary(op, node::constant(p[0]), node::constant(p[1]))
                .constant()
                .unwrap();
            // min and max of +0 and -0 may return either: commuted operands are one node.
            let either_zero = matches!(op, BinOp::Min | BinOp::Max) && folded == 0.0 && v == 0.0;
            assert!(
                same(folded, v) || either_zero,
                "{op:?}({:e}, {:e}): folded {folded:e}, tape {v:e}",
                p[0],
                p[1]
            );
        }
    }
}

/// The identities `node::binary` applies when one operand is a constant or both are the same
/// node hold for finite values: `a·0 = 0`, `a/2ᵏ = a·2⁻ᵏ`, `a^2 = a·a`, `a − a = 0`, ...
/// Checked against the folded value. The one documented departure: `0 / y` is 0 also where
/// `y = 0`, as the derivative rules need (IEEE gives NaN there).
#[test]
fn simplified_forms_give_the_folded_value_for_finite_operands() {
    let (x, y) = (node::position(0), node::position(1));
    let finite: Vec<f64> = SPECIAL.iter().copied().filter(|v| v.is_finite()).collect();
    let constants = [0.0, 1.0, -1.0, 2.0, 0.5, 0.25, 4.0, 3.0, -8.0];
    for op in every_bin_op() {
        for &c in &constants {
            let left = node::binary(op, node::constant(c), y.clone());
            let right = node::binary(op, x.clone(), node::constant(c));
            let points: Vec<[f64; 3]> = finite.iter().map(|&v| [v, v, 0.0]).collect();
            let got = tape(&[left, right], &points, Precision::Double);
            for (i, &v) in finite.iter().enumerate() {
                for (side, (a, b)) in [(0, (c, v)), (1, (v, c))] {
                    let expected = op.apply(a, b);
                    let got = got[side][i];
                    let departs = matches!(op, BinOp::Div) && a == 0.0 && b == 0.0;
                    // `a · 0` is +0 for negative `a` too: the sign of a zero is not kept.
                    let agrees = same(expected, got) || (expected == 0.0 && got == 0.0);
                    // Products that overflow are ±inf whichever way they are computed, but
                    // only when the simplified form computes the same thing.
                    let overflow = !expected.is_finite();
                    assert!(
                        agrees || departs || (overflow && !got.is_finite()),
                        "{op:?}({a:e}, {b:e}) simplified: {got:e}, expected {expected:e}"
                    );
                }
            }
        }
        // Both operands the same node: `a + a = 2a`, `a - a = 0`, `min(a, a) = a`.
        let both = node::binary(op, x.clone(), x.clone());
        let points: Vec<[f64; 3]> = finite.iter().map(|&v| [v, 0.0, 0.0]).collect();
        let got = tape(&[both], &points, Precision::Double);
        for (i, &v) in finite.iter().enumerate() {
            let expected = op.apply(v, v);
            let g = got[0][i];
            let agrees = same(expected, g) || (expected == 0.0 && g == 0.0);
            let departs = matches!(op, BinOp::Div) && v == 0.0;
            assert!(
                agrees || departs,
                "{op:?}({v:e}, {v:e}): {g:e} vs {expected:e}"
            );
        }
    }
    // The documented departure, so that it stays documented.
    let zero_over = node::binary(BinOp::Div, node::constant(0.0), y.clone());
    assert_eq!(zero_over.constant(), Some(0.0));
}

#[test]
fn select_folds_and_evaluates_alike() {
    let (x, y, z) = (node::position(0), node::position(1), node::position(2));
    let sel = node::select(x.clone(), y.clone(), z.clone());
    let points: Vec<[f64; 3]> = SPECIAL.iter().map(|&c| [c, 1.0, 2.0]).collect();
    let got = tape(&[sel], &points, Precision::Double);
    for (i, &c) in SPECIAL.iter().enumerate() {
        let folded = node::select(node::constant(c), node::constant(1.0), node::constant(2.0))
            .constant()
            .unwrap();
        assert!(
            same(folded, got[0][i]),
            "select({c:e}): {folded} vs {}",
            got[0][i]
        );
    }
}

/// A tape without noise runs entirely in `f64`, so both precisions give the same bits.
#[test]
fn precision_changes_nothing_but_noise() {
    let (x, y) = (node::position(0), node::position(1));
    let mut roots: Vec<NodeRef> = every_math_fn()
        .into_iter()
        .map(|m| node::unary(m, x.clone()))
        .collect();
    roots.extend(
        every_bin_op()
            .into_iter()
            .map(|op| node::binary(op, x.clone(), y.clone())),
    );
    let mut rng = Rng(7);
    let points: Vec<[f64; 3]> = (0..600)
        .map(|_| [rng.range(-4.0, 4.0), rng.range(-4.0, 4.0), 0.0])
        .collect();
    let single = tape(&roots, &points, Precision::Single);
    let double = tape(&roots, &points, Precision::Double);
    for (r, (s, d)) in single.iter().zip(&double).enumerate() {
        for (i, (a, b)) in s.iter().zip(d).enumerate() {
            assert!(same(*a, *b), "root {r} at {:?}: {a:e} vs {b:e}", points[i]);
        }
    }
}

/// Noise in `f32` offsets against its `f64` reference. Stated bounds: the value within 2e-6
/// (about 16 ulps of f32 at 1), the gradient within 2e-5 and the Hessian within 5e-4 per
/// component, near the origin and 1e5 units away, where the f64 base keeps the lattice exact.
#[test]
fn noise_in_single_precision_is_within_its_stated_bounds() {
    const BOUNDS: [f64; 3] = [2e-6, 2e-5, 5e-4];
    let mut rng = Rng(11);
    for kind in [NoiseKind::Perlin, NoiseKind::Simplex, NoiseKind::Worley] {
        let roots: Vec<NodeRef> = (0..10)
            .map(|i| {
                node::kernel_output(
                    Kernel::Noise { kind, seed: 3 },
                    (0..3).map(node::position).collect(),
                    i,
                )
            })
            .collect();
        let mut worst = [0f64; 3];
        for far in [0.0, 1e5] {
            for _ in 0..8 {
                let base = DVec3::new(rng.range(-9.0, 9.0), rng.range(-9.0, 9.0), 0.0) + far;
                let points: Vec<[f64; 3]> = (0..BLOCK)
                    .map(|_| {
                        let p = base + DVec3::new(rng.unit(), rng.unit(), rng.unit()) * 2.0;
                        p.to_array()
                    })
                    .collect();
                let single = tape(&roots, &points, Precision::Single);
                let double = tape(&roots, &points, Precision::Double);
                for out in 0..10 {
                    let group = match out {
                        0 => 0,
                        1..=3 => 1,
                        _ => 2,
                    };
                    for (s, d) in single[out].iter().zip(&double[out]) {
                        // Worley's F1 has kinks and jumps in its derivatives where the
                        // nearest feature point changes; compare values only there.
                        if kind == NoiseKind::Worley && group > 0 {
                            continue;
                        }
                        worst[group] = worst[group].max((s - d).abs());
                    }
                }
            }
        }
        for g in 0..3 {
            assert!(
                worst[g] <= BOUNDS[g],
                "{kind:?}: output group {g} differs by {:e} > {:e}",
                worst[g],
                BOUNDS[g]
            );
        }
    }
}

/// An interval to evaluate a rule on: random, straddling a special point, huge, a point, or
/// reaching infinity.
fn draw_interval(rng: &mut Rng, specials: &[f64]) -> (f64, f64) {
    let (lo, hi) = match rng.below(7) {
        0 => {
            let c = rng.range(-10.0, 10.0);
            let w = 10f64.powf(rng.range(-6.0, 1.0));
            (c - w * rng.unit(), c + w * rng.unit())
        }
        1 | 2 => {
            let s = specials[rng.below(specials.len())];
            let w = 10f64.powf(rng.range(-12.0, 0.5));
            match rng.below(4) {
                0 => (s, s),
                1 => (s - w, s),
                2 => (s, s + w),
                _ => (s - w * rng.unit(), s + w * rng.unit()),
            }
        }
        3 => {
            let c = rng.sign() * 10f64.powf(rng.range(5.0, 300.0));
            let w = c.abs() * 10f64.powf(rng.range(-17.0, 0.0));
            (c - w * rng.unit(), c + w * rng.unit())
        }
        4 => {
            let v = rng.sign() * 10f64.powf(rng.range(-8.0, 20.0));
            (v, v)
        }
        5 => {
            let a = rng.range(-3.0, 3.0);
            let b = rng.range(-3.0, 3.0);
            (a.min(b), a.max(b))
        }
        _ => match rng.below(4) {
            0 => (-INF, INF),
            1 => (rng.range(-2.0, 2.0), INF),
            2 => (-INF, rng.range(-2.0, 2.0)),
            _ => (1e308, INF),
        },
    };
    (lo.min(hi), lo.max(hi))
}

/// Points of `[lo, hi]` to check: the ends, their neighbours inside, the special points inside,
/// and random points between.
fn samples_of(rng: &mut Rng, (lo, hi): (f64, f64), specials: &[f64], random: usize) -> Vec<f64> {
    let mut s = vec![lo, hi, lo.next_up().min(hi), hi.next_down().max(lo)];
    s.extend(specials.iter().copied().filter(|&v| lo <= v && v <= hi));
    for _ in 0..random {
        let t = rng.unit();
        // Written so that no intermediate overflows at huge magnitudes.
        let v = lo * (1.0 - t) + hi * t;
        if v.is_finite() && lo <= v && v <= hi {
            s.push(v);
        }
    }
    s.retain(|v| v.is_finite() || *v == lo || *v == hi);
    s
}

/// Special points of the one-argument rules: poles, crests and zeros of sin, cos and tan,
/// integers (floor, ceil, fract, sign), the ends of asin and acos's domain.
fn unary_specials() -> Vec<f64> {
    let mut s = vec![0.0, -0.0, 1.0, -1.0, 2.0, -2.0, 0.5, 1e-300, -1e-300];
    for k in -6..=6 {
        s.push(k as f64 * FRAC_PI_2);
    }
    s
}

/// Checks `value` at `at` against the interval, with a readable message.
fn assert_contains(what: &str, iv: Interval, value: f64, at: &dyn std::fmt::Debug) {
    if value.is_nan() {
        return;
    }
    assert!(
        iv.lo <= value && value <= iv.hi,
        "{what} at {at:?} = {value:e}, outside its interval [{:e}, {:e}]",
        iv.lo,
        iv.hi
    );
}

fn region(x: (f64, f64), y: (f64, f64), z: (f64, f64)) -> Aabb {
    Aabb::new(DVec3::new(x.0, y.0, z.0), DVec3::new(x.1, y.1, z.1))
}

/// Boxes per op in the interval tests: enough to hit every category many times, few enough to
/// keep the suite to seconds.
const BOXES: usize = 3000;

#[test]
fn math_fn_ranges_contain_every_sampled_value() {
    let specials = unary_specials();
    let x = node::position(0);
    for m in every_math_fn() {
        let root = node::unary(m, x.clone());
        let intervals = IntervalTape::new(std::slice::from_ref(&root));
        let mut rng = Rng(0x5eed ^ m as u64);
        let mut boxes = Vec::new();
        let mut points = Vec::new();
        for _ in 0..BOXES {
            let ix = draw_interval(&mut rng, &specials);
            let iv = intervals.ranges(&region(ix, (0.0, 0.0), (0.0, 0.0)))[0];
            for v in samples_of(&mut rng, ix, &specials, 6) {
                boxes.push((ix, iv));
                points.push([v, 0.0, 0.0]);
            }
        }
        let values = tape(std::slice::from_ref(&root), &points, Precision::Double);
        for ((ix, iv), (p, v)) in boxes.iter().zip(points.iter().zip(&values[0])) {
            assert_contains(
                &format!("{m:?} over [{:e}, {:e}]", ix.0, ix.1),
                *iv,
                *v,
                &p[0],
            );
        }
    }
}

#[test]
fn binary_op_ranges_contain_every_sampled_value() {
    let specials = unary_specials();
    let (x, y) = (node::position(0), node::position(1));
    for op in every_bin_op() {
        let root = node::binary(op, x.clone(), y.clone());
        let intervals = IntervalTape::new(std::slice::from_ref(&root));
        let mut rng = Rng(0xb1 ^ (op as u64) << 8);
        let mut boxes = Vec::new();
        let mut points = Vec::new();
        for _ in 0..BOXES {
            let (ix, iy) = (
                draw_interval(&mut rng, &specials),
                draw_interval(&mut rng, &specials),
            );
            let iv = intervals.ranges(&region(ix, iy, (0.0, 0.0)))[0];
            let xs = samples_of(&mut rng, ix, &specials, 3);
            let ys = samples_of(&mut rng, iy, &specials, 3);
            for &a in &xs {
                for &b in &ys {
                    boxes.push((ix, iy, iv));
                    points.push([a, b, 0.0]);
                }
            }
        }
        let values = tape(std::slice::from_ref(&root), &points, Precision::Double);
        for ((ix, iy, iv), (p, v)) in boxes.iter().zip(points.iter().zip(&values[0])) {
            let what = format!(
                "{op:?} over [{:e}, {:e}] x [{:e}, {:e}]",
                ix.0, ix.1, iy.0, iy.1
            );
            assert_contains(&what, *iv, *v, &(p[0], p[1]));
        }
    }
}

#[test]
fn select_ranges_contain_every_sampled_value() {
    let specials = [0.0, -0.0, 1.0, -1.0];
    let root = node::select(node::position(0), node::position(1), node::position(2));
    let intervals = IntervalTape::new(std::slice::from_ref(&root));
    let mut rng = Rng(0x5e1);
    for _ in 0..BOXES {
        let b = [(); 3].map(|_| draw_interval(&mut rng, &specials));
        let iv = intervals.ranges(&region(b[0], b[1], b[2]))[0];
        let s = b.map(|i| samples_of(&mut rng, i, &specials, 2));
        let mut points: Vec<[f64; 3]> = Vec::new();
        for &c in &s[0] {
            for &a in &s[1] {
                points.extend(s[2].iter().map(|&e| [c, a, e]));
            }
        }
        let values = tape(std::slice::from_ref(&root), &points, Precision::Double);
        for (p, v) in points.iter().zip(&values[0]) {
            assert_contains("select", iv, *v, p);
        }
    }
}

/// A random box of positions: small to a few cells, near the origin or 1e5 units away.
fn draw_box(rng: &mut Rng, reach: f64) -> Aabb {
    let far = if rng.below(4) == 0 { 1e5 } else { 0.0 };
    let c = DVec3::new(
        rng.range(-reach, reach),
        rng.range(-reach, reach),
        rng.range(-reach, reach),
    ) + far;
    let half = DVec3::new(rng.unit(), rng.unit(), rng.unit()) * 10f64.powf(rng.range(-3.0, 0.5));
    Aabb::new(c - half, c + half)
}

fn points_in_box(rng: &mut Rng, b: &Aabb, count: usize) -> Vec<[f64; 3]> {
    let mut points: Vec<[f64; 3]> = (0..8)
        .map(|n| {
            let pick = |bit: usize, a: usize| if n & bit != 0 { b.max[a] } else { b.min[a] };
            [pick(1, 0), pick(2, 1), pick(4, 2)]
        })
        .collect();
    while points.len() < count {
        let t = DVec3::new(rng.unit(), rng.unit(), rng.unit());
        points.push((b.min + (b.max - b.min) * t).to_array());
    }
    points
}

#[test]
fn noise_ranges_contain_both_precisions() {
    let mut rng = Rng(0x401);
    for kind in [NoiseKind::Perlin, NoiseKind::Simplex, NoiseKind::Worley] {
        let roots: Vec<NodeRef> = (0..10)
            .map(|i| {
                node::kernel_output(
                    Kernel::Noise { kind, seed: 9 },
                    (0..3).map(node::position).collect(),
                    i,
                )
            })
            .collect();
        let intervals = IntervalTape::new(&roots);
        for _ in 0..150 {
            let b = draw_box(&mut rng, 40.0);
            let ranges = intervals.ranges(&b);
            let points = points_in_box(&mut rng, &b, BLOCK);
            for precision in [Precision::Single, Precision::Double] {
                let values = tape(&roots, &points, precision);
                for (out, iv) in ranges.iter().enumerate() {
                    for (p, v) in points.iter().zip(&values[out]) {
                        let what = format!("{kind:?} output {out} ({precision:?})");
                        assert_contains(&what, *iv, *v, p);
                    }
                }
            }
        }
    }
}

/// A small grid with rough values (cubic reads overshoot them) and a non-zero background.
fn rough_grid(background: f64) -> Arc<Cache> {
    let domain = Domain::with_cells(
        DVec3::new(-0.5, -0.25, 0.0),
        DVec3::new(1.5, 1.0, 1.0),
        DVec3::ZERO,
        0.125,
        0.125,
    )
    .unwrap();
    let field = crate::sample::FnField::new(1, |p: DVec3, out: &mut [f64]| {
        out[0] = ((p.x * 23.0).sin() * (p.y * 17.0).cos() + p.z * 2.0).round();
    });
    let cache = Cache::from_field(domain, 1, Arc::new(field), vec![background], "t".into());
    Arc::new(cache.unwrap())
}

#[test]
fn grid_read_ranges_contain_every_value() {
    let mut rng = Rng(0x6e1d);
    for background in [0.0, -3.0] {
        let grid = rough_grid(background);
        for interp in [Interp::Linear, Interp::Cubic] {
            let field = Field::from_grid(
                grid.clone() as Arc<dyn GridSource>,
                interp,
                GridDerivative::Interpolant,
            )
            .unwrap();
            let intervals = IntervalTape::new(field.components());
            for _ in 0..200 {
                let mut b = draw_box(&mut rng, 1.5);
                if b.min.x > 1e4 {
                    b = Aabb::new(b.min - 1e5, b.max - 1e5);
                }
                let iv = intervals.ranges(&b)[0];
                let points = points_in_box(&mut rng, &b, 64);
                let values = tape(field.components(), &points, Precision::Double);
                for (p, v) in points.iter().zip(&values[0]) {
                    assert_contains(&format!("{interp:?} read"), iv, *v, p);
                }
            }
        }
    }
}

/// A random expression of the position that is finite everywhere, `depth` levels deep.
fn finite_expression(rng: &mut Rng, depth: usize) -> NodeRef {
    if depth == 0 {
        return match rng.below(4) {
            3 => node::constant(rng.range(-2.0, 2.0)),
            axis => node::position(axis),
        };
    }
    let mut sub = || finite_expression(rng, depth - 1);
    let (a, b, c) = (sub(), sub(), sub());
    match rng.below(12) {
        0 => node::add(a, b),
        1 => node::sub(a, b),
        2 => node::mul(a, b),
        3 => node::binary(BinOp::Min, a, b),
        4 => node::binary(BinOp::Max, a, b),
        5 => node::unary(MathFn::Sin, a),
        6 => node::unary(MathFn::Fract, a),
        7 => node::unary(MathFn::Sqrt, node::unary(MathFn::Abs, a)),
        8 => node::unary(MathFn::Step, a),
        9 => node::binary(BinOp::Atan2, a, b),
        10 => node::select(a, b, node::constant(0.25)),
        _ => {
            let at = [a, b, c].map(Field::scalar);
            let at = Field::vector_from(&at[0], &at[1], &at[2]).unwrap();
            let warped = Field::noise(NoiseKind::Perlin, 5).compose(&at).unwrap();
            warped.components()[0].clone()
        }
    }
}

/// The point of skipping: a brick whose range is exactly the background is never evaluated.
/// Here every brick the fill skipped is sampled densely — its cell centres, which the fill
/// would have stored, and random points between them — in both precisions, and every value
/// must be the background.
#[test]
fn bricks_skipped_as_empty_are_empty() {
    let mut rng = Rng(0xb71c);
    let domain = Domain::with_cells(
        DVec3::splat(-1.0),
        DVec3::splat(2.0),
        DVec3::new(0.0, 0.2, 0.0),
        1.0 / 16.0,
        1.0 / 16.0,
    )
    .unwrap();
    let [nx, ny, nz] = domain.resolution.unwrap();
    let mut skipped_total = 0;
    for case in 0..24 {
        // Compact support: a ball, a slab or a mask of noise, times a random expression.
        let p = Field::identity();
        let centre = DVec3::new(
            rng.range(-0.5, 0.5),
            rng.range(-0.5, 0.5),
            rng.range(-0.5, 0.5),
        );
        let offset = p.sub(&Field::constant_vector(centre)).unwrap();
        let radius = Field::constant_scalar(rng.range(0.2, 0.6));
        let inside = match case % 3 {
            0 => radius.sub(&offset.length().unwrap()).unwrap(),
            1 => radius
                .sub(&offset.component(1).unwrap().math(MathFn::Abs).unwrap())
                .unwrap(),
            _ => Field::noise(NoiseKind::Simplex, case as u32)
                .sub(&Field::constant_scalar(0.4))
                .unwrap(),
        };
        let shape = if case % 2 == 0 {
            Field::max(&inside, &Field::constant_scalar(0.0)).unwrap()
        } else {
            inside.mask().unwrap()
        };
        let density = shape
            .mul(&Field::scalar(finite_expression(&mut rng, 3)))
            .unwrap();
        let compiled = Arc::new(CompiledField::new(&density));
        let cache = Cache::from_field(
            domain.clone(),
            1,
            compiled.clone() as Arc<dyn FieldSampler>,
            vec![0.0],
            "skip".into(),
        )
        .unwrap();
        cache.fill_all();
        let bricks = [nx, ny, nz].map(|n| n.div_ceil(BRICK));
        let mut skipped = 0;
        for bz in 0..bricks[2] {
            for by in 0..bricks[1] {
                for bx in 0..bricks[0] {
                    let lo = [bx, by, bz].map(|b| b * BRICK);
                    let hi = [(bx + 1) * BRICK, (by + 1) * BRICK, (bz + 1) * BRICK];
                    let hi = [hi[0].min(nx), hi[1].min(ny), hi[2].min(nz)];
                    let mut centres = Vec::new();
                    for k in lo[2]..hi[2] {
                        for j in lo[1]..hi[1] {
                            for i in lo[0]..hi[0] {
                                centres.push(domain.cell_center(i, j, k));
                            }
                        }
                    }
                    let mut bounds = Aabb::new(centres[0], centres[0]);
                    for c in &centres {
                        bounds = bounds.union(&Aabb::new(*c, *c));
                    }
                    // The fill's own decision, asked again the same way.
                    if compiled.range(&bounds) != vec![(0.0, 0.0)] {
                        continue;
                    }
                    skipped += 1;
                    let mut points: Vec<[f64; 3]> = centres.iter().map(|c| c.to_array()).collect();
                    points.extend(points_in_box(&mut rng, &bounds, 512));
                    for precision in [Precision::Single, Precision::Double] {
                        let values = tape(density.components(), &points, precision);
                        for (p, v) in points.iter().zip(&values[0]) {
                            assert!(
                                *v == 0.0,
                                "case {case}: brick {bx},{by},{bz} was skipped but is {v:e} at {p:?}"
                            );
                        }
                    }
                }
            }
        }
        assert_eq!(
            skipped,
            cache.bricks_skipped(),
            "case {case}: skip decisions differ"
        );
        skipped_total += skipped;
    }
    // The property is only worth something if bricks were skipped.
    assert!(skipped_total > 100, "only {skipped_total} bricks skipped");
}
