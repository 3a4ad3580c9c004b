//! Field engine tests: exact derivatives against closed forms and finite differences,
//! hash-consing, warps, advection orders, deep graphs, supports, determinism.

use super::*;
use crate::field::noise::NoiseKind;
use crate::space::domain::Domain;
use crate::space::{Aabb, FieldSampler};

pub(super) fn x() -> Field {
    Field::identity()
}

pub(super) fn s(c: f64) -> Field {
    Field::constant_scalar(c)
}

pub(super) fn scalar_at(f: &Field, p: DVec3) -> f64 {
    match probe(f, p).unwrap() {
        FieldValue::Scalar(v) => v,
        other => panic!("not a scalar: {other:?}"),
    }
}

fn vector_at(f: &Field, p: DVec3) -> DVec3 {
    match probe(f, p).unwrap() {
        FieldValue::Vector(v) => v,
        other => panic!("not a vector: {other:?}"),
    }
}

fn matrix_at(f: &Field, p: DVec3) -> DMat3 {
    match probe(f, p).unwrap() {
        FieldValue::Matrix(m) => m,
        other => panic!("not a matrix: {other:?}"),
    }
}

/// Deterministic pseudo-random points in [-r, r]³.
fn points(count: usize, r: f64) -> Vec<DVec3> {
    let mut state = 0x9e3779b97f4a7c15u64;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    };
    (0..count)
        .map(|_| DVec3::new(next(), next(), next()) * r)
        .collect()
}

#[test]
fn gradient_of_distance_is_the_unit_direction_and_finite_at_the_origin() {
    let dist = x().mul(&x()).unwrap().math(MathFn::Sqrt).unwrap();
    let g = grad(&dist).unwrap();
    for p in points(200, 3.0) {
        let expected = p / p.length();
        let got = vector_at(&g, p);
        assert!(
            (got - expected).abs().max_element() < 1e-12,
            "{p}: {got} vs {expected}"
        );
    }
    let at_origin = vector_at(&g, DVec3::ZERO);
    assert!(at_origin.is_finite(), "{at_origin}");
    assert_eq!(at_origin, DVec3::ZERO);
}

#[test]
fn hessian_of_the_squared_length_is_exactly_twice_the_identity() {
    let q = x().mul(&x()).unwrap();
    let h = grad(&grad(&q).unwrap()).unwrap();
    // Symbolically constant: no evaluation needed, and exactly 2I.
    assert_eq!(
        h.as_constant(),
        Some(FieldValue::Matrix(DMat3::from_diagonal(DVec3::splat(2.0))))
    );
    for p in points(10, 5.0) {
        assert_eq!(matrix_at(&h, p), DMat3::from_diagonal(DVec3::splat(2.0)));
    }
    assert_eq!(
        scalar_at(&laplacian(&q).unwrap(), DVec3::new(0.3, 1.0, -2.0)),
        6.0
    );
}

#[test]
fn jacobian_of_a_composition_matches_finite_differences() {
    // F(p) = (sin p.x * p.y, p.z², exp(0.1 p.x)), G(p) = (p.y p.z, p.x + cos p.z, |p|)
    let c = |i| x().component(i).unwrap();
    let f = Field::vector_from(
        &c(0).math(MathFn::Sin).unwrap().mul(&c(1)).unwrap(),
        &c(2).mul(&c(2)).unwrap(),
        &c(0).mul(&s(0.1)).unwrap().math(MathFn::Exp).unwrap(),
    )
    .unwrap();
    let g = Field::vector_from(
        &c(1).mul(&c(2)).unwrap(),
        &c(0).add(&c(2).math(MathFn::Cos).unwrap()).unwrap(),
        &x().length().unwrap(),
    )
    .unwrap();
    let fg = compose(&f, &g).unwrap();
    let j = grad(&fg).unwrap();
    let h = 1e-5;
    for p in points(20, 1.5) {
        let exact = matrix_at(&j, p);
        for axis in 0..3 {
            let e = DVec3::AXES[axis] * h;
            let fd = (vector_at(&fg, p + e) - vector_at(&fg, p - e)) / (2.0 * h);
            for row in 0..3 {
                let got = exact.row(row)[axis];
                assert!(
                    (got - fd[row]).abs() < 1e-6 * (1.0 + fd[row].abs()),
                    "{p} J[{row}][{axis}] {got} vs {}",
                    fd[row]
                );
            }
        }
    }
}

#[test]
fn identical_expressions_are_one_node() {
    let build = || {
        let r = x().length().unwrap();
        r.mul(&s(2.0)).unwrap().math(MathFn::Sin).unwrap()
    };
    let (a, b) = (build(), build());
    assert!(a.same_as(&b));
    // Commutative operations share their node too.
    let p = x().component(0).unwrap();
    let q = x().component(1).unwrap();
    assert!(p.add(&q).unwrap().same_as(&q.add(&p).unwrap()));
    // The printed summary counts distinct nodes: x*x shares its three products' inputs.
    assert_eq!(x().mul(&x()).unwrap().to_string(), "scalarfield (8 nodes)");
}

#[test]
fn normalize_of_zero_is_zero_and_division_by_zero_is_ieee() {
    let n = Field::constant_vector(DVec3::ZERO)
        .add(&x().mul(&s(0.0)).unwrap())
        .unwrap();
    assert_eq!(vector_at(&n.normalize().unwrap(), DVec3::ONE), DVec3::ZERO);
    let v = x().normalize().unwrap();
    assert_eq!(vector_at(&v, DVec3::ZERO), DVec3::ZERO);
    let p = DVec3::new(3.0, 0.0, 4.0);
    assert!((vector_at(&v, p) - p / 5.0).length() < 1e-15);
    let inv = s(1.0).div(&x().component(0).unwrap()).unwrap();
    assert_eq!(scalar_at(&inv, DVec3::ZERO), f64::INFINITY);
    let nan = x()
        .component(0)
        .unwrap()
        .div(&x().component(0).unwrap())
        .unwrap();
    assert!(scalar_at(&nan, DVec3::ZERO).is_nan());
}

#[test]
fn a_500_step_advection_chain_evaluates() {
    // Uniform velocity: 500 back-traces of dt 0.01 shift by exactly 5 units (to rounding).
    // A velocity that varies in space (so every step is a real substitution) but moves x
    // uniformly: u = (1, 0, sin(y / 1000)).
    let swirl = x()
        .component(1)
        .unwrap()
        .mul(&s(1e-3))
        .unwrap()
        .math(MathFn::Sin)
        .unwrap();
    let u = Field::vector_from(&s(1.0), &s(0.0), &swirl).unwrap();
    let mut f = x().component(0).unwrap();
    for _ in 0..500 {
        f = advect(&f, &u, &s(0.01), 1).unwrap();
    }
    let v = scalar_at(&f, DVec3::new(2.0, 0.5, 0.0));
    assert!((v - (2.0 - 5.0)).abs() < 1e-9, "{v}");
    let g = grad(&f).unwrap();
    assert!((vector_at(&g, DVec3::new(2.0, 0.5, 0.0)) - DVec3::X).length() < 1e-9);
}

#[test]
fn runge_kutta_back_traces_converge_at_their_order() {
    // Rigid rotation about z: the exact back-trace over dt is a rotation by -dt.
    let c = |i| x().component(i).unwrap();
    let u = Field::vector_from(&c(1).neg(), &c(0), &s(0.0)).unwrap();
    let p = DVec3::new(1.0, 0.5, 0.2);
    let error = |order: u32, dt: f64| {
        let traced = advect(&x(), &u, &s(dt), order).unwrap();
        let exact = DMat3::from_rotation_z(-dt) * p;
        (vector_at(&traced, p) - exact).length()
    };
    for order in 1..=4u32 {
        let (coarse, fine) = (error(order, 0.2), error(order, 0.1));
        let measured = (coarse / fine).log2();
        // Local error of an order-p scheme is O(dt^(p+1)).
        assert!(
            (measured - (order as f64 + 1.0)).abs() < 0.3,
            "order {order}: {measured}"
        );
    }
}

#[test]
fn noise_gradients_are_exact_and_hessians_symmetric() {
    let n = Field::noise(NoiseKind::Perlin, 7)
        .compose(&x().mul(&s(1.7)).unwrap())
        .unwrap();
    let g = grad(&n).unwrap();
    let h = grad(&g).unwrap();
    let step = 1e-6;
    for p in points(30, 4.0) {
        let exact = vector_at(&g, p);
        let fd = DVec3::from_array(std::array::from_fn(|a| {
            let e = DVec3::AXES[a] * step;
            (scalar_at(&n, p + e) - scalar_at(&n, p - e)) / (2.0 * step)
        }));
        assert!((exact - fd).abs().max_element() < 1e-6, "{exact} vs {fd}");
        let m = matrix_at(&h, p);
        assert!((m - m.transpose()).abs_diff_eq(DMat3::ZERO, 1e-12));
    }
    // Third derivatives are central differences of the exact Hessian: they match a wider
    // difference of the Hessian to the accuracy of the wider one.
    let third = grad(&h.component(0).unwrap()).unwrap();
    let wide = 1e-4;
    for p in points(10, 4.0) {
        let t = matrix_at(&third, p);
        let scale = 1.0 + t.abs().to_cols_array().iter().cloned().fold(0.0, f64::max);
        for axis in 0..3 {
            let e = DVec3::AXES[axis] * wide;
            let fd = (matrix_at(&h, p + e).row(0) - matrix_at(&h, p - e).row(0)) / (2.0 * wide);
            for c in 0..3 {
                assert!((t.row(c)[axis] - fd[c]).abs() < 1e-4 * scale, "{t} vs {fd}");
            }
        }
    }
}

#[test]
fn warps_move_fields_as_documented() {
    let f = x()
        .component(0)
        .unwrap()
        .mul(&x().component(1).unwrap())
        .unwrap();
    let p = DVec3::new(0.3, -1.2, 2.0);
    let t = translate(&f, DVec3::new(1.0, 2.0, 3.0)).unwrap();
    assert_eq!(scalar_at(&t, p), (p.x - 1.0) * (p.y - 2.0));
    let sc = scale(&f, DVec3::new(2.0, 4.0, 1.0)).unwrap();
    assert_eq!(scalar_at(&sc, p), (p.x / 2.0) * (p.y / 4.0));
    let r = rotate(
        &x().component(0).unwrap(),
        DVec3::Z,
        std::f64::consts::FRAC_PI_2,
    )
    .unwrap();
    // Turning the field x by +90° about z: the value at (0, 1, 0) is the old value at (1, 0, 0).
    assert!((scalar_at(&r, DVec3::Y) - 1.0).abs() < 1e-15);
}

#[test]
fn calculus_identities_hold() {
    let c = |i| x().component(i).unwrap();
    let phi = c(0)
        .math(MathFn::Sin)
        .unwrap()
        .mul(&c(1).mul(&c(2)).unwrap())
        .unwrap();
    let curl_grad = curl(&grad(&phi).unwrap()).unwrap();
    let v = Field::vector_from(
        &c(1).mul(&c(2)).unwrap(),
        &c(0).math(MathFn::Exp).unwrap(),
        &c(0).mul(&c(1)).unwrap().math(MathFn::Cos).unwrap(),
    )
    .unwrap();
    let div_curl = div(&curl(&v).unwrap()).unwrap();
    for p in points(20, 2.0) {
        assert!(vector_at(&curl_grad, p).length() < 1e-14);
        assert!(scalar_at(&div_curl, p).abs() < 1e-14);
    }
    // div of the identity is 3 and its curl zero, symbolically.
    assert_eq!(
        div(&x()).unwrap().as_constant(),
        Some(FieldValue::Scalar(3.0))
    );
}

#[test]
fn matrix_operators_follow_the_language_table() {
    let m = DMat3::from_cols_array(&[2.0, 0.0, 1.0, 1.0, 3.0, 0.0, 0.0, 1.0, 4.0]);
    let mf = Field::constant_matrix(m)
        .mul(&x().component(0).unwrap())
        .unwrap();
    let p = DVec3::new(1.5, 2.0, -1.0);
    let v = DVec3::new(1.0, -2.0, 0.5);
    let vf = Field::constant_vector(v);
    // m * v, v * m = transpose(m) * v, m * m, det, trace, inverse.
    let mp = m * p.x;
    assert!((vector_at(&mf.mul(&vf).unwrap(), p) - mp * v).length() < 1e-12);
    assert!((vector_at(&vf.mul(&mf).unwrap(), p) - mp.transpose() * v).length() < 1e-12);
    assert!(matrix_at(&mf.mul(&mf).unwrap(), p).abs_diff_eq(mp * mp, 1e-12));
    assert!((scalar_at(&mf.det().unwrap(), p) - mp.determinant()).abs() < 1e-12);
    assert!((scalar_at(&mf.trace().unwrap(), p) - 9.0 * p.x).abs() < 1e-12);
    assert!(matrix_at(&mf.inverse().unwrap(), p).abs_diff_eq(mp.inverse(), 1e-12));
    // Vector * vector is the dot product.
    assert_eq!(scalar_at(&vf.mul(&x()).unwrap(), p), v.dot(p));
    assert!(vf.add(&s(1.0)).is_err());
}

#[test]
fn supports_bound_where_fields_are_nonzero() {
    // A ball of radius 1 around (2, 0, 0) as a hard mask.
    let ball = s(1.0)
        .sub(
            &translate(&x(), DVec3::new(2.0, 0.0, 0.0))
                .unwrap()
                .length()
                .unwrap(),
        )
        .unwrap();
    let density = ball.mask().unwrap().mul(&s(3.0)).unwrap();
    let sampler = CompiledField::new(&density);
    let b = sampler.bounds().expect("a finite support");
    assert!(
        b.min.x <= 1.0 && b.max.x >= 3.0 && b.min.y <= -1.0 && b.max.z >= 1.0,
        "{b:?}"
    );
    assert!(
        b.max.x < 3.5 && b.min.x > 0.5 && b.size().max_element() < 3.0,
        "{b:?}"
    );
    // A field that is nonzero everywhere has no finite support.
    assert_eq!(CompiledField::new(&x().length().unwrap()).bounds(), None);
    // Ranges are conservative.
    let r = sampler.range(&Aabb::new(DVec3::splat(-5.0), DVec3::splat(5.0)));
    assert!(r[0].0 <= 0.0 && r[0].1 >= 3.0);
}

#[test]
fn blocks_and_threads_do_not_change_values() {
    let f = Field::noise(NoiseKind::Simplex, 3)
        .compose(&x().mul(&s(3.1)).unwrap())
        .unwrap()
        .add(&x().length().unwrap())
        .unwrap();
    let d = Domain::with_cells(
        DVec3::splat(-1.0),
        DVec3::splat(2.0),
        DVec3::ZERO,
        2.0 / 40.0,
        2.0 / 40.0,
    )
    .unwrap();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let a = one.install(|| stats(&f, &d).unwrap());
    let b = two.install(|| stats(&f, &d).unwrap());
    assert_eq!(
        (a.0.to_bits(), a.1.to_bits(), a.2.to_bits()),
        (b.0.to_bits(), b.1.to_bits(), b.2.to_bits())
    );
    // One point at a time or a whole block: the same bits.
    let sampler = CompiledField::new(&f);
    let mut eval = sampler.evaluator();
    let pts = points(300, 1.0);
    let (xs, ys, zs): (Vec<f64>, Vec<f64>, Vec<f64>) = (
        pts.iter().map(|p| p.x).collect(),
        pts.iter().map(|p| p.y).collect(),
        pts.iter().map(|p| p.z).collect(),
    );
    let mut all = vec![0.0; 300];
    eval.eval_f64(&xs, &ys, &zs, &mut all);
    for i in (0..300).step_by(37) {
        let mut one = [0.0];
        eval.eval_f64(&xs[i..i + 1], &ys[i..i + 1], &zs[i..i + 1], &mut one);
        assert_eq!(one[0].to_bits(), all[i].to_bits());
    }
}

#[test]
fn stats_match_closed_forms() {
    // Mean of x over cell centres of [0, 2] with 4 cells: (0.25 + 0.75 + 1.25 + 1.75) / 4 = 1.
    let d = Domain::with_cells(DVec3::ZERO, DVec3::splat(2.0), DVec3::ZERO, 0.5, 0.5).unwrap();
    let (min, max, mean) = stats(&x().component(0).unwrap(), &d).unwrap();
    assert_eq!((min, max, mean), (0.25, 1.75, 1.0));
    assert!(stats(&x(), &d).is_err());
}

#[test]
fn every_output_is_emitted_once_with_its_final_value() {
    // Outputs of every origin: a coordinate (no instruction writes it), a constant, one value
    // twice, and values finalised at different points of the tape. Each must reach `emit`
    // exactly once, equal to what the output registers hold after the run.
    use crate::field::eval::{Evaluator, Precision};
    use crate::field::program::Program;
    let p = Field::identity();
    let r = p.length().unwrap();
    let g = grad(&r).unwrap();
    let mut roots = vec![p.component(1).unwrap().components()[0].clone()];
    roots.push(s(2.5).components()[0].clone());
    roots.extend_from_slice(r.components());
    roots.extend_from_slice(g.components());
    roots.extend_from_slice(r.components());
    let program = Program::compile(&roots);
    let mut evaluator = Evaluator::new(&program);
    let xs = [0.3, -1.0, 2.0];
    let ys = [0.4, 0.5, -2.0];
    let zs = [1.2, 0.0, 1.0];
    let mut seen = vec![None; roots.len()];
    evaluator.run_emitting(&xs, &ys, &zs, Precision::Double, |c, values| {
        assert!(seen[c].is_none(), "output {c} emitted twice");
        seen[c] = Some(values.to_vec());
    });
    for (c, values) in seen.iter().enumerate() {
        assert_eq!(
            values.as_deref(),
            Some(evaluator.output(c, 3)),
            "output {c}"
        );
    }
    assert_eq!(seen[0].as_deref(), Some(&ys[..]));
    assert_eq!(seen[1].as_deref(), Some(&[2.5; 3][..]));
    let length = (0.3f64 * 0.3 + 0.4 * 0.4 + 1.2 * 1.2).sqrt();
    assert_eq!(seen[2].as_ref().unwrap()[0], length);
    assert_eq!(seen[3].as_ref().unwrap()[0], 0.3 / length);
}

/// A chain of advections is built in time linear in its length: each step substitutes the
/// back trace only into the layer the step before added (it used to walk the whole graph, so
/// 5,000 RK4 steps never finished building). The velocity is built from temporaries, as a
/// script builds it, so the position's z node is dropped and made again between steps.
#[test]
fn each_step_of_an_advection_chain_costs_the_same() {
    let velocity = || {
        Field::vector_from(
            &Field::identity().component(1).unwrap().neg(),
            &Field::identity().component(0).unwrap(),
            &s(0.0),
        )
        .unwrap()
    };
    let mut f = Field::identity().component(0).unwrap();
    let steps = 2_000;
    let mut costs = Vec::with_capacity(steps);
    for _ in 0..steps {
        let before = substitution::visits();
        f = advect(&f, &velocity(), &s(0.001), 4).unwrap();
        costs.push(substitution::visits() - before);
    }
    // About 30 nodes a step; a step that walked the graph would cost 30 per step so far. A
    // sweep of the shared hash-consing table (by any test) can make one step walk it all.
    let walked = costs.iter().filter(|&&c| c > 100).count();
    assert!(walked <= 5, "{walked} steps walked the graph: {costs:?}");
    let graph = node::postorder(f.components()).len();
    assert!(graph < 40 * steps, "{graph} nodes");
    // Rotation by 2 radians about z: the back-traced x of (0.1, 0.2, 0).
    let (angle, p) = (2.0f64, DVec3::new(0.1, 0.2, 0.0));
    let expected = p.x * angle.cos() + p.y * angle.sin();
    assert!((scalar_at(&f, p) - expected).abs() < 1e-9);
}

#[test]
fn deep_graphs_need_no_deep_stack() {
    // A chain 200,000 nodes deep, built, flattened into its linear form, compiled, evaluated,
    // given intervals and dropped, all on a thread with a 256 KiB stack: every pass over a
    // graph, and dropping it, is iterative.
    let worker = std::thread::Builder::new()
        .stack_size(256 << 10)
        .spawn(|| {
            let x = node::position(0);
            let mut f = x.clone();
            for k in 0..100_000 {
                f = node::add(node::mul(f, node::constant(0.5)), x.clone());
                if k % 2 == 0 {
                    f = node::unary(MathFn::Sin, f);
                }
            }
            let field = Field::scalar(f);
            let compiled = CompiledField::new(&field);
            assert!(compiled.program().nodes > 200_000);
            let mut eval = compiled.evaluator();
            let mut out = [0f64; 1];
            eval.eval_f64(&[0.25], &[0.0], &[0.0], &mut out);
            assert!(out[0].is_finite());
            let range = compiled.range(&Aabb::new(DVec3::ZERO, DVec3::splat(0.5)))[0];
            assert!(
                range.0 <= out[0] && out[0] <= range.1,
                "{range:?} {}",
                out[0]
            );
            drop(eval);
            drop(compiled);
            drop(field);
        })
        .unwrap();
    worker
        .join()
        .expect("the deep graph is handled on a small stack");
}
