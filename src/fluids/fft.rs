//! Fourier-space work on periodic grids: Gaussian random fields with a chosen correlation
//! length (`gaussiannoise`), and the projection that removes the divergent part of a vector
//! field (`fftdivfree`).
//!
//! The one key decision: everything happens in the Fourier domain of the whole grid, treated
//! as one period of an infinite periodic field, in `f64`. A 3D transform is three passes of 1D
//! transforms (`rustfft`), one per axis, with the lines of a pass spread over threads; each
//! line is transformed the same way on any thread, and the white noise behind a random field
//! comes from a counter-based hash of (seed, component, cell), so results are bit-identical
//! for any thread count.
//!
//! Conventions. Samples sit at cell centres, component-major: component `c` of cell
//! `(i, j, k)` is `data[c·n + i + nx·(j + ny·k)]` with `n = nx·ny·nz`. A random field has
//! covariance `C(r) = exp(−|r|²/(2ℓ²))` for a correlation length `ℓ` in world units, so its
//! power spectrum is proportional to `exp(−ℓ²|k|²/2)`. The spectrum is normalised on the grid
//! itself: every sample has ensemble mean 0 and variance exactly 1 (for a vector field, the
//! variance averaged over the three components is 1). The `k = 0` mode is removed, so the
//! mean over the grid is 0 exactly. The spectral derivative multiplies mode `m` along an axis
//! of `N` cells of size `h` by `i·2πm/(Nh)` (with `m` folded to `[−N/2, N/2)`), and by 0 at
//! the Nyquist mode `m = N/2`, whose derivative would not be real.

use crate::base::failure::{Failure, Outcome};
use crate::space::domain::Domain;
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftDirection, FftPlanner};
use std::f64::consts::PI;
use std::sync::Arc;

type Complex64 = Complex<f64>;

/// The longest correlation length `gaussiannoise` takes: its square, in the spectrum's
/// exponent, must stay finite (`1e308` made every sample NaN).
const MAX_CORRELATION: f64 = 1e150;

/// Which derivative a projection makes divergence-free.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DivergenceOperator {
    /// The derivative of the grid's trigonometric interpolant: the spectral divergence of the
    /// result vanishes to round-off; a finite-difference divergence is small where the field
    /// is smooth on the scale of a cell.
    Spectral,
    /// Central differences, `(u[i+1] − u[i−1]) / 2h` along each axis (wrapping around): that
    /// discrete divergence of the result vanishes to round-off. Checkerboard modes, which
    /// central differences cannot see, are left as they are.
    CentralDifference,
}

/// Samples at the domain's cell centres, component-major (width 1, or 3 when
/// `divergence_free`), of a periodic Gaussian random field with covariance
/// `exp(−|r|²/(2·correlation²))` (see the module notes for the normalisation: zero mean, unit
/// variance per sample). A divergence-free field is three independent fields projected onto
/// `k·û = 0` and scaled back to unit variance; its vectors are in world coordinates.
pub fn gaussian_random_field(
    domain: &Domain,
    correlation: f64,
    seed: u32,
    divergence_free: bool,
) -> Outcome<Vec<f32>> {
    if !(correlation > 0.0 && correlation <= MAX_CORRELATION) {
        return Err(Failure::new(format!(
            "gaussiannoise correlation must be a length above 0 and at most {MAX_CORRELATION:e}, \
             got {correlation:?}"
        ))
        .with_help(
            "a correlation much longer than the domain gives the same field as one a few \
             times the domain's size",
        ));
    }
    let Some(resolution) = domain.resolution else {
        return Err(
            Failure::new("gaussiannoise needs a domain with cells").with_help(
                "give the domain a cell size: domain d(origin, lengths, orientation, cell)",
            ),
        );
    };
    let width = if divergence_free { 3 } else { 1 };
    domain.check_grid_memory(width)?;
    let grid = Grid::new(resolution, domain.cell.to_array())?;
    // The spectra, one scratch copy for a transform pass, and the f32 result.
    let _working =
        check_working_memory(grid.counts, 16 * (width + 1) + 4 * width, "gaussiannoise")?;

    let amplitude = grid.gaussian_amplitude(correlation);
    let mut spectra: Vec<Vec<Complex64>> = (0..width)
        .map(|component| {
            let mut s: Vec<Complex64> = (0..grid.len)
                .into_par_iter()
                .map(|cell| Complex64::new(white_noise(seed, component, cell), 0.0))
                .collect();
            grid.transform(&mut s, FftDirection::Forward);
            s.par_iter_mut().zip(&amplitude).for_each(|(v, a)| *v *= *a);
            s
        })
        .collect();
    let mut scale = 1.0 / grid.len as f64;
    if divergence_free {
        grid.project(&mut spectra, DivergenceOperator::Spectral);
        scale /= grid.kept_variance(&amplitude).sqrt();
    }
    let mut samples: Vec<Vec<f64>> = spectra
        .into_iter()
        .map(|mut s| {
            grid.transform(&mut s, FftDirection::Inverse);
            s.into_par_iter().map(|v| v.re * scale).collect()
        })
        .collect();
    if divergence_free && domain.rotation != DMat3::IDENTITY {
        rotate_vectors(&mut samples, domain.rotation);
    }
    let values: Vec<f32> = samples.concat().into_par_iter().map(|v| v as f32).collect();
    // The checks above keep every factor finite; this is the guarantee that no NaN slips out.
    if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
        return Err(Failure::new(format!(
            "gaussiannoise with correlation {correlation:?} gave a non-finite value at cell {}",
            bad % grid.len
        )));
    }
    Ok(values)
}

/// Takes the working memory of a transform over a grid of `counts` cells from the run's
/// budget, before any of it is allocated; held until the returned reservation is dropped.
/// Besides `bytes_per_cell` of every cell it counts what the passes hold per worker thread
/// and the plans (`transform_scratch_bytes`).
pub fn check_working_memory(
    counts: [usize; 3],
    bytes_per_cell: usize,
    what: &str,
) -> Outcome<crate::engine::budget::Reservation> {
    let cells = counts.iter().map(|&n| n as f64).product::<f64>();
    crate::engine::budget::reserve(
        cells * bytes_per_cell as f64 + transform_scratch_bytes(counts),
        &format!("{what} over {cells} cells (its working memory)"),
    )
}

/// What the passes of a transform over `counts` cells hold besides the data: each worker
/// thread's copy of a z-slab for the y pass (`nx·ny` complex values) and its scratch for one
/// line, and the three axes' plans. rustfft's scratch and twiddles for a line of `n` stay
/// within `8n` complex values (a prime length's Rader or Bluestein plan pads its inner
/// transform; the largest scratch measured up to 1024 is 4.7n, at n = 653), so the figure is a
/// bound.
pub fn transform_scratch_bytes([nx, ny, nz]: [usize; 3]) -> f64 {
    let complex = std::mem::size_of::<Complex64>() as f64;
    let line = 8.0 * nx.max(ny).max(nz) as f64;
    let threads = rayon::current_num_threads() as f64;
    complex * (threads * ((nx * ny) as f64 + line) + 3.0 * line)
}

/// A standard normal number for one (seed, component, cell): two uniforms from a
/// splitmix64-style hash of the counter, then Box–Muller.
fn white_noise(seed: u32, component: usize, cell: usize) -> f64 {
    let key = mix64(seed as u64 ^ 0x6a09_e667_f3bc_c909);
    let counter = ((component as u64) << 42) ^ cell as u64;
    let a = mix64(key ^ mix64(counter << 1));
    let b = mix64(key ^ mix64((counter << 1) | 1));
    let unit = 1.0 / (1u64 << 53) as f64;
    let u1 = ((a >> 11) + 1) as f64 * unit; // (0, 1]: the logarithm stays finite
    let u2 = (b >> 11) as f64 * unit;
    (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
}

fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Rotates the vector at every cell from the domain's frame to world axes.
fn rotate_vectors(samples: &mut [Vec<f64>], rotation: DMat3) {
    let [x, y, z] = samples else { return };
    x.par_iter_mut()
        .zip(y.par_iter_mut())
        .zip(z.par_iter_mut())
        .for_each(|((x, y), z)| {
            let v = rotation * DVec3::new(*x, *y, *z);
            (*x, *y, *z) = (v.x, v.y, v.z);
        });
}

/// A periodic grid's shape and cell size, with the transforms and wavenumbers on it.
struct Grid {
    counts: [usize; 3],
    cell: [f64; 3],
    len: usize,
}

impl Grid {
    fn new(counts: [usize; 3], cell: [f64; 3]) -> Outcome<Grid> {
        if counts.contains(&0) {
            return Err(Failure::new(format!(
                "a grid needs at least one cell along each axis, got {counts:?}"
            )));
        }
        if cell.iter().any(|h| !(h.is_finite() && *h > 0.0)) {
            return Err(Failure::new(format!(
                "grid cell sizes must be positive and finite, got {cell:?}"
            )));
        }
        let len = counts
            .iter()
            .try_fold(1usize, |n, c| n.checked_mul(*c))
            .ok_or_else(|| Failure::new(format!("a grid of {counts:?} cells is too large")))?;
        Ok(Grid { counts, cell, len })
    }

    fn cell_of(&self, index: usize) -> [usize; 3] {
        let [nx, ny, _] = self.counts;
        [index % nx, index / nx % ny, index / (nx * ny)]
    }

    /// Signed wavenumbers `2πm/(Nh)` of each mode along an axis, `m` folded to `[−N/2, N/2)`.
    fn frequencies(&self, axis: usize) -> Vec<f64> {
        let (n, h) = (self.counts[axis], self.cell[axis]);
        (0..n)
            .map(|m| {
                let folded = if 2 * m >= n {
                    m as f64 - n as f64
                } else {
                    m as f64
                };
                2.0 * PI * folded / (n as f64 * h)
            })
            .collect()
    }

    /// What the operator's derivative multiplies each mode by along an axis (divided by `i`).
    fn derivative_symbols(&self, axis: usize, operator: DivergenceOperator) -> Vec<f64> {
        let (n, h) = (self.counts[axis], self.cell[axis]);
        match operator {
            DivergenceOperator::Spectral => {
                let mut k = self.frequencies(axis);
                if n % 2 == 0 {
                    k[n / 2] = 0.0;
                }
                k
            }
            // The Nyquist mode (and the mean) are set to exactly zero: central differences
            // cannot see them, and `sin(π)` rounds to 1.2e-16, which would otherwise make the
            // projection remove a mode that the divergence does not contain.
            DivergenceOperator::CentralDifference => (0..n)
                .map(|m| {
                    if m == 0 || 2 * m == n {
                        0.0
                    } else {
                        (2.0 * PI * m as f64 / n as f64).sin() / h
                    }
                })
                .collect(),
        }
    }

    /// Per-mode amplitudes `√(n·S(k)/Σ S)` with `S(k) = exp(−ℓ²|k|²/2)` and `S(0) = 0`, so
    /// that `(1/n)·Σ A² = 1`, the variance of each sample. The exponent is taken relative to
    /// the smallest nonzero `|k|²`, so a correlation far longer than the grid cannot underflow
    /// every mode to zero.
    fn gaussian_amplitude(&self, correlation: f64) -> Vec<f64> {
        let k: [Vec<f64>; 3] = std::array::from_fn(|a| self.frequencies(a));
        let lowest = (0..3)
            .filter(|&a| self.counts[a] > 1)
            .map(|a| k[a][1] * k[a][1])
            .fold(f64::INFINITY, f64::min);
        let half_l2 = 0.5 * correlation * correlation;
        let mut power: Vec<f64> = (0..self.len)
            .into_par_iter()
            .map(|index| {
                let [i, j, l] = self.cell_of(index);
                let k2 = k[0][i] * k[0][i] + k[1][j] * k[1][j] + k[2][l] * k[2][l];
                if index == 0 {
                    0.0
                } else {
                    (-half_l2 * (k2 - lowest)).exp()
                }
            })
            .collect();
        // A sum in a fixed order: the same bits on any thread count.
        let total: f64 = power.iter().sum();
        let norm = if total > 0.0 {
            self.len as f64 / total
        } else {
            0.0
        };
        power.par_iter_mut().for_each(|p| *p = (*p * norm).sqrt());
        power
    }

    /// Removes, from every mode of a 3-component spectrum, its part along the operator's
    /// wave vector `κ`: `û ← û − κ(κ·û)/|κ|²`. Modes with `κ = 0` are left as they are.
    fn project(&self, spectra: &mut [Vec<Complex64>], operator: DivergenceOperator) {
        let kappa: [Vec<f64>; 3] = std::array::from_fn(|a| self.derivative_symbols(a, operator));
        self.project_with(spectra, &kappa);
    }

    /// [`Grid::project`] with the wave vector's components per mode index along each axis
    /// given (for a half spectrum, whose x modes are the first `nx/2 + 1` of the full grid's).
    fn project_with(&self, spectra: &mut [Vec<Complex64>], kappa: &[Vec<f64>; 3]) {
        let [x, y, z] = spectra else { return };
        x.par_iter_mut()
            .zip(y.par_iter_mut())
            .zip(z.par_iter_mut())
            .enumerate()
            .for_each(|(index, ((x, y), z))| {
                let [i, j, l] = self.cell_of(index);
                let k = [kappa[0][i], kappa[1][j], kappa[2][l]];
                let k2 = k[0] * k[0] + k[1] * k[1] + k[2] * k[2];
                if k2 == 0.0 {
                    return;
                }
                let along = (*x * k[0] + *y * k[1] + *z * k[2]) / k2;
                *x -= along * k[0];
                *y -= along * k[1];
                *z -= along * k[2];
            });
    }

    /// The variance per component left after a spectral projection of three independent
    /// fields with these amplitudes: each projected mode keeps 2 of its 3 dimensions.
    fn kept_variance(&self, amplitude: &[f64]) -> f64 {
        let kappa: [Vec<f64>; 3] =
            std::array::from_fn(|a| self.derivative_symbols(a, DivergenceOperator::Spectral));
        let mut total = 0.0;
        for (index, a) in amplitude.iter().enumerate() {
            let [i, j, l] = self.cell_of(index);
            let flat = kappa[0][i] == 0.0 && kappa[1][j] == 0.0 && kappa[2][l] == 0.0;
            total += a * a * if flat { 3.0 } else { 2.0 };
        }
        total / (3.0 * self.len as f64)
    }

    /// The unnormalised 3D discrete Fourier transform, in place: 1D transforms along x, then
    /// y, then z. Lines along y and z are made contiguous by transposing, tile by tile, so every
    /// cache line read is used whole: along y one z-slab at a time (it fits in cache), along z
    /// the whole array, viewed as `nz` rows of `nx·ny`, in tiles of consecutive columns.
    fn transform(&self, data: &mut [Complex64], direction: FftDirection) {
        let mut lines = Vec::new();
        self.transform_with(data, direction, &mut lines);
    }

    /// [`Grid::transform`] with the buffer for the z pass supplied by the caller, so a sequence
    /// of transforms allocates (and page-faults) it once.
    fn transform_with(
        &self,
        data: &mut [Complex64],
        direction: FftDirection,
        lines: &mut Vec<Complex64>,
    ) {
        self.transform_axes(data, direction, lines, true);
    }

    /// The passes of [`Grid::transform_with`], the one along x only when `along_x` (a half
    /// spectrum has had its x pass done by a real transform).
    fn transform_axes(
        &self,
        data: &mut [Complex64],
        direction: FftDirection,
        lines: &mut Vec<Complex64>,
        along_x: bool,
    ) {
        let mut planner = FftPlanner::<f64>::new();
        let [nx, ny, nz] = self.counts;
        if nx > 1 && along_x {
            let fft = planner.plan_fft(nx, direction);
            let scratch = || vec![Complex64::default(); fft.get_inplace_scratch_len()];
            data.par_chunks_mut(nx)
                .for_each_init(scratch, |s, line| fft.process_with_scratch(line, s));
        }
        self.pass_y(data, &planner.plan_fft(ny, direction));
        if nz > 1 {
            lines.resize(self.len, Complex64::default());
            self.gather_z(data, lines, &planner.plan_fft(nz, direction));
            self.scatter_z(lines, data);
        }
    }

    /// Transforms every line along y, one z-slab at a time: the slab is transposed so its
    /// y lines are contiguous (it fits in cache), transformed, and transposed back.
    fn pass_y(&self, data: &mut [Complex64], fft: &Arc<dyn Fft<f64>>) {
        let [nx, ny, _] = self.counts;
        if ny == 1 {
            return;
        }
        let scratch = || {
            (
                vec![Complex64::default(); nx * ny],
                vec![Complex64::default(); fft.get_inplace_scratch_len()],
            )
        };
        data.par_chunks_mut(nx * ny)
            .for_each_init(scratch, |(columns, s), slab| {
                transpose(slab, columns, ny, nx);
                for line in columns.chunks_mut(ny) {
                    fft.process_with_scratch(line, s);
                }
                transpose(columns, slab, nx, ny);
            });
    }

    /// Copies `data` (x fastest) into `lines` in z-major order, `lines[m·nz + k] =
    /// data[m + k·nx·ny]` with `m = i + nx·j`, and transforms each line. The array is viewed as
    /// `nz` rows of `nx·ny` and read in tiles of consecutive columns, so every cache line read
    /// is used whole.
    fn gather_z(&self, data: &[Complex64], lines: &mut [Complex64], fft: &Arc<dyn Fft<f64>>) {
        let [nx, ny, nz] = self.counts;
        let columns = nx * ny;
        // Columns per tile: 16 complex values are four cache lines.
        const TILE: usize = 16;
        lines.par_chunks_mut(nz * TILE).enumerate().for_each_init(
            || vec![Complex64::default(); fft.get_inplace_scratch_len()],
            |s, (tile, out)| {
                let first = tile * TILE;
                let width = out.len() / nz;
                for t in 0..nz {
                    let row = &data[t * columns + first..t * columns + first + width];
                    for (q, v) in row.iter().enumerate() {
                        out[q * nz + t] = *v;
                    }
                }
                for line in out.chunks_mut(nz) {
                    fft.process_with_scratch(line, s);
                }
            },
        );
    }

    /// The inverse of the copy in [`Grid::gather_z`], a band of rows at a time: each column of
    /// the band is contiguous in `lines`.
    fn scatter_z(&self, lines: &[Complex64], data: &mut [Complex64]) {
        let [nx, ny, nz] = self.counts;
        let columns = nx * ny;
        const BAND: usize = 8;
        data.par_chunks_mut(columns * BAND)
            .enumerate()
            .for_each(|(band, rows)| {
                let first = band * BAND;
                let height = rows.len() / columns;
                for m in 0..columns {
                    let line = &lines[m * nz + first..m * nz + first + height];
                    for (q, v) in line.iter().enumerate() {
                        rows[q * columns + m] = *v;
                    }
                }
            });
    }
}

/// `to[c·rows + r] = from[r·cols + c]`: the transpose of a `rows × cols` row-major matrix,
/// in 8×8 tiles, each tile's rows taken as slices so the inner loop has no bounds checks.
fn transpose(from: &[Complex64], to: &mut [Complex64], rows: usize, cols: usize) {
    const T: usize = 8;
    for r0 in (0..rows).step_by(T) {
        let r1 = (r0 + T).min(rows);
        for c0 in (0..cols).step_by(T) {
            let c1 = (c0 + T).min(cols);
            for c in c0..c1 {
                let column = &mut to[c * rows + r0..c * rows + r1];
                for (k, out) in column.iter_mut().enumerate() {
                    *out = from[(r0 + k) * cols + c];
                }
            }
        }
    }
}

mod projection;
#[cfg(test)]
mod tests;

pub use projection::{
    PROJECTION_BYTES_PER_CELL, project_divergence_free, project_divergence_free_with,
};
