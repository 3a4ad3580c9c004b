//! Statistical tests of the noise: the variance of Perlin and simplex noise against closed
//! forms, and the hard case of distance: noise 1e5 units from the origin, evaluated in `f32`
//! blocks, has the statistics and the smoothness of noise near the origin.

use super::tests::{KINDS, Stream, full_f32, full_f64, random_points};
use super::*;
use crate::space::BLOCK;

/// `∫₀¹ f` by the midpoint rule.
fn integrate(f: impl Fn(f64) -> f64) -> f64 {
    let n = 20_000;
    (0..n).map(|i| f((i as f64 + 0.5) / n as f64)).sum::<f64>() / n as f64
}

/// Mean and variance of a sample.
fn moments(values: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let n = values.clone().count() as f64;
    let mean = values.clone().sum::<f64>() / n;
    let variance = values.map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, variance)
}

/// Over random gradients the noise has mean 0 (`g` and `−g` are equally likely) and, since
/// distinct corners are independent and `E[g gᵀ] = ⅔ I` for the twelve edge vectors,
/// variance `⅔·Σ w²|d|²` at a point. Averaged over space:
/// Perlin `⅔·3·A·B²` with `A = ∫ (1−s)²t² + s²(1−t)²`, `B = ∫ (1−s)² + s²`;
/// simplex `SCALE²·⅔·ρ·∫ 4πr²·(½ − r²)⁸·r² dr`, with `ρ = 2` lattice points per unit volume
/// (unskewing halves volumes). Points 1000 units apart sample that average.
#[test]
fn variance_matches_the_closed_form() {
    let fade = |t: f64| perlin::fade(t).0;
    let a = integrate(|t| (1.0 - fade(t)).powi(2) * t * t + fade(t).powi(2) * (1.0 - t).powi(2));
    let b = integrate(|t| (1.0 - fade(t)).powi(2) + fade(t).powi(2));
    let perlin_variance = 2.0 / 3.0 * 3.0 * a * b * b;
    let radius = 0.5f64.sqrt();
    let radial = radius
        * integrate(|u| {
            let r = u * radius;
            4.0 * std::f64::consts::PI * r.powi(4) * (0.5 - r * r).powi(8)
        });
    let simplex_variance = simplex::SCALE.powi(2) * 2.0 / 3.0 * 2.0 * radial;
    // Standard deviations 0.2700 and 0.3880.
    assert!((perlin_variance.sqrt() - 0.2700).abs() < 1e-3);
    assert!((simplex_variance.sqrt() - 0.3880).abs() < 1e-3);

    let mut stream = Stream::new(3);
    let points = random_points(&mut stream, 60_000, 0.0, 1e4);
    for (kind, variance) in [
        (NoiseKind::Perlin, perlin_variance),
        (NoiseKind::Simplex, simplex_variance),
    ] {
        let samples = full_f64(kind, 9, &points);
        let (mean, measured) = moments(samples.iter().map(|s| s.0));
        // Standard error of the mean ≈ 0.0016; of the variance ≈ 1 %.
        assert!(mean.abs() < 0.008, "{kind:?}: mean {mean}");
        assert!(
            (measured / variance - 1.0).abs() < 0.04,
            "{kind:?}: variance {measured} vs {variance}"
        );
    }
}

/// What a set of rows of samples shows: value mean and variance, mean square and largest
/// difference quotient between neighbours, largest exact gradient length.
#[derive(Debug)]
struct RowStatistics {
    mean: f64,
    variance: f64,
    mean_square_slope: f64,
    largest_slope: f64,
    largest_gradient: f64,
    /// Largest gap between a difference quotient and the mean of the exact x-derivatives at
    /// its two ends (the trapezoid rule, exact to `h²·f'''/12`).
    largest_mismatch: f64,
}

/// Rows of `BLOCK` points `h` apart along x, each a block based at `centre` plus a random
/// shift, evaluated in f32.
fn row_statistics(kind: NoiseKind, centre: f64, stream: &mut Stream) -> RowStatistics {
    let h = 1.0 / 32.0;
    let offsets: Vec<[f32; 3]> = (0..BLOCK)
        .map(|i| [(i as f64 * h) as f32, 0.0, 0.0])
        .collect();
    let mut values = Vec::new();
    let mut quotients = Vec::new();
    let mut largest_gradient: f64 = 0.0;
    let mut largest_mismatch: f64 = 0.0;
    for _ in 0..300 {
        let base = [0, 1, 2].map(|_| centre + stream.range(-50.0, 50.0));
        let row = full_f32(kind, 17, base, &offsets, BLOCK);
        for pair in row.windows(2) {
            let quotient = (pair[1].0 as f64 - pair[0].0 as f64) / h;
            let trapezoid = 0.5 * (pair[0].1[0] as f64 + pair[1].1[0] as f64);
            largest_mismatch = largest_mismatch.max((quotient - trapezoid).abs());
            quotients.push(quotient);
        }
        for s in &row {
            values.push(s.0 as f64);
            let g = s.1.map(f64::from);
            largest_gradient =
                largest_gradient.max((g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt());
        }
    }
    let (mean, variance) = moments(values.iter().copied());
    RowStatistics {
        mean,
        variance,
        mean_square_slope: quotients.iter().map(|q| q * q).sum::<f64>() / quotients.len() as f64,
        largest_slope: quotients.iter().fold(0.0, |m, q| m.max(q.abs())),
        largest_gradient,
        largest_mismatch,
    }
}

/// 76 800 samples near the origin and 1e5 away (in f32 blocks with an f64 base) agree in
/// mean (±0.03: rows span 8 cells, so about 2400 independent cells give a standard error
/// near 0.006 per mean), variance and mean square slope (±6 %), largest slope and gradient (±15 %,
/// extremes of 76 800 samples); far rows are as smooth as near ones: difference quotients
/// match the exact derivative and never exceed the Lipschitz bound.
#[test]
fn far_noise_has_the_statistics_of_near_noise() {
    for kind in KINDS {
        let mut stream = Stream::new(8);
        let near = row_statistics(kind, 0.0, &mut stream);
        for centre in [1.0e5, -1.0e5] {
            let far = row_statistics(kind, centre, &mut stream);
            let close = |a: f64, b: f64, relative: f64| (a / b - 1.0).abs() < relative;
            assert!(
                (near.mean - far.mean).abs() < 0.03,
                "{kind:?}: {near:?} {far:?}"
            );
            assert!(
                close(far.variance, near.variance, 0.06),
                "{kind:?}: {near:?} {far:?}"
            );
            assert!(
                close(far.mean_square_slope, near.mean_square_slope, 0.06),
                "{kind:?}: {near:?} {far:?}"
            );
            assert!(
                close(far.largest_slope, near.largest_slope, 0.15),
                "{kind:?}: {near:?} {far:?}"
            );
            assert!(
                close(far.largest_gradient, near.largest_gradient, 0.15),
                "{kind:?}: {near:?} {far:?}"
            );
            for stats in [&near, &far] {
                assert!(
                    stats.largest_slope <= lipschitz(kind) + 1e-3,
                    "{kind:?}: {stats:?}"
                );
                // Perlin and simplex are C², so the trapezoid rule is off by h²/12·|f‴|, up
                // to about 0.03 for simplex at h = 1/32. Positions quantised to f32 at 1e5
                // (steps of 1/128) would put errors near 1 into the quotients. Worley's
                // derivative jumps across Voronoi faces, where the rule does not apply.
                if kind != NoiseKind::Worley {
                    assert!(stats.largest_mismatch < 0.05, "{kind:?}: {stats:?}");
                }
            }
        }
    }
}
