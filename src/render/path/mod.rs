//! The reference integrator: an unbiased volumetric path tracer over the scene the march
//! renders (`integrator = "path"`).
//!
//! Each sample of a pixel estimates the radiance reaching the camera along its ray,
//!
//! ```text
//! L(x, ω) = ∫₀^d T(x, x_t) [ ε(x_t) + σs(x_t) ∫ p(ω, ω') L_i(x_t, ω') dω' ] dt
//!           + T(x, x_d) L_sky                    (only after at least one scattering)
//! L_i     = Σ_lights T(x_t, light) E_light  +  L(x_t, ω')
//! ```
//!
//! with `σt = κρ`, `σs = albedo·color·σt`, `p` per steradian, `E` a distant light's irradiance
//! or a point light's intensity over r², `ε` the emission per unit length and `T` the
//! transmittance (DESIGN.md, "Light transport"). Free flights are drawn by spectral delta
//! tracking (`tracking`) over the majorant grid (`majorant`), the lights are reached by
//! next-event estimation with ratio-tracked shadow rays, the phase is sampled exactly
//! (`sampling`), and the sky is seen by paths leaving the box and, where it varies with
//! direction, sampled by next-event estimation too (`emitters`). Russian roulette
//! ends weak paths after `ROULETTE_AFTER` scatterings, unbiased. The one key decision: like the
//! march's image, a pixel's colour is premultiplied and the sky is not drawn behind the medium:
//! alpha is one minus the camera ray's transmittance, so composited over the sky
//! (`rgb + (1 − alpha)·sky`) the image is what a camera inside that sky sees. A `background`
//! does that compositing per path instead, with each camera ray's own direction and
//! transmittance (`T(x, x_d)·L_background`), and makes alpha 1.

pub mod emitters;
pub mod majorant;
pub mod sampling;
pub mod tracking;

#[cfg(test)]
mod tests;

use super::band;
use super::camera::{Raster, Ray};
use super::image::Image;
use super::motion::Motion;
use super::progress::Progress;
use super::settings::RenderSettings;
use super::sky::Sky;
use super::space::clip_to_box;
use super::{RenderStats, Scene};
use crate::base::failure::{Failure, Outcome};
use crate::space::{Aabb, FieldSampler};
use emitters::Emitter;
use glam::DVec3;
use majorant::{MAJORANT_CELLS, Majorants};
use rayon::prelude::*;
use sampling::PathRandom;
use std::f64::consts::PI;
use std::time::Instant;
use tracking::{Flight, Medium, MediumCounts};

/// Scatterings after which Russian roulette may end a path.
pub const ROULETTE_AFTER: u32 = 3;

/// The AOV channels the path tracer writes, in order.
pub fn aov_names(settings: &RenderSettings) -> Vec<String> {
    if settings.aovs.variance {
        ["variance.R", "variance.G", "variance.B"]
            .map(String::from)
            .to_vec()
    } else {
        Vec::new()
    }
}

/// What the paths of a render share.
struct Frame<'a> {
    scene: &'a Scene<'a>,
    settings: &'a RenderSettings,
    raster: Raster,
    bounds: Aabb,
    majorants: &'a Majorants,
    emitters: Vec<Emitter<'a>>,
    albedo: f64,
    motion: Option<&'a Motion<'a>>,
}

/// What becomes of a path that leaves the box without scattering.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Unscattered {
    /// A camera ray: the sky is not drawn behind the medium; its transmittance is the alpha.
    Transmitted,
    /// A ray from a point inside the medium: it sees the sky, shadowed along the way.
    SeesSky,
}

/// The path tracer's estimate of the light arriving at points inside the medium, for the
/// march's indirect light (`render::indirect`): the same medium, lights and sky as a
/// path-traced render of the scene.
pub(crate) struct Arrivals<'a> {
    frame: Frame<'a>,
}

impl<'a> Arrivals<'a> {
    pub fn new(
        scene: &'a Scene<'a>,
        settings: &'a RenderSettings,
        bounds: Aabb,
        majorants: &'a Majorants,
    ) -> Arrivals<'a> {
        Arrivals {
            frame: Frame::new(scene, settings, bounds, majorants, None),
        }
    }

    /// One thread's evaluators of the medium.
    pub fn medium(&self) -> Medium<'a> {
        self.frame.medium()
    }

    /// One estimate of the radiance arriving at `origin` from `−direction` that is not the
    /// lights' unscattered light there: scattered light, emission and the sky, each shadowed
    /// by the medium in between. The estimate is unbiased and carries `bounces` scatterings.
    pub fn arriving(
        &self,
        medium: &mut Medium,
        origin: DVec3,
        direction: DVec3,
        random: &mut PathRandom,
    ) -> DVec3 {
        let ray = Ray { origin, direction };
        self.frame
            .trace(medium, ray, random, Unscattered::SeesSky)
            .0
    }
}

/// One row of pixels.
struct Row {
    rgba: Vec<[f32; 4]>,
    variance: Vec<f32>,
    counts: MediumCounts,
    bad_pixels: u64,
}

/// Renders `scene` with the path tracer over `bounds`.
///
/// Under motion blur, `bounds` is the box widened by the motion's reach, and the majorants
/// bound `density` and `emission` as the motion sweeps them (`motion::Swept`).
pub fn render(
    scene: &Scene,
    settings: &RenderSettings,
    bounds: Aabb,
    motion: Option<&Motion>,
    density: &dyn FieldSampler,
    emission: Option<&dyn FieldSampler>,
) -> Outcome<(Image, RenderStats)> {
    if scene.holdout.is_some() {
        return Err(Failure::new("the path tracer does not take a holdout yet")
            .with_help("render holdouts with the march (leave out integrator = \"path\")"));
    }
    if settings.aovs.variance && settings.spp < 2 {
        return Err(Failure::new(format!(
            "the variance AOV needs at least 2 samples per pixel, got {}",
            settings.spp
        ))
        .with_help("pass spp = 16 or more for a useful estimate"));
    }
    let started = Instant::now();
    let majorants = Majorants::build(density, emission, bounds, MAJORANT_CELLS)?;
    let majorant_seconds = started.elapsed().as_secs_f64();
    let frame = Frame::new(scene, settings, bounds, &majorants, motion);
    let rows = band::rows(settings.height)?;
    let progress = Progress::new(rows.len() as u64);
    let tracing = Instant::now();
    let outputs: Vec<Row> = rows
        .clone()
        .into_par_iter()
        .map_init(
            || frame.medium(),
            |medium, y| {
                if crate::engine::interrupt::requested() {
                    return None;
                }
                let row = frame.row(medium, y);
                progress.tick();
                Some(row)
            },
        )
        .collect::<Vec<Option<Row>>>()
        .into_iter()
        .collect::<Option<Vec<Row>>>()
        .ok_or_else(|| Failure::new("interrupted"))?;
    progress.finish();

    let mut image = Image::new(settings.width, settings.height);
    image.aovs = aov_names(settings)
        .into_iter()
        .map(|name| (name, vec![0.0; settings.width * settings.height]))
        .collect();
    let mut stats = RenderStats {
        shadow_seconds: majorant_seconds,
        march_seconds: tracing.elapsed().as_secs_f64(),
        bricks: majorants.cells(),
        empty_bricks: majorants.empty_cells(),
        ..RenderStats::default()
    };
    let mut counts = MediumCounts::default();
    for (y, row) in rows.zip(&outputs) {
        let start = y * settings.width;
        image.rgba[start..start + settings.width].copy_from_slice(&row.rgba);
        for (c, (_, values)) in image.aovs.iter_mut().enumerate() {
            for x in 0..settings.width {
                values[start + x] = row.variance[3 * x + c];
            }
        }
        counts.merge(&row.counts);
        stats.march.bad_pixels += row.bad_pixels;
    }
    stats.march.samples = counts.density.samples;
    stats.march.density = counts.density;
    stats.march.color = counts.color;
    stats.march.emission = counts.emission;
    stats.above_majorant = counts.above_majorant;
    stats.first_above_majorant = counts.first_above_majorant;
    Ok((image, stats))
}

/// A value for a 32-bit pixel: NaN is written as 0 and infinities as they are, each counted.
fn channel(value: f64, bad: &mut u64) -> f32 {
    let v = value as f32;
    if v.is_finite() {
        return v;
    }
    *bad += 1;
    if v.is_nan() { 0.0 } else { v }
}

impl<'a> Frame<'a> {
    fn new(
        scene: &'a Scene<'a>,
        settings: &'a RenderSettings,
        bounds: Aabb,
        majorants: &'a Majorants,
        motion: Option<&'a Motion<'a>>,
    ) -> Frame<'a> {
        let mut emitters: Vec<Emitter> = scene.lights.iter().map(Emitter::Delta).collect();
        match &settings.sky {
            Sky::Uniform(radiance) if *radiance != DVec3::ZERO => {
                emitters.push(Emitter::Sky(*radiance))
            }
            sky if sky.is_sampled() && !sky.is_black() => emitters.push(Emitter::Environment(sky)),
            _ => {}
        }
        Frame {
            scene,
            settings,
            raster: scene.camera.raster(settings.width, settings.height),
            bounds,
            majorants,
            emitters,
            // The albedo model always: without `albedo` the medium scatters all it extinguishes.
            albedo: settings.albedo.unwrap_or(1.0),
            motion,
        }
    }

    fn medium(&self) -> Medium<'a> {
        Medium::new(
            self.scene.density,
            self.scene.color,
            self.scene.emission,
            self.majorants,
            self.settings.kappa,
            self.albedo,
            self.motion,
        )
    }

    /// The pixels of row `y`: the mean of `spp` paths each, and the variance of that mean.
    fn row(&self, medium: &mut Medium, y: usize) -> Row {
        let s = self.settings;
        let spp = s.spp as usize;
        let mut row = Row {
            rgba: Vec::with_capacity(s.width),
            variance: Vec::with_capacity(if s.aovs.variance { 3 * s.width } else { 0 }),
            counts: MediumCounts::default(),
            bad_pixels: 0,
        };
        for x in 0..s.width {
            let pixel = (y * s.width + x) as u64;
            let (mut sum, mut squares, mut transmitted) = (DVec3::ZERO, DVec3::ZERO, 0.0);
            for sample in 0..spp {
                if let Some(motion) = self.motion {
                    medium.time = motion.time(s.seed, pixel, sample as u64);
                }
                let mut random = PathRandom::new(s.seed, pixel, sample as u64);
                let ray = self.raster.ray(x, y, random.uniform(), random.uniform());
                let (mut radiance, transmittance) =
                    self.trace(medium, ray, &mut random, Unscattered::Transmitted);
                if let Some(background) = &s.background {
                    radiance += transmittance * background.radiance(ray.direction);
                }
                sum += radiance;
                squares += radiance * radiance;
                transmitted += transmittance.element_sum() / 3.0;
            }
            let n = spp as f64;
            let mean = sum / n;
            let bad = &mut row.bad_pixels;
            row.rgba.push([
                channel(mean.x, bad),
                channel(mean.y, bad),
                channel(mean.z, bad),
                channel(
                    match s.background {
                        Some(_) => 1.0,
                        None => 1.0 - transmitted / n,
                    },
                    bad,
                ),
            ]);
            if s.aovs.variance {
                // The sample variance of the paths over n: the variance of the pixel's mean.
                let variance = ((squares - mean * sum) / ((n - 1.0) * n)).max(DVec3::ZERO);
                for v in variance.to_array() {
                    row.variance.push(channel(v, bad));
                }
            }
        }
        row.counts = std::mem::take(&mut medium.counts);
        row
    }

    /// One path along `ray`: the radiance it carries back, and the ray's transmittance (the
    /// path's weight if it left the box without scattering, else 0). What a path that never
    /// scattered sees of the sky is `unscattered`'s to say.
    fn trace(
        &self,
        medium: &mut Medium,
        mut ray: Ray,
        random: &mut PathRandom,
        unscattered: Unscattered,
    ) -> (DVec3, DVec3) {
        let s = self.settings;
        let mut weight = DVec3::ONE;
        let mut radiance = DVec3::ZERO;
        let mut order = 0u32;
        // The density per steradian with which phase sampling drew the ray's direction.
        let mut phase_pdf = 0.0;
        loop {
            random.start_bounce(order);
            let flight = match clip_to_box(&ray, &self.bounds) {
                Some((t0, t1)) => medium.fly(&ray, t0, t1, &mut weight, &mut radiance, random),
                None => Flight::Escaped,
            };
            let t = match flight {
                Flight::Absorbed => return (radiance, DVec3::ZERO),
                Flight::Escaped if order == 0 && unscattered == Unscattered::Transmitted => {
                    return (radiance, weight);
                }
                Flight::Escaped => {
                    // An unscattered ray from inside the medium (the march's indirect grid)
                    // left a point no next-event estimate was made from.
                    let drawn = (order > 0).then_some(phase_pdf);
                    for emitter in &self.emitters {
                        radiance += weight * emitter.escaping(ray.direction, drawn);
                    }
                    return (radiance, DVec3::ZERO);
                }
                Flight::Scattered(t) => t,
            };
            order += 1;
            if order > s.bounces {
                return (radiance, DVec3::ZERO);
            }
            let p = ray.at(t);
            radiance += weight * self.next_event(medium, p, ray.direction, random);
            let scattered = sampling::scatter(&s.phase, ray.direction, random);
            phase_pdf = s.phase.relative(scattered.dot(ray.direction)) / (4.0 * PI);
            ray = Ray {
                origin: p,
                direction: scattered,
            };
            if order >= ROULETTE_AFTER {
                let survival = weight.max_element().min(1.0);
                if survival.is_nan() || random.uniform() >= survival {
                    return (radiance, DVec3::ZERO);
                }
                weight /= survival;
            }
        }
    }

    /// Light scattered at `p` towards a path arriving along `direction`, per unit of path
    /// weight: `Σ p(cosθ)·T·E` over the sources that are sampled, `p` per steradian.
    fn next_event(
        &self,
        medium: &mut Medium,
        p: DVec3,
        direction: DVec3,
        random: &mut PathRandom,
    ) -> DVec3 {
        let mut total = DVec3::ZERO;
        for emitter in &self.emitters {
            let Some(incident) = emitter.incident(p, random) else {
                continue;
            };
            // The phase's angle is between the light's travel and the way back to the camera.
            let phase = self
                .settings
                .phase
                .relative(incident.travelling.dot(-direction))
                / (4.0 * PI);
            let unshadowed =
                incident.strength * phase * emitters::light_weight(incident.pdf, phase);
            if unshadowed.max_element() <= 0.0 {
                continue;
            }
            let shadow = Ray {
                origin: p,
                direction: incident.towards,
            };
            let transmittance = match clip_to_box(&shadow, &self.bounds) {
                Some((t0, t1)) => {
                    medium.transmittance(&shadow, t0, t1.min(incident.distance), random)
                }
                None => DVec3::ONE,
            };
            total += unshadowed * transmittance;
        }
        total
    }
}
