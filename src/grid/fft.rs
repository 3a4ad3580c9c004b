//! FFT-synthesised Gaussian random fields, and divergence-free projection, on periodic grids.
//!
//! White noise at the cell centres (from a counter-based hash of seed, cell and component, so
//! the result does not depend on threads) is filtered in Fourier space by the square root of the
//! power spectrum of the Gaussian covariance `C(r) = exp(−r²/(2ℓ²))`, i.e. multiplied by
//! `exp(−|k|²ℓ²/4)`. The one key decision: the result is normalised by its own sample standard
//! deviation, so every field has zero mean and unit variance per component exactly, whatever
//! the grid; the correlation shape is what the spectrum sets. The 3D transform is three passes
//! of 1D transforms (rustfft) over lines, in parallel, each line independent.

use crate::failure::{Failure, Outcome};
use crate::grid::domain::Domain;
use glam::DVec3;
use rayon::prelude::*;
use rustfft::FftPlanner;
use rustfft::num_complex::Complex64;
use std::f64::consts::PI;

/// Samples at `domain`'s cell centres, component-major (`width` 1, or 3 when
/// `vector`), index `i + nx (j + ny k)`. With `divergence_free` the vector field is projected
/// onto its divergence-free part before normalising.
pub fn gaussian_random_field(
    domain: &Domain,
    correlation: f64,
    seed: u32,
    vector: bool,
    divergence_free: bool,
) -> Outcome<Vec<Vec<f32>>> {
    if !(correlation.is_finite() && correlation > 0.0) {
        return Err(Failure::new(format!(
            "the correlation length must be positive, found {correlation}"
        )));
    }
    let res = domain
        .resolution
        .ok_or_else(|| Failure::new("gaussiannoise needs a domain with a cell size"))?;
    let width = if vector { 3 } else { 1 };
    // Complex working storage: 16 bytes per cell and component.
    domain.check_grid_memory(4 * width)?;
    let cells = res[0] * res[1] * res[2];
    let mut components: Vec<Vec<Complex64>> = (0..width)
        .map(|c| {
            (0..cells)
                .into_par_iter()
                .map(|i| Complex64::new(gaussian(seed, c as u32, i as u64), 0.0))
                .collect()
        })
        .collect();
    for data in components.iter_mut() {
        transform(data, res, false);
    }
    let cell = domain.cell;
    let wavenumber = |index: usize, n: usize, h: f64| {
        let signed = if index <= n / 2 {
            index as f64
        } else {
            index as f64 - n as f64
        };
        2.0 * PI * signed / (n as f64 * h)
    };
    let k_of = |i: usize| {
        let (x, y, z) = (i % res[0], (i / res[0]) % res[1], i / (res[0] * res[1]));
        DVec3::new(
            wavenumber(x, res[0], cell.x),
            wavenumber(y, res[1], cell.y),
            wavenumber(z, res[2], cell.z),
        )
    };
    let filter = |k: DVec3| (-k.length_squared() * correlation * correlation / 4.0).exp();
    for data in components.iter_mut() {
        data.par_iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v *= filter(k_of(i)));
    }
    if vector && divergence_free {
        let (a, rest) = components.split_at_mut(1);
        let (b, c) = rest.split_at_mut(1);
        let (u, v, w) = (&mut a[0], &mut b[0], &mut c[0]);
        u.par_iter_mut()
            .zip(v.par_iter_mut())
            .zip(w.par_iter_mut())
            .enumerate()
            .for_each(|(i, ((u, v), w))| {
                let k = k_of(i);
                let k2 = k.length_squared();
                if k2 == 0.0 {
                    return;
                }
                // û ← û − k (k·û)/|k|²
                let dot = *u * k.x + *v * k.y + *w * k.z;
                *u -= dot * (k.x / k2);
                *v -= dot * (k.y / k2);
                *w -= dot * (k.z / k2);
            });
    }
    for data in components.iter_mut() {
        transform(data, res, true);
    }
    // Zero mean, unit variance per component.
    Ok(components
        .into_iter()
        .map(|data| {
            let n = data.len() as f64;
            let mean = data.iter().map(|v| v.re).sum::<f64>() / n;
            let var = data.iter().map(|v| (v.re - mean).powi(2)).sum::<f64>() / n;
            let scale = if var > 0.0 { 1.0 / var.sqrt() } else { 0.0 };
            data.iter()
                .map(|v| ((v.re - mean) * scale) as f32)
                .collect()
        })
        .collect())
}

/// A standard normal sample from a hash of (seed, component, cell) (Box–Muller).
fn gaussian(seed: u32, component: u32, cell: u64) -> f64 {
    let a = mix(((seed as u64) << 34) ^ ((component as u64) << 62) ^ cell.wrapping_mul(2));
    let b = mix(((seed as u64) << 34) ^ ((component as u64) << 62) ^ (cell.wrapping_mul(2) + 1));
    let u1 = ((a >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    let u2 = (b >> 11) as f64 / (1u64 << 53) as f64;
    (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
}

/// SplitMix64 finaliser: a bijective scramble of 64 bits.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// In-place 3D FFT of `data` (index `i + nx (j + ny k)`), forward or inverse (scaled by 1/N).
fn transform(data: &mut [Complex64], res: [usize; 3], inverse: bool) {
    let mut planner = FftPlanner::new();
    let [nx, ny, nz] = res;
    for axis in 0..3 {
        let n = res[axis];
        if n < 2 {
            continue;
        }
        let fft = if inverse {
            planner.plan_fft_inverse(n)
        } else {
            planner.plan_fft_forward(n)
        };
        let (stride, lines): (usize, Vec<usize>) = match axis {
            0 => (1, (0..ny * nz).map(|l| l * nx).collect()),
            1 => (
                nx,
                (0..nx * nz)
                    .map(|l| (l % nx) + (l / nx) * nx * ny)
                    .collect(),
            ),
            _ => (nx * ny, (0..nx * ny).collect()),
        };
        let shared = SharedSlice(data.as_mut_ptr());
        lines.par_iter().for_each_init(
            || vec![Complex64::new(0.0, 0.0); n],
            |line, &start| {
                let shared = &shared;
                // SAFETY: the lines of one pass are disjoint sets of indices (each index
                // belongs to exactly one line), all inside `data`.
                unsafe {
                    for (t, v) in line.iter_mut().enumerate() {
                        *v = *shared.0.add(start + t * stride);
                    }
                }
                fft.process(line);
                unsafe {
                    for (t, v) in line.iter().enumerate() {
                        *shared.0.add(start + t * stride) = *v;
                    }
                }
            },
        );
    }
    if inverse {
        let scale = 1.0 / data.len() as f64;
        data.par_iter_mut().for_each(|v| *v *= scale);
    }
}

struct SharedSlice(*mut Complex64);
// SAFETY: used only for disjoint writes from parallel lines (see `transform`).
unsafe impl Sync for SharedSlice {}
unsafe impl Send for SharedSlice {}

#[cfg(test)]
mod tests {
    use super::*;

    fn domain(n: usize, cell: f64) -> Domain {
        Domain::with_cells(
            DVec3::ZERO,
            DVec3::splat(n as f64 * cell),
            DVec3::ZERO,
            cell,
            cell,
        )
        .unwrap()
    }

    #[test]
    fn correlation_matches_the_gaussian_covariance() {
        let (n, cell, ell) = (64, 1.0, 4.0);
        let f = &gaussian_random_field(&domain(n, cell), ell, 7, false, false).unwrap()[0];
        let mean: f64 = f.iter().map(|&v| v as f64).sum::<f64>() / f.len() as f64;
        let var: f64 = f.iter().map(|&v| (v as f64).powi(2)).sum::<f64>() / f.len() as f64;
        assert!(
            mean.abs() < 1e-6 && (var - 1.0).abs() < 1e-5,
            "{mean} {var}"
        );
        // Autocorrelation along x at lags ℓ/2, ℓ and 2ℓ against exp(−r²/(2ℓ²)).
        for lag in [2usize, 4, 8] {
            let mut sum = 0.0;
            for k in 0..n {
                for j in 0..n {
                    for i in 0..n {
                        let a = f[i + n * (j + n * k)] as f64;
                        let b = f[(i + lag) % n + n * (j + n * k)] as f64;
                        sum += a * b;
                    }
                }
            }
            let measured = sum / (n * n * n) as f64;
            let r = lag as f64 * cell;
            let expected = (-r * r / (2.0 * ell * ell)).exp();
            assert!(
                (measured - expected).abs() < 0.06,
                "lag {lag}: {measured} vs {expected}"
            );
        }
    }

    #[test]
    fn projected_fields_have_no_divergence() {
        let n = 32;
        let d = domain(n, 1.0);
        let div = |f: &[Vec<f32>]| {
            // Central differences, periodic.
            let at = |c: usize, i: usize, j: usize, k: usize| {
                f[c][(i % n) + n * ((j % n) + n * (k % n))] as f64
            };
            let mut total = 0.0;
            for k in 0..n {
                for j in 0..n {
                    for i in 0..n {
                        let d = (at(0, i + 1, j, k) - at(0, i + n - 1, j, k))
                            + (at(1, i, j + 1, k) - at(1, i, j + n - 1, k))
                            + (at(2, i, j, k + 1) - at(2, i, j, k + n - 1));
                        total += (0.5 * d).powi(2);
                    }
                }
            }
            (total / (n * n * n) as f64).sqrt()
        };
        let free = gaussian_random_field(&d, 3.0, 1, true, true).unwrap();
        let plain = gaussian_random_field(&d, 3.0, 1, true, false).unwrap();
        let (a, b) = (div(&free), div(&plain));
        // The discrete central divergence of a spectrally projected field is not zero (the
        // central difference is not the spectral derivative) but far smaller.
        assert!(a < 0.1 * b, "{a} vs {b}");
    }

    #[test]
    fn results_do_not_depend_on_threads() {
        let d = domain(24, 0.5);
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let a = one.install(|| gaussian_random_field(&d, 1.0, 3, true, true).unwrap());
        let b = two.install(|| gaussian_random_field(&d, 1.0, 3, true, true).unwrap());
        assert!(a == b);
        assert!(gaussian_random_field(&d, 0.0, 3, false, false).is_err());
    }
}
