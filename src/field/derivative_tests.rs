//! `div` and `laplacian` from the diagonal of the Jacobian alone: the same nodes, and so the
//! same bits, as the trace of the full Jacobian, checked against that trace, closed forms and
//! central differences.

use super::tests::{s, scalar_at, x};
use super::*;
use crate::field::noise::NoiseKind;

/// The Laplacian as it was first written: the trace of the full Hessian, all nine second
/// derivatives built.
fn trace_of_hessian(f: &Field) -> Field {
    grad(&grad(f).unwrap()).unwrap().trace().unwrap()
}

fn perlin_stretched() -> Field {
    Field::noise(NoiseKind::Perlin, 3)
        .compose(&x().mul(&s(1.3)).unwrap())
        .unwrap()
}

fn sines(a: f64, b: f64, c: f64) -> Field {
    let axis = |i: usize, k: f64| x().component(i).unwrap().mul(&s(k)).unwrap();
    axis(0, a)
        .math(MathFn::Sin)
        .unwrap()
        .mul(&axis(1, b).math(MathFn::Sin).unwrap())
        .unwrap()
        .mul(&axis(2, c).math(MathFn::Sin).unwrap())
        .unwrap()
}

const POINTS: [DVec3; 4] = [
    DVec3::new(0.1, 0.2, 0.3),
    DVec3::new(-1.7, 0.45, 2.2),
    DVec3::new(3.3, -2.9, 0.05),
    DVec3::new(0.0, 0.0, 0.0),
];

/// Nested Laplacians of noise and of an analytic field, up to three levels deep, are the very
/// nodes of the nested traces of the full Hessian, so they agree bit for bit at every point.
#[test]
fn laplacians_are_the_trace_of_the_hessian_node_for_node() {
    for f in [perlin_stretched(), sines(0.7, 1.9, -1.1)] {
        let (mut diagonal, mut full) = (f.clone(), f);
        for level in 1..=3 {
            diagonal = laplacian(&diagonal).unwrap();
            full = trace_of_hessian(&full);
            let (d, t) = (&diagonal.components()[0], &full.components()[0]);
            assert_eq!(d.id, t.id, "level {level}: {d:?} vs {t:?}");
            for p in POINTS {
                let (a, b) = (scalar_at(&diagonal, p), scalar_at(&full, p));
                assert_eq!(a.to_bits(), b.to_bits(), "level {level} at {p}: {a} vs {b}");
            }
        }
    }
}

/// `div` of vectorfields whose components share their graphs, or do not, is the trace of
/// `grad`, node for node; `div(curl(v))` too.
#[test]
fn divergence_is_the_trace_of_the_jacobian_node_for_node() {
    let c = |i| x().component(i).unwrap();
    let shared = grad(&perlin_stretched()).unwrap();
    let apart = Field::vector_from(
        &c(1).mul(&c(2)).unwrap().math(MathFn::Sin).unwrap(),
        &c(0).math(MathFn::Exp).unwrap().mul(&c(2)).unwrap(),
        &Field::noise(NoiseKind::Simplex, 9),
    )
    .unwrap();
    let curled = curl(&apart).unwrap();
    for v in [shared, apart, curled] {
        let diagonal = div(&v).unwrap();
        let full = grad(&v).unwrap().trace().unwrap();
        assert_eq!(diagonal.components()[0].id, full.components()[0].id);
        for p in POINTS {
            let (a, b) = (scalar_at(&diagonal, p), scalar_at(&full, p));
            assert_eq!(a.to_bits(), b.to_bits(), "at {p}: {a} vs {b}");
        }
    }
}

/// Δ of sin(ax) sin(by) sin(cz) is -(a² + b² + c²) times itself, and Δ² is the square of that
/// factor times it: the closed form, to rounding.
#[test]
fn nested_laplacians_of_sines_follow_the_closed_form() {
    let (a, b, c) = (0.7, 1.9, -1.1);
    let f = sines(a, b, c);
    let k = -(a * a + b * b + c * c);
    let once = laplacian(&f).unwrap();
    let twice = laplacian(&once).unwrap();
    for p in POINTS {
        let value = (a * p.x).sin() * (b * p.y).sin() * (c * p.z).sin();
        assert!((scalar_at(&once, p) - k * value).abs() < 1e-14, "at {p}");
        assert!(
            (scalar_at(&twice, p) - k * k * value).abs() < 1e-13,
            "at {p}"
        );
    }
}

/// The Laplacian of noise, from its exact Hessian, against central differences of its exact
/// gradient.
#[test]
fn the_laplacian_of_noise_matches_central_differences_of_its_gradient() {
    let f = perlin_stretched();
    let g = grad(&f).unwrap();
    let lap = laplacian(&f).unwrap();
    let h = 1e-5;
    // Not the origin: a lattice point, where the difference straddles eight cells.
    for p in &POINTS[..3] {
        let p = *p;
        let differences: f64 = (0..3)
            .map(|axis| {
                let e = DVec3::AXES[axis] * h;
                let along = |q: DVec3| match probe(&g, q).unwrap() {
                    FieldValue::Vector(v) => v[axis],
                    other => panic!("not a vector: {other:?}"),
                };
                (along(p + e) - along(p - e)) / (2.0 * h)
            })
            .sum();
        let exact = scalar_at(&lap, p);
        assert!(
            (exact - differences).abs() < 1e-6 * (1.0 + exact.abs()),
            "at {p}: {exact} vs {differences}"
        );
    }
}
