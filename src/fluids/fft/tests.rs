//! Value tests of the Fourier-space grid operations: the transform against a direct DFT,
//! random-field statistics against the covariance model, divergence after projection by two
//! independent measures, determinism across thread counts, and errors.

use super::*;

fn domain(counts: [usize; 3], cell: [f64; 3]) -> Domain {
    let mut d = Domain::with_cells(
        DVec3::ZERO,
        DVec3::new(
            counts[0] as f64 * cell[0],
            counts[1] as f64 * cell[1],
            counts[2] as f64 * cell[2],
        ),
        DVec3::ZERO,
        cell[0],
        cell[2],
    )
    .unwrap();
    // `with_cells` takes one spacing for x and y; set y's own for anisotropic tests.
    d.cell = DVec3::from_array(cell);
    d.resolution = Some(counts);
    d
}

fn grid(counts: [usize; 3], cell: [f64; 3]) -> Grid {
    Grid::new(counts, cell).unwrap()
}

fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

/// The divergence of a width-3 field by the given operator, computed in Fourier space for the
/// spectral one and directly in real space (wrapping around) for central differences.
fn divergence(
    counts: [usize; 3],
    cell: [f64; 3],
    data: &[f32],
    op: DivergenceOperator,
) -> Vec<f64> {
    let g = grid(counts, cell);
    let n = g.len;
    match op {
        DivergenceOperator::Spectral => {
            let mut total = vec![Complex64::default(); n];
            for axis in 0..3 {
                let k = g.derivative_symbols(axis, op);
                let mut s: Vec<Complex64> = data[axis * n..(axis + 1) * n]
                    .iter()
                    .map(|v| Complex64::new(*v as f64, 0.0))
                    .collect();
                g.transform(&mut s, FftDirection::Forward);
                for (index, (t, v)) in total.iter_mut().zip(&s).enumerate() {
                    let m = g.cell_of(index)[axis];
                    *t += Complex64::new(0.0, k[m]) * v;
                }
            }
            g.transform(&mut total, FftDirection::Inverse);
            total.iter().map(|v| v.re / n as f64).collect()
        }
        DivergenceOperator::CentralDifference => (0..n)
            .map(|index| {
                let c = g.cell_of(index);
                let mut sum = 0.0;
                for axis in 0..3 {
                    let at = |shift: usize| {
                        let mut q = c;
                        q[axis] = (q[axis] + shift) % counts[axis];
                        data[axis * n + q[0] + counts[0] * (q[1] + counts[1] * q[2])] as f64
                    };
                    sum += (at(1) - at(counts[axis] - 1)) / (2.0 * cell[axis]);
                }
                sum
            })
            .collect(),
    }
}

#[test]
fn transform_matches_a_direct_dft() {
    let counts = [6, 5, 4];
    let g = grid(counts, [1.0; 3]);
    let data: Vec<Complex64> = (0..g.len)
        .map(|i| Complex64::new(white_noise(1, 0, i), white_noise(1, 1, i)))
        .collect();
    let mut fast = data.clone();
    g.transform(&mut fast, FftDirection::Forward);
    for (index, value) in fast.iter().enumerate() {
        let m = g.cell_of(index);
        let mut direct = Complex64::default();
        for (cell, v) in data.iter().enumerate() {
            let x = g.cell_of(cell);
            let phase: f64 = (0..3)
                .map(|a| (m[a] * x[a]) as f64 / counts[a] as f64)
                .sum();
            direct += v * Complex64::from_polar(1.0, -2.0 * PI * phase);
        }
        assert!(
            (direct - value).norm() < 1e-10,
            "mode {m:?}: {value} vs {direct}"
        );
    }
    g.transform(&mut fast, FftDirection::Inverse);
    for (a, b) in fast.iter().zip(&data) {
        assert!((a / g.len as f64 - b).norm() < 1e-12);
    }
}

#[test]
fn white_noise_is_standard_normal() {
    let samples: Vec<f64> = (0..200_000).map(|i| white_noise(9, 2, i)).collect();
    let n = samples.len() as f64;
    let mean = samples.iter().sum::<f64>() / n;
    let variance = samples.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    let within_one = samples.iter().filter(|v| v.abs() < 1.0).count() as f64 / n;
    // Standard errors: 0.0022, 0.0032 and 0.001; P(|x| < 1) = erf(1/√2) = 0.682689.
    assert!(mean.abs() < 0.01, "{mean}");
    assert!((variance - 1.0).abs() < 0.015, "{variance}");
    assert!((within_one - 0.682_689).abs() < 0.005, "{within_one}");
}

/// Mean, variance and autocorrelation at lags ℓ and 2ℓ along each axis, over four seeds, on
/// a 64 × 64 × 32 grid whose z cells are twice as long (so the lags are 4, 4 and 2 cells):
/// the covariance model gives exp(−½) = 0.6065 and exp(−2) = 0.1353. With ℓ = 4 cells a
/// 64³-cell field holds about V/(π^{3/2}ℓ³) ≈ 370 independent blobs per seed, so the
/// standard errors are about 0.02 for the variance and 0.025 for a correlation.
#[test]
fn random_field_matches_the_covariance_model() {
    let counts = [64, 64, 32];
    let cell = [1.0 / 64.0, 1.0 / 64.0, 1.0 / 32.0];
    let correlation = 4.0 / 64.0;
    let d = domain(counts, cell);
    let n = 64 * 64 * 32;
    let mut variance = 0.0;
    let mut lag = [[0.0; 2]; 3];
    let seeds = [1u32, 2, 3, 4];
    for seed in seeds {
        let f = gaussian_random_field(&d, correlation, seed, false).unwrap();
        assert_eq!(f.len(), n);
        let mean = f.iter().map(|v| *v as f64).sum::<f64>() / n as f64;
        assert!(mean.abs() < 1e-6, "seed {seed}: grid mean {mean}");
        let g = grid(counts, cell);
        let at = |c: [usize; 3]| f[c[0] + 64 * (c[1] + 64 * c[2])] as f64;
        for index in 0..n {
            let c = g.cell_of(index);
            let v = at(c);
            variance += v * v;
            for axis in 0..3 {
                let step = (correlation / cell[axis]).round() as usize;
                for (slot, shift) in [step, 2 * step].into_iter().enumerate() {
                    let mut q = c;
                    q[axis] = (q[axis] + shift) % counts[axis];
                    lag[axis][slot] += v * at(q);
                }
            }
        }
    }
    let samples = (n * seeds.len()) as f64;
    let variance = variance / samples;
    assert!((variance - 1.0).abs() < 0.08, "variance {variance}");
    for (axis, sums) in lag.iter().enumerate() {
        let rho1 = sums[0] / samples / variance;
        let rho2 = sums[1] / samples / variance;
        assert!(
            (rho1 - (-0.5f64).exp()).abs() < 0.08,
            "axis {axis}: ρ(ℓ) = {rho1}"
        );
        assert!(
            (rho2 - (-2.0f64).exp()).abs() < 0.08,
            "axis {axis}: ρ(2ℓ) = {rho2}"
        );
    }
}

/// Three independent random fields make a vector field with plenty of divergence. After the
/// spectral projection, its spectral divergence is at f32 round-off and its central-difference
/// divergence is a few percent of the original's (the two derivatives differ by
/// `(kh)²/6` on the field's wavelengths); after the central-difference projection it is the
/// other way round.
#[test]
fn projection_removes_the_divergence() {
    let counts = [32, 32, 24];
    let cell = [0.1, 0.1, 0.125];
    let d = domain(counts, cell);
    let mut field = Vec::new();
    for seed in [11, 12, 13] {
        field.extend(gaussian_random_field(&d, 0.3, seed, false).unwrap());
    }
    let spectral = DivergenceOperator::Spectral;
    let central = DivergenceOperator::CentralDifference;
    let before = [spectral, central].map(|op| rms(&divergence(counts, cell, &field, op)));
    assert!(before[0] > 1.0 && before[1] > 1.0, "{before:?}");

    let mut projected = field.clone();
    project_divergence_free(counts, DVec3::from_array(cell), &mut projected).unwrap();
    let after = [spectral, central].map(|op| rms(&divergence(counts, cell, &projected, op)));
    assert!(
        after[0] < 1e-5 * before[0],
        "spectral {after:?} vs {before:?}"
    );
    assert!(
        after[1] < 0.1 * before[1],
        "central {after:?} vs {before:?}"
    );
    assert!(
        after[1] > 1e-3 * before[1],
        "central {after:?} vs {before:?}"
    );

    let mut wide: Vec<f64> = field.iter().map(|&v| f64::from(v)).collect();
    project_divergence_free_with(counts, DVec3::from_array(cell), &mut wide, central).unwrap();
    let discrete: Vec<f32> = wide.iter().map(|&v| v as f32).collect();
    let after = [spectral, central].map(|op| rms(&divergence(counts, cell, &discrete, op)));
    assert!(
        after[1] < 1e-5 * before[1],
        "central {after:?} vs {before:?}"
    );
    assert!(
        after[0] < 0.1 * before[0],
        "spectral {after:?} vs {before:?}"
    );

    // Projecting twice changes nothing beyond round-off: a projection.
    let mut twice = projected.clone();
    project_divergence_free(counts, DVec3::from_array(cell), &mut twice).unwrap();
    for (a, b) in twice.iter().zip(&projected) {
        assert!((a - b).abs() < 1e-5, "{a} vs {b}");
    }
}

/// A divergence-free random field has unit variance per component and no spectral
/// divergence; in a rotated domain its vectors are in world axes, so rotating them back into
/// the domain's frame gives the divergence-free field of the domain's grid.
#[test]
fn divergence_free_random_field() {
    let counts = [32, 32, 32];
    let cell = [1.0 / 32.0; 3];
    let mut d = domain(counts, cell);
    let plain = gaussian_random_field(&d, 3.0 / 32.0, 5, true).unwrap();
    let n = 32 * 32 * 32;
    assert_eq!(plain.len(), 3 * n);
    for c in 0..3 {
        let v: Vec<f64> = plain[c * n..(c + 1) * n]
            .iter()
            .map(|v| *v as f64)
            .collect();
        let variance = rms(&v).powi(2);
        // About 180 independent blobs per component: standard error near 0.1.
        assert!(
            (variance - 1.0).abs() < 0.3,
            "component {c}: variance {variance}"
        );
    }
    let slopes = rms(&divergence(
        counts,
        cell,
        &plain,
        DivergenceOperator::Spectral,
    ));
    // Unit-variance components vary over ℓ = 3 cells: their derivatives are ~1/ℓ ≈ 10.
    assert!(slopes < 1e-4, "spectral divergence {slopes}");

    d.orientation = DVec3::new(0.3, -0.5, 0.8);
    d.rotation = DMat3::from_quat(glam::DQuat::from_scaled_axis(d.orientation));
    let rotated = gaussian_random_field(&d, 3.0 / 32.0, 5, true).unwrap();
    let mut local = vec![0f32; 3 * n];
    for i in 0..n {
        let w = DVec3::new(
            rotated[i] as f64,
            rotated[n + i] as f64,
            rotated[2 * n + i] as f64,
        );
        let v = d.rotation.transpose() * w;
        for c in 0..3 {
            local[c * n + i] = v[c] as f32;
            assert!((local[c * n + i] - plain[c * n + i]).abs() < 1e-5);
        }
    }
}

#[test]
fn output_is_the_same_for_any_thread_count() {
    let d = domain([24, 20, 16], [0.1, 0.1, 0.1]);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| gaussian_random_field(&d, 0.25, 77, true).unwrap())
    };
    let one = run(1);
    let three = run(3);
    assert!(
        one.iter()
            .zip(&three)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
}

#[test]
fn bad_requests_are_failures() {
    let d = domain([8, 8, 8], [0.1; 3]);
    for correlation in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let e = gaussian_random_field(&d, correlation, 0, false).unwrap_err();
        assert!(e.message.contains("correlation"), "{}", e.message);
    }
    // 1e308 squared overflowed inside the spectrum and made every sample NaN.
    for correlation in [1e308, 2e150] {
        let e = gaussian_random_field(&d, correlation, 0, false).unwrap_err();
        assert_eq!(
            e.message,
            format!(
                "gaussiannoise correlation must be a length above 0 and at most 1e150, got \
                 {correlation:?}"
            )
        );
    }
    // Up to the limit every sample is finite, scalar or divergence-free, and a correlation
    // far longer than the grid gives the same field as one a few times its size.
    for divergence_free in [false, true] {
        let longest = gaussian_random_field(&d, 1e150, 3, divergence_free).unwrap();
        assert!(longest.iter().all(|v| v.is_finite()));
        let long = gaussian_random_field(&d, 1e3, 3, divergence_free).unwrap();
        let gap = longest
            .iter()
            .zip(&long)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        assert!(gap < 1e-3, "{gap}");
    }
    let cellless = Domain::new(DVec3::ZERO, DVec3::ONE, DVec3::ZERO).unwrap();
    let e = gaussian_random_field(&cellless, 0.1, 0, false).unwrap_err();
    assert!(e.message.contains("domain with cells") && e.help.is_some());

    // Too big to store at all, and storable but too big to transform: neither allocates.
    let mut huge = d.clone();
    huge.resolution = Some([1 << 14, 1 << 14, 1 << 14]);
    let e = gaussian_random_field(&huge, 0.1, 0, true).unwrap_err();
    assert!(e.message.contains("memory budget"), "{}", e.message);
    let side = ((crate::space::domain::memory_limit() as f64 / 4.0 / 2.0).cbrt()) as usize;
    let mut large = d.clone();
    large.resolution = Some([side, side, side]);
    assert!(large.check_grid_memory(1).is_ok());
    let e = gaussian_random_field(&large, 0.1, 0, false).unwrap_err();
    assert!(e.message.contains("working memory"), "{}", e.message);

    let cell = DVec3::splat(0.1);
    let mut short = vec![0f32; 3 * 64 - 1];
    assert!(project_divergence_free([4, 4, 4], cell, &mut short).is_err());
    let mut data = vec![0f32; 3 * 64];
    assert!(project_divergence_free([4, 0, 4], cell, &mut data).is_err());
    assert!(project_divergence_free([4, 4, 4], DVec3::new(0.1, -0.1, 0.1), &mut data).is_err());
    data[64 + 5] = f32::NAN;
    let e = project_divergence_free([4, 4, 4], cell, &mut data).unwrap_err();
    assert!(
        e.message.contains("component 1 of cell (1, 1, 0)"),
        "{}",
        e.message
    );
}

/// The working memory charged for a transform bounds what rustfft asks for: each line's
/// in-place scratch stays within the `8n` complex values per thread that
/// `transform_scratch_bytes` counts, for every length up to 1024 (primes, which rustfft
/// transforms by Rader's or Bluestein's algorithm, included), both directions.
#[test]
fn charged_scratch_bounds_what_the_plans_ask_for() {
    let mut planner = FftPlanner::<f64>::new();
    let mut largest = (0.0, 0);
    for n in 1..=1024 {
        for direction in [FftDirection::Forward, FftDirection::Inverse] {
            let scratch = planner.plan_fft(n, direction).get_inplace_scratch_len();
            assert!(scratch <= 8 * n, "length {n}: scratch {scratch}");
            if scratch as f64 / n as f64 > largest.0 {
                largest = (scratch as f64 / n as f64, n);
            }
        }
    }
    println!("largest scratch: {:.2} n at n = {}", largest.0, largest.1);
    // One thread's share: a 32 × 16 slab and a line of 8 × 32, plus three plans' lines.
    let bytes = transform_scratch_bytes([32, 16, 8]);
    let threads = rayon::current_num_threads() as f64;
    assert_eq!(bytes, 16.0 * (threads * (512.0 + 256.0) + 3.0 * 256.0));
}
