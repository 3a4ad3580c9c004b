//! A tile's rays: their state while marching, and the pixels they average into.
//!
//! State is kept as structure of arrays, one entry per sample ray (pixel-major, then sample),
//! so the march can gather and scatter a block of rays by index. The one key decision: a pixel
//! is the plain average (box filter) of its samples, each placed by a counter hash of
//! `(seed, pixel, sample)`; colour is premultiplied by construction, alpha is one minus the
//! mean transmittance over the three channels.

use super::adaptive::Snapshot;
use super::camera::jitter;
use super::deep::{DeepCurves, DeepSample, curve_points};
use super::march::Frame;
use super::space::{BrickWalk, clip_to_box};
use super::surface::Surface;
use glam::DVec3;

/// Counts for `--profile` and tests.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MarchStats {
    /// Sample points evaluated (density evaluations along camera rays).
    pub samples: u64,
    /// Adaptive steps discarded and retried shorter.
    pub rejected: u64,
    /// What each input field gave that the march could not use as it was (see `Scene`).
    pub density: InputCounts,
    pub color: InputCounts,
    pub emission: InputCounts,
    pub holdout: InputCounts,
    /// Pixel channels whose value does not fit a 32-bit float (written as infinity), or came
    /// out NaN (written as 0).
    pub bad_pixels: u64,
}

impl MarchStats {
    pub fn merge(&mut self, other: &MarchStats) {
        self.samples += other.samples;
        self.rejected += other.rejected;
        self.density.merge(&other.density);
        self.color.merge(&other.color);
        self.emission.merge(&other.emission);
        self.holdout.merge(&other.holdout);
        self.bad_pixels += other.bad_pixels;
    }
}

/// One input field's samples along camera rays, and how many of them were unusable.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct InputCounts {
    /// Samples where the field was evaluated.
    pub samples: u64,
    /// Samples where some component was NaN or infinite.
    pub non_finite: u64,
    /// Samples where some component was negative (and none was NaN or infinite).
    pub negative: u64,
    /// Where the first non-finite sample was, in tile order (the same for any thread count).
    pub first_non_finite: Option<DVec3>,
    /// Whether the negative samples are all the work of grid reads extrapolating in the
    /// half-cell border inside their faces: the field read with those borders held is
    /// provably non-negative over the render box (the render decides this after the march).
    pub negative_only_at_faces: bool,
}

impl InputCounts {
    pub fn merge(&mut self, other: &InputCounts) {
        self.samples += other.samples;
        self.non_finite += other.non_finite;
        self.negative += other.negative;
        if self.first_non_finite.is_none() {
            self.first_non_finite = other.first_non_finite;
        }
    }

    /// Nothing to report: no unusable sample, or only negatives that the faces of the grids
    /// read made from samples that are all at least zero, which the clamp to zero puts right.
    pub fn is_clean(&self) -> bool {
        self.non_finite == 0 && (self.negative == 0 || self.negative_only_at_faces)
    }
}

/// One tile's pixels: RGBA and `aov_count` AOV values per pixel, row-major within the tile.
pub struct TileOutput {
    pub x0: usize,
    pub y0: usize,
    pub width: usize,
    pub height: usize,
    pub rgba: Vec<[f32; 4]>,
    pub aovs: Vec<f32>,
    /// Deep output only: samples per pixel (row-major within the tile), and the samples.
    pub deep_counts: Vec<u32>,
    pub deep_samples: Vec<DeepSample>,
    pub stats: MarchStats,
}

/// Per-ray state, structure of arrays.
#[derive(Default)]
pub struct Rays {
    pub origin: Vec<DVec3>,
    pub direction: Vec<DVec3>,
    /// The walk through the brick grid that gives each ray's next run of occupied bricks.
    pub walk: Vec<BrickWalk>,
    /// Where the run being marched ends; `−∞` once the ray has nothing left to march.
    pub run_end: Vec<f64>,
    pub t: Vec<f64>,
    /// Adaptive step length, and whether the ray stands at the start of a run.
    pub h: Vec<f64>,
    pub fresh: Vec<bool>,
    pub u: Vec<f64>,
    /// Each ray's time in the shutter (motion blur only).
    pub time: Vec<f64>,
    pub transmittance: Vec<DVec3>,
    pub color: Vec<DVec3>,
    pub emitted: Vec<DVec3>,
    /// Per ray, one colour per light.
    pub lit: Vec<DVec3>,
    pub depth_weighted: Vec<f64>,
    pub opacity: Vec<f64>,
    /// Adaptive stepping: the state before the last accepted step, per ray (and per light).
    pub undo: Vec<Snapshot>,
    pub undo_lit: Vec<DVec3>,
    /// Deep output only: each ray's colour and transmittance by depth.
    pub deep: Option<DeepCurves>,
    /// The position, normal and motion AOVs only: their sums per ray.
    pub surface: Option<Surface>,
}

impl Rays {
    /// Remembers ray `r`'s state before a step of length `length`.
    pub fn save(&mut self, r: usize, lights: usize, length: f64, quiet: bool) {
        self.undo[r] = Snapshot {
            length,
            quiet,
            t: self.t[r],
            fresh: self.fresh[r],
            transmittance: self.transmittance[r],
            color: self.color[r],
            emitted: self.emitted[r],
            depth_weighted: self.depth_weighted[r],
            opacity: self.opacity[r],
            surface: self
                .surface
                .as_ref()
                .map_or_else(Default::default, |s| s.sums(r)),
        };
        let lit = r * lights..(r + 1) * lights;
        self.undo_lit[lit.clone()].copy_from_slice(&self.lit[lit]);
    }

    /// Puts ray `r` back to where it was before its last accepted step.
    pub fn restore(&mut self, r: usize, lights: usize) {
        let u = self.undo[r];
        self.t[r] = u.t;
        self.fresh[r] = u.fresh;
        self.transmittance[r] = u.transmittance;
        self.color[r] = u.color;
        self.emitted[r] = u.emitted;
        self.depth_weighted[r] = u.depth_weighted;
        self.opacity[r] = u.opacity;
        if let Some(surface) = self.surface.as_mut() {
            surface.restore(r, u.surface);
        }
        let lit = r * lights..(r + 1) * lights;
        self.lit[lit.clone()].copy_from_slice(&self.undo_lit[lit]);
        self.undo[r].length = 0.0;
        if let Some(curves) = self.deep.as_mut() {
            curves.rewind(r, u.t, u.transmittance, u.color);
        }
    }

    /// Sets up the rays of the tile at `(x0, y0)` of size `w × h`.
    pub fn start(&mut self, frame: &Frame<'_>, x0: usize, y0: usize, w: usize, h: usize) {
        let s = frame.settings;
        let spp = s.spp as usize;
        let lights = frame.illumination.lights.len();
        let n = w * h * spp;
        let r = self;
        r.origin.clear();
        r.direction.clear();
        r.walk.clear();
        r.run_end.clear();
        r.t.clear();
        r.u.clear();
        r.time.clear();
        for py in 0..h {
            for px in 0..w {
                let (x, y) = (x0 + px, y0 + py);
                let pixel = (y * s.width + x) as u64;
                for sample in 0..spp as u64 {
                    let (jx, jy) = if spp == 1 {
                        (0.5, 0.5)
                    } else {
                        (
                            jitter(s.seed, pixel, sample, 0),
                            jitter(s.seed, pixel, sample, 1),
                        )
                    };
                    let ray = frame.raster.ray(x, y, jx, jy);
                    // Runs are found as the march reaches them, so a ray that turns opaque
                    // never walks the bricks behind.
                    let mut walk = match clip_to_box(&ray, &frame.bounds) {
                        Some((t0, t1)) => frame.occupancy.walk(&ray, t0, t1),
                        None => BrickWalk::spent(),
                    };
                    let (t, end) = frame
                        .occupancy
                        .next_run(&mut walk)
                        .unwrap_or((0.0, f64::NEG_INFINITY));
                    r.walk.push(walk);
                    r.t.push(t);
                    r.run_end.push(end);
                    r.origin.push(ray.origin);
                    r.direction.push(ray.direction);
                    r.u.push(jitter(s.seed, pixel, sample, 2));
                    if let Some(motion) = frame.motion {
                        r.time.push(motion.time(s.seed, pixel, sample));
                    }
                }
            }
        }
        let first = s.adaptive.map_or(frame.step, |a| a.max_step);
        reset(&mut r.h, n, first);
        reset(&mut r.fresh, n, true);
        reset(&mut r.transmittance, n, DVec3::ONE);
        reset(&mut r.color, n, DVec3::ZERO);
        reset(&mut r.emitted, n, DVec3::ZERO);
        reset(&mut r.lit, n * lights, DVec3::ZERO);
        reset(&mut r.depth_weighted, n, 0.0);
        reset(&mut r.opacity, n, 0.0);
        if s.adaptive.is_some() {
            reset(&mut r.undo, n, Snapshot::default());
            reset(&mut r.undo_lit, n * lights, DVec3::ZERO);
        }
        r.surface = Surface::wanted(&s.aovs)
            .then(|| Surface::new(s.aovs, frame.camera, s.width, s.height, n));
        match s.deep {
            Some(most) => {
                let curves = r.deep.get_or_insert_with(DeepCurves::default);
                curves.reset(n, curve_points(most));
                let forward = frame.camera.axes().2;
                for (origin, direction) in r.origin.iter().zip(&r.direction) {
                    curves.aim(frame.camera.depth(*origin), direction.dot(forward));
                }
            }
            None => r.deep = None,
        }
    }

    /// Averages each pixel's samples into the tile's RGBA and AOVs.
    pub fn finish(
        &self,
        frame: &Frame<'_>,
        x0: usize,
        y0: usize,
        w: usize,
        h: usize,
        mut stats: MarchStats,
    ) -> TileOutput {
        let spp = frame.settings.spp as usize;
        let lights = frame.illumination.lights.len();
        let aovs = &frame.settings.aovs;
        let inv = 1.0 / spp as f64;
        let rays = self;
        let mut rgba = Vec::with_capacity(w * h);
        let mut out = Vec::with_capacity(w * h * frame.aov_count);
        for pixel in 0..w * h {
            let range = pixel * spp..(pixel + 1) * spp;
            let mean = |v: &[DVec3]| v[range.clone()].iter().copied().sum::<DVec3>() * inv;
            let mut color = mean(&rays.color);
            let transmittance = mean(&rays.transmittance).element_sum() / 3.0;
            // Behind the medium each ray sees the background through what it has left.
            let alpha = match &frame.settings.background {
                Some(background) => {
                    let seen = range
                        .clone()
                        .map(|r| rays.transmittance[r] * background.radiance(rays.direction[r]));
                    color += seen.sum::<DVec3>() * inv;
                    1.0
                }
                None => 1.0 - transmittance,
            };
            let bad = &mut stats.bad_pixels;
            rgba.push([
                channel(color.x, bad),
                channel(color.y, bad),
                channel(color.z, bad),
                alpha as f32,
            ]);
            if aovs.depth {
                let weight: f64 = rays.opacity[range.clone()].iter().sum();
                let depth: f64 = rays.depth_weighted[range.clone()].iter().sum();
                out.push(if weight > 0.0 {
                    (depth / weight) as f32
                } else {
                    f32::INFINITY
                });
            }
            if aovs.transmittance {
                out.push(transmittance as f32);
            }
            if aovs.emission {
                let e = mean(&rays.emitted);
                let bad = &mut stats.bad_pixels;
                out.extend([channel(e.x, bad), channel(e.y, bad), channel(e.z, bad)]);
            }
            if aovs.lights {
                for light in 0..lights {
                    let mut sum = DVec3::ZERO;
                    for r in range.clone() {
                        sum += rays.lit[r * lights + light];
                    }
                    let l = sum * inv;
                    let bad = &mut stats.bad_pixels;
                    out.extend([channel(l.x, bad), channel(l.y, bad), channel(l.z, bad)]);
                }
            }
            if let Some(surface) = &rays.surface {
                let opacity: f64 = rays.opacity[range.clone()].iter().sum();
                surface.pixel(range.clone(), opacity, &mut out);
            }
        }
        let (deep_counts, deep_samples) = match (&rays.deep, frame.settings.deep) {
            (Some(curves), Some(most)) => {
                let (mut counts, mut samples) = (Vec::with_capacity(w * h), Vec::new());
                let mut scratch = Vec::new();
                for pixel in 0..w * h {
                    let count = curves.pixel_samples(
                        pixel * spp..(pixel + 1) * spp,
                        &rays.transmittance,
                        &rays.color,
                        most,
                        &mut scratch,
                        &mut samples,
                    );
                    counts.push(count as u32);
                }
                (counts, samples)
            }
            _ => (Vec::new(), Vec::new()),
        };
        TileOutput {
            x0,
            y0,
            width: w,
            height: h,
            rgba,
            aovs: out,
            deep_counts,
            deep_samples,
            stats,
        }
    }
}

/// A colour channel as written. The march's inputs are sanitised, so only arithmetic overflow
/// (values near the largest floats multiplied together) can leave a channel beyond the `f32`
/// range (written as infinity) or NaN (written as 0); both are counted for a warning.
fn channel(value: f64, bad: &mut u64) -> f32 {
    let v = value as f32;
    if v.is_finite() {
        return v;
    }
    *bad += 1;
    if v.is_nan() { 0.0 } else { v }
}

fn reset<T: Clone>(v: &mut Vec<T>, n: usize, value: T) {
    v.clear();
    v.resize(n, value);
}
