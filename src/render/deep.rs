//! Deep output: each camera ray's colour and transmittance as functions of depth, and the
//! per-pixel samples a deep OpenEXR file holds (docs/language.md, "Deep images").
//!
//! While it marches, a ray records its curve: the premultiplied colour `C(z)` and mean
//! transmittance `T(z)` it has accumulated by depth `z` (the camera-axis distance of the
//! flat `depth.Z` AOV), as points joined by straight lines. A pixel's curves are averaged over
//! its rays (`C̄`, `T̄`), cut at boundaries `z_0 < … < z_K`, and each interval becomes one
//! sample with `A = 1 − T̄(z_k)/T̄(z_{k−1})` and colour `(C̄(z_k) − C̄(z_{k−1}))/T̄(z_{k−1})`.
//! Compositing the samples front to back multiplies the ratios and sums the colour steps, so
//! it telescopes to `1 − T̄(z_K)` and `C̄(z_K)`: the flat pixel, for any boundaries and any
//! number of rays, because `z_K` is past the end of every ray.
//!
//! The one key decision: memory per ray is bounded. A ray keeps at most `curve_points` points,
//! spaced by how much the curve changes (transmittance lost, colour gained relative to the
//! colour so far), not by depth: the latest point follows the ray until the change since the
//! point before reaches a merge size. When the points are full every other one is dropped (the
//! first and the latest always stay) and the merge size doubles, so a long ray's curve grows
//! coarser but stays evenly spread and exact at its ends. Steps that change nothing (empty
//! space inside a run) record nothing. Boundaries fall where the pixel's accumulated
//! change — the transmittance lost plus the colour gained, each as a fraction of its total —
//! crosses equal fractions of the whole, so samples are dense where the medium is.

use glam::DVec3;

/// One point of a ray's curve.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct CurvePoint {
    depth: f32,
    /// Transmittance, the mean of the three channels.
    transmittance: f32,
    color: [f32; 3],
}

impl CurvePoint {
    fn new(depth: f64, transmittance: DVec3, color: DVec3) -> CurvePoint {
        CurvePoint {
            depth: depth as f32,
            transmittance: (transmittance.element_sum() / 3.0) as f32,
            color: color.as_vec3().to_array(),
        }
    }

    fn state(&self) -> [f64; 4] {
        [
            f64::from(self.transmittance),
            f64::from(self.color[0]),
            f64::from(self.color[1]),
            f64::from(self.color[2]),
        ]
    }
}

/// A ray's state before anything is marched: clear, no colour.
const CLEAR: [f64; 4] = [1.0, 0.0, 0.0, 0.0];

/// Points kept per ray for `samples` deep samples per pixel: twice the samples, within
/// [16, 128], so a tile's 4096 rays hold at most 10 MB of curves.
pub fn curve_points(samples: usize) -> usize {
    (2 * samples).clamp(16, 128)
}

/// Bytes of the curves of `rays` rays at `samples` deep samples per pixel.
pub fn curve_bytes(samples: usize, rays: usize) -> usize {
    rays * (curve_points(samples) * std::mem::size_of::<CurvePoint>() + 32)
}

/// Every ray's curve in a tile, structure of arrays: ray `r` owns `points[r·bound ..]`.
#[derive(Default)]
pub struct DeepCurves {
    bound: usize,
    points: Vec<CurvePoint>,
    len: Vec<usize>,
    /// Depth along ray `r` at parameter `t` is `start + t·rate` (a ray is a straight line).
    start: Vec<f64>,
    rate: Vec<f64>,
    /// Per ray, how much the curve must change (`measure`) before its latest point stays:
    /// doubled each time the ray's points are thinned.
    merge: Vec<f32>,
}

impl DeepCurves {
    /// Empties the curves for `n` rays of `bound` points each.
    pub fn reset(&mut self, n: usize, bound: usize) {
        self.bound = bound;
        self.points.clear();
        self.points.resize(n * bound, CurvePoint::default());
        self.len.clear();
        self.len.resize(n, 0);
        self.start.clear();
        self.rate.clear();
        self.merge.clear();
        self.merge.resize(n, 1.0 / (4 * bound) as f32);
    }

    /// Adds the next ray: its depth at `t = 0` and the depth gained per unit of `t`.
    pub fn aim(&mut self, start: f64, rate: f64) {
        self.start.push(start);
        self.rate.push(rate);
    }

    fn depth(&self, r: usize, t: f64) -> f64 {
        self.start[r] + t * self.rate[r]
    }

    fn curve(&self, r: usize) -> &[CurvePoint] {
        &self.points[r * self.bound..r * self.bound + self.len[r]]
    }

    /// Records ray `r`'s step over `[t0, t1]` from state `(T, C)` before to after. A step
    /// that changes nothing is not recorded; one that follows a gap (empty space, or steps
    /// that changed nothing) first records where the change began. The latest point moves
    /// with the ray until the curve since the point before it has changed by the ray's merge
    /// size; then it stays and a new latest point follows.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &mut self,
        r: usize,
        t0: f64,
        t1: f64,
        before: DVec3,
        color_before: DVec3,
        after: DVec3,
        color_after: DVec3,
    ) {
        if before == after && color_before == color_after {
            return;
        }
        let to = CurvePoint::new(self.depth(r, t1), after, color_after);
        let from = CurvePoint::new(self.depth(r, t0), before, color_before);
        if self.curve(r).last().is_none_or(|p| p.depth < from.depth) {
            // A corner: the curve was flat up to here.
            self.push(r, from);
            self.push(r, to);
            return;
        }
        let curve = self.curve(r);
        if curve.len() >= 2 && measure(&curve[curve.len() - 2], &to) < self.merge[r] {
            let last = r * self.bound + self.len[r] - 1;
            self.points[last] = to;
        } else {
            self.push(r, to);
        }
    }

    /// Puts ray `r`'s curve back to the state at `t` (adaptive stepping rewound a step).
    pub fn rewind(&mut self, r: usize, t: f64, transmittance: DVec3, color: DVec3) {
        let at = CurvePoint::new(self.depth(r, t), transmittance, color);
        while self.curve(r).last().is_some_and(|p| p.depth > at.depth) {
            self.len[r] -= 1;
        }
        match self.curve(r).last() {
            Some(p) if p.state() == at.state() => {}
            Some(p) if p.depth == at.depth => {
                let last = r * self.bound + self.len[r] - 1;
                self.points[last] = at;
            }
            Some(_) => self.push(r, at),
            // Nothing recorded yet, or everything was past `t`: the ray is as it started.
            None if at.state() == CLEAR => {}
            None => self.push(r, at),
        }
    }

    fn push(&mut self, r: usize, point: CurvePoint) {
        let base = r * self.bound;
        if self.len[r] == self.bound {
            // Keep points 0, 2, 4, …, and the latest: half as dense, both ends exact.
            let kept = self.bound / 2;
            for i in 1..kept {
                self.points[base + i] = self.points[base + 2 * i];
            }
            self.points[base + kept] = self.points[base + self.bound - 1];
            self.len[r] = kept + 1;
            self.merge[r] *= 2.0;
        }
        self.points[base + self.len[r]] = point;
        self.len[r] += 1;
    }

    /// Ray `r`'s state `[T, C_r, C_g, C_b]` at depth `z`: the curve's straight line through
    /// `z`, the state after the last point at or before it (a jump counts as done).
    fn state_at(&self, r: usize, z: f64) -> [f64; 4] {
        let curve = self.curve(r);
        let next = curve.partition_point(|p| f64::from(p.depth) <= z);
        if next == 0 {
            return CLEAR;
        }
        let a = &curve[next - 1];
        let Some(b) = curve.get(next) else {
            return a.state();
        };
        let (za, zb) = (f64::from(a.depth), f64::from(b.depth));
        let w = ((z - za) / (zb - za)).clamp(0.0, 1.0);
        let (sa, sb) = (a.state(), b.state());
        std::array::from_fn(|i| sa[i] + w * (sb[i] - sa[i]))
    }

    /// The deep samples of the pixel whose rays are `rays`, at most `most` of them, appended
    /// to `out`; returns how many. `transmittance` and `color` are the rays' final states,
    /// which the last boundary takes exactly (see the module notes).
    pub fn pixel_samples(
        &self,
        rays: std::ops::Range<usize>,
        transmittance: &[DVec3],
        color: &[DVec3],
        most: usize,
        scratch: &mut Vec<(f64, f64)>,
        out: &mut Vec<DeepSample>,
    ) -> usize {
        let Some(boundaries) = self.boundaries(rays.clone(), most, scratch) else {
            return 0;
        };
        let inv = 1.0 / rays.len() as f64;
        let last = boundaries.len() - 1;
        let mean: Vec<[f64; 4]> = boundaries
            .iter()
            .enumerate()
            .map(|(k, &z)| {
                let mut sum = [0.0; 4];
                for r in rays.clone() {
                    let state = if k == 0 {
                        // Nothing is marched before the first boundary (a rewound curve may
                        // start past it): the first sample takes whatever happened there.
                        CLEAR
                    } else if k == last {
                        let c = color[r];
                        [transmittance[r].element_sum() / 3.0, c.x, c.y, c.z]
                    } else {
                        self.state_at(r, z)
                    };
                    for (s, v) in sum.iter_mut().zip(state) {
                        *s += v;
                    }
                }
                sum.map(|s| s * inv)
            })
            .collect();
        let pixel: Vec<(f64, [f64; 4])> = boundaries.into_iter().zip(mean).collect();
        samples_between(&pixel, out)
    }

    /// The pixel's boundaries `z_0 < … < z_K` (distinct as 32-bit floats), or `None` when no
    /// ray recorded anything. `z_0` is where the first change begins, `z_K` where the last
    /// ends; between, at most `most − 1` depths where the pooled change of the pixel's rays
    /// crosses `k/most` of its total.
    fn boundaries(
        &self,
        rays: std::ops::Range<usize>,
        most: usize,
        changes: &mut Vec<(f64, f64)>,
    ) -> Option<Vec<f64>> {
        let mut front = f64::INFINITY;
        let mut back = f64::NEG_INFINITY;
        // Totals of the transmittance lost and the colour gained, for the weights.
        let mut totals = [0.0f64; 2];
        for r in rays.clone() {
            let curve = self.curve(r);
            let (Some(first), Some(last)) = (curve.first(), curve.last()) else {
                continue;
            };
            front = front.min(f64::from(first.depth));
            back = back.max(f64::from(last.depth));
            let mut previous = CLEAR;
            for p in curve {
                let (dt, dc) = change(previous, p.state());
                totals[0] += dt;
                totals[1] += dc;
                previous = p.state();
            }
        }
        if front > back {
            return None;
        }
        changes.clear();
        let scale = totals.map(|t| if t > 0.0 { 1.0 / t } else { 0.0 });
        for r in rays {
            let mut previous = CLEAR;
            for p in self.curve(r) {
                let (dt, dc) = change(previous, p.state());
                changes.push((f64::from(p.depth), dt * scale[0] + dc * scale[1]));
                previous = p.state();
            }
        }
        changes.sort_by(|a, b| a.0.total_cmp(&b.0));
        let total: f64 = changes.iter().map(|c| c.1).sum();
        let mut boundaries = vec![front];
        let mut reached = 0.0;
        let mut k = 1;
        for &(depth, weight) in changes.iter() {
            reached += weight;
            while k < most && reached >= total * k as f64 / most as f64 {
                k += 1;
                push_distinct(&mut boundaries, depth, back);
            }
        }
        if boundaries.len() == 1 || (back as f32) > (boundaries[boundaries.len() - 1] as f32) {
            // With every change at one depth, a point sample: front and back alike.
            boundaries.push(back);
        }
        Some(boundaries)
    }
}

/// How much a ray's curve changed from `a` to `b`: the transmittance lost plus the colour
/// gained relative to the colour at `b` (so bright emission is measured as dim).
fn measure(a: &CurvePoint, b: &CurvePoint) -> f32 {
    let gained: f32 = (0..3).map(|c| (b.color[c] - a.color[c]).abs()).sum();
    let color: f32 = b.color.iter().map(|c| c.abs()).sum();
    (a.transmittance - b.transmittance).abs() + if color > 0.0 { gained / color } else { 0.0 }
}

/// The transmittance lost and the colour gained (sum of channels) from state `a` to `b`.
fn change(a: [f64; 4], b: [f64; 4]) -> (f64, f64) {
    let color = (1..4).map(|i| (b[i] - a[i]).abs()).sum();
    ((b[0] - a[0]).abs(), color)
}

/// Appends `z` if it lies after the last boundary and before `limit` as 32-bit floats.
fn push_distinct(boundaries: &mut Vec<f64>, z: f64, limit: f64) {
    let last = boundaries.last().copied().unwrap_or(f64::NEG_INFINITY);
    if (z as f32) > (last as f32) && (z as f32) < (limit as f32) {
        boundaries.push(z);
    }
}

/// One deep sample: the slab `[front, back]` of depth, its alpha and premultiplied colour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeepSample {
    pub front: f32,
    pub back: f32,
    pub alpha: f32,
    pub color: [f32; 3],
}

/// The samples between a pixel's boundaries, given as `(z_k, [T̄, C̄])` from `z_0` (where
/// `T̄ = 1` and `C̄ = 0`) to `z_K`; returns how many were appended.
///
/// Where a holdout made `T̄` rise, a sample's alpha would be negative. Boundaries are then
/// dropped, walking back from `z_K`, until `T̄` never rises from one kept boundary to the
/// next: every alpha is in [0, 1] and the samples still telescope to the flat pixel (any
/// subset of boundaries that keeps both ends does). A boundary where `T̄ = 0` is dropped too
/// (nothing behind it is seen, and it would divide by zero). Samples of zero alpha and zero
/// colour change nothing and are left out.
pub fn samples_between(pixel: &[(f64, [f64; 4])], out: &mut Vec<DeepSample>) -> usize {
    if pixel.len() < 2 {
        return 0;
    }
    let mut kept = vec![pixel[pixel.len() - 1]];
    for &boundary in pixel[1..pixel.len() - 1].iter().rev() {
        let floor = kept.last().map_or(0.0, |b| b.1[0]);
        if boundary.1[0] > 0.0 && boundary.1[0] >= floor {
            kept.push(boundary);
        }
    }
    kept.push(pixel[0]);
    kept.reverse();
    let mut count = 0;
    for pair in kept.windows(2) {
        let ((front, a), (back, b)) = (pair[0], pair[1]);
        let alpha = if a[0] > 0.0 { 1.0 - b[0] / a[0] } else { 0.0 };
        let lit = |i: usize| {
            if a[0] > 0.0 {
                (b[i] - a[i]) / a[0]
            } else {
                0.0
            }
        };
        let sample = DeepSample {
            front: front as f32,
            back: back as f32,
            alpha: alpha.clamp(0.0, 1.0) as f32,
            color: [lit(1) as f32, lit(2) as f32, lit(3) as f32],
        };
        if sample.alpha != 0.0 || sample.color != [0.0; 3] {
            out.push(sample);
            count += 1;
        }
    }
    count
}

/// A deep image: per pixel (row-major, top row first) its samples, front to back.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeepImage {
    pub width: usize,
    pub height: usize,
    /// Samples per pixel.
    pub counts: Vec<u32>,
    /// Every pixel's samples, pixel after pixel.
    pub samples: Vec<DeepSample>,
}

impl DeepImage {
    /// The most samples any pixel has.
    pub fn max_samples(&self) -> u32 {
        self.counts.iter().copied().max().unwrap_or(0)
    }
}

/// The deep image of a render from its tiles' samples.
pub(super) fn gather(
    tiles: &[super::tile::TileOutput],
    width: usize,
    height: usize,
) -> crate::base::failure::Outcome<DeepImage> {
    let total: usize = tiles.iter().map(|t| t.deep_samples.len()).sum();
    let bytes = total * std::mem::size_of::<DeepSample>() + width * height * 8;
    let _image = crate::engine::budget::reserve(
        bytes as f64,
        &format!("a {width} x {height} deep image of {total} samples"),
    )?;
    let mut counts = vec![0u32; width * height];
    for tile in tiles {
        for (local, &count) in tile.deep_counts.iter().enumerate() {
            let (tx, ty) = (local % tile.width, local / tile.width);
            counts[(tile.y0 + ty) * width + tile.x0 + tx] = count;
        }
    }
    let mut offsets = Vec::with_capacity(counts.len());
    let mut next = 0usize;
    for &count in &counts {
        offsets.push(next);
        next += count as usize;
    }
    let mut samples = vec![
        DeepSample {
            front: 0.0,
            back: 0.0,
            alpha: 0.0,
            color: [0.0; 3],
        };
        total
    ];
    for tile in tiles {
        let mut from = 0;
        for (local, &count) in tile.deep_counts.iter().enumerate() {
            let (tx, ty) = (local % tile.width, local / tile.width);
            let at = offsets[(tile.y0 + ty) * width + tile.x0 + tx];
            let count = count as usize;
            samples[at..at + count].copy_from_slice(&tile.deep_samples[from..from + count]);
            from += count;
        }
    }
    Ok(DeepImage {
        width,
        height,
        counts,
        samples,
    })
}

/// Composites samples front to back with `over`: premultiplied `[R, G, B, A]`.
pub fn flatten(samples: &[DeepSample]) -> [f64; 4] {
    let mut out = [0.0; 4];
    let mut clear = 1.0;
    for s in samples {
        for c in 0..3 {
            out[c] += clear * f64::from(s.color[c]);
        }
        clear *= 1.0 - f64::from(s.alpha);
    }
    out[3] = 1.0 - clear;
    out
}

#[cfg(test)]
#[path = "deep_tests.rs"]
mod tests;
