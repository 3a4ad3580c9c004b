//! Reading a cache: interpolated values, exact gradients of the interpolant, and its cells.
//! Ranges are in `range.rs`.
//!
//! A point is mapped to the domain's continuous cell-index coordinates, `interp` builds one
//! stencil per axis, and the stencil's cells are read from at most 2×2×2 bricks (a stencil of
//! four cells never spans more than two bricks along an axis), each filled on first touch.
//! The one key decision: the per-point work is generic over the number of components and, for
//! the common stencil shapes, over the stencil length, so the inner loops have fixed trip
//! counts and no per-point dispatch; and a stencil that lies inside one brick (most linear
//! ones, about a quarter of cubic ones) is read from that brick with fixed strides, without
//! the table of bricks. Outside the domain box a point reads the background and a zero
//! gradient.

#[cfg(test)]
mod tests;

use super::outside::Outside;
use super::{BRICK, Cache, local_index, lock};
use crate::grid::interp::{AxisStencil, axis_stencil};
use crate::grid::points::{self, PointRead};
use crate::space::domain::Domain;
use crate::space::{Aabb, GridSource, Interp, Lattice};
use glam::{DMat3, DVec3};
use std::sync::Arc;

/// The cells one point reads, resolved to brick storage.
struct Stencil<'a> {
    axes: [AxisStencil; 3],
    /// Per axis and stencil entry: which of the (at most two) bricks along the axis holds the
    /// cell, as an offset into `bricks` (steps 1, 2, 4 for x, y, z).
    brick_of: [[usize; 4]; 3],
    /// Per axis and stencil entry: the cell's offset within its brick (steps 1, 8, 64).
    offset: [[usize; 4]; 3],
    /// The bricks, indexed `x + 2 (y + 2 z)` by brick step.
    bricks: [&'a [f32]; 8],
}

const BRICK_STEP: [usize; 3] = [1, 2, 4];
const CELL_STEP: [usize; 3] = [1, BRICK, BRICK * BRICK];

impl Cache {
    /// Continuous cell-index coordinates of a world point inside the domain box.
    #[inline]
    pub(super) fn index_coords(&self, p: DVec3) -> Option<DVec3> {
        let offset = p - self.domain.origin;
        // Most caches are axis-aligned: skip the rotation there.
        let local = if self.axis_aligned {
            offset
        } else {
            self.to_local * offset
        };
        let inside = local.cmpge(DVec3::ZERO).all() && local.cmple(self.domain.lengths).all();
        inside.then(|| local / self.domain.cell - DVec3::splat(0.5))
    }

    /// Where cell `(0, 0, 0)` of `domain` sits among this cache's cells, when `domain`'s cells
    /// are this cache's own: the same rotation and cell size, an origin a whole number of
    /// cells inside (to the bit, so they are the same cells), as for a render's light grid
    /// fitted over the part of a cache that holds density.
    fn cell_offset(&self, domain: &Domain) -> Option<[usize; 3]> {
        if *domain == self.domain {
            return Some([0; 3]);
        }
        if !self.axis_aligned || domain.rotation != self.domain.rotation {
            return None;
        }
        let mut offset = [0usize; 3];
        for a in 0..3 {
            let cell = self.domain.cell[a];
            let steps = ((domain.origin[a] - self.domain.origin[a]) / cell).round();
            let exact = domain.cell[a] == cell
                && (0.0..self.shape.cells[a] as f64).contains(&steps)
                && self.domain.origin[a] + steps * cell == domain.origin[a];
            if !exact {
                return None;
            }
            offset[a] = steps as usize;
        }
        Some(offset)
    }

    /// Trilinear values of a cache of `W` components with at least two cells on every axis:
    /// what `points::values` computes through `read`, bit for bit, for the case renders ask
    /// most (a density or an emission marched at blocks of points). The general path builds
    /// three `AxisStencil`s of four weights and slopes per point and copies them around, which
    /// cost more than the eight reads themselves; here the weights stay in registers and the
    /// eight cells are read straight from their bricks (one brick for most points, up to eight
    /// where the stencil crosses brick faces). A point exactly on a cell centre takes the
    /// general path, which reads that cell alone. Output is component-major, `out[c * n + i]`.
    fn sample_linear<const W: usize>(&self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        let n = xs.len();
        let cells = self.shape.cells;
        let mut unused = [[0.0; 3]; W];
        let mut outside = 0;
        for i in 0..n {
            let Some(u) = self.index_coords(DVec3::new(xs[i], ys[i], zs[i])) else {
                for c in 0..W {
                    out[c * n + i] = self.background[c];
                }
                outside += 1;
                continue;
            };
            let u = u.to_array();
            if u.iter().all(|&v| v >= 0.0) && (0..3).all(|a| u[a] as i64 as f64 == u[a]) {
                let mut value = [0.0; W];
                let u = DVec3::from_array(u);
                self.read::<W, false>(Interp::Linear, u, &mut value, &mut unused);
                for c in 0..W {
                    out[c * n + i] = value[c];
                }
                continue;
            }
            // The same cell and fraction as `axis_stencil`'s linear rule.
            let cell: [usize; 3] =
                std::array::from_fn(|a| (u[a].max(0.0) as i64).min(cells[a] as i64 - 2) as usize);
            let t: [f64; 3] = std::array::from_fn(|a| u[a] - cell[a] as f64);
            let [wx, wy, wz] = t.map(|t| [1.0 - t, t]);
            let mut sample = [[0f32; W]; 8];
            if cell.iter().all(|&c| c % BRICK != BRICK - 1) {
                let brick = [cell[0] / BRICK, cell[1] / BRICK, cell[2] / BRICK];
                let Some(values) = self.brick(self.shape.brick_index(brick)).values.as_deref()
                else {
                    // A uniform brick reads its value.
                    for c in 0..W {
                        out[c * n + i] = self.background[c];
                    }
                    continue;
                };
                let base = local_index(cell[0] % BRICK, cell[1] % BRICK, cell[2] % BRICK);
                for (k, s) in sample.iter_mut().enumerate() {
                    let (kx, ky, kz) = (k & 1, (k >> 1) & 1, k >> 2);
                    let at = (base + kx + BRICK * (ky + BRICK * kz)) * W;
                    s.copy_from_slice(&values[at..at + W]);
                }
            } else {
                for (k, s) in sample.iter_mut().enumerate() {
                    let c = [
                        cell[0] + (k & 1),
                        cell[1] + ((k >> 1) & 1),
                        cell[2] + (k >> 2),
                    ];
                    let brick = [c[0] / BRICK, c[1] / BRICK, c[2] / BRICK];
                    let values = self.brick_values(self.shape.brick_index(brick));
                    let at = local_index(c[0] % BRICK, c[1] % BRICK, c[2] % BRICK) * W;
                    s.copy_from_slice(&values[at..at + W]);
                }
            }
            // Same terms in the same order as `accumulate`.
            let mut value = [0.0; W];
            for kz in 0..2 {
                for ky in 0..2 {
                    let weight_yz = wy[ky] * wz[kz];
                    for kx in 0..2 {
                        let weight = wx[kx] * weight_yz;
                        let cell = &sample[kx + 2 * (ky + 2 * kz)];
                        for c in 0..W {
                            value[c] += weight * f64::from(cell[c]);
                        }
                    }
                }
            }
            for c in 0..W {
                out[c * n + i] = value[c];
            }
        }
        self.add_reads_outside(outside);
    }

    /// The stencil sum when every cell lies in `brick`, from local cell `base`; `LEN` as for
    /// `accumulate`. Same terms in the same order as `accumulate`.
    #[inline(always)]
    fn accumulate_within<const W: usize, const GRADIENT: bool, const LEN: usize>(
        axes: &[AxisStencil; 3],
        brick: &[f32],
        base: usize,
        value: &mut [f64; W],
        gradient: &mut [[f64; 3]; W],
    ) {
        let [sx, sy, sz] = axes;
        let len = |axis: &AxisStencil| if LEN == 0 { axis.len } else { LEN };
        for kz in 0..len(sz) {
            for ky in 0..len(sy) {
                let weight_yz = sy.weight[ky] * sz.weight[kz];
                let slope_y = sy.slope[ky] * sz.weight[kz];
                let slope_z = sy.weight[ky] * sz.slope[kz];
                let row = (base + BRICK * (ky + BRICK * kz)) * W;
                let row = &brick[row..row + len(sx) * W];
                for kx in 0..len(sx) {
                    let cell = &row[kx * W..kx * W + W];
                    let weight = sx.weight[kx] * weight_yz;
                    for c in 0..W {
                        let sample = f64::from(cell[c]);
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

    /// Resolves a stencil that spans bricks.
    fn stencil(&self, axes: [AxisStencil; 3]) -> Stencil<'_> {
        let mut brick_of = [[0; 4]; 3];
        let mut offset = [[0; 4]; 3];
        let mut first = [0; 3];
        let mut span = [0; 3];
        for a in 0..3 {
            let axis = &axes[a];
            first[a] = axis.start / BRICK;
            span[a] = (axis.start + axis.len - 1) / BRICK - first[a];
            for k in 0..axis.len {
                let cell = axis.start + k;
                brick_of[a][k] = (cell / BRICK - first[a]) * BRICK_STEP[a];
                offset[a][k] = (cell % BRICK) * CELL_STEP[a];
            }
        }
        let mut bricks = [&self.background_brick[..]; 8];
        for dz in 0..=span[2] {
            for dy in 0..=span[1] {
                for dx in 0..=span[0] {
                    let index =
                        self.shape
                            .brick_index([first[0] + dx, first[1] + dy, first[2] + dz]);
                    bricks[dx + 2 * (dy + 2 * dz)] = self.brick_values(index);
                }
            }
        }
        Stencil {
            axes,
            brick_of,
            offset,
            bricks,
        }
    }

    /// Accumulates the interpolated value and, when `GRADIENT`, its derivatives with respect
    /// to the three index coordinates, over a stencil that spans bricks.
    fn interpolate<const W: usize, const GRADIENT: bool>(
        stencil: &Stencil<'_>,
        value: &mut [f64; W],
        gradient: &mut [[f64; 3]; W],
    ) {
        // The common shapes get loops of fixed length, which the compiler unrolls; the sums
        // are taken in the same order either way.
        match [0, 1, 2].map(|a| stencil.axes[a].len) {
            [2, 2, 2] => Cache::accumulate::<W, GRADIENT, 2>(stencil, value, gradient),
            [4, 4, 4] => Cache::accumulate::<W, GRADIENT, 4>(stencil, value, gradient),
            _ => Cache::accumulate::<W, GRADIENT, 0>(stencil, value, gradient),
        }
    }

    /// The sum over the stencil; `LEN` is the stencil length on every axis, or 0 for lengths
    /// read from the stencil.
    #[inline(always)]
    fn accumulate<const W: usize, const GRADIENT: bool, const LEN: usize>(
        stencil: &Stencil<'_>,
        value: &mut [f64; W],
        gradient: &mut [[f64; 3]; W],
    ) {
        let [sx, sy, sz] = &stencil.axes;
        let len = |axis: &AxisStencil| if LEN == 0 { axis.len } else { LEN };
        for kz in 0..len(sz) {
            let brick_z = stencil.brick_of[2][kz];
            let offset_z = stencil.offset[2][kz];
            for ky in 0..len(sy) {
                let weight_yz = sy.weight[ky] * sz.weight[kz];
                let slope_y = sy.slope[ky] * sz.weight[kz];
                let slope_z = sy.weight[ky] * sz.slope[kz];
                let brick_yz = brick_z + stencil.brick_of[1][ky];
                let offset_yz = offset_z + stencil.offset[1][ky];
                for kx in 0..len(sx) {
                    let brick = stencil.bricks[brick_yz + stencil.brick_of[0][kx]];
                    let at = (offset_yz + stencil.offset[0][kx]) * W;
                    let cell = &brick[at..at + W];
                    let weight = sx.weight[kx] * weight_yz;
                    for c in 0..W {
                        let sample = f64::from(cell[c]);
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

    /// Interpolated values at world points with other edges than the default (see
    /// `outside`): extrapolated beyond the box, or held in the half-cell border.
    pub fn sample_outside(
        &self,
        outside: Outside,
        interp: Interp,
        xs: &[f64],
        ys: &[f64],
        zs: &[f64],
        out: &mut [f64],
    ) {
        match outside {
            Outside::Extrapolate => {
                points::values_of(&Edges::<false>(self), self.width, interp, xs, ys, zs, out)
            }
            Outside::Hold => {
                points::values_of(&Edges::<true>(self), self.width, interp, xs, ys, zs, out)
            }
        }
    }

    /// The derivative of [`Cache::sample_outside`]'s interpolant (in a held border, the edge
    /// cells' slope).
    pub fn gradient_outside(
        &self,
        outside: Outside,
        interp: Interp,
        xs: &[f64],
        ys: &[f64],
        zs: &[f64],
        out: &mut [f64],
    ) {
        match outside {
            Outside::Extrapolate => {
                points::gradients_of(&Edges::<false>(self), self.width, interp, xs, ys, zs, out)
            }
            Outside::Hold => {
                points::gradients_of(&Edges::<true>(self), self.width, interp, xs, ys, zs, out)
            }
        }
    }
}

impl PointRead for Cache {
    #[inline(always)]
    fn index_of(&self, p: DVec3) -> Option<DVec3> {
        self.index_coords(p)
    }

    #[inline(always)]
    fn read<const W: usize, const GRADIENT: bool>(
        &self,
        interp: Interp,
        u: DVec3,
        value: &mut [f64; W],
        gradient: &mut [[f64; 3]; W],
    ) {
        let cells = self.shape.cells;
        // Truncation, not `floor`: without SSE4.1 `floor` is a library call.
        // Through i64: x86 converts signed integers in one instruction, unsigned ones not.
        let [i, j, k] = [u.x as i64, u.y as i64, u.z as i64];
        if !GRADIENT && u.cmpge(DVec3::ZERO).all() && DVec3::new(i as f64, j as f64, k as f64) == u
        {
            let [i, j, k] = [i as usize, j as usize, k as usize];
            // Exactly on a cell centre (as when a solve or a cache over the same cells reads
            // this one): every rule's weights are 1 there and 0 elsewhere.
            if i < cells[0] && j < cells[1] && k < cells[2] {
                let index = self.shape.brick_index([i / BRICK, j / BRICK, k / BRICK]);
                match self.brick(index).values.as_deref() {
                    Some(values) => {
                        let at = (i % BRICK + BRICK * (j % BRICK + BRICK * (k % BRICK))) * W;
                        for c in 0..W {
                            value[c] = f64::from(values[at + c]);
                        }
                    }
                    None => value.copy_from_slice(&self.background[..W]),
                }
                return;
            }
        }
        let axes = [
            axis_stencil(interp, u.x, cells[0]),
            axis_stencil(interp, u.y, cells[1]),
            axis_stencil(interp, u.z, cells[2]),
        ];
        let first = axes.map(|axis| axis.start / BRICK);
        let last = axes.map(|axis| (axis.start + axis.len - 1) / BRICK);
        if first != last {
            let stencil = self.stencil(axes);
            return Cache::interpolate::<W, GRADIENT>(&stencil, value, gradient);
        }
        // Most stencils lie inside one brick: read it with fixed strides.
        let Some(brick) = self.brick(self.shape.brick_index(first)).values.as_deref() else {
            // A uniform brick reads its value, with no slope.
            value.copy_from_slice(&self.background[..W]);
            return;
        };
        let base = axes.map(|axis| axis.start % BRICK);
        let base = base[0] + BRICK * (base[1] + BRICK * base[2]);
        match axes.map(|axis| axis.len) {
            [2, 2, 2] => {
                Cache::accumulate_within::<W, GRADIENT, 2>(&axes, brick, base, value, gradient)
            }
            [4, 4, 4] => {
                Cache::accumulate_within::<W, GRADIENT, 4>(&axes, brick, base, value, gradient)
            }
            _ => Cache::accumulate_within::<W, GRADIENT, 0>(&axes, brick, base, value, gradient),
        }
    }

    fn outside(&self) -> &[f64] {
        &self.background
    }

    fn placement(&self) -> (DMat3, DVec3) {
        (self.domain.rotation, self.domain.cell.recip())
    }
}

/// A cache read with other edges: `HOLD`, index coordinates are held within the span of cell
/// centres (the background beyond the box); otherwise any point is read, and outside the box
/// the stencils extrapolate linearly from the two outermost cells.
struct Edges<'a, const HOLD: bool>(&'a Cache);

impl<const HOLD: bool> PointRead for Edges<'_, HOLD> {
    #[inline(always)]
    fn index_of(&self, p: DVec3) -> Option<DVec3> {
        let cache = self.0;
        if HOLD {
            let last = cache.shape.cells.map(|n| (n - 1) as f64);
            return cache
                .index_coords(p)
                .map(|u| u.clamp(DVec3::ZERO, DVec3::from_array(last)));
        }
        let local = cache.to_local * (p - cache.domain.origin);
        Some(local / cache.domain.cell - DVec3::splat(0.5))
    }

    #[inline(always)]
    fn read<const W: usize, const GRADIENT: bool>(
        &self,
        interp: Interp,
        u: DVec3,
        value: &mut [f64; W],
        gradient: &mut [[f64; 3]; W],
    ) {
        self.0.read::<W, GRADIENT>(interp, u, value, gradient);
    }

    fn outside(&self) -> &[f64] {
        &self.0.background
    }

    fn placement(&self) -> (DMat3, DVec3) {
        self.0.placement()
    }
}

impl GridSource for Cache {
    fn width(&self) -> usize {
        self.width
    }

    fn identity(&self) -> u64 {
        self.identity
    }

    fn label(&self) -> String {
        self.label.clone()
    }

    fn sample(&self, interp: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        if interp == Interp::Linear && self.shape.cells.iter().all(|&n| n > 1) {
            match self.width {
                1 => return self.sample_linear::<1>(xs, ys, zs, out),
                3 => return self.sample_linear::<3>(xs, ys, zs, out),
                _ => {}
            }
        }
        self.count_reads_outside(xs, ys, zs);
        points::values_of(self, self.width, interp, xs, ys, zs, out);
    }

    fn sample_gradient(&self, interp: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        points::gradients_of(self, self.width, interp, xs, ys, zs, out);
    }

    fn bounds(&self) -> Aabb {
        self.domain.bounds()
    }

    fn background(&self) -> Vec<f64> {
        self.background.clone()
    }

    fn cell_size(&self) -> DVec3 {
        self.domain.cell
    }

    fn lattice(&self) -> Option<Lattice> {
        Some(self.domain.lattice())
    }

    fn pending_inputs(&self) -> Vec<Arc<dyn GridSource>> {
        match lock(&self.source).as_ref() {
            Some(source) => source.grids(),
            None => Vec::new(),
        }
    }

    /// Copies the stored cells, a brick's row at a time, when `domain`'s cells are among this
    /// cache's own (`cell_offset`).
    fn cells(&self, domain: &Domain, lo: [usize; 3], hi: [usize; 3], out: &mut [f32]) -> bool {
        let Some(offset) = self.cell_offset(domain) else {
            return false;
        };
        let lo: [usize; 3] = std::array::from_fn(|a| lo[a] + offset[a]);
        let hi: [usize; 3] = std::array::from_fn(|a| hi[a] + offset[a]);
        if (0..3).any(|a| hi[a] > self.shape.cells[a]) {
            return false;
        }
        let width = self.width;
        let mut at = 0;
        for k in lo[2]..hi[2] {
            for j in lo[1]..hi[1] {
                let mut i = lo[0];
                while i < hi[0] {
                    let end = ((i / BRICK + 1) * BRICK).min(hi[0]);
                    let values = self.brick_values(self.shape.brick_index([
                        i / BRICK,
                        j / BRICK,
                        k / BRICK,
                    ]));
                    let from = local_index(i % BRICK, j % BRICK, k % BRICK) * width;
                    let count = (end - i) * width;
                    out[at..at + count].copy_from_slice(&values[from..from + count]);
                    at += count;
                    i = end;
                }
            }
        }
        true
    }

    /// Fills the bricks whose cells the interpolant reads inside `region`, on the calling
    /// thread (no rayon: this may run inside another cache's brick fill).
    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        self.range_of(region, Interp::Cubic, false)
    }

    /// As `range`, for reads through `interp` only: a linear read reaches fewer cells.
    fn range_read(&self, region: &Aabb, interp: Interp) -> Vec<(f64, f64)> {
        self.range_of(region, interp, false)
    }

    /// As `range_read`, as if the read held its outermost cells in the half-cell border: for a
    /// linear read, the range of the samples it reads.
    fn range_held(&self, region: &Aabb, interp: Interp) -> Vec<(f64, f64)> {
        self.range_of(region, interp, true)
    }
}
