//! Smoothing the `cld` bits into a continuous density (seed 003, eq. 2.11 and §4.4).
//!
//! ```text
//! q(i,j,k,t) = Σ w(i′,j′,k′,t′) · cld(i+i′, j+j′, k+k′, t−t′)  /  Σ w
//!              |i′|,|j′|,|k′| ≤ r,  0 ≤ t′ ≤ t₀
//! w          = (r+1−|i′|)(r+1−|j′|)(r+1−|k′|) · (t₀+1−t′)
//! ```
//!
//! Eq. 2.11 divides by the window's cell count; dividing by the weights' sum instead makes the
//! inside of a cloud exactly 1, whatever the weights. The time window trails (the current step
//! and `t₀` before it) because later steps do not exist yet when a frame is drawn: the density
//! lags the bits by about `t₀/3` steps, the price of not stepping ahead. Cells outside the
//! domain count as empty. The one key decision: this is a `FieldSampler` evaluated at cell
//! centres, and `clouddensity` hands it to a cache, so the smoothing is done brick by brick
//! when a render or a cache read first asks, and a brick with no cloud bit within reach is
//! skipped without being evaluated (the density-map test of §7.2.2, per brick).

use super::bits::Planes;
use crate::space::domain::Domain;
use crate::space::{Aabb, BlockEval, FieldSampler};
use glam::DVec3;
use std::sync::Arc;

/// Largest smoothing radius, in cells (the window along x is read as one byte).
pub const MAX_RADIUS: usize = 3;

/// Bits of the all-frames window index at most: a table of 2^15 weights (128 KiB) still sits
/// in a core's cache, and covers radius 2 with three frames.
const COMBINED_BITS: usize = 15;

/// The smoothing window.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Smoothing {
    /// Cells either side, along each axis.
    pub radius: usize,
    /// Earlier steps included.
    pub window: usize,
}

/// The smoothed density of one automaton state.
pub struct SmoothedCloud {
    domain: Domain,
    planes: Planes,
    /// `cld` now and before, newest first.
    frames: Vec<Arc<Vec<u64>>>,
    /// The cells with cloud in any of the frames (their union), for the range test.
    any_frame: Vec<u64>,
    radius: usize,
    /// Weight of each frame, newest first.
    frame_weight: Vec<u32>,
    /// Weight of each offset along y and z, index `offset + radius`.
    axis_weight: Vec<u32>,
    /// Weighted count of the `2r+1` bits of a window along x, by the window's bits.
    row_sum: Vec<u32>,
    /// The same for the windows of all frames at once, weighted by frame (frame `f`'s window
    /// in bits `f·(2r+1)..`), when that index has at most `COMBINED_BITS` bits; else empty.
    frames_sum: Vec<u32>,
    normaliser: f64,
}

impl SmoothedCloud {
    pub fn new(
        domain: Domain,
        planes: Planes,
        mut frames: Vec<Arc<Vec<u64>>>,
        smoothing: Smoothing,
    ) -> SmoothedCloud {
        let r = smoothing.radius.min(MAX_RADIUS);
        frames.truncate(smoothing.window + 1);
        let frame_weight: Vec<u32> = (0..frames.len())
            .map(|t| (smoothing.window + 1 - t) as u32)
            .collect();
        let axis_weight: Vec<u32> = (0..=2 * r)
            .map(|o| (r + 1 - o.abs_diff(r)) as u32)
            .collect();
        let row_sum: Vec<u32> = (0..1usize << (2 * r + 1))
            .map(|bits: usize| {
                (0..=2 * r)
                    .filter(|&b| bits >> b & 1 == 1)
                    .map(|b| axis_weight[b])
                    .sum::<u32>()
            })
            .collect();
        let axis: u32 = axis_weight.iter().sum();
        let normaliser = (axis * axis * axis * frame_weight.iter().sum::<u32>()) as f64;
        let width = 2 * r + 1;
        let frames_sum: Vec<u32> = if width * frames.len() <= COMBINED_BITS {
            (0..1usize << (width * frames.len()))
                .map(|bits| {
                    (0..frames.len())
                        .map(|f| {
                            frame_weight[f] * row_sum[(bits >> (f * width)) & ((1 << width) - 1)]
                        })
                        .sum()
                })
                .collect()
        } else {
            Vec::new()
        };
        let mut any_frame = vec![0u64; planes.len()];
        for frame in &frames {
            for (any, &word) in any_frame.iter_mut().zip(frame.iter()) {
                *any |= word;
            }
        }
        SmoothedCloud {
            domain,
            planes,
            frames,
            any_frame,
            radius: r,
            frame_weight,
            axis_weight,
            row_sum,
            frames_sum,
            normaliser,
        }
    }

    /// The `2r+1` bits of row `row` centred on cell `i` (bit `b` is cell `i − r + b`), zeros
    /// outside the row.
    fn window(&self, plane: &[u64], row: usize, i: usize) -> usize {
        let words = self.planes.words;
        let base = &plane[row * words..(row + 1) * words];
        segment(
            base,
            i as i64 - self.radius as i64,
            2 * self.radius as u32 + 1,
        ) as usize
    }

    /// The smoothed density at cell `(i, j, k)`.
    pub fn at_cell(&self, i: usize, j: usize, k: usize) -> f64 {
        let r = self.radius as i64;
        let p = &self.planes;
        let mut sum = 0u32;
        for (frame, tw) in self.frames.iter().zip(&self.frame_weight) {
            for dk in -r..=r {
                let kk = k as i64 + dk;
                if !(0..p.nz as i64).contains(&kk) {
                    continue;
                }
                let wk = self.axis_weight[(dk + r) as usize];
                for dj in -r..=r {
                    let jj = j as i64 + dj;
                    if !(0..p.ny as i64).contains(&jj) {
                        continue;
                    }
                    let bits = self.window(frame, p.row(jj as usize, kk as usize), i);
                    if bits != 0 {
                        sum += tw * wk * self.axis_weight[(dj + r) as usize] * self.row_sum[bits];
                    }
                }
            }
        }
        sum as f64 / self.normaliser
    }

    /// Whether any cloud bit of any frame lies in cells `[lo, hi]` (inclusive, clamped).
    fn any_cloud(&self, lo: [i64; 3], hi: [i64; 3]) -> bool {
        let p = &self.planes;
        let n = [p.nx as i64, p.ny as i64, p.nz as i64];
        let lo = [0, 1, 2].map(|a| lo[a].max(0));
        let hi = [0, 1, 2].map(|a| hi[a].min(n[a] - 1));
        if (0..3).any(|a| lo[a] > hi[a]) {
            return false;
        }
        let (w0, w1) = ((lo[0] / 64) as usize, (hi[0] / 64) as usize);
        // The mask of each word's cells within [lo.x, hi.x].
        let masks: Vec<u64> = (w0..=w1)
            .map(|w| {
                let first = (64 * w) as i64;
                let from = (lo[0] - first).clamp(0, 63) as u32;
                let to = (hi[0] - first + 1).clamp(0, 64) as u32;
                (if to >= 64 { u64::MAX } else { (1u64 << to) - 1 }) & !((1u64 << from) - 1)
            })
            .collect();
        for k in lo[2]..=hi[2] {
            for j in lo[1]..=hi[1] {
                let row = p.row(j as usize, k as usize) * p.words;
                let words = &self.any_frame[row + w0..=row + w1];
                if words
                    .iter()
                    .zip(&masks)
                    .any(|(word, mask)| word & mask != 0)
                {
                    return true;
                }
            }
        }
        false
    }

    /// The cell holding world point `p`, if inside.
    fn cell_of(&self, p: DVec3) -> Option<[usize; 3]> {
        let local = self.domain.world_to_local(p) / self.domain.cell;
        let n = [self.planes.nx, self.planes.ny, self.planes.nz];
        let mut out = [0usize; 3];
        for a in 0..3 {
            let x = local[a].floor();
            if !(0.0..n[a] as f64).contains(&x) {
                return None;
            }
            out[a] = x as usize;
        }
        Some(out)
    }

    /// The smoothed density of every cell in `[lo, hi)` into `out` (index
    /// `i + nx·(j + ny·k)` within the box). Equals `at_cell`'s bit for bit (see `sums`).
    pub fn fill_box(&self, lo: [usize; 3], hi: [usize; 3], out: &mut Vec<f64>, sums: &mut Sums) {
        self.sums(lo, hi, sums);
        out.clear();
        out.extend(sums.out.iter().map(|&s| s as f64 / self.normaliser));
    }

    /// The x windows of row `row` from cell `x_lo` on, weighted and summed over the frames,
    /// added into `along_x`: one table lookup per cell and frame.
    fn along_x_by_frame(&self, row: usize, x_lo: usize, along_x: &mut [u32]) {
        let (p, r) = (&self.planes, self.radius);
        let mask = (1u64 << (2 * r + 1)) - 1;
        // Cells along x read at once: a chunk plus its window's reach fits in one word.
        let chunk = 64 - 2 * r;
        for (frame, &tw) in self.frames.iter().zip(&self.frame_weight) {
            let base = &frame[row * p.words..(row + 1) * p.words];
            for x0 in (0..along_x.len()).step_by(chunk) {
                let count = chunk.min(along_x.len() - x0);
                let start = (x_lo + x0) as i64 - r as i64;
                let bits = segment(base, start, (count + 2 * r) as u32);
                if bits == 0 {
                    continue;
                }
                for (x, value) in along_x[x0..x0 + count].iter_mut().enumerate() {
                    *value += tw * self.row_sum[(bits >> x & mask) as usize];
                }
            }
        }
    }

    /// The same, one lookup per cell for all frames together (`frames_sum`).
    fn along_x_together(&self, row: usize, x_lo: usize, along_x: &mut [u32]) {
        let (p, r) = (&self.planes, self.radius);
        let width = 2 * r + 1;
        let mask = (1u64 << width) - 1;
        let chunk = 64 - 2 * r;
        let mut bits = [0u64; 8];
        for x0 in (0..along_x.len()).step_by(chunk) {
            let count = chunk.min(along_x.len() - x0);
            let start = (x_lo + x0) as i64 - r as i64;
            let mut any = 0;
            for (bits, frame) in bits.iter_mut().zip(&self.frames) {
                *bits = segment(
                    &frame[row * p.words..(row + 1) * p.words],
                    start,
                    (count + 2 * r) as u32,
                );
                any |= *bits;
            }
            if any == 0 {
                continue;
            }
            let bits = &bits[..self.frames.len()];
            for (x, value) in along_x[x0..x0 + count].iter_mut().enumerate() {
                let mut index = 0;
                for (f, b) in bits.iter().enumerate() {
                    index |= ((b >> x & mask) as usize) << (f * width);
                }
                *value += self.frames_sum[index];
            }
        }
    }

    /// The weighted sums of every cell in `[lo, hi)` into `sums.out` (the density times the
    /// normaliser), separably: the windows along x per frame, then the weights along y, then
    /// along z. Every weight is a whole number, so the sums are exact integers and the same
    /// whatever order they are formed in: dividing them gives `at_cell`'s values bit for bit.
    fn sums(&self, lo: [usize; 3], hi: [usize; 3], sums: &mut Sums) {
        let p = &self.planes;
        let r = self.radius;
        let n = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        // The rows the y and z weights reach, clamped to the domain.
        let (j0, j1) = (lo[1].saturating_sub(r), (hi[1] + r).min(p.ny));
        let (k0, k1) = (lo[2].saturating_sub(r), (hi[2] + r).min(p.nz));
        let (hj, hk) = (j1 - j0, k1 - k0);
        // Along x, frames summed: along_x[i + n0·(j − j0 + hj·(k − k0))].
        let along_x = &mut sums.along_x;
        along_x.clear();
        along_x.resize(n[0] * hj * hk, 0);
        for k in k0..k1 {
            for j in j0..j1 {
                let at = n[0] * ((j - j0) + hj * (k - k0));
                let row = p.row(j, k);
                let along_x = &mut along_x[at..at + n[0]];
                if self.frames_sum.is_empty() {
                    self.along_x_by_frame(row, lo[0], along_x);
                } else {
                    self.along_x_together(row, lo[0], along_x);
                }
            }
        }
        // Along y then z, into the box.
        let along_y = &mut sums.along_y;
        along_y.clear();
        along_y.resize(n[0] * n[1] * hk, 0);
        for k in 0..hk {
            for j in 0..n[1] {
                let target = &mut along_y[n[0] * (j + n[1] * k)..][..n[0]];
                let centre = lo[1] + j;
                for jj in centre.saturating_sub(r)..(centre + r + 1).min(p.ny) {
                    let w = self.axis_weight[jj + r - centre];
                    let from = &along_x[n[0] * ((jj - j0) + hj * k)..][..n[0]];
                    for (t, f) in target.iter_mut().zip(from) {
                        *t += w * f;
                    }
                }
            }
        }
        let out = &mut sums.out;
        out.clear();
        out.resize(n[0] * n[1] * n[2], 0);
        for k in 0..n[2] {
            let centre = lo[2] + k;
            for kk in centre.saturating_sub(r)..(centre + r + 1).min(p.nz) {
                let w = self.axis_weight[kk + r - centre];
                let from = &along_y[n[0] * n[1] * (kk - k0)..][..n[0] * n[1]];
                for (t, f) in out[n[0] * n[1] * k..][..n[0] * n[1]].iter_mut().zip(from) {
                    *t += w * f;
                }
            }
        }
    }
}

/// Scratch space for the separable sums of one box.
#[derive(Default)]
pub struct Sums {
    along_x: Vec<u32>,
    along_y: Vec<u32>,
    out: Vec<u32>,
}

/// The `count <= 64` bits of a row's cells `start .. start + count` (bit `b` is cell
/// `start + b`), zeros outside the row.
#[inline]
fn segment(row: &[u64], start: i64, count: u32) -> u64 {
    let read = |w: i64| {
        if (0..row.len() as i64).contains(&w) {
            row[w as usize]
        } else {
            0
        }
    };
    let (w, b) = (start.div_euclid(64), start.rem_euclid(64) as u32);
    let mut v = read(w) >> b;
    if b != 0 {
        v |= read(w + 1) << (64 - b);
    }
    if count >= 64 {
        v
    } else {
        v & ((1u64 << count) - 1)
    }
}

/// Evaluates blocks of points: the cells they fall in, smoothed as one box when they fill
/// most of it (as a cache's brick fill asks), cell by cell otherwise.
struct Evaluator<'a> {
    cloud: &'a SmoothedCloud,
    cells: Vec<Option<[usize; 3]>>,
    values: Vec<f64>,
    scratch: Sums,
}

impl Evaluator<'_> {
    fn eval(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], mut put: impl FnMut(usize, f64)) {
        let cloud = self.cloud;
        self.cells.clear();
        let (mut lo, mut hi) = ([usize::MAX; 3], [0usize; 3]);
        for n in 0..xs.len() {
            let cell = cloud.cell_of(DVec3::new(xs[n], ys[n], zs[n]));
            if let Some(c) = cell {
                for a in 0..3 {
                    lo[a] = lo[a].min(c[a]);
                    hi[a] = hi[a].max(c[a] + 1);
                }
            }
            self.cells.push(cell);
        }
        let volume: usize = (0..3).map(|a| hi[a].saturating_sub(lo[a])).product();
        let boxed = volume > 0 && volume <= 2 * xs.len();
        if boxed {
            cloud.fill_box(lo, hi, &mut self.values, &mut self.scratch);
        }
        let n = [hi[0].saturating_sub(lo[0]), hi[1].saturating_sub(lo[1])];
        for (index, cell) in self.cells.iter().enumerate() {
            let value = match cell {
                None => 0.0,
                Some([i, j, k]) if boxed => {
                    self.values[(i - lo[0]) + n[0] * ((j - lo[1]) + n[1] * (k - lo[2]))]
                }
                Some([i, j, k]) => cloud.at_cell(*i, *j, *k),
            };
            put(index, value);
        }
    }
}

impl BlockEval for Evaluator<'_> {
    fn eval_f32(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f32]) {
        self.eval(xs, ys, zs, |n, v| out[n] = v as f32);
    }

    fn eval_f64(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        self.eval(xs, ys, zs, |n, v| out[n] = v);
    }
}

impl FieldSampler for SmoothedCloud {
    fn width(&self) -> usize {
        1
    }

    fn evaluator(&self) -> Box<dyn BlockEval + '_> {
        Box::new(Evaluator {
            cloud: self,
            cells: Vec::new(),
            values: Vec::new(),
            scratch: Sums::default(),
        })
    }

    /// A brick of the cloud's own domain is its cells' sums, without locating points.
    fn fill_cells(&self, domain: &Domain, lo: [usize; 3], hi: [usize; 3], out: &mut [f32]) -> bool {
        if *domain != self.domain {
            return false;
        }
        let mut sums = Sums::default();
        self.sums(lo, hi, &mut sums);
        for (o, &s) in out.iter_mut().zip(&sums.out) {
            *o = (s as f64 / self.normaliser) as f32;
        }
        true
    }

    fn bounds(&self) -> Option<Aabb> {
        Some(self.domain.bounds())
    }

    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        // The cells whose centres may lie in the region, widened by the radius.
        let region = region.intersection(&self.domain.bounds());
        if region.is_empty() {
            return vec![(0.0, 0.0)];
        }
        let mut lo = [i64::MAX; 3];
        let mut hi = [i64::MIN; 3];
        for corner in region.corners() {
            let c = self.domain.world_to_local(corner) / self.domain.cell;
            for a in 0..3 {
                lo[a] = lo[a].min(c[a].floor() as i64 - 1);
                hi[a] = hi[a].max(c[a].floor() as i64 + 1);
            }
        }
        let r = self.radius as i64;
        if self.any_cloud(lo.map(|v| v - r), hi.map(|v| v + r)) {
            vec![(0.0, 1.0)]
        } else {
            vec![(0.0, 0.0)]
        }
    }
}
