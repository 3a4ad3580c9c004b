//! The deep samples against the flat pixel they must composite to, and the curves' bounds.

use super::*;

fn state(t: f64, c: [f64; 3]) -> [f64; 4] {
    [t, c[0], c[1], c[2]]
}

#[test]
fn samples_composite_to_the_pixel_they_cut() {
    // A pixel's mean curve at four boundaries, worked by hand: T̄ falls 1 → 0.5 → 0.2 → 0.1
    // while C̄ grows; over of the samples is the last boundary's (1 − T̄, C̄).
    let pixel = [
        (1.0, state(1.0, [0.0; 3])),
        (2.0, state(0.5, [0.3, 0.2, 0.1])),
        (3.0, state(0.2, [0.5, 0.2, 0.4])),
        (4.5, state(0.1, [0.55, 0.25, 0.4])),
    ];
    let mut out = Vec::new();
    assert_eq!(samples_between(&pixel, &mut out), 3);
    assert_eq!((out[0].front, out[0].back), (1.0, 2.0));
    assert!((out[1].alpha - 0.6).abs() < 1e-7, "{:?}", out[1]);
    // The second sample's colour is its step over the transmittance in front: 0.2 / 0.5.
    assert!((out[1].color[0] - 0.4).abs() < 1e-7);
    let flat = flatten(&out);
    for (got, want) in flat.iter().zip([0.55, 0.25, 0.4, 0.9]) {
        assert!((got - want).abs() < 1e-7, "{flat:?}");
    }
}

#[test]
fn an_opaque_boundary_and_a_holdout_keep_alphas_in_range_and_flattening_exact() {
    // T̄ falls to 0.1 (or to 0), then a holdout raises it to 0.3, as the march's lerp can.
    for low in [0.1, 0.0] {
        let pixel = [
            (0.0, state(1.0, [0.0; 3])),
            (1.0, state(0.4, [0.2, 0.2, 0.2])),
            (2.0, state(low, [0.5, 0.4, 0.3])),
            (3.0, state(0.3, [0.5, 0.4, 0.3])),
            (4.0, state(0.25, [0.6, 0.4, 0.3])),
        ];
        let mut out = Vec::new();
        samples_between(&pixel, &mut out);
        assert!(
            out.iter().all(|s| (0.0..=1.0).contains(&s.alpha)),
            "{out:?}"
        );
        assert!(out.iter().all(|s| s.color.iter().all(|c| c.is_finite())));
        let flat = flatten(&out);
        for (got, want) in flat.iter().zip([0.6, 0.4, 0.3, 0.75]) {
            assert!((got - want).abs() < 1e-6, "T̄ down to {low}: {flat:?}");
        }
    }
}

/// A ray through a slab, marched in `steps` equal steps from depth 2 to 3 with optical
/// thickness `tau` and colour `c` per unit of opacity, recorded into `curves` as ray `r`.
fn march_slab(
    curves: &mut DeepCurves,
    r: usize,
    steps: usize,
    tau: f64,
    c: DVec3,
) -> (DVec3, DVec3) {
    let (mut t, mut color) = (DVec3::ONE, DVec3::ZERO);
    let dt = 1.0 / steps as f64;
    for i in 0..steps {
        let after = t * (-tau * dt).exp();
        let gained = c * (t - after).x;
        let t0 = 2.0 + i as f64 * dt;
        curves.record(r, t0, t0 + dt, t, color, after, color + gained);
        t = after;
        color += gained;
    }
    (t, color)
}

#[test]
fn a_long_ray_is_thinned_within_its_bound_and_still_flattens_exactly() {
    for (steps, most, spp) in [(1000, 32, 1), (300, 1, 4), (5, 32, 2), (5000, 1024, 3)] {
        let mut curves = DeepCurves::default();
        let bound = curve_points(most);
        curves.reset(spp, bound);
        let (mut ts, mut cs) = (Vec::new(), Vec::new());
        for r in 0..spp {
            curves.aim(0.0, 1.0);
            let (t, c) = march_slab(
                &mut curves,
                r,
                steps,
                1.0 + r as f64,
                DVec3::new(0.5, 1.0, 2.0),
            );
            assert!(curves.curve(r).len() <= bound);
            ts.push(t);
            cs.push(c);
        }
        let mut out = Vec::new();
        let n = curves.pixel_samples(0..spp, &ts, &cs, most, &mut Vec::new(), &mut out);
        assert!(n <= most && n >= 1, "{n} samples for at most {most}");
        let flat = flatten(&out);
        let mean_t: f64 = ts.iter().map(|t| t.element_sum() / 3.0).sum::<f64>() / spp as f64;
        let mean_c: DVec3 = cs.iter().copied().sum::<DVec3>() / spp as f64;
        for (got, want) in flat
            .iter()
            .zip([mean_c.x, mean_c.y, mean_c.z, 1.0 - mean_t])
        {
            assert!(
                (got - want).abs() < 1e-5,
                "{steps} steps: {flat:?} against {want}"
            );
        }
        for pair in out.windows(2) {
            assert!(pair[0].back <= pair[1].front);
        }
        // The samples span the slab, faces included (its first step begins at 2, its last
        // ends at 3).
        assert_eq!(out[0].front, 2.0);
        assert_eq!(out[n - 1].back, 3.0);
        assert!(out.iter().all(|s| s.front < s.back));
    }
}

#[test]
fn a_rewound_step_leaves_the_curve_as_before_it() {
    let mut curves = DeepCurves::default();
    curves.reset(1, 16);
    curves.aim(1.0, 2.0);
    let half = DVec3::splat(0.5);
    curves.record(0, 0.0, 0.5, DVec3::ONE, DVec3::ZERO, half, DVec3::ONE);
    let kept = curves.curve(0).to_vec();
    curves.record(0, 0.5, 1.0, half, DVec3::ONE, half * 0.5, DVec3::splat(1.5));
    curves.rewind(0, 0.5, half, DVec3::ONE);
    assert_eq!(curves.curve(0), kept.as_slice());
    // Depth follows the ray's line: 1 + 2t.
    assert_eq!((kept[0].depth, kept[1].depth), (1.0, 2.0));
    assert_eq!(curves.state_at(0, 1.5), [0.75, 0.5, 0.5, 0.5]);
}

#[test]
fn an_empty_pixel_has_no_samples() {
    let mut curves = DeepCurves::default();
    curves.reset(2, 16);
    curves.aim(0.0, 1.0);
    curves.aim(0.0, 1.0);
    // A step through empty space records nothing.
    curves.record(
        0,
        0.0,
        1.0,
        DVec3::ONE,
        DVec3::ZERO,
        DVec3::ONE,
        DVec3::ZERO,
    );
    let mut out = Vec::new();
    let finals = [DVec3::ONE; 2];
    let n = curves.pixel_samples(
        0..2,
        &finals,
        &[DVec3::ZERO; 2],
        8,
        &mut Vec::new(),
        &mut out,
    );
    assert_eq!(n, 0);
    assert!(out.is_empty());
}
