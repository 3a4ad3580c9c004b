//! The slice-by-slice sweep that fills a light's density-column grid in one pass.
//!
//! Cells are visited slice by slice along the grid axis closest to the light's direction, in
//! the order the light travels (the attenuation sweep of the real-time cloud shading in seed
//! 003, done on the CPU): a cell's column is the column at its upstream point — where the line
//! towards the light crosses the slice just done — plus the trapezoid integral of density over
//! the segment between them. The one key decision is how the upstream column is read: with
//! clamped Catmull-Rom weights, because repeated linear interpolation slice after slice blurs
//! shadow edges by about `h·√(slices)`, and not at all in the half-cell band next to a face,
//! where the column bends to zero on the face and the walk continues one more slice instead.

use super::light::Light;
use crate::engine::spare::Spare;
use crate::space::domain::Domain;
use glam::DVec3;
use rayon::prelude::*;

/// The slice-by-slice sweep. Works in a permuted copy where the sweep axis is the slowest, so
/// each slice is contiguous, and returns the columns in that order with the strides of the
/// grid's axes in it (`Layout::strides`).
pub fn sweep(
    rho: &[f32],
    light: &Light,
    domain: &Domain,
    resolution: [usize; 3],
    (axis, forward): (usize, bool),
) -> (Vec<f32>, [usize; 3]) {
    // Permuted axes: a (sweep), b, c.
    let (b_axis, c_axis) = match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let n = [resolution[axis], resolution[b_axis], resolution[c_axis]];
    let h = [domain.cell[axis], domain.cell[b_axis], domain.cell[c_axis]];
    let len = [
        domain.lengths[axis],
        domain.lengths[b_axis],
        domain.lengths[c_axis],
    ];
    let slice_len = n[1] * n[2];
    let permute = |v: DVec3| DVec3::new(v[axis], v[b_axis], v[c_axis]);
    // Direction towards the light, in permuted local coordinates, per cell.
    enum Towards {
        Parallel(DVec3),
        Point(DVec3),
    }
    let towards = match light {
        Light::Distant(d) => Towards::Parallel(-permute(domain.rotation.transpose() * d.direction)),
        Light::Point(p) => Towards::Point(permute(domain.world_to_local(p.position))),
    };
    let layout = Layout {
        resolution,
        axes: [axis, b_axis, c_axis],
    };
    let rho_p = layout.to_slices(rho, WORKING.take(rho.len()));
    let shift = match towards {
        Towards::Parallel(u) => Some(Shift::new(u, h)),
        Towards::Point(_) => None,
    };
    // Every cell of every slice is written below.
    let mut column = WORKING.take(rho.len());
    let order: Vec<usize> = if forward {
        (0..n[0]).collect()
    } else {
        (0..n[0]).rev().collect()
    };
    for (s, &ia) in order.iter().enumerate() {
        let (done, rest) = column.split_at_mut(ia * slice_len);
        let (current, after) = rest.split_at_mut(slice_len);
        let (done, after) = (&*done, &*after);
        // Slices already swept, by their place in the sweep order.
        let prior = |place: usize| {
            let ip = order[place];
            let col = if ip < ia {
                &done[ip * slice_len..(ip + 1) * slice_len]
            } else {
                &after[(ip - ia - 1) * slice_len..(ip - ia) * slice_len]
            };
            (col, &rho_p[ip * slice_len..(ip + 1) * slice_len])
        };
        let rho_slice = &rho_p[ia * slice_len..(ia + 1) * slice_len];
        // One cell's column by walking towards the light slice by slice until the column
        // upstream is known: normally one step; more only while the upstream point lies in
        // the half-cell band between the outermost cell centres and an entry face.
        let walk = |ib: usize, ic: usize| {
            let mut x = DVec3::new(
                (ia as f64 + 0.5) * h[0],
                (ib as f64 + 0.5) * h[1],
                (ic as f64 + 0.5) * h[2],
            );
            let mut rho_x = rho_slice[ib + n[1] * ic] as f64;
            let mut place = s;
            let mut total = 0.0;
            loop {
                let u = match &towards {
                    Towards::Parallel(u) => *u,
                    Towards::Point(p) => (*p - x).normalize_or_zero(),
                };
                // Distance along u to the previous slice's plane, or to the face.
                let along = if place > 0 { h[0] } else { 0.5 * h[0] };
                let delta = along / u.x.abs().max(1e-12);
                let y = x + u * delta;
                let mut inside = 1.0f64;
                for lat in 1..3 {
                    if y[lat] < 0.0 {
                        inside = inside.min(x[lat] / (x[lat] - y[lat]));
                    } else if y[lat] > len[lat] {
                        inside = inside.min((len[lat] - x[lat]) / (y[lat] - x[lat]));
                    }
                }
                if place == 0 || inside < 1.0 {
                    // The light enters the domain on this segment: density outside is
                    // zero, inside taken as the point's own.
                    total += rho_x * delta * inside;
                    break;
                }
                let (col, rho) = prior(place - 1);
                let (column_up, rho_up) =
                    upstream(col, rho, n[1], n[2], y.y / h[1] - 0.5, y.z / h[2] - 0.5);
                // D(x) = D(y) + ∫ρ over [y, x], by the trapezoid rule.
                total += delta * 0.5 * (rho_x + rho_up);
                if let Some(d) = column_up {
                    total += d;
                    break;
                }
                x = y;
                rho_x = rho_up;
                place -= 1;
            }
            total as f32
        };
        // After the first slice a distant light's upstream stencil is the same for every
        // cell; cells whose whole stencil lies inside the previous slice take it directly.
        let stencil = shift
            .as_ref()
            .filter(|_| s > 0)
            .map(|shift| (shift, prior(s - 1)));
        current
            .par_chunks_mut(n[1] * ROWS_PER_TASK)
            .enumerate()
            .for_each(|(task, rows)| {
                for (r, row) in rows.chunks_mut(n[1]).enumerate() {
                    let ic = task * ROWS_PER_TASK + r;
                    let rho_row = &rho_slice[n[1] * ic..n[1] * (ic + 1)];
                    let (first, last) = match &stencil {
                        Some((shift, (col, rho))) => match shift.interior(ic, n[1], n[2]) {
                            Some((first, last)) => {
                                shift.row(col, rho, n[1], ic, rho_row, first..last, row);
                                (first, last)
                            }
                            None => (n[1], n[1]),
                        },
                        None => (n[1], n[1]),
                    };
                    for ib in (0..first).chain(last..n[1]) {
                        row[ib] = walk(ib, ic);
                    }
                }
            });
    }
    WORKING.give(rho_p);
    (column, layout.strides())
}

/// Working grids in slice order, kept for the next sweep of the same size (an animation sweeps
/// every frame): fresh ones cost a page fault per 4 KiB, as much as the sweep itself.
pub static WORKING: Spare<f32> = Spare::new();

/// Rows of a slice per parallel task.
const ROWS_PER_TASK: usize = 8;

/// The order of the cells while sweeping: slice `a` (the sweep axis) slowest, then `c`, with
/// `b` fastest, so that each slice is contiguous; the grid's own order is x fastest.
struct Layout {
    resolution: [usize; 3],
    /// The sweep axis a, then b and c.
    axes: [usize; 3],
}

impl Layout {
    /// Copies `values` from the grid's order into slice order, in `out`: one pass over the
    /// output, a slice per parallel task. When b is x the rows along x are contiguous in both
    /// orders and are copied whole.
    fn to_slices(&self, values: &[f32], mut out: Vec<f32>) -> Vec<f32> {
        let [nx, ny, _] = self.resolution;
        let [a, b, c] = self.axes;
        let n = self.axes.map(|axis| self.resolution[axis]);
        let natural = |ijk: [usize; 3]| ijk[0] + nx * (ijk[1] + ny * ijk[2]);
        out.par_chunks_mut(n[1] * n[2])
            .enumerate()
            .for_each(|(ia, out)| {
                let mut ijk = [0usize; 3];
                ijk[a] = ia;
                if b == 0 {
                    // Rows along x: the slice's row `ic` is the grid's (y, z) row.
                    for (ic, row) in out.chunks_exact_mut(nx).enumerate() {
                        ijk[c] = ic;
                        let from = natural(ijk);
                        row.copy_from_slice(&values[from..from + nx]);
                    }
                    return;
                }
                for (at, value) in out.iter_mut().enumerate() {
                    ijk[b] = at % n[1];
                    ijk[c] = at / n[1];
                    *value = values[natural(ijk)];
                }
            });
        out
    }

    /// Where one step along each of the grid's axes x, y, z moves in slice order.
    fn strides(&self) -> [usize; 3] {
        let [a, b, c] = self.axes;
        let n = self.axes.map(|axis| self.resolution[axis]);
        let mut strides = [0; 3];
        strides[a] = n[1] * n[2];
        strides[b] = 1;
        strides[c] = n[1];
        strides
    }
}

/// Where a distant light's upstream points fall from one slice to the previous: at the same
/// offset from every cell, so the interpolation weights are computed once per sweep.
struct Shift {
    /// Path length between the slices.
    delta: f64,
    /// Whole cells from a cell to the lower corner of its upstream point, along b and c.
    cells: [i64; 2],
    /// The upstream point's fractions within that cell.
    fraction: [f64; 2],
    weights: [[f64; 4]; 2],
}

impl Shift {
    /// `u` is the unit direction towards the light in sweep coordinates, `h` the cell size.
    fn new(u: DVec3, h: [f64; 3]) -> Shift {
        let delta = h[0] / u.x.abs().max(1e-12);
        let offset = [u.y * delta / h[1], u.z * delta / h[2]];
        let cells = offset.map(|o| o.floor() as i64);
        let fraction = [offset[0] - cells[0] as f64, offset[1] - cells[1] as f64];
        Shift {
            delta,
            cells,
            fraction,
            weights: fraction.map(catmull_rom),
        }
    }

    /// The cells `first..last` of row `ic` whose upstream Catmull-Rom stencil lies inside the
    /// previous slice (away from its edges and the half-cell band), if any.
    fn interior(&self, ic: usize, nb: usize, nc: usize) -> Option<(usize, usize)> {
        let j = ic as i64 + self.cells[1];
        if j < 1 || j + 2 >= nc as i64 {
            return None;
        }
        let first = (1 - self.cells[0]).max(0);
        let last = (nb as i64 - 2 - self.cells[0]).min(nb as i64);
        (first < last).then_some((first as usize, last as usize))
    }

    /// Columns of cells `cells` of row `ic`, from the previous slice's column `col` and
    /// density `rho`; `rho_row` is this row's density. The same arithmetic as `upstream` and
    /// the walk's first step.
    /// Compiled a second time for AVX2 and picked at run time (the results are the same: no
    /// fused multiply-adds), as the field evaluator's kernels are.
    #[allow(clippy::too_many_arguments)]
    fn row(
        &self,
        col: &[f32],
        rho: &[f32],
        nb: usize,
        ic: usize,
        rho_row: &[f32],
        cells: std::ops::Range<usize>,
        out: &mut [f32],
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2, checked just above.
            unsafe { self.row_avx2(col, rho, nb, ic, rho_row, cells, out) };
            return;
        }
        self.row_body(col, rho, nb, ic, rho_row, cells, out);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[allow(clippy::too_many_arguments)]
    unsafe fn row_avx2(
        &self,
        col: &[f32],
        rho: &[f32],
        nb: usize,
        ic: usize,
        rho_row: &[f32],
        cells: std::ops::Range<usize>,
        out: &mut [f32],
    ) {
        self.row_body(col, rho, nb, ic, rho_row, cells, out);
    }

    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn row_body(
        &self,
        col: &[f32],
        rho: &[f32],
        nb: usize,
        ic: usize,
        rho_row: &[f32],
        cells: std::ops::Range<usize>,
        out: &mut [f32],
    ) {
        let j = (ic as i64 + self.cells[1]) as usize;
        let [wu, wv] = self.weights;
        let [fu, fv] = self.fraction;
        let half = 0.5 * self.delta;
        let mut along = [[0.0f64; CHUNK]; 4];
        let mut first = cells.start;
        while first < cells.end {
            let m = CHUNK.min(cells.end - first);
            let i = (first as i64 + self.cells[0]) as usize;
            // Catmull-Rom along b on each of the four rows around the upstream point.
            for (b, along) in along.iter_mut().enumerate() {
                let [x0, x1, x2, x3] = shifted(&col[nb * (j + b - 1)..nb * (j + b)], i, m);
                for ((((a, x0), x1), x2), x3) in along.iter_mut().zip(x0).zip(x1).zip(x2).zip(x3) {
                    *a = wu[0] * *x0 as f64
                        + wu[1] * *x1 as f64
                        + wu[2] * *x2 as f64
                        + wu[3] * *x3 as f64;
                }
            }
            // Across the rows, clamped to the four nearest columns; the density bilinear.
            let [_, c0, c1, _] = shifted(&col[nb * j..nb * (j + 1)], i, m);
            let [_, c2, c3, _] = shifted(&col[nb * (j + 1)..nb * (j + 2)], i, m);
            let [_, r0, r1, _] = shifted(&rho[nb * j..nb * (j + 1)], i, m);
            let [_, r2, r3, _] = shifted(&rho[nb * (j + 1)..nb * (j + 2)], i, m);
            let own = &rho_row[first..first + m];
            let out = &mut out[first..first + m];
            for t in 0..m {
                let sum = wv[0] * along[0][t]
                    + wv[1] * along[1][t]
                    + wv[2] * along[2][t]
                    + wv[3] * along[3][t];
                let near = [c0[t], c1[t], c2[t], c3[t]].map(f64::from);
                let lo = near[0].min(near[1]).min(near[2].min(near[3]));
                let hi = near[0].max(near[1]).max(near[2].max(near[3]));
                let [r0, r1, r2, r3] = [r0[t], r1[t], r2[t], r3[t]].map(f64::from);
                let top = r0 + (r1 - r0) * fu;
                let bottom = r2 + (r3 - r2) * fu;
                let density = top + (bottom - top) * fv;
                out[t] = (half * (own[t] as f64 + density) + sum.max(lo).min(hi)) as f32;
            }
            first += m;
        }
    }
}

/// Four views of `row` from `i − 1`, each `m` long and shifted by one more cell: zipped, they
/// give the loops of `Shift::row` a form that vectorises.
fn shifted(row: &[f32], i: usize, m: usize) -> [&[f32]; 4] {
    [0, 1, 2, 3].map(|d| &row[i - 1 + d..i - 1 + d + m])
}

/// Cells of a row computed together by `Shift::row`.
const CHUNK: usize = 64;

/// A swept slice's column and density at continuous cell index `(u, v)`.
///
/// The column is read with Catmull-Rom weights, clamped to the range of the four nearest
/// values: repeated linear interpolation, slice after slice, blurs shadow edges by about
/// `h·√(slices)`; the cubic much less, and the clamp keeps it from ringing. Next to the slice's
/// edges it is bilinear. Between the outermost cell centres and a face the column is not
/// interpolated at all (`None`): it bends there, from its value inside to zero on a face the
/// light enters through, and the caller walks on towards the light instead. The density is
/// bilinear, extended from the edge cells; it only enters a trapezoid.
fn upstream(
    column: &[f32],
    rho: &[f32],
    nb: usize,
    nc: usize,
    u: f64,
    v: f64,
) -> (Option<f64>, f64) {
    let in_band = u < 0.0 || v < 0.0 || u > (nb - 1) as f64 || v > (nc - 1) as f64;
    let u = u.clamp(0.0, (nb - 1) as f64);
    let v = v.clamp(0.0, (nc - 1) as f64);
    // Clamped non-negative: truncation is the floor.
    let i = (u as usize).min(nb.saturating_sub(2));
    let j = (v as usize).min(nc.saturating_sub(2));
    let (fu, fv) = (u - i as f64, v - j as f64);
    let di = usize::from(nb > 1);
    let dj = if nc > 1 { nb } else { 0 };
    let at = i + nb * j;
    let corners = |s: &[f32]| [s[at], s[at + di], s[at + dj], s[at + dj + di]].map(|x| x as f64);
    let bilinear = |c: [f64; 4]| {
        let top = c[0] + (c[1] - c[0]) * fu;
        let bottom = c[2] + (c[3] - c[2]) * fu;
        top + (bottom - top) * fv
    };
    let density = bilinear(corners(rho));
    if in_band {
        return (None, density);
    }
    let near = corners(column);
    if i == 0 || j == 0 || i + 2 >= nb || j + 2 >= nc {
        return (Some(bilinear(near)), density);
    }
    let (wu, wv) = (catmull_rom(fu), catmull_rom(fv));
    let mut sum = 0.0;
    for (b, wb) in wv.iter().enumerate() {
        let row = &column[(i - 1) + nb * (j + b - 1)..];
        let line: f64 = wu.iter().zip(row).map(|(w, x)| w * *x as f64).sum();
        sum += wb * line;
    }
    let lo = near.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = near.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (Some(sum.clamp(lo, hi)), density)
}

/// Catmull-Rom weights of the four samples around a fraction `t` in [0, 1).
fn catmull_rom(t: f64) -> [f64; 4] {
    let t2 = t * t;
    let t3 = t2 * t;
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}
