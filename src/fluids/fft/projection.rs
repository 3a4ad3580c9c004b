//! The divergence-free projection of a real vector field, in Fourier space.
//!
//! The samples are real, so along x only the modes `0..=nx/2` are kept (the others are their
//! complex conjugates): a real-to-complex transform along x (`realfft`), complex transforms
//! along y and z over that half spectrum, the projection, and back the same way. The one key
//! decision is where the spectrum lives between the two ways: the z pass leaves it in z-major
//! order, the projection works on it there (it only needs each mode's indices), and the
//! inverse z pass starts from there, so of the four whole-array transposes a z pass would
//! otherwise need per component, two are never made. Working buffers are kept for the next
//! projection of the same size, since page faults on fresh buffers cost as much as the
//! transposes (`spare`).

use super::{Complex64, DivergenceOperator, Grid, check_working_memory};
use crate::base::failure::{Failure, Outcome};
use crate::engine::spare::Spare;
use glam::DVec3;
use rayon::prelude::*;
use realfft::RealFftPlanner;
use rustfft::{FftDirection, FftPlanner};

/// Bytes per cell that [`project_divergence_free_with`] needs beyond its input: three half
/// spectra and one half-size work array (rounded up).
pub const PROJECTION_BYTES_PER_CELL: usize = 40;

/// Removes the divergent part of a periodic vector field sampled at cell centres
/// (component-major, width 3, components along the grid's own axes) in place, by projection in
/// Fourier space with the spectral derivative. The samples are projected in `f64` and rounded
/// back to `f32`.
pub fn project_divergence_free(
    resolution: [usize; 3],
    cell: DVec3,
    data: &mut [f32],
) -> Outcome<()> {
    let mut wide: Vec<f64> = data.iter().map(|&v| f64::from(v)).collect();
    project_divergence_free_with(resolution, cell, &mut wide, DivergenceOperator::Spectral)?;
    for (out, v) in data.iter_mut().zip(wide) {
        *out = v as f32;
    }
    Ok(())
}

/// Spare spectra, reused by the next projection of the same size.
static SPECTRA: Spare<Complex64> = Spare::new();

/// Removes, in place, the part of a periodic vector field (`f64` samples at cell centres,
/// component-major, width 3, components along the grid's own axes) that `operator`'s
/// divergence sees: afterwards that discrete divergence vanishes to round-off, and projecting
/// again changes nothing beyond round-off. Used by `fftdivfree` with central differences.
pub fn project_divergence_free_with(
    resolution: [usize; 3],
    cell: DVec3,
    data: &mut [f64],
    operator: DivergenceOperator,
) -> Outcome<()> {
    let grid = Grid::new(resolution, cell.to_array())?;
    if data.len() != 3 * grid.len {
        return Err(Failure::new(format!(
            "a divergence-free projection needs 3 components of {} cells ({} values), got {}",
            grid.len,
            3 * grid.len,
            data.len()
        )));
    }
    let any_bad = data.par_iter().any(|v| !v.is_finite());
    if let Some(at) = any_bad
        .then(|| data.iter().position(|v| !v.is_finite()))
        .flatten()
    {
        let (c, i) = (at / grid.len, at % grid.len);
        let [x, y, z] = grid.cell_of(i);
        return Err(Failure::new(format!(
            "cannot remove the divergence of a field with a non-finite value ({}) in component {c} of cell ({x}, {y}, {z})",
            data[at]
        )));
    }
    let _working = check_working_memory(grid.counts, PROJECTION_BYTES_PER_CELL, "fftdivfree")?;
    let [nx, ny, nz] = resolution;
    let h = nx / 2 + 1;
    let half = Grid::new([h, ny, nz], cell.to_array())?;
    let mut real = RealFftPlanner::<f64>::new();
    let (forward_x, inverse_x) = (real.plan_fft_forward(nx), real.plan_fft_inverse(nx));
    let mut planner = FftPlanner::<f64>::new();
    let plan = |planner: &mut FftPlanner<f64>, n, d| planner.plan_fft(n, d);
    let (forward_y, inverse_y) = (
        plan(&mut planner, ny, FftDirection::Forward),
        plan(&mut planner, ny, FftDirection::Inverse),
    );
    let (forward_z, inverse_z) = (
        plan(&mut planner, nz, FftDirection::Forward),
        plan(&mut planner, nz, FftDirection::Inverse),
    );

    let mut work = SPECTRA.take(half.len);
    let mut spectra: [Vec<Complex64>; 3] = std::array::from_fn(|_| SPECTRA.take(half.len));
    for (component, spectrum) in data.chunks(grid.len).zip(spectra.iter_mut()) {
        work.par_chunks_mut(h)
            .zip(component.par_chunks(nx))
            .for_each_init(
                || (forward_x.make_input_vec(), forward_x.make_scratch_vec()),
                |(row, scratch), (out, samples)| {
                    row.copy_from_slice(samples);
                    // Lengths match by construction, so the transform cannot fail.
                    let _ = forward_x.process_with_scratch(row, out, scratch);
                },
            );
        half.pass_y(&mut work, &forward_y);
        if nz > 1 {
            half.gather_z(&work, spectrum, &forward_z);
        } else {
            spectrum.copy_from_slice(&work);
        }
    }

    // Project each mode of the z-major spectra: entry `m·nz + k`, `m = i + h·j`.
    let mut kappa: [Vec<f64>; 3] = std::array::from_fn(|a| grid.derivative_symbols(a, operator));
    kappa[0].truncate(h);
    {
        let [sx, sy, sz] = &mut spectra;
        sx.par_chunks_mut(nz)
            .zip(sy.par_chunks_mut(nz))
            .zip(sz.par_chunks_mut(nz))
            .enumerate()
            .for_each(|(m, ((x, y), z))| {
                let (kx, ky) = (kappa[0][m % h], kappa[1][m / h]);
                for k in 0..nz {
                    let kz = kappa[2][k];
                    let k2 = kx * kx + ky * ky + kz * kz;
                    if k2 == 0.0 {
                        continue;
                    }
                    let along = (x[k] * kx + y[k] * ky + z[k] * kz) / k2;
                    x[k] -= along * kx;
                    y[k] -= along * ky;
                    z[k] -= along * kz;
                }
            });
    }

    let scale = 1.0 / grid.len as f64;
    for (spectrum, out) in spectra.iter_mut().zip(data.chunks_mut(grid.len)) {
        if nz > 1 {
            spectrum.par_chunks_mut(nz).for_each_init(
                || vec![Complex64::default(); inverse_z.get_inplace_scratch_len()],
                |s, line| inverse_z.process_with_scratch(line, s),
            );
            half.scatter_z(spectrum, &mut work);
        } else {
            work.copy_from_slice(spectrum);
        }
        half.pass_y(&mut work, &inverse_y);
        out.par_chunks_mut(nx)
            .zip(work.par_chunks_mut(h))
            .for_each_init(
                || inverse_x.make_scratch_vec(),
                |scratch, (row, modes)| {
                    // The mean and (for even nx) Nyquist modes of a real line are real; their
                    // imaginary parts here are round-off of the y and z passes.
                    modes[0].im = 0.0;
                    if nx % 2 == 0 {
                        modes[h - 1].im = 0.0;
                    }
                    let _ = inverse_x.process_with_scratch(modes, row, scratch);
                    for v in row.iter_mut() {
                        *v *= scale;
                    }
                },
            );
    }
    SPECTRA.give(work);
    for buffer in spectra {
        SPECTRA.give(buffer);
    }
    Ok(())
}
