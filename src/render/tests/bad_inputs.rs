//! Input values the march cannot use: NaN, infinite and negative samples of each field are read
//! by `Scene`'s one rule, counted exactly, and reported in one warning per field.

use super::*;
use crate::base::failure::{grouped, vector_text};
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

/// Counts of a test field's evaluations: all of them, the NaN or infinite ones, the negative ones.
#[derive(Default)]
struct Tally {
    calls: AtomicU64,
    non_finite: AtomicU64,
    negative: AtomicU64,
}

impl Tally {
    /// Records one evaluation that returned `values`, as the march counts samples.
    fn note(&self, values: &[f64]) {
        self.calls.fetch_add(1, Relaxed);
        if values.iter().any(|v| !v.is_finite()) {
            self.non_finite.fetch_add(1, Relaxed);
        } else if values.iter().any(|&v| v < 0.0) {
            self.negative.fetch_add(1, Relaxed);
        }
    }

    fn check(&self, counts: &InputCounts) {
        assert_eq!(counts.samples, self.calls.load(Relaxed), "{counts:?}");
        assert_eq!(
            counts.non_finite,
            self.non_finite.load(Relaxed),
            "{counts:?}"
        );
        assert_eq!(counts.negative, self.negative.load(Relaxed), "{counts:?}");
    }
}

/// The box `[-1, 1]² × [-0.5, 0.5]` marched with steps of 0.05 and κ = 2, 8 × 8 pixels.
fn settings() -> RenderSettings {
    RenderSettings {
        bounds: Some(Aabb::new(
            DVec3::new(-1.0, -1.0, -0.5),
            DVec3::new(1.0, 1.0, 0.5),
        )),
        step: Some(0.05),
        kappa: DVec3::splat(2.0),
        ..small(8, 8)
    }
}

fn message(stats: &RenderStats, field: &str) -> String {
    let found: Vec<RenderWarning> = stats
        .warnings()
        .into_iter()
        .filter(|w| w.message.starts_with(&format!("render: {field} ")))
        .collect();
    assert_eq!(found.len(), 1, "{:?}", stats.warnings());
    found[0].message.clone()
}

#[test]
fn non_finite_density_is_empty_and_negative_emission_is_dark() {
    // In the slab |z| <= 0.25 the density is 1 where x > 0 and NaN (y < 0) or +inf (y > 0)
    // where x < 0; elsewhere in the box it is -1. Emission is 0.5 where x < 0 and -2 where x > 0.
    let (rho, glow) = (Tally::default(), Tally::default());
    let density = FnField::new(1, |p: DVec3, out: &mut [f64]| {
        out[0] = if p.z.abs() > 0.25 {
            -1.0
        } else if p.x > 0.0 {
            1.0
        } else if p.y < 0.0 {
            f64::NAN
        } else {
            f64::INFINITY
        };
        rho.note(out);
    });
    let emission = FnField::new(3, |p: DVec3, out: &mut [f64]| {
        out.fill(if p.x < 0.0 { 0.5 } else { -2.0 });
        glow.note(out);
    });
    let mut sc = scene(&density, vec![]);
    sc.emission = Some(&emission);
    let (image, stats) = render_with_stats(&sc, &settings()).unwrap();
    for y in 0..8 {
        for x in 0..8 {
            let p = image.rgba[y * 8 + x];
            if x < 4 {
                // Infinite and NaN density alike are empty: alpha 0, and the emission crosses
                // the unit depth of the box unabsorbed.
                assert_eq!(p[3], 0.0, "{x} {y}");
                assert!((p[0] - 0.5).abs() < 1e-6, "{p:?}");
            } else {
                // The slab absorbs; negative emission is no light, not negative light.
                assert!(
                    (p[3] as f64 - (1.0 - (-1.0f64).exp())).abs() < 1e-6,
                    "{p:?}"
                );
                assert_eq!(&p[..3], &[0.0; 3]);
            }
        }
    }
    rho.check(&stats.march.density);
    glow.check(&stats.march.emission);
    let d = &stats.march.density;
    assert!(d.non_finite > 0 && d.negative > 0 && stats.march.emission.negative > 0);
    let first = d.first_non_finite.unwrap();
    assert!(first.x < 0.0 && first.z.abs() <= 0.25, "{first}");
    assert_eq!(
        message(&stats, "density"),
        format!(
            "render: density was NaN or infinite at {} of {} samples (treated as 0: empty), the \
             first at {}, and negative at {} (clamped to 0)",
            grouped(d.non_finite),
            grouped(d.samples),
            vector_text(first),
            grouped(d.negative)
        )
    );
    assert_eq!(
        message(&stats, "emission"),
        format!(
            "render: emission was negative at {} of {} samples (clamped to 0)",
            grouped(stats.march.emission.negative),
            grouped(stats.march.emission.samples)
        )
    );
    assert_eq!(stats.warnings().len(), 2);
}

#[test]
fn bad_colour_is_black_and_bad_holdouts_follow_the_same_rule() {
    // Density 1 in the slab. Colour NaN where x < 0, (-1, 0.5, 0.5) where x > 0. Holdout NaN
    // where y > 0 (read as 1: not held out) and -0.5 where y < 0 (clamped to 0: held out).
    let density = slab(1, DVec3::ONE, -0.25, 0.25);
    let (tint, hold) = (Tally::default(), Tally::default());
    let color = FnField::new(3, |p: DVec3, out: &mut [f64]| {
        if p.x < 0.0 {
            out.fill(f64::NAN);
        } else {
            out.copy_from_slice(&[-1.0, 0.5, 0.5]);
        }
        tint.note(out);
    });
    let holdout = FnField::new(1, |p: DVec3, out: &mut [f64]| {
        out[0] = if p.y > 0.0 { f64::NAN } else { -0.5 };
        hold.note(out);
    });
    let mut sc = scene(&density, vec![]);
    sc.color = Some(&color);
    sc.holdout = Some(&holdout);
    let settings = RenderSettings {
        ambient: DVec3::ONE,
        ..settings()
    };
    let (image, stats) = render_with_stats(&sc, &settings).unwrap();
    let alpha = (1.0 - (-1.0f64).exp()) as f32;
    for y in 0..8 {
        for x in 0..8 {
            let p = image.rgba[y * 8 + x];
            // Row 0 is the top (y > 0).
            if y >= 4 {
                assert_eq!(&p[..3], &[0.0; 3], "held out at {x} {y}");
                assert!(p[3].abs() < 1e-6, "{p:?}");
            } else if x < 4 {
                assert_eq!(&p[..3], &[0.0; 3]);
                assert!((p[3] - alpha).abs() < 1e-6, "{p:?}");
            } else {
                assert_eq!(p[0], 0.0);
                assert!(p[1] > 0.1 && p[1] == p[2], "{p:?}");
                assert!((p[3] - alpha).abs() < 1e-6, "{p:?}");
            }
        }
    }
    tint.check(&stats.march.color);
    hold.check(&stats.march.holdout);
    let (c, h) = (&stats.march.color, &stats.march.holdout);
    assert!(c.non_finite > 0 && c.negative > 0 && h.non_finite > 0 && h.negative > 0);
    let (cf, hf) = (c.first_non_finite.unwrap(), h.first_non_finite.unwrap());
    assert_eq!(
        message(&stats, "color"),
        format!(
            "render: color was NaN or infinite at {} of {} samples (treated as 0: black), the \
             first at {}, and negative at {} (clamped to 0)",
            grouped(c.non_finite),
            grouped(c.samples),
            vector_text(cf),
            grouped(c.negative)
        )
    );
    assert_eq!(
        message(&stats, "holdout"),
        format!(
            "render: holdout was NaN or infinite at {} of {} samples (treated as 1: not held \
             out), the first at {}, and negative at {} (clamped to 0)",
            grouped(h.non_finite),
            grouped(h.samples),
            vector_text(hf),
            grouped(h.negative)
        )
    );
    assert_eq!(stats.warnings().len(), 2, "{:?}", stats.warnings());
}

#[test]
fn clean_inputs_give_no_warnings_and_counts_do_not_depend_on_threads() {
    let density = FnField::new(1, |p: DVec3, out: &mut [f64]| {
        out[0] = if p.x * p.y > 0.1 {
            f64::NAN
        } else {
            0.7 - p.length()
        };
    });
    let sc = scene(&density, vec![]);
    let in_pool = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| render_with_stats(&sc, &settings()).unwrap())
    };
    let ((one, a), (three, b)) = (in_pool(1), in_pool(3));
    let bits = |im: &Image| -> Vec<u32> { im.rgba.iter().flatten().map(|x| x.to_bits()).collect() };
    assert_eq!(bits(&one), bits(&three));
    assert_eq!(a.march, b.march);
    assert!(a.march.density.non_finite > 0 && a.march.density.negative > 0);
    assert!(
        one.rgba
            .iter()
            .flatten()
            .all(|v| v.is_finite() && *v >= 0.0)
    );

    let clean = slab(1, DVec3::ONE, -0.25, 0.25);
    let (_, stats) = render_with_stats(&scene(&clean, vec![]), &settings()).unwrap();
    assert!(stats.march.density.is_clean());
    assert_eq!(stats.warnings(), Vec::new());
}

#[test]
fn pixels_that_overflow_are_counted() {
    // κ = 0 and a density near the f32 limit over a unit depth: ρ·Δs summed is finite in f64
    // but the colour exceeds what an f32 pixel holds.
    let density = slab(1, DVec3::splat(3e38), -0.5, 0.5);
    let settings = RenderSettings {
        kappa: DVec3::ZERO,
        ambient: DVec3::splat(1e10),
        ..settings()
    };
    let (image, stats) = render_with_stats(&scene(&density, vec![]), &settings).unwrap();
    assert!(
        image
            .rgba
            .iter()
            .all(|p| p[0] == f32::INFINITY && p[3] == 0.0)
    );
    assert_eq!(stats.march.bad_pixels, 3 * 64);
    assert_eq!(
        stats.warnings()[0].message,
        "render: 192 pixel values overflowed the 32-bit image (infinite ones are written as \
         infinity, NaN ones as 0)"
    );
}
