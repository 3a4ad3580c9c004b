//! Nacelle warps (FELT chapter 4): the chapter's lines run as printed, the iteration converges
//! on the object's surface, the stable root handles the cases the printed root cannot (Γ → 0,
//! no real root, a vanishing gradient), and the cached variant stays close to the exact one.

mod common;

use std::path::Path;

use common::{lines_of, numbers};

/// Felt definitions the scripts below share: the objects of the chapter's figures and the
/// worst residual |Lo − Lr(X)| over a shape's vertices.
const OBJECTS: &str = r#"
    func float residual(scalarfield Lo, scalarfield Lr, vectorfield X, shape obj) {
        float[] r = pointattrfloat(setpointattr(obj, "r", abs(Lo - compose(Lr, X))), "r");
        float worst = 0;
        for (int i = 0; i < size(r); i++) { worst = max(worst, r[i]); }
        return worst;
    }
    scalarfield ellipsoid = scale(sphere((0, 0, 0), 1.0), (1.2, 0.8, 0.9));
    scalarfield ring = torus((0, 0, 0), 0.7, 0.25);
    scalarfield ringA = torus((0, 0, 0), 0.55, 0.16);
    scalarfield ringB = translate(rotate(torus((0, 0, 0), 0.55, 0.16), (1, 0, 0), 1.5707963267948966), (0.55, 0, 0));
    scalarfield spike = cone((-0.3, 0.9, 0), (0, -1, 0), 0.35, 1.3);
    scalarfield conetori = union(spike, union(ringA, ringB));
    domain d((-1.5, -1.5, -1.5), (3, 3, 3), (0, 0, 0), 0.06);
"#;

fn run(body: &str) -> Vec<String> {
    lines_of(common::run_source(
        "nacelle.felt",
        &format!("{OBJECTS}\n{body}"),
    ))
}

#[test]
fn the_chapters_lines_run_as_printed() {
    let out = lines_of(common::run_script(
        Path::new("tests/scripts/chapter/nacelle.felt"),
        &[],
    ));
    assert_eq!(out[0], "true true", "{out:?}");
    // Closed form: Γ = −3|x|², so the printed root is accurate here and equals the stable one.
    let x = [0.2f64, 0.7, 0.3];
    let r2: f64 = x.iter().map(|c| c * c).sum();
    let lr = 0.25 * (1.0 - r2 * r2);
    let scaled = [x[0] / 1.2, x[1] / 0.8, x[2] / 0.9];
    let lo = 1.0 - scaled.iter().map(|c| c * c).sum::<f64>().sqrt();
    let bb = r2 * r2 * r2;
    let delta = (lo - lr) / bb;
    let gamma = -3.0 * r2;
    let a = (-1.0 + (1.0 + 2.0 * delta * gamma).sqrt()) / gamma;
    let expected: Vec<f64> = x.iter().map(|c| c - a * r2 * c).collect();
    for (got, want) in numbers(&out[1]).iter().zip(&expected) {
        assert!((got - want).abs() < 1e-12, "{} vs {expected:?}", out[1]);
    }
}

/// Residuals after 1–4 iterations towards a smooth sphere level set that is not a distance,
/// `sin(1 − |x|)` (with an exact distance one step is already exact, see below).
#[test]
fn the_residual_falls_on_every_object() {
    let out = run(r#"
        scalarfield Lr = sin(1.0 - length(identity()));
        scalarfield[] objects = {ellipsoid, ring, conetori};
        for (int o = 0; o < size(objects); o++) {
            shape obj = ls2shape(objects[o], d);
            float[] row;
            for (int n = 1; n <= 4; n++) {
                row[size(row)] = residual(objects[o], Lr, nacelle(objects[o], Lr, n), obj);
            }
            print(vertices(obj), row);
        }
    "#);
    assert_eq!(out.len(), 3, "{out:?}");
    for line in &out {
        let v = numbers(line);
        let (count, r) = (v[0], &v[1..]);
        assert!(count > 500.0, "{line}");
        // Monotone, down to round-off.
        for n in 1..4 {
            assert!(r[n] <= r[n - 1] || r[n] < 1e-13, "{line}");
        }
        assert!(r[0] > 1e-4, "one step is not already exact: {line}");
        // The stated tolerance: 1e-8 after three iterations.
        assert!(r[2] < 1e-8, "{line}");
    }
}

#[test]
fn an_exact_sphere_distance_gives_the_full_step() {
    let out = run(r#"
        scalarfield Lr = sphere((0, 0, 0), 1.0);
        vector p = (0.3, -0.2, 0.5);
        // The printed root: Γ is round-off, and (−1 + √(1 + 2ΔΓ))/Γ is no step at all.
        vectorfield B = grad(Lr);
        scalarfield del = (ellipsoid - Lr) / (B * B);
        scalarfield Gamma = (B * grad(grad(Lr)) * B) / (B * B);
        scalarfield A = (scalarfield(-1) + (scalarfield(1) + 2.0 * del * Gamma) ^ 0.5) / Gamma;
        print(probe(Gamma, p), probe(identity() + A * B, p));
        print(probe(nacelle(ellipsoid, Lr, 1), p));
        print(residual(ellipsoid, Lr, nacelle(ellipsoid, Lr, 1), ls2shape(ellipsoid, d)));
    "#);
    let gamma = numbers(&out[0])[0];
    assert!(gamma.abs() < 1e-14, "{}", out[0]);
    let printed = &numbers(&out[0])[1..];
    let p = [0.3f64, -0.2, 0.5];
    let r = p.iter().map(|c| c * c).sum::<f64>().sqrt();
    // The printed form moves by nothing (or by round-off) where the step should be Δ.
    let printed_move: f64 = printed.iter().zip(&p).map(|(a, b)| (a - b).abs()).sum();
    assert!(
        printed_move < 1e-6 || printed.iter().any(|v| v.is_nan()),
        "{}",
        out[0]
    );
    // Closed form: X = x + Δ·∇Lr with ∇Lr = −x/|x| and Δ = Lo(x) − Lr(x), so |X| = |x| − Δ.
    let scaled = [p[0] / 1.2, p[1] / 0.8, p[2] / 0.9];
    let lo = 1.0 - scaled.iter().map(|c| c * c).sum::<f64>().sqrt();
    let delta = lo - (1.0 - r);
    let got = numbers(&out[1]);
    for k in 0..3 {
        let want = p[k] - delta * p[k] / r;
        assert!((got[k] - want).abs() < 1e-14, "{} vs {want}", out[1]);
    }
    assert!(delta.abs() > 0.01);
    // One step is exact on the whole surface.
    assert!(numbers(&out[2])[0] < 1e-13, "{}", out[2]);
}

#[test]
fn a_planar_reference_gives_the_linear_step_exactly() {
    let out = run(r#"
        scalarfield Lr = plane((0.1, 0.2, 0.3), (1, 2, 2));
        vectorfield X = nacelle(ellipsoid, Lr, 1);
        print(probe(X, (0.4, -0.3, 0.2)), probe(ellipsoid, (0.4, -0.3, 0.2)), probe(Lr, (0.4, -0.3, 0.2)));
        print(residual(ellipsoid, Lr, X, ls2shape(ellipsoid, d)));
    "#);
    let v = numbers(&out[0]);
    let (x, lo, lr) = ([v[0], v[1], v[2]], v[3], v[4]);
    // Lr = −(x − p)·n̂: ∇Lr = −n̂, |∇Lr|² = 1, Hessian zero, so X = x + (Lo − Lr)(−n̂).
    let n = [1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0];
    let p = [0.4, -0.3, 0.2];
    for k in 0..3 {
        let want = p[k] - (lo - lr) * n[k];
        assert!((x[k] - want).abs() < 1e-15, "{} vs {want}", out[0]);
    }
    assert!(numbers(&out[1])[0] < 1e-14, "{}", out[1]);
}

#[test]
fn no_real_root_is_clamped_finite_and_counted() {
    // Reference (1 − |x|⁴)/4: Γ = −3|x|² and 1 + 2ΔΓ = 1 − 6(Lo − Lr)/|x|⁴, negative on the
    // surface of an object wherever |x|⁴ > 3 (|x| > 1.316). A sphere of radius 2 lies there.
    let out = run(r#"
        scalarfield Lr = 0.25 * (1.0 - (identity() * identity()) ^ 2);
        scalarfield far = sphere((0, 0, 0), 2.0);
        domain big((-2.5, -2.5, -2.5), (5, 5, 5), (0, 0, 0), 0.25);
        shape obj = ls2shape(far, big);
        print(vertices(obj), nacelleclamped(far, Lr, 3, obj));
        vectorfield X = nacelle(far, Lr, 3);
        vector[] moved = pointattr(warpshape(obj, X), "P");
        float worst = 0;
        for (int i = 0; i < size(moved); i++) { worst = max(worst, length(moved[i])); }
        print(worst, residual(far, Lr, nacelle(far, Lr, 1), obj), residual(far, Lr, X, obj));
    "#);
    let v = numbers(&out[0]);
    // Every vertex is clamped in the first step; the vertex steps bring them back within reach.
    assert_eq!(v[1], v[0], "{}", out[0]);
    assert!(v[3] < v[1], "{}", out[0]);
    let w = numbers(&out[1]);
    assert!(w.iter().all(|x| x.is_finite()), "{}", out[1]);
    assert!(w[0] < 2.5, "{}", out[1]);
    assert!(w[2] < w[1], "{}", out[1]);
}

#[test]
fn a_vanishing_gradient_gives_a_finite_warp() {
    let out = run(r#"
        print(probe(nacelle(ellipsoid, sphere((0, 0, 0), 1.0), 3), (0, 0, 0)));
        print(probe(nacelle(ellipsoid, 0.25 * (1.0 - (identity() * identity()) ^ 2), 3), (0, 0, 0)));
        print(probe(nacelle(ellipsoid, 0.25 * (1.0 - (identity() * identity()) ^ 2), 3), (1e-4, 0, 0)));
    "#);
    assert_eq!(numbers(&out[0]), [0.0, 0.0, 0.0], "{}", out[0]);
    assert_eq!(numbers(&out[1]), [0.0, 0.0, 0.0], "{}", out[1]);
    assert!(numbers(&out[2]).iter().all(|v| v.is_finite()), "{}", out[2]);
}

#[test]
fn the_cached_variant_stays_close_to_the_exact_one() {
    let out = run(r#"
        scalarfield Lr = sin(1.0 - length(identity()));
        shape obj = ls2shape(conetori, d);
        float[] exact;
        float[] cached;
        for (int n = 1; n <= 4; n++) {
            exact[size(exact)] = residual(conetori, Lr, nacelle(conetori, Lr, n), obj);
            cached[size(cached)] = residual(conetori, Lr, nacelle(conetori, Lr, n, d), obj);
        }
        print(exact);
        print(cached);
    "#);
    let (exact, cached) = (numbers(&out[0]), numbers(&out[1]));
    // The stated factor: within 3× of the exact residual after one step, and converging
    // (the fixed point Lo = Lr(X) does not depend on the cached B·B and B·M·B) to below 1e-5
    // after four.
    assert!(cached[0] < 3.0 * exact[0], "{exact:?} {cached:?}");
    for n in 1..4 {
        assert!(cached[n] < cached[n - 1], "{cached:?}");
    }
    assert!(cached[3] < 1e-5, "{cached:?}");
}

#[test]
fn bad_nacelle_arguments_are_diagnostics() {
    for (body, message) in [
        (
            "vectorfield X = nacelle(ring, ring, 0);",
            "at least one iteration",
        ),
        ("vectorfield X = nacelle(ring, ring, 1000);", "at most 64"),
        (
            "domain nocells((0, 0, 0), (1, 1, 1), (0, 0, 0)); vectorfield X = nacelle(ring, ring, 1, nocells);",
            "cell size",
        ),
    ] {
        let outcome = common::run_source("bad.felt", &format!("{OBJECTS}\n{body}"));
        assert!(!outcome.ok, "{body}");
        assert!(outcome.rendered.contains(message), "{}", outcome.rendered);
        assert!(
            outcome.rendered.contains("bad.felt:"),
            "{}",
            outcome.rendered
        );
    }
}
