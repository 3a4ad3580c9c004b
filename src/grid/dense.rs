//! Dense grids in double precision: the storage of whole-grid solves (`fftdivfree`).
//!
//! A solve produces every cell at once, so there is nothing to gain from bricks filled on
//! demand; what matters is that reading the result back costs little and loses nothing. The
//! one key decision: values are kept in `f64`, not the `f32` of caches, so a projected velocity
//! read back at its cell centres is the projection's output to the last bit, and projecting it
//! again changes it only by round-off (the idempotence that `fftdivfree` promises). Reads use
//! the same stencils as caches (`interp`), so linear and cubic reads, their exact derivatives
//! and the linear border behave identically; outside the box a read gives the background.
//! Ranges come from a table of per-8³-block extremes made once, widened by the stencil's
//! weight bound like a cache's.

use crate::engine::spare::Spare;
use crate::grid::interp::{AxisStencil, axis_stencil};
use crate::grid::points::{self, PointRead};
use crate::grid::reach;
use crate::space::domain::Domain;
use crate::space::{Aabb, Interp};
use glam::{DMat3, DVec3};
use rayon::prelude::*;

/// Cells along each edge of a block of the range table.
const BLOCK: usize = 8;

/// Values at the cell centres of a domain, `width` components each.
pub struct DenseGrid {
    domain: Domain,
    to_local: DMat3,
    axis_aligned: bool,
    inverse_cell: DVec3,
    cells: [usize; 3],
    width: usize,
    /// Component `c` of cell `(i, j, k)` at `(i + nx (j + ny k)) * width + c`.
    values: Vec<f64>,
    background: Vec<f64>,
    blocks: [usize; 3],
    /// Per block and component: the smallest and largest value; NaN-free by construction of
    /// the callers (solves refuse non-finite input).
    block_ranges: Vec<(f64, f64)>,
}

impl DenseGrid {
    /// A grid over `domain` (which has cells) holding `values`, interleaved as documented on
    /// the field, reading `background` outside the box.
    pub fn new(domain: Domain, width: usize, values: Vec<f64>, background: Vec<f64>) -> DenseGrid {
        let cells = domain.resolution.unwrap_or([1, 1, 1]);
        debug_assert_eq!(values.len(), cells[0] * cells[1] * cells[2] * width);
        let blocks = cells.map(|n| n.div_ceil(BLOCK));
        let mut grid = DenseGrid {
            to_local: domain.rotation.transpose(),
            axis_aligned: domain.rotation == DMat3::IDENTITY,
            inverse_cell: domain.cell.recip(),
            domain,
            cells,
            width,
            values,
            background,
            blocks,
            block_ranges: Vec::new(),
        };
        grid.block_ranges = grid.compute_block_ranges();
        grid
    }

    pub fn width(&self) -> usize {
        self.width
    }

    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    pub fn background(&self) -> &[f64] {
        &self.background
    }

    /// Bytes held by the values and the range table.
    pub fn bytes(&self) -> u64 {
        ((self.values.len() + 2 * self.block_ranges.len()) * size_of::<f64>()) as u64
    }

    /// The stored value of cell `(i, j, k)`.
    pub fn cell(&self, i: usize, j: usize, k: usize) -> &[f64] {
        let at = (i + self.cells[0] * (j + self.cells[1] * k)) * self.width;
        &self.values[at..at + self.width]
    }

    /// One slab of blocks (a fixed z block) per task: the same extremes on any thread count.
    fn compute_block_ranges(&self) -> Vec<(f64, f64)> {
        let [bx, by, _] = self.blocks;
        let slab = bx * by * self.width;
        let mut ranges = vec![(f64::INFINITY, f64::NEG_INFINITY); slab * self.blocks[2]];
        ranges
            .par_chunks_mut(slab)
            .enumerate()
            .for_each(|(block_z, slab)| {
                let k_end = ((block_z + 1) * BLOCK).min(self.cells[2]);
                for k in block_z * BLOCK..k_end {
                    for j in 0..self.cells[1] {
                        for i in 0..self.cells[0] {
                            let block = i / BLOCK + bx * (j / BLOCK);
                            for (c, &v) in self.cell(i, j, k).iter().enumerate() {
                                let r = &mut slab[block * self.width + c];
                                r.0 = r.0.min(v);
                                r.1 = r.1.max(v);
                            }
                        }
                    }
                }
            });
        ranges
    }

    /// Continuous cell-index coordinates of a world point inside the box.
    #[inline]
    fn index_coords_inside(&self, p: DVec3) -> Option<DVec3> {
        let offset = p - self.domain.origin;
        // Most simulation domains are axis-aligned: skip the rotation there.
        let local = if self.axis_aligned {
            offset
        } else {
            self.to_local * offset
        };
        let inside = local.cmpge(DVec3::ZERO).all() && local.cmple(self.domain.lengths).all();
        inside.then(|| local * self.inverse_cell - DVec3::splat(0.5))
    }

    /// Trilinear reads, the common case, with fixed loop counts: the same weights as the
    /// linear stencil of `interp` (`1 − t`, `t` from the cell at or below, kept inside).
    #[inline(always)]
    fn read_linear<const W: usize, const GRADIENT: bool>(
        &self,
        u: DVec3,
        value: &mut [f64; W],
        gradient: &mut [[f64; 3]; W],
    ) {
        let mut below = [0usize; 3];
        let mut t = [0.0; 3];
        for a in 0..3 {
            // Through i64: x86 converts signed integers in one instruction, unsigned ones not.
            let cell = (u[a].max(0.0) as i64).min(self.cells[a] as i64 - 2);
            below[a] = cell as usize;
            t[a] = u[a] - cell as f64;
        }
        let (nx, ny) = (self.cells[0], self.cells[1]);
        let base = below[0] + nx * (below[1] + ny * below[2]);
        if !GRADIENT && t == [0.0; 3] {
            // Exactly on a cell centre (as when a solve samples its predecessor there): the
            // trilinear sum is that cell's value.
            value.copy_from_slice(&self.values[base * W..base * W + W]);
            return;
        }
        let w = t.map(|t| [1.0 - t, t]);
        for kz in 0..2 {
            for ky in 0..2 {
                let weight_yz = w[1][ky] * w[2][kz];
                let slope_y = if ky == 0 { -w[2][kz] } else { w[2][kz] };
                let slope_z = if kz == 0 { -w[1][ky] } else { w[1][ky] };
                let row = (base + nx * (ky + ny * kz)) * W;
                for kx in 0..2 {
                    let at = row + kx * W;
                    let weight = w[0][kx] * weight_yz;
                    let slope_x = if kx == 0 { -weight_yz } else { weight_yz };
                    for c in 0..W {
                        let sample = self.values[at + c];
                        value[c] += weight * sample;
                        if GRADIENT {
                            gradient[c][0] += slope_x * sample;
                            gradient[c][1] += w[0][kx] * slope_y * sample;
                            gradient[c][2] += w[0][kx] * slope_z * sample;
                        }
                    }
                }
            }
        }
    }

    /// Interpolated values at world points, component-major (`out[c * n + i]`).
    pub fn sample(&self, interp: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        points::values_of(self, self.width, interp, xs, ys, zs, out);
    }

    /// Derivatives of the interpolant, `out[(c * 3 + j) * n + i]`; zero outside the box.
    pub fn sample_gradient(
        &self,
        interp: Interp,
        xs: &[f64],
        ys: &[f64],
        zs: &[f64],
        out: &mut [f64],
    ) {
        points::gradients_of(self, self.width, interp, xs, ys, zs, out);
    }

    /// A conservative range per component of what the interpolant reaches in `region`.
    pub fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        let lattice = self.domain.lattice();
        reach::range(
            &lattice,
            region,
            Interp::Cubic,
            false,
            &self.background,
            BLOCK,
            |[bx, by, bz], _, samples| {
                let block = bx + self.blocks[0] * (by + self.blocks[1] * bz);
                for (c, s) in samples.iter_mut().enumerate() {
                    let r = self.block_ranges[block * self.width + c];
                    s.0 = s.0.min(r.0);
                    s.1 = s.1.max(r.1);
                }
            },
        )
    }
}

/// Values arrays of grids that were dropped, for the next solve of the same size.
pub static SPARE_VALUES: Spare<f64> = Spare::new();

impl Drop for DenseGrid {
    fn drop(&mut self) {
        SPARE_VALUES.give(std::mem::take(&mut self.values));
    }
}

impl PointRead for DenseGrid {
    #[inline(always)]
    fn index_of(&self, p: DVec3) -> Option<DVec3> {
        self.index_coords_inside(p)
    }

    #[inline(always)]
    fn read<const W: usize, const GRADIENT: bool>(
        &self,
        interp: Interp,
        u: DVec3,
        value: &mut [f64; W],
        gradient: &mut [[f64; 3]; W],
    ) {
        if interp == Interp::Linear && self.cells.iter().all(|&n| n >= 2) {
            return self.read_linear::<W, GRADIENT>(u, value, gradient);
        }
        let axes: [AxisStencil; 3] =
            std::array::from_fn(|a| axis_stencil(interp, u[a], self.cells[a]));
        let [sx, sy, sz] = &axes;
        let (nx, ny) = (self.cells[0], self.cells[1]);
        for kz in 0..sz.len {
            for ky in 0..sy.len {
                let weight_yz = sy.weight[ky] * sz.weight[kz];
                let slope_y = sy.slope[ky] * sz.weight[kz];
                let slope_z = sy.weight[ky] * sz.slope[kz];
                let row = sx.start + nx * (sy.start + ky + ny * (sz.start + kz));
                for kx in 0..sx.len {
                    let at = (row + kx) * W;
                    let weight = sx.weight[kx] * weight_yz;
                    for c in 0..W {
                        let sample = self.values[at + c];
                        value[c] += weight * sample;
                        if GRADIENT {
                            gradient[c][0] += sx.slope[kx] * weight_yz * sample;
                            gradient[c][1] += sx.weight[kx] * slope_y * sample;
                            gradient[c][2] += sx.weight[kx] * slope_z * sample;
                        }
                    }
                }
            }
        }
    }

    fn outside(&self) -> &[f64] {
        &self.background
    }

    fn placement(&self) -> (DMat3, DVec3) {
        (self.domain.rotation, self.inverse_cell)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_a_linear_field_exactly_and_its_gradient() {
        let domain = Domain::with_cells(
            DVec3::new(-1.0, 0.5, 2.0),
            DVec3::new(2.0, 1.0, 1.5),
            DVec3::new(0.2, -0.4, 0.3),
            0.125,
            0.125,
        )
        .unwrap();
        let [nx, ny, nz] = domain.resolution.unwrap();
        let f = |p: DVec3| 0.5 + p.dot(DVec3::new(1.5, -2.0, 0.25));
        let mut values = Vec::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    values.push(f(domain.cell_center(i, j, k)));
                }
            }
        }
        let grid = DenseGrid::new(domain.clone(), 1, values, vec![0.0]);
        let p = domain.local_to_world(DVec3::new(0.73, 0.41, 1.1));
        for interp in [Interp::Linear, Interp::Cubic] {
            let mut out = [0.0];
            grid.sample(interp, &[p.x], &[p.y], &[p.z], &mut out);
            assert!((out[0] - f(p)).abs() < 1e-12, "{interp:?}");
            let mut g = [0.0; 3];
            grid.sample_gradient(interp, &[p.x], &[p.y], &[p.z], &mut g);
            assert!((DVec3::from_array(g) - DVec3::new(1.5, -2.0, 0.25)).length() < 1e-12);
        }
        let range = grid.range(&Aabb::new(p - 0.05, p + 0.05));
        assert!(range[0].0 <= f(p) && f(p) <= range[0].1);
        let far = grid.range(&Aabb::new(DVec3::splat(50.0), DVec3::splat(51.0)));
        assert_eq!(far, vec![(0.0, 0.0)]);
    }
}
