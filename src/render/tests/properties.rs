//! Properties every render must have: ranges, determinism, agreement between methods, skipped
//! empty space, convergence of adaptive steps, and clear failures.

use super::*;
use crate::render::testing::{Ball, Pieces};
use crate::space::FnField;
use std::sync::atomic::Ordering;

#[test]
fn random_fields_keep_alpha_in_range_colour_non_negative_and_transmittance_falling() {
    // Every step of these renders also checks (debug assertion in the march) that the
    // transmittance stays in [0, 1] and never rises along the ray.
    let mut state = 0x1234_5678_9abc_def0u64;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for case in 0..12 {
        let mut balls = Vec::new();
        for _ in 0..4 {
            balls.push(Ball {
                centre: DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5),
                radius: 0.1 + 0.4 * next(),
                value: 10f64.powf(3.0 * next() - 1.0),
            });
        }
        let density = Pieces::new(balls.clone());
        let color = Pieces::new(balls.clone()).tinted(&[next(), next(), next()]);
        let emission = Pieces::new(balls).tinted(&[next(), 0.0, next()]);
        let kappa = match case % 3 {
            0 => DVec3::ZERO,
            1 => DVec3::new(next() * 10.0, next(), 1e6 * next()),
            _ => DVec3::splat(next() * 5.0),
        };
        let lights = vec![
            Light::distant(
                DVec3::new(next() - 0.5, -1.0, next() - 0.5),
                DVec3::splat(next()),
            )
            .unwrap(),
            Light::point(DVec3::new(2.0 * next(), 1.0, 0.5), DVec3::splat(2.0)).unwrap(),
        ];
        let mut sc = scene(&density, lights);
        sc.color = Some(&color);
        sc.emission = Some(&emission);
        sc.camera = Camera::new(DVec3::new(0.3, 0.2, 3.0), DVec3::ZERO, DVec3::Y, 40.0).unwrap();
        let settings = RenderSettings {
            kappa,
            step: Some(0.005 + 0.05 * next()),
            spp: 1 + (case % 2) as u32,
            seed: case as u64,
            adaptive: (case % 4 == 3).then(|| Adaptive::around(0.02)),
            shadows: if case % 5 == 4 {
                Shadows::March
            } else {
                Shadows::default()
            },
            phase: Phase::HenyeyGreenstein { g: 0.6 },
            multiscatter: (case % 2 == 0).then(MultiScatter::default),
            powder: Some(next()),
            ..small(12, 10)
        };
        let image = render(&sc, &settings).unwrap();
        for p in &image.rgba {
            assert!((0.0..=1.0).contains(&p[3]), "case {case}: alpha {}", p[3]);
            assert!(
                p[..3].iter().all(|v| v.is_finite() && *v >= 0.0),
                "case {case}: {p:?}"
            );
        }
    }
}

#[test]
fn cached_and_marched_shadows_agree() {
    // A ball lit obliquely: the shadow grid (swept, default cell) against a march towards the
    // light from every sample. Stated tolerance: RMSE of the colour below 1% of its peak.
    let ball = Pieces::new(vec![Ball {
        centre: DVec3::ZERO,
        radius: 0.8,
        value: 1.0,
    }]);
    let light = Light::distant(DVec3::new(0.5, -1.0, -0.3), DVec3::ONE).unwrap();
    let mut sc = scene(&ball, vec![light]);
    sc.camera = Camera::new(DVec3::new(0.0, 0.0, 4.0), DVec3::ZERO, DVec3::Y, 30.0).unwrap();
    let base = RenderSettings {
        kappa: DVec3::splat(2.0),
        step: Some(0.02),
        ..small(32, 32)
    };
    let cached = render(&sc, &base).unwrap();
    let marched = render(
        &sc,
        &RenderSettings {
            shadows: Shadows::March,
            ..base.clone()
        },
    )
    .unwrap();
    let peak = marched.rgba.iter().map(|p| p[0]).fold(0.0f32, f32::max) as f64;
    let rmse = (cached
        .rgba
        .iter()
        .zip(&marched.rgba)
        .map(|(a, b)| ((a[0] - b[0]) as f64).powi(2))
        .sum::<f64>()
        / cached.rgba.len() as f64)
        .sqrt();
    assert!(peak > 0.05, "{peak}");
    assert!(rmse < 0.01 * peak, "rmse {rmse} peak {peak}");
    // Alpha does not depend on shadows at all.
    assert!(
        cached
            .rgba
            .iter()
            .zip(&marched.rgba)
            .all(|(a, b)| a[3] == b[3])
    );
}

#[test]
fn empty_bricks_are_never_sampled() {
    // Two balls far apart: the space between them is proven empty by interval ranges, so no
    // sample may fall in |x| < 2.
    let gap = Aabb::new(DVec3::new(-2.0, -5.0, -5.0), DVec3::new(2.0, 5.0, 5.0));
    let balls = Pieces::new(vec![
        Ball {
            centre: DVec3::new(-3.0, 0.0, 0.0),
            radius: 0.5,
            value: 1.0,
        },
        Ball {
            centre: DVec3::new(3.0, 0.0, 0.0),
            radius: 0.5,
            value: 1.0,
        },
    ])
    .forbidding(gap);
    let light = Light::distant(-DVec3::Y, DVec3::ONE).unwrap();
    let mut sc = scene(&balls, vec![light]);
    // Looking along x through both balls and the gap.
    sc.camera = Camera::new(DVec3::new(-8.0, 0.0, 0.0), DVec3::ZERO, DVec3::Y, 10.0).unwrap();
    let settings = RenderSettings {
        step: Some(0.01),
        ..small(16, 16)
    };
    let (image, stats) = render_with_stats(&sc, &settings).unwrap();
    assert!(image.rgba.iter().any(|p| p[3] > 0.5));
    assert!(stats.empty_bricks > stats.bricks / 2, "{stats:?}");
    assert!(balls.evaluated.load(Ordering::Relaxed) > 0);
    assert_eq!(balls.evaluated_forbidden.load(Ordering::Relaxed), 0);
}

#[test]
fn images_are_bit_identical_for_any_thread_count() {
    let ball = Pieces::new(vec![
        Ball {
            centre: DVec3::ZERO,
            radius: 0.7,
            value: 2.0,
        },
        Ball {
            centre: DVec3::new(0.4, 0.3, 0.2),
            radius: 0.3,
            value: 5.0,
        },
    ]);
    let light = Light::distant(DVec3::new(0.5, -1.0, -0.3), DVec3::ONE).unwrap();
    let mut sc = scene(&ball, vec![light]);
    sc.camera = Camera::new(DVec3::new(0.0, 0.5, 3.0), DVec3::ZERO, DVec3::Y, 40.0).unwrap();
    let settings = RenderSettings {
        spp: 3,
        step: Some(0.03),
        adaptive: Some(Adaptive::around(0.03)),
        aovs: Aovs {
            depth: true,
            transmittance: true,
            emission: true,
            lights: true,
            position: true,
            normal: true,
            ..Aovs::default()
        },
        ..small(37, 21)
    };
    let in_pool = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| render(&sc, &settings).unwrap())
    };
    let (one, two) = (in_pool(1), in_pool(2));
    let bits = |im: &Image| -> Vec<u32> {
        let mut v: Vec<u32> = im.rgba.iter().flatten().map(|x| x.to_bits()).collect();
        for (_, channel) in &im.aovs {
            v.extend(channel.iter().map(|x| x.to_bits()));
        }
        v
    };
    assert!(one.rgba.iter().any(|p| p[3] > 0.1));
    assert_eq!(bits(&one), bits(&two));
}

#[test]
fn adaptive_steps_converge_to_the_fine_march_with_fewer_samples() {
    // A small dense ball in a large, mostly empty box whose field gives no range information,
    // so only the step control can save samples.
    let field = FnField::new(1, |p: DVec3, out: &mut [f64]| {
        out[0] = if p.length() < 0.3 { 8.0 } else { 0.0 };
    })
    .with_bounds(Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)));
    let light = Light::distant(DVec3::new(0.0, -1.0, -1.0), DVec3::ONE).unwrap();
    let mut sc = scene(&field, vec![light]);
    sc.camera = Camera::new(DVec3::new(0.0, 0.0, 6.0), DVec3::ZERO, DVec3::Y, 8.0).unwrap();
    let fine_step = 0.004;
    let run_seeded = |step: f64, adaptive: Option<Adaptive>, seed: u64| {
        let settings = RenderSettings {
            step: Some(step),
            adaptive,
            seed,
            shadows: Shadows::Cache {
                cell_size: Some(0.05),
                method: TransmissivityMethod::Auto,
            },
            ..small(24, 24)
        };
        render_with_stats(&sc, &settings).unwrap()
    };
    let run = |step: f64, adaptive: Option<Adaptive>| run_seeded(step, adaptive, 0);
    // Steps of 8 × the fine one where nothing happens; a step only sees its midpoint, so the
    // longest step must still resolve the thinnest feature (here the ball's chords near its
    // silhouette).
    let (fine, fine_stats) = run(fine_step, None);
    let (coarse, _) = run(8.0 * fine_step, None);
    let adaptive = Adaptive {
        min_step: fine_step,
        max_step: 8.0 * fine_step,
        tolerance: 1.0 / 512.0,
    };
    let (adapted, adapted_stats) = run(fine_step, Some(adaptive));
    let rmse = |a: &Image, b: &Image| {
        let sum: f64 = a
            .rgba
            .iter()
            .zip(&b.rgba)
            .flat_map(|(p, q)| (0..4).map(move |c| ((p[c] - q[c]) as f64).powi(2)))
            .sum();
        (sum / (4 * a.rgba.len()) as f64).sqrt()
    };
    let (adaptive_error, coarse_error) = (rmse(&adapted, &fine), rmse(&coarse, &fine));
    // The fine march itself differs from a differently jittered fine march by its noise.
    let noise = rmse(&run_seeded(fine_step, None, 1).0, &fine);
    assert!(
        adaptive_error < 1.5 * noise,
        "adaptive {adaptive_error}, fine-step noise {noise}"
    );
    assert!(
        adaptive_error < 0.5 * coarse_error,
        "adaptive {adaptive_error} coarse {coarse_error}"
    );
    let (a, f) = (adapted_stats.march.samples, fine_stats.march.samples);
    assert!(a * 4 < f, "adaptive {a} samples, fixed fine {f}");
}

#[test]
fn bad_scenes_and_settings_are_failures_with_help() {
    let density = slab(1, DVec3::ONE, -0.3, 0.3);
    let vector = slab(3, DVec3::ONE, -0.3, 0.3);
    let good = scene(&density, vec![]);
    let settings = small(4, 4);
    let err = render(&scene(&vector, vec![]), &settings).unwrap_err();
    assert!(
        err.message.contains("density must be a scalar field"),
        "{}",
        err.message
    );
    let mut wrong_color = scene(&density, vec![]);
    wrong_color.color = Some(&density);
    assert!(
        render(&wrong_color, &settings)
            .unwrap_err()
            .message
            .contains("color")
    );
    for bad in [
        RenderSettings {
            step: Some(-1.0),
            ..small(4, 4)
        },
        RenderSettings {
            width: 0,
            ..small(4, 4)
        },
        RenderSettings {
            spp: 0,
            ..small(4, 4)
        },
        RenderSettings {
            kappa: DVec3::new(-1.0, 0.0, 0.0),
            ..small(4, 4)
        },
        RenderSettings {
            step: Some(1e-9),
            ..small(4, 4)
        },
    ] {
        assert!(render(&good, &bad).is_err(), "{bad:?}");
    }
    let unbounded = FnField::new(1, |_p: DVec3, out: &mut [f64]| out[0] = 1.0);
    let err = render(&scene(&unbounded, vec![]), &settings).unwrap_err();
    assert!(
        err.help
            .as_deref()
            .unwrap_or("")
            .contains("pass bounds = some domain")
    );
    // With bounds given, the same field renders.
    let bounded = RenderSettings {
        bounds: Some(Aabb::new(DVec3::splat(-0.5), DVec3::splat(0.5))),
        ..small(4, 4)
    };
    let image = render(&scene(&unbounded, vec![]), &bounded).unwrap();
    assert!((image.rgba[0][3] as f64 - (1.0 - (-1.0f64).exp())).abs() < 1e-5);
}

#[test]
fn seeds_change_the_jitter_and_nothing_else() {
    let ball = Pieces::new(vec![Ball {
        centre: DVec3::ZERO,
        radius: 0.5,
        value: 3.0,
    }]);
    let mut sc = scene(&ball, vec![]);
    sc.camera = Camera::new(DVec3::new(0.0, 0.0, 3.0), DVec3::ZERO, DVec3::Y, 30.0).unwrap();
    let at = |seed: u64| {
        let settings = RenderSettings {
            seed,
            spp: 4,
            step: Some(0.05),
            ..small(16, 16)
        };
        render(&sc, &settings).unwrap()
    };
    let (a, b, c) = (at(1), at(1), at(2));
    assert_eq!(a, b);
    assert_ne!(a, c);
    let mean_alpha = |im: &Image| im.rgba.iter().map(|p| p[3] as f64).sum::<f64>() / 256.0;
    assert!((mean_alpha(&a) - mean_alpha(&c)).abs() < 0.01);
}
