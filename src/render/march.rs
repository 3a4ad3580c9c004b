//! The integrator: marching tiles of camera rays through density, colour and emission.
//!
//! Per step of length `Δs` at a sample with density `ρ`, per colour channel (the course notes'
//! eqs. 1.1–1.4, with emission and holdouts):
//!
//! ```text
//! x   += Δs·n                                          (1.1; samples at segment midpoints)
//! ΔT   = exp(−κρΔs)                                    (1.2)
//! C_a += W·[ C_d·(1−ΔT)/κ·T_L·L  +  E·(1−ΔT)/(κρ) ]    (1.3, plus emission)
//! T    = lerp(1 − T_h, T, ΔT)                          (1.4 with a holdout, notes §3.4.2)
//! W    = max(T + T_h − 1, 0)                           (T before the update; without a
//!                                                       holdout T_h = 1 and W = T)
//! ```
//!
//! `(1−ΔT)/κ` is computed as `Δs·ρ·φ(κρΔs)` and `(1−ΔT)/(κρ)` as `Δs·φ(κρΔs)`, with
//! `φ(x) = −expm1(−x)/x → 1` as `x → 0`, so κ = 0 (a transparent medium that still glows and
//! scatters: `Δs·ρ` and `Δs` exactly) and κρΔs = 1e4 (`ΔT` = 0, no 0/0) are both finite and
//! exact. Both are the exact integrals over the step of a constant sample value attenuated by
//! `exp(−κρs)`, so the step's own self-shadowing is accounted for (Frostbite's energy-conserving
//! form). `W` weighs a step's colour by the same factor the holdout lerp gives its opacity
//! (`T_before − T_after = (1−ΔT)·W`), so a constant holdout of ½ halves colour and alpha alike.
//! The lerp is the notes' form as written: where `T_h` falls along a ray, `T` is pulled towards
//! `1 − T_h` and may rise (alpha then shrinks), while `W` keeps colour behind the holdout at 0.
//! `T_L·L` is `lighting::Illumination`'s `S`, summed over lights, plus ambient. With an
//! `albedo` the same update is single scattering: `C_d` is `albedo·color·κ/4π` and the
//! ambient `4π·ambient` (`RenderSettings::albedo_scales`).
//!
//! The one key decision: rays are marched a tile (16×16 pixels × samples; smaller tiles at
//! high sample counts) at a time, in lockstep: each round gathers the next sample of every
//! still-active ray into blocks of `BLOCK` points and evaluates each field once per block, colour and lighting only where the
//! density is positive. A ray is marched only over its runs of non-empty bricks; its samples
//! lie on a lattice `(n + u)·Δs` along the ray, `u` one jitter per ray from a counter hash, so
//! the image is the same for any thread count.

use super::adaptive::StepRule;
use super::camera::{Camera, Raster};
use super::lighting::Illumination;
use super::settings::RenderSettings;
use super::space::Occupancy;
use super::tile::{InputCounts, MarchStats, Rays, TileOutput};
use super::transmittance::ColumnScratch;
use crate::space::{Aabb, BLOCK, BlockEval, FieldSampler};
use glam::DVec3;

/// Pixels along a tile's side at one sample per pixel.
const TILE: usize = 16;
/// Sample rays marched together in a tile, at most (unless one pixel alone has more).
const TILE_RAYS: usize = 4096;

/// Pixels along a tile's side for `spp` samples per pixel: 16, halved while a tile would hold
/// more than 4096 rays, so a worker's ray state stays a few megabytes at any `spp`. It depends
/// only on the settings, never on the thread count.
pub fn tile_side(spp: u32) -> usize {
    let mut side = TILE;
    while side > 1 && side * side * spp as usize > TILE_RAYS {
        side /= 2;
    }
    side
}

/// Sample rays in a tile at `spp` samples per pixel.
pub fn side_rays(spp: u32) -> usize {
    let side = tile_side(spp);
    side * side * spp as usize
}

/// `(ΔT, φ)` for a step of optical thickness `x = κρΔs` from one `expm1`: `ΔT = 1 + expm1(−x)`
/// (exact to 1e-16 absolute, in [0, 1]) and `φ(x) = −expm1(−x)/x = (1 − e^−x)/x`, which tends
/// to 1 as `x → 0` (taken from its series below 1e-8) and to 0 as `x → ∞`.
fn step_factors(x: f64) -> (f64, f64) {
    if x < 1e-8 {
        return (1.0 - x, 1.0 - 0.5 * x);
    }
    let m = (-x).exp_m1();
    (1.0 + m, -m / x)
}

/// Replaces the unusable values of one field's block of samples (`width` components, stored
/// component-major) and counts them per sample: a NaN or infinite component becomes
/// `if_non_finite` and a negative one zero. A branch-free pass over the block first finds
/// whether anything is wrong, so only a block with bad values takes the per-sample path.
fn sanitise(
    values: &mut [f32],
    width: usize,
    positions: &[DVec3],
    if_non_finite: f32,
    counts: &mut InputCounts,
) {
    let n = positions.len();
    let values = &mut values[..width * n];
    let suspect = values
        .iter()
        .fold(false, |any, &v| any | !v.is_finite() | (v < 0.0));
    if !suspect {
        return;
    }
    for k in 0..n {
        let (mut non_finite, mut negative) = (false, false);
        for c in 0..width {
            let v = &mut values[c * n + k];
            if !v.is_finite() {
                *v = if_non_finite;
                non_finite = true;
            } else if *v < 0.0 {
                *v = 0.0;
                negative = true;
            }
        }
        if non_finite {
            counts.non_finite += 1;
            counts.first_non_finite.get_or_insert(positions[k]);
        } else if negative {
            counts.negative += 1;
        }
    }
}

/// What every tile shares.
pub struct Frame<'a> {
    pub density: &'a dyn FieldSampler,
    pub color: Option<&'a dyn FieldSampler>,
    pub emission: Option<&'a dyn FieldSampler>,
    pub holdout: Option<&'a dyn FieldSampler>,
    pub camera: &'a Camera,
    pub raster: Raster,
    pub bounds: Aabb,
    pub occupancy: &'a Occupancy,
    pub illumination: &'a Illumination<'a>,
    /// The albedo model's indirect light, read at every dense sample.
    pub indirect: Option<&'a super::indirect::IndirectGrid>,
    pub settings: &'a RenderSettings,
    pub step: f64,
    /// AOV values per pixel, see `aov_layout`.
    pub aov_count: usize,
    /// Motion blur: each ray's samples are shifted to where the medium was at its time.
    pub motion: Option<&'a super::motion::Motion<'a>>,
}

/// Per-block scratch.
#[derive(Default)]
struct Block {
    ray: Vec<usize>,
    segment: Vec<(f64, f64)>,
    position: Vec<DVec3>,
    xs: Vec<f64>,
    ys: Vec<f64>,
    zs: Vec<f64>,
    density: Vec<f32>,
    emission: Vec<f32>,
    holdout: Vec<f32>,
    color: Vec<f32>,
    /// Samples with positive density: index into the block, and their positions.
    dense: Vec<usize>,
    dense_position: Vec<DVec3>,
    dense_xs: Vec<f64>,
    dense_ys: Vec<f64>,
    dense_zs: Vec<f64>,
    columns: Vec<f64>,
    /// Per light, per dense sample.
    scattered: Vec<DVec3>,
    /// Motion blur: each sample's ray time, and the velocity at the samples.
    times: Vec<f64>,
    velocity: Vec<f64>,
    /// The normal AOV: the density's gradient at each dense sample.
    gradient: Vec<DVec3>,
}

/// One worker's evaluators and scratch space, reused across its tiles.
pub struct Worker<'a> {
    density: Box<dyn BlockEval + 'a>,
    color: Option<Box<dyn BlockEval + 'a>>,
    emission: Option<Box<dyn BlockEval + 'a>>,
    holdout: Option<Box<dyn BlockEval + 'a>>,
    velocity: Option<Box<dyn BlockEval + 'a>>,
    rays: Rays,
    block: Block,
    shadow: ColumnScratch,
    active: Vec<usize>,
    pending: Vec<(usize, (f64, f64))>,
}

impl<'a> Worker<'a> {
    pub fn new(frame: &Frame<'a>) -> Worker<'a> {
        Worker {
            density: frame.density.evaluator(),
            color: frame.color.map(|f| f.evaluator()),
            emission: frame.emission.map(|f| f.evaluator()),
            holdout: frame.holdout.map(|f| f.evaluator()),
            velocity: frame.motion.map(|m| m.evaluator()),
            rays: Rays::default(),
            block: Block::default(),
            shadow: ColumnScratch::default(),
            active: Vec::new(),
            pending: Vec::new(),
        }
    }

    /// Renders tile number `tile` of the image.
    pub fn tile(&mut self, frame: &Frame<'_>, tile: usize) -> TileOutput {
        let s = frame.settings;
        let side = tile_side(s.spp);
        let tiles_x = s.width.div_ceil(side);
        let (x0, y0) = ((tile % tiles_x) * side, (tile / tiles_x) * side);
        let (w, h) = (side.min(s.width - x0), side.min(s.height - y0));
        let spp = s.spp as usize;
        self.rays.start(frame, x0, y0, w, h);
        let mut stats = MarchStats::default();
        self.active.clear();
        self.active.extend(0..w * h * spp);
        while !self.active.is_empty() {
            self.pending.clear();
            let mut still = std::mem::take(&mut self.active);
            still.retain(|&r| match self.next_segment(frame, r) {
                Some(segment) => {
                    self.pending.push((r, segment));
                    true
                }
                None => false,
            });
            self.active = still;
            let pending = std::mem::take(&mut self.pending);
            for chunk in pending.chunks(BLOCK) {
                self.shade(frame, chunk, &mut stats);
            }
            self.pending = pending;
        }
        self.rays.finish(frame, x0, y0, w, h, stats)
    }

    /// The next segment `[a, b]` of ray `r`, moving on to its next run when one is done.
    fn next_segment(&mut self, frame: &Frame<'_>, r: usize) -> Option<(f64, f64)> {
        let rays = &mut self.rays;
        loop {
            let run_end = rays.run_end[r];
            let t = rays.t[r];
            // A sliver left by rounding at the end of a run is not worth a sample.
            if t >= run_end - 1e-9 * frame.step {
                if run_end == f64::NEG_INFINITY {
                    return None;
                }
                match frame.occupancy.next_run(&mut rays.walk[r]) {
                    Some((begin, end)) => {
                        rays.t[r] = begin;
                        rays.run_end[r] = end;
                        rays.fresh[r] = true;
                    }
                    None => rays.run_end[r] = f64::NEG_INFINITY,
                }
                if let Some(undo) = rays.undo.get_mut(r) {
                    // Rewinding never reaches back across empty space into the previous run.
                    undo.length = 0.0;
                }
                continue;
            }
            let b = match frame.settings.adaptive {
                None => {
                    // The lattice (n + u)·Δs: the first point past t.
                    let ds = frame.step;
                    let u = rays.u[r];
                    // q > −1 (t ≥ 0, u < 1), so truncation corrected for negatives is the
                    // floor, without a libm call.
                    let q = t / ds - u;
                    let n = (q as i64 - i64::from(q < 0.0)) as f64;
                    let mut b = (n + 1.0 + u) * ds;
                    if b <= t + 1e-9 * ds {
                        b += ds;
                    }
                    b
                }
                Some(_) => {
                    let h = rays.h[r];
                    // The first step of a run is jittered: (1 − u)·h is in (0, h].
                    t + if rays.fresh[r] {
                        (1.0 - rays.u[r]) * h
                    } else {
                        h
                    }
                }
            };
            return Some((t, b.min(run_end)));
        }
    }

    /// Evaluates the fields at one block of samples and advances their rays.
    fn shade(&mut self, frame: &Frame<'_>, chunk: &[(usize, (f64, f64))], stats: &mut MarchStats) {
        let n = chunk.len();
        let lights = frame.illumination.lights.len();
        let b = &mut self.block;
        b.ray.clear();
        b.segment.clear();
        b.position.clear();
        b.xs.clear();
        b.ys.clear();
        b.zs.clear();
        for &(r, (t0, t1)) in chunk {
            let p = self.rays.origin[r] + self.rays.direction[r] * (0.5 * (t0 + t1));
            b.ray.push(r);
            b.segment.push((t0, t1));
            b.position.push(p);
            b.xs.push(p.x);
            b.ys.push(p.y);
            b.zs.push(p.z);
        }
        if let Some(velocity) = self.velocity.as_mut() {
            // Every input is read where the medium was at the ray's time.
            b.times.clear();
            b.times.extend(b.ray.iter().map(|&r| self.rays.time[r]));
            super::motion::Motion::shift(
                velocity.as_mut(),
                &mut b.xs,
                &mut b.ys,
                &mut b.zs,
                &b.times,
                &mut b.velocity,
            );
            for k in 0..n {
                b.position[k] = DVec3::new(b.xs[k], b.ys[k], b.zs[k]);
            }
        }
        stats.samples += n as u64;
        b.density.resize(n, 0.0);
        self.density.eval_f32(&b.xs, &b.ys, &b.zs, &mut b.density);
        if let Some(e) = self.emission.as_mut() {
            b.emission.resize(3 * n, 0.0);
            e.eval_f32(&b.xs, &b.ys, &b.zs, &mut b.emission);
        }
        if let Some(h) = self.holdout.as_mut() {
            b.holdout.resize(n, 0.0);
            h.eval_f32(&b.xs, &b.ys, &b.zs, &mut b.holdout);
        }
        // Sanitise (the rules are `Scene`'s): a NaN or infinite sample contributes nothing,
        // negative density and emission are zero; each input's bad samples are counted.
        stats.density.samples += n as u64;
        sanitise(&mut b.density, 1, &b.position, 0.0, &mut stats.density);
        if frame.emission.is_some() {
            stats.emission.samples += n as u64;
            sanitise(&mut b.emission, 3, &b.position, 0.0, &mut stats.emission);
        }
        if frame.holdout.is_some() {
            stats.holdout.samples += n as u64;
            sanitise(&mut b.holdout, 1, &b.position, 1.0, &mut stats.holdout);
        }
        b.dense.clear();
        b.dense.extend((0..n).filter(|&k| b.density[k] > 0.0));
        let m = b.dense.len();
        b.dense_position.clear();
        b.dense_position
            .extend(b.dense.iter().map(|&k| b.position[k]));
        if m > 0
            && let Some(c) = self.color.as_mut()
        {
            b.dense_xs.clear();
            b.dense_ys.clear();
            b.dense_zs.clear();
            for p in &b.dense_position {
                b.dense_xs.push(p.x);
                b.dense_ys.push(p.y);
                b.dense_zs.push(p.z);
            }
            b.color.resize(3 * m, 0.0);
            c.eval_f32(&b.dense_xs, &b.dense_ys, &b.dense_zs, &mut b.color);
            stats.color.samples += m as u64;
            sanitise(&mut b.color, 3, &b.dense_position, 0.0, &mut stats.color);
        }
        if frame.settings.aovs.normal {
            let h = 0.5 * frame.step;
            super::surface::gradients(self.density.as_mut(), &b.dense_position, h, &mut b.gradient);
        }
        b.scattered.resize(lights * m, DVec3::ZERO);
        b.columns.resize(m, 0.0);
        for light in 0..lights {
            if m == 0 {
                break;
            }
            frame.illumination.columns_at(
                light,
                &b.dense_position,
                self.density.as_mut(),
                &mut self.shadow,
                &mut b.columns,
            );
            for j in 0..m {
                let r = b.ray[b.dense[j]];
                b.scattered[light * m + j] = frame.illumination.scattered(
                    light,
                    b.dense_position[j],
                    self.rays.direction[r],
                    b.columns[j],
                );
            }
        }
        let dense = std::mem::take(&mut b.dense);
        let mut j = 0;
        for k in 0..n {
            let dense_index = (j < m && dense[j] == k).then(|| {
                j += 1;
                j - 1
            });
            self.advance(frame, k, n, m, dense_index, stats);
        }
        self.block.dense = dense;
    }

    /// Applies the update of the module formula to sample `k` of the block.
    fn advance(
        &mut self,
        frame: &Frame<'_>,
        k: usize,
        n: usize,
        m: usize,
        dense_index: Option<usize>,
        stats: &mut MarchStats,
    ) {
        let s = frame.settings;
        let b = &self.block;
        let rays = &mut self.rays;
        let r = b.ray[k];
        let (t0, t1) = b.segment[k];
        let ds = t1 - t0;
        let rho = b.density[k] as f64;
        let holdout = if frame.holdout.is_some() {
            (b.holdout[k] as f64).clamp(0.0, 1.0)
        } else {
            1.0
        };
        let optical = s.kappa * (rho * ds);
        let (step_t, phis) = if s.grey_kappa() {
            let (t, p) = step_factors(optical.x);
            (DVec3::splat(t), DVec3::splat(p))
        } else {
            let [(tx, px), (ty, py), (tz, pz)] = optical.to_array().map(step_factors);
            (DVec3::new(tx, ty, tz), DVec3::new(px, py, pz))
        };
        let emission = if frame.emission.is_some() {
            DVec3::new(
                b.emission[k] as f64,
                b.emission[n + k] as f64,
                b.emission[2 * n + k] as f64,
            ) * phis
                * ds
        } else {
            DVec3::ZERO
        };
        let lights = frame.illumination.lights.len();
        // Δs·ρ·φ(κρΔs) = (1−ΔT)/κ, the colour weight of eq. 1.3.
        let weight = phis * (rho * ds);
        let (albedo, in_scattered) = match dense_index {
            Some(j) => {
                let albedo = if frame.color.is_some() {
                    DVec3::new(
                        b.color[j] as f64,
                        b.color[m + j] as f64,
                        b.color[2 * m + j] as f64,
                    )
                } else {
                    DVec3::ONE
                };
                let mut total = frame.illumination.ambient;
                if let Some(grid) = frame.indirect {
                    total += grid.at(b.dense_position[j]);
                }
                let albedo = match s.albedo_scales() {
                    None => albedo,
                    Some((per_colour, per_ambient)) => {
                        total *= per_ambient;
                        albedo * per_colour
                    }
                };
                for light in 0..lights {
                    total += b.scattered[light * m + j];
                }
                (albedo, total)
            }
            None => (DVec3::ZERO, DVec3::ZERO),
        };
        let before = rays.transmittance[r];
        let visible = (before + DVec3::splat(holdout - 1.0)).max(DVec3::ZERO);
        let contribution = visible * (albedo * weight * in_scattered + emission);
        // T = lerp(1 − T_h, T, ΔT)
        let after = (DVec3::ONE - step_t) * (1.0 - holdout) + step_t * before;
        // Without a holdout the lerp is T·ΔT: transmittance stays in [0, 1] and never rises.
        debug_assert!(
            frame.holdout.is_some()
                || (after.cmple(before).all() && after.cmpge(DVec3::ZERO).all()),
            "transmittance rose from {before} to {after}"
        );
        let opacity = (before - after).element_sum() / 3.0;
        if let Some(adaptive) = &s.adaptive {
            let size = contribution.max_element().max(opacity);
            match StepRule::after(adaptive, rays.h[r], ds, size) {
                StepRule::Retry(shorter) => {
                    stats.rejected += 1;
                    let undo = rays.undo[r];
                    if undo.rewinds(adaptive) {
                        rays.restore(r, lights);
                        rays.h[r] = (0.5 * undo.length).max(adaptive.min_step);
                    } else {
                        rays.h[r] = shorter;
                    }
                    return;
                }
                rule => {
                    rays.save(r, lights, ds, size < 0.25 * adaptive.tolerance);
                    if let StepRule::Grow(longer) = rule {
                        rays.h[r] = longer;
                    }
                }
            }
        }
        // Deep output keeps the step on the ray's curve by depth (`deep`); a flat render has
        // no curves, and this test is all it pays.
        if let Some(curves) = rays.deep.as_mut() {
            let color = rays.color[r];
            curves.record(r, t0, t1, before, color, after, color + contribution);
        }
        rays.color[r] += contribution;
        if frame.aov_count > 0 {
            rays.emitted[r] += visible * emission;
            if let Some(j) = dense_index {
                for light in 0..lights {
                    rays.lit[r * lights + light] +=
                        visible * albedo * weight * b.scattered[light * m + j];
                }
            }
            let depth = frame.camera.depth(b.position[k]);
            rays.depth_weighted[r] += opacity.max(0.0) * depth;
            rays.opacity[r] += opacity.max(0.0);
            if let Some(surface) = rays.surface.as_mut() {
                let sample = super::surface::SurfaceSample {
                    point: rays.origin[r] + rays.direction[r] * (0.5 * (t0 + t1)),
                    gradient: dense_index.map_or(DVec3::ZERO, |j| {
                        b.gradient.get(j).copied().unwrap_or_default()
                    }),
                    velocity: match frame.motion {
                        Some(_) => {
                            DVec3::new(b.velocity[k], b.velocity[n + k], b.velocity[2 * n + k])
                        }
                        None => DVec3::ZERO,
                    },
                };
                surface.add(r, opacity, &sample);
            }
        }
        rays.transmittance[r] = after;
        rays.t[r] = t1;
        rays.fresh[r] = false;
        if after.max_element() + holdout - 1.0 < s.threshold {
            // Nothing behind can show: retire the ray.
            rays.run_end[r] = f64::NEG_INFINITY;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_factors_are_finite_and_exact_at_both_ends() {
        for x in [0.0, 1e-12, 1.1e-8, 1e-3, 0.5, 3.0, 40.0, 1e4, f64::INFINITY] {
            let (t, p) = step_factors(x);
            assert!((t - (-x).exp()).abs() < 2e-16, "{x}: {t}");
            assert!((0.0..=1.0).contains(&t) && p.is_finite());
        }
        assert_eq!(step_factors(0.0), (1.0, 1.0));
        // φ(1) = 1 − 1/e; φ(1e4) = 1e-4; φ(∞) = 0.
        assert!((step_factors(1.0).1 - (1.0 - (-1.0f64).exp())).abs() < 1e-15);
        assert_eq!(step_factors(1e4), (0.0, 1e-4));
        assert_eq!(step_factors(f64::INFINITY).1, 0.0);
        // Near the switch to the series both forms agree.
        assert!((step_factors(1.1e-8).1 - (1.0 - 0.5 * 1.1e-8)).abs() < 1e-15);
        // (1 − ΔT)/κ = Δs·ρ·φ(κρΔs), against the naive form where it is well conditioned.
        let (kappa, rho, ds) = (3.0f64, 0.7, 0.2);
        let naive = (1.0 - (-kappa * rho * ds).exp()) / kappa;
        assert!((ds * rho * step_factors(kappa * rho * ds).1 - naive).abs() < 1e-15);
    }

    #[test]
    fn tiles_shrink_with_the_sample_count() {
        assert_eq!(tile_side(1), 16);
        assert_eq!(tile_side(16), 16);
        assert_eq!(tile_side(17), 8);
        assert_eq!(tile_side(1024), 2);
        assert_eq!(tile_side(65536), 1);
    }
}
