//! Motion blur: the medium seen over the shutter, Eulerian style.
//!
//! `render(..., velocity = v, shutter = s, shutterposition = ...)` gives every camera sample a
//! time `t` in the shutter (in frames, around the frame's own time 0), drawn from the sample's
//! own counter hash like every other felt random number, and reads density, colour, emission
//! and holdout at `x − v(x)·t` instead of `x`: a point of the medium that moves at `v` is where
//! it would be `t` frames later (the Eulerian motion blur of Arnold, Cycles and the course
//! notes' production chapters, exact for a uniform translation, first order otherwise).
//! Velocity is in world units per frame.
//!
//! The one key decision: the shift is applied to the whole sample, so everything read there —
//! the light arriving through the march's light cache included — comes from the medium's rest
//! position, and a shadow moves with what casts it. Both integrators do so: the march shifts
//! its block of samples, the path tracer every point of a path and of its shadow rays (a path
//! keeps one time). What the renderer knows of where the medium is (the box it renders, the
//! march's empty-space bricks, the path tracer's majorants) is widened by the motion's
//! *reach*, the most any point moves within the shutter, from the velocity's interval bounds:
//! [`Swept`] is the density as seen by those queries. A velocity that is zero everywhere
//! reads every point where it was, so its image is the still image bit for bit.

use super::camera::jitter;
use crate::base::failure::{Failure, Outcome};
use crate::space::{Aabb, BlockEval, FieldSampler, GridSource};
use glam::DVec3;
use std::sync::Arc;

/// Where the shutter opens relative to the frame, as Cycles names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ShutterPosition {
    /// Opens at the frame: times in `[0, s]`.
    Start,
    /// Centred on the frame: times in `[−s/2, s/2]`.
    #[default]
    Center,
    /// Closes at the frame: times in `[−s, 0]`.
    End,
}

impl ShutterPosition {
    pub fn parse(name: &str) -> Outcome<ShutterPosition> {
        match name {
            "start" => Ok(ShutterPosition::Start),
            "center" => Ok(ShutterPosition::Center),
            "end" => Ok(ShutterPosition::End),
            other => Err(Failure::new(format!(
                "shutterposition must be \"start\", \"center\" or \"end\", found \"{other}\""
            ))),
        }
    }

    /// The shutter's open and close times, in frames, for a shutter `length` frames long.
    pub fn interval(self, length: f64) -> (f64, f64) {
        match self {
            ShutterPosition::Start => (0.0, length),
            ShutterPosition::Center => (-0.5 * length, 0.5 * length),
            ShutterPosition::End => (-length, 0.0),
        }
    }
}

/// The counter-hash dimension of a sample's time (the march's jitter takes 0 to 2).
const TIME_DIMENSION: u64 = 7;

/// A render's motion: the velocity field, the shutter and how far anything moves in it.
pub struct Motion<'a> {
    velocity: &'a dyn FieldSampler,
    open: f64,
    close: f64,
    /// The most any point moves within the shutter, per axis.
    pub reach: DVec3,
}

impl<'a> Motion<'a> {
    /// The motion of a render over `bounds` (the still medium's box): the reach is found from
    /// the velocity's range over the box widened by the reach itself, until it holds.
    pub fn new(
        velocity: &'a dyn FieldSampler,
        open: f64,
        close: f64,
        bounds: &Aabb,
    ) -> Outcome<Motion<'a>> {
        let longest = open.abs().max(close.abs());
        let mut reach = DVec3::ZERO;
        for _ in 0..16 {
            let region = Aabb::new(bounds.min - reach, bounds.max + reach);
            let range = velocity.range(&region);
            let speed = DVec3::new(
                range[0].0.abs().max(range[0].1.abs()),
                range[1].0.abs().max(range[1].1.abs()),
                range[2].0.abs().max(range[2].1.abs()),
            );
            if !speed.is_finite() {
                return Err(Failure::new(
                    "motion blur needs a velocity with known bounds, and this one's are infinite",
                )
                .with_help("cache the velocity, or clamp it (velocity = clamp(v, -10, 10))"));
            }
            let next = speed * longest;
            if next.cmple(reach).all() {
                return Ok(Motion {
                    velocity,
                    open,
                    close,
                    reach,
                });
            }
            // Grow a little past what was found, so the loop ends quickly.
            reach = next * 1.0625;
        }
        Err(Failure::new(
            "the velocity grows with distance faster than the shutter allows: the medium's \
             reach over the shutter has no bound",
        )
        .with_help("use a shorter shutter or a bounded velocity"))
    }

    /// The time of sample `sample` of pixel `pixel`, in the shutter.
    pub fn time(&self, seed: u64, pixel: u64, sample: u64) -> f64 {
        self.open + (self.close - self.open) * jitter(seed, pixel, sample, TIME_DIMENSION)
    }

    /// An evaluator of the velocity, for one thread.
    pub fn evaluator(&self) -> Box<dyn BlockEval + 'a> {
        self.velocity.evaluator()
    }

    /// Moves each point `i` to `p − v(p)·times[i]`, in place (at most `BLOCK` points).
    pub fn shift(
        eval: &mut dyn BlockEval,
        xs: &mut [f64],
        ys: &mut [f64],
        zs: &mut [f64],
        times: &[f64],
        scratch: &mut Vec<f64>,
    ) {
        let n = xs.len();
        scratch.resize(3 * n, 0.0);
        eval.eval_f64(xs, ys, zs, scratch);
        for i in 0..n {
            let v = DVec3::new(scratch[i], scratch[n + i], scratch[2 * n + i]);
            // A velocity that is not finite moves nothing (it would put NaN in the image).
            if v.is_finite() {
                xs[i] -= v.x * times[i];
                ys[i] -= v.y * times[i];
                zs[i] -= v.z * times[i];
            }
        }
    }
}

/// A field as the renderer's bounds see it under motion: zero only where the field is zero
/// within `reach` of the point, so a box, a brick or a majorant cell it calls empty stays
/// empty at every time of the shutter. Values are the field's own (the integrators shift the
/// points they evaluate).
pub struct Swept<'a> {
    pub inner: &'a dyn FieldSampler,
    pub reach: DVec3,
}

impl FieldSampler for Swept<'_> {
    fn width(&self) -> usize {
        self.inner.width()
    }

    fn evaluator(&self) -> Box<dyn BlockEval + '_> {
        self.inner.evaluator()
    }

    fn bounds(&self) -> Option<Aabb> {
        self.inner
            .bounds()
            .map(|b| Aabb::new(b.min - self.reach, b.max + self.reach))
    }

    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        self.inner
            .range(&Aabb::new(region.min - self.reach, region.max + self.reach))
    }

    fn range_held(&self, region: &Aabb) -> Vec<(f64, f64)> {
        self.inner
            .range_held(&Aabb::new(region.min - self.reach, region.max + self.reach))
    }

    fn grids(&self) -> Vec<Arc<dyn GridSource>> {
        self.inner.grids()
    }
}
