//! Op-consistency tests: every math function, binary operation and kernel of the field engine
//! is defined three times — constant folding (`node`), the point tape (`eval`) and interval
//! ranges (`interval`) — and these tests check, op by op, that the three agree.
//!
//! The one key decision: the tables are written as exhaustive matches over the op enums
//! (`every_math_fn`, `every_bin_op`), so a new node kind that is not added here fails to
//! compile instead of going untested. Kernels are an open set (`field::kernel`); those with a
//! range narrower than "anything" have it checked here (`noise_ranges_contain_both_precisions`,
//! `grid_read_ranges_contain_every_value`). Inputs are seeded and deterministic; boxes
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
use crate::field::kernel::noise::Noise;
use crate::field::node::{self, BinOp, MathFn, NodeRef};
use crate::field::noise::NoiseKind;
use crate::field::program::Program;
use crate::field::{CompiledField, Field};
use crate::grid::cache::{BRICK, Cache};
use crate::space::domain::Domain;
use crate::space::{Aabb, BLOCK, FieldSampler, GridDerivative, GridSource, Interp};
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

use crate::base::test_random::SplitMix as Rng;

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
fn a_sine_and_cosine_of_one_value_run_as_one_instruction_with_the_folded_values() {
    use crate::field::program::Instr;
    let (x, y) = (node::position(0), node::position(1));
    let r = node::binary(BinOp::Mul, x.clone(), y.clone());
    let s = node::binary(BinOp::Add, x.clone(), y);
    // One pair with the cosine first in the tape and one with the sine first; a lone sine
    // stays as it is.
    let roots = [
        node::unary(MathFn::Cos, r.clone()),
        node::unary(MathFn::Sin, r),
        node::unary(MathFn::Sin, s.clone()),
        node::unary(MathFn::Cos, s),
        node::unary(MathFn::Sin, x),
    ];
    let program = Program::compile(&roots);
    let count = |f: fn(&Instr) -> bool| program.instrs.iter().filter(|i| f(i)).count();
    assert_eq!(count(|i| matches!(i, Instr::SinCos { .. })), 2);
    assert_eq!(count(|i| matches!(i, Instr::Unary { .. })), 1);
    let mut rng = Rng(11);
    let mut points: Vec<[f64; 3]> = SPECIAL.iter().map(|&v| [v, 1.0, 0.0]).collect();
    points.extend((0..3000).map(|_| {
        let scale = 10f64.powi(rng.below(12) as i32 - 3);
        [rng.range(-scale, scale), rng.range(-2.0, 2.0), 0.0]
    }));
    let values = tape(&roots, &points, Precision::Double);
    let folded = |m: MathFn, v: f64| node::unary(m, node::constant(v)).constant().unwrap();
    for (i, p) in points.iter().enumerate() {
        let (r, s) = (p[0] * p[1], p[0] + p[1]);
        let expected = [
            (MathFn::Cos, r),
            (MathFn::Sin, r),
            (MathFn::Sin, s),
            (MathFn::Cos, s),
            (MathFn::Sin, p[0]),
        ];
        for (root, (m, v)) in expected.into_iter().enumerate() {
            assert!(
                same(values[root][i], folded(m, v)),
                "{m:?}({v:e}): tape {:e}, folded {:e}",
                values[root][i],
                folded(m, v)
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

/// An operation with one constant operand runs as `BinaryConstant` (the constant read once,
/// not as a register) and gives the folded value, on either side, for every special input.
#[test]
fn a_constant_operand_gives_the_folded_value_on_either_side() {
    use crate::field::program::Instr;
    let x = node::position(0);
    let points: Vec<[f64; 3]> = SPECIAL.iter().map(|&v| [v, 0.0, 0.0]).collect();
    for op in every_bin_op() {
        for k in [0.3, -7.1, 1e300, 3.5e-310, INF] {
            let roots = [
                node::binary(op, node::constant(k), x.clone()),
                node::binary(op, x.clone(), node::constant(k)),
            ];
            let program = Program::compile(&roots);
            // Commuted operands of a symmetric operation are one node.
            let count = |f: fn(&Instr) -> bool| program.instrs.iter().filter(|i| f(i)).count();
            let with_constant = count(|i| matches!(i, Instr::BinaryConstant { .. }));
            assert!((1..=2).contains(&with_constant), "{op:?} with {k:e}");
            assert_eq!(count(|i| matches!(i, Instr::Binary { .. })), 0);
            let got = tape(&roots, &points, Precision::Double);
            for (i, &v) in SPECIAL.iter().enumerate() {
                for (side, (a, b)) in [(0, (k, v)), (1, (v, k))] {
                    let folded = op.apply(a, b);
                    let either_zero = matches!(op, BinOp::Min | BinOp::Max)
                        && folded == 0.0
                        && got[side][i] == 0.0;
                    assert!(
                        same(folded, got[side][i]) || either_zero,
                        "{op:?}({a:e}, {b:e}): folded {folded:e}, tape {:e}",
                        got[side][i]
                    );
                }
            }
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
                    Arc::new(Noise { kind, seed: 3 }),
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

mod intervals;
mod pruning;
