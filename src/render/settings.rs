//! What a render is asked to do: image size, sampling, the medium's optical constants, shadows,
//! artistic controls and extra outputs, with the defaults a TD expects.
//!
//! The one key decision: every length is in world units (`step`, cell sizes, `bounds`) and
//! `kappa` is extinction per world unit, whatever grids lie behind the fields, so a scene looks
//! the same when a cache's resolution changes. Settings are validated up front, each failure
//! worded in the script author's terms.

use super::phase::Phase;
use super::sky::Sky;
use super::transmittance::TransmissivityMethod;
use crate::base::failure::{Failure, Outcome};
use crate::space::Aabb;
use glam::DVec3;

/// How the light reaching a sample through the volume (`T_L`) is found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shadows {
    /// Precomputed once per light into a grid over the marched box and read trilinearly.
    /// `cell_size: None` takes the camera step, with at most 256 cells along the box's longest
    /// side (96 where the light is marched from every cell, as for a point light inside the box).
    /// Trilinear reads of a coarser column grid overestimate the column just inside a lit
    /// surface, where it is convex, so coarse cells darken dense media.
    Cache {
        cell_size: Option<f64>,
        method: TransmissivityMethod,
    },
    /// A march towards every light from every sample: slow, the reference the cache is
    /// measured against.
    March,
}

impl Default for Shadows {
    fn default() -> Shadows {
        Shadows::Cache {
            cell_size: None,
            method: TransmissivityMethod::Auto,
        }
    }
}

/// Contribution-driven step control (Svea's scheme, see `adaptive`): a step whose contribution
/// to the pixel exceeds `tolerance` is discarded and retried at half the length (down to
/// `min_step`); after a step contributing less than a quarter of `tolerance` the next one is
/// twice as long (up to `max_step`). A step samples only its midpoint, so `max_step` must still
/// resolve the thinnest feature of the density.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    pub min_step: f64,
    pub max_step: f64,
    /// Largest accepted change of any colour channel or of alpha in one step.
    pub tolerance: f64,
}

impl Adaptive {
    /// What `adaptive = true` means: `step` is the longest step, refined down to `step / 8`
    /// where a step would change the pixel by more than 1/256 (one 8-bit level). Never coarser
    /// than the fixed march at `step`; finer where it matters.
    pub fn around(step: f64) -> Adaptive {
        Adaptive {
            min_step: step / 8.0,
            max_step: step,
            tolerance: 1.0 / 256.0,
        }
    }
}

/// An artistic approximation of multiple scattering (after Wrenninge's octaves): the light is
/// summed over `octaves` terms, term `i` seeing the light's extinction scaled by
/// `attenuation^i`, contributing `contribution^i` of the light and using a phase whose
/// eccentricity is scaled by `eccentricity^i`. One octave is plain single scattering. It is not
/// energy conserving; it brightens the inside of dense media the way bounced light does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MultiScatter {
    pub octaves: u32,
    /// `a` in [0, 1]: how much thinner the medium looks to each further octave.
    pub attenuation: f64,
    /// `b` in [0, 1]: how much each further octave contributes.
    pub contribution: f64,
    /// `c` in [0, 1]: how much less directional each further octave scatters.
    pub eccentricity: f64,
}

impl Default for MultiScatter {
    fn default() -> MultiScatter {
        MultiScatter {
            octaves: 3,
            attenuation: 0.5,
            contribution: 0.5,
            eccentricity: 0.5,
        }
    }
}

/// Which integrator turns the scene into pixels.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Integrator {
    /// The ray marcher: exact single scattering, artistic multiple scattering (`march`).
    #[default]
    March,
    /// The unbiased volumetric path tracer (`path`): delta tracking, ratio-tracked shadow
    /// rays, every order of scattering up to `bounces`, the shadowed `sky`.
    Path,
}

/// The most scattering events a path-traced path may have.
pub const MAX_BOUNCES: u32 = 4096;

/// Extra image channels besides RGBA.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Aovs {
    /// `depth.Z`: opacity-weighted mean distance along the view axis; +∞ where alpha is 0.
    pub depth: bool,
    /// `transmittance.Y`: the remaining transmittance, averaged over the three channels.
    pub transmittance: bool,
    /// `emission.R/G/B`: the part of the colour emitted by the medium.
    pub emission: bool,
    /// `light0.R/G/B`, `light1.R/G/B`, ...: the part scattered from each light.
    pub lights: bool,
    /// `variance.R/G/B` (path tracer only): the variance of each pixel's mean colour, the
    /// sample variance of its `spp` path estimates divided by `spp`.
    pub variance: bool,
    /// `position.X/Y/Z`, `normal.X/Y/Z`, `forward.u/v` (march only): where the visible medium
    /// lies, which way its density falls and how it moves on screen (`render::surface`).
    pub position: bool,
    pub normal: bool,
    pub motion: bool,
}

impl Aovs {
    /// The AOVs named in `aovs = {...}`.
    pub fn parse(names: &[String]) -> Outcome<Aovs> {
        let mut aovs = Aovs::default();
        for name in names {
            let on = match name.as_str() {
                "depth" => &mut aovs.depth,
                "transmittance" => &mut aovs.transmittance,
                "emission" => &mut aovs.emission,
                "lights" => &mut aovs.lights,
                "variance" => &mut aovs.variance,
                "position" => &mut aovs.position,
                "normal" => &mut aovs.normal,
                "motion" => &mut aovs.motion,
                other => {
                    return Err(Failure::new(format!("unknown AOV \"{other}\""))
                        .with_help(format!("the AOVs are {}", quoted_list(Aovs::NAMES))));
                }
            };
            *on = true;
        }
        Ok(aovs)
    }

    /// Every AOV's name, as `aovs = {...}` takes it.
    pub const NAMES: &[&str] = &[
        "depth",
        "transmittance",
        "emission",
        "lights",
        "variance",
        "position",
        "normal",
        "motion",
    ];
}

/// `"a", "b" and "c"`.
fn quoted_list(names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
    match quoted.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} and {last}", rest.join(", ")),
        _ => quoted.join(""),
    }
}

/// Everything a render needs besides the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: usize,
    pub height: usize,
    /// Samples (rays) per pixel.
    pub spp: u32,
    /// Seeds the pixel and march jitter; the same seed gives the same image.
    pub seed: u64,
    /// March step in world units; `None` takes 1/256 of the marched box's longest side (about a
    /// voxel of a 256³ cache over the box).
    pub step: Option<f64>,
    /// Extinction per world unit for each colour channel; a scalar is `DVec3::splat(k)`.
    pub kappa: DVec3,
    /// A ray stops once every channel's transmittance is below this (default 1e-3: what is
    /// left would change alpha by at most 0.001).
    pub threshold: f64,
    pub phase: Phase,
    pub multiscatter: Option<MultiScatter>,
    /// Artistic "powder" darkening of the lit side of dense media (Horizon Zero Dawn's
    /// Beer–powder): strength in [0, 1], strongest with the light behind the camera.
    pub powder: Option<f64>,
    /// Unshadowed light from all around, added to every sample's illumination.
    pub ambient: DVec3,
    /// Single-scattering albedo in [0, 1]. `None` is the course notes' colour model: `color`
    /// is eq. 1.3's `C_d` and a lit opaque region shows `C_d·L/κ`. With an albedo the medium
    /// scatters `σs = albedo·color·κ` of the `σt = κ` it extinguishes, the phase function
    /// counts per steradian (isotropic `1/4π`) and `ambient` is the radiance of a uniform
    /// sky, so `color` is a tint in [0, 1] and an opaque white region lit head-on shows
    /// `albedo·L·p/2`, whatever κ.
    pub albedo: Option<f64>,
    pub adaptive: Option<Adaptive>,
    pub shadows: Shadows,
    /// The box to march; `None` takes the density's bounds.
    pub bounds: Option<Aabb>,
    pub aovs: Aovs,
    pub integrator: Integrator,
    /// Path tracer: the most scattering events along a path (0 shows emission alone, 1 is
    /// single scattering).
    pub bounces: u32,
    /// Path tracer: the sky around the render box (a uniform radiance, an environment map or
    /// the daylight sky), seen by every path that leaves the box after scattering (so it is
    /// shadowed by the medium).
    pub sky: Sky,
    /// What a camera ray sees where it leaves the medium, weighed by its transmittance, in
    /// both integrators (alpha is then 1); `None` leaves the image transparent there, to be
    /// composited. It is not light: the medium is lit by `sky`, which is usually the same.
    pub background: Option<Sky>,
    /// March in the albedo model: the grid of indirect light (orders ≥ 2, the sky, scattered
    /// emission), or `None` for single scattering alone (`multiscatter = 0`, or the octaves).
    pub indirect: Option<super::indirect::IndirectSettings>,
    /// Motion blur (with a velocity): the shutter's length in frames and where it opens.
    pub shutter: f64,
    pub shutter_position: super::motion::ShutterPosition,
    /// Deep output (`deep = true`): the most samples per pixel the march keeps per-depth
    /// colour for (`render::deep`); `None` for a flat image, which records nothing per depth.
    pub deep: Option<usize>,
}

impl RenderSettings {
    /// The march's indirect grid, where this render has one: the march in the albedo model
    /// with neither single scattering nor octaves asked for.
    pub fn indirect_grid(&self) -> Option<super::indirect::IndirectSettings> {
        match (self.integrator, self.albedo, &self.multiscatter) {
            (Integrator::March, Some(_), None) => self.indirect,
            _ => None,
        }
    }

    /// The shutter's open and close times in frames, around the frame at 0.
    pub fn shutter_interval(&self) -> (f64, f64) {
        self.shutter_position.interval(self.shutter)
    }
}

impl Default for RenderSettings {
    fn default() -> RenderSettings {
        RenderSettings {
            width: 640,
            height: 360,
            spp: 1,
            seed: 0,
            step: None,
            kappa: DVec3::ONE,
            threshold: 1e-3,
            phase: Phase::Isotropic,
            multiscatter: None,
            powder: None,
            ambient: DVec3::ZERO,
            albedo: None,
            adaptive: None,
            shadows: Shadows::default(),
            bounds: None,
            aovs: Aovs::default(),
            integrator: Integrator::March,
            bounces: 64,
            sky: Sky::default(),
            background: None,
            indirect: Some(super::indirect::IndirectSettings::default()),
            shutter: 0.5,
            shutter_position: super::motion::ShutterPosition::Center,
            deep: None,
        }
    }
}

/// The largest image side accepted.
pub const MAX_IMAGE_SIDE: usize = 1 << 16;
/// The most samples a single ray may take at the fixed step (or the smallest adaptive step).
pub const MAX_STEPS_PER_RAY: f64 = 1e7;

/// A uniform radiance given as `what` must be finite and non-negative per channel (a map or
/// the daylight sky is checked where it is made).
fn uniform_radiance(what: &str, sky: &Sky) -> Outcome<()> {
    match sky {
        Sky::Uniform(radiance) if !radiance.is_finite() || radiance.min_element() < 0.0 => {
            Err(Failure::new(format!(
                "{what} must be finite and non-negative, got {radiance}"
            ))
            .with_help(format!(
                "{what} is the radiance of a uniform sky, per colour channel"
            )))
        }
        _ => Ok(()),
    }
}

fn positive(what: &str, v: f64) -> Outcome<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(Failure::new(format!(
            "{what} must be a positive number, got {v}"
        )))
    }
}

fn unit_interval(what: &str, v: f64) -> Outcome<()> {
    if (0.0..=1.0).contains(&v) {
        Ok(())
    } else {
        Err(Failure::new(format!(
            "{what} must be between 0 and 1, got {v}"
        )))
    }
}

impl RenderSettings {
    /// Checks everything that does not depend on the scene.
    pub fn validate(&self) -> Outcome<()> {
        for (what, side) in [("width", self.width), ("height", self.height)] {
            if side == 0 || side > MAX_IMAGE_SIDE {
                return Err(Failure::new(format!(
                    "image {what} must be between 1 and {MAX_IMAGE_SIDE} pixels, got {side}"
                )));
            }
        }
        if self.spp == 0 || self.spp > 1 << 16 {
            return Err(Failure::new(format!(
                "samples per pixel must be between 1 and 65536, got {}",
                self.spp
            )));
        }
        if let Some(step) = self.step {
            positive("step", step).map_err(|e| {
                e.with_help(
                    "step is a world-space length, e.g. 0.01 for a scene a few units across",
                )
            })?;
        }
        if !(self.shutter.is_finite() && (0.0..=1e3).contains(&self.shutter)) {
            return Err(Failure::new(format!(
                "shutter must be between 0 and 1000 frames, got {}",
                self.shutter
            ))
            .with_help("shutter is the exposure in frames: 0.5 is a 180° film shutter"));
        }
        if !self.kappa.is_finite() || self.kappa.min_element() < 0.0 {
            return Err(Failure::new(format!(
                "kappa must be finite and non-negative in every channel, got {}",
                self.kappa
            ))
            .with_help(
                "kappa is extinction per world unit; 0 makes the medium fully transparent",
            ));
        }
        if !(0.0..1.0).contains(&self.threshold) {
            return Err(Failure::new(format!(
                "threshold must be at least 0 and below 1, got {}",
                self.threshold
            )));
        }
        self.phase.validate()?;
        if let Some(ms) = &self.multiscatter {
            if ms.octaves == 0 || ms.octaves > 16 {
                return Err(Failure::new(format!(
                    "multiscatter octaves must be between 1 and 16, got {}",
                    ms.octaves
                )));
            }
            unit_interval("multiscatter attenuation", ms.attenuation)?;
            unit_interval("multiscatter contribution", ms.contribution)?;
            unit_interval("multiscatter eccentricity", ms.eccentricity)?;
        }
        if let Some(p) = self.powder {
            unit_interval("powder strength", p)?;
        }
        if let Some(a) = self.albedo {
            unit_interval("albedo", a).map_err(|e| {
                e.with_help("albedo is the fraction of extinguished light that is scattered")
            })?;
        }
        if !self.ambient.is_finite() || self.ambient.min_element() < 0.0 {
            return Err(Failure::new(format!(
                "ambient must be finite and non-negative, got {}",
                self.ambient
            )));
        }
        if let Some(most) = self.deep {
            if !(1..=1024).contains(&most) {
                return Err(Failure::new(format!(
                    "deep samples per pixel must be between 1 and 1024, got {most}"
                )));
            }
            if self.integrator == Integrator::Path {
                return Err(Failure::new(
                    "deep output needs the march: the path tracer keeps no colour per depth",
                ));
            }
        }
        if let Some(a) = &self.adaptive {
            positive("adaptive min_step", a.min_step)?;
            positive("adaptive max_step", a.max_step)?;
            positive("adaptive tolerance", a.tolerance)?;
            if a.min_step > a.max_step {
                return Err(Failure::new(format!(
                    "adaptive min_step {} is larger than max_step {}",
                    a.min_step, a.max_step
                )));
            }
        }
        if let Shadows::Cache {
            cell_size: Some(c), ..
        } = self.shadows
        {
            positive("shadow cache cell size", c)?;
        }
        if let Some(b) = &self.bounds
            && (!b.is_finite() || b.is_empty() || b.size().min_element() <= 0.0)
        {
            return Err(Failure::new(format!(
                "render bounds must be a finite box with positive size, got {} to {}",
                b.min, b.max
            )));
        }
        self.validate_integrator()
    }

    /// The options that belong to one integrator only are refused by the other, so a script
    /// never sets a control that silently does nothing.
    fn validate_integrator(&self) -> Outcome<()> {
        if self.bounces > MAX_BOUNCES {
            return Err(Failure::new(format!(
                "bounces must be between 0 and {MAX_BOUNCES}, got {}",
                self.bounces
            )));
        }
        uniform_radiance("sky", &self.sky)?;
        if let Some(background) = &self.background {
            uniform_radiance("background", background)?;
        }
        match self.integrator {
            Integrator::March => {
                if !self.sky.is_black() && self.indirect_grid().is_none() {
                    return Err(Failure::new(
                        "the march shows sky light through its indirect grid, which this render \
                         does not have",
                    )
                    .with_help(
                        "the grid needs the albedo model and no multiscatter octaves: add \
                         albedo = 1 and leave out multiscatter (or light with ambient)",
                    ));
                }
                if self.aovs.variance {
                    return Err(Failure::new("the variance AOV belongs to the path tracer")
                        .with_help("add integrator = \"path\""));
                }
            }
            Integrator::Path => {
                let march_only = [
                    (
                        "ambient",
                        self.ambient != DVec3::ZERO,
                        "use sky = (r, g, b): the path tracer shadows it",
                    ),
                    (
                        "multiscatter",
                        self.multiscatter.is_some(),
                        "the path tracer scatters light as often as bounces allows",
                    ),
                    (
                        "powder",
                        self.powder.is_some(),
                        "the path tracer's multiple scattering brightens and darkens by itself",
                    ),
                    (
                        "adaptive",
                        self.adaptive.is_some(),
                        "the path tracer takes no steps: leave out adaptive",
                    ),
                    (
                        "the depth, transmittance, emission, lights, position, normal and motion \
                         AOVs",
                        self.aovs.depth
                            || self.aovs.transmittance
                            || self.aovs.emission
                            || self.aovs.lights
                            || super::surface::Surface::wanted(&self.aovs),
                        "the path tracer writes the variance AOV",
                    ),
                ];
                for (what, given, help) in march_only {
                    if given {
                        return Err(Failure::new(format!(
                            "{what} belongs to the march, not integrator = \"path\""
                        ))
                        .with_help(help));
                    }
                }
            }
        }
        Ok(())
    }

    /// With an albedo, what `color` and the ambient light are multiplied by so that the
    /// march's colour update (eq. 1.3 with the phase relative to isotropic) becomes single
    /// scattering with `σs = albedo·color·κ` and the phase per steradian: `albedo·κ/4π` and
    /// `4π` (a uniform sky of radiance `ambient` scatters `σs·ambient`).
    pub(crate) fn albedo_scales(&self) -> Option<(DVec3, f64)> {
        let four_pi = 4.0 * std::f64::consts::PI;
        self.albedo.map(|a| (self.kappa * (a / four_pi), four_pi))
    }

    /// Kappa that is the same in all channels lets the march compute one exponential, not three.
    pub(crate) fn grey_kappa(&self) -> bool {
        self.kappa.x == self.kappa.y && self.kappa.y == self.kappa.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_bad_values_are_named() {
        RenderSettings::default().validate().unwrap();
        let bad = |f: fn(&mut RenderSettings), word: &str| {
            let mut s = RenderSettings::default();
            f(&mut s);
            let err = s.validate().unwrap_err();
            assert!(err.message.contains(word), "{}", err.message);
        };
        bad(|s| s.width = 0, "width");
        bad(|s| s.height = 1 << 20, "height");
        bad(|s| s.spp = 0, "samples per pixel");
        bad(|s| s.step = Some(0.0), "step");
        bad(|s| s.step = Some(f64::NAN), "step");
        bad(|s| s.kappa = DVec3::new(1.0, -1.0, 1.0), "kappa");
        bad(|s| s.threshold = 1.0, "threshold");
        bad(
            |s| s.phase = Phase::HenyeyGreenstein { g: -1.0 },
            "eccentricity",
        );
        bad(|s| s.powder = Some(2.0), "powder");
        bad(|s| s.albedo = Some(1.5), "albedo");
        bad(|s| s.albedo = Some(f64::NAN), "albedo");
        bad(
            |s| {
                s.adaptive = Some(Adaptive {
                    min_step: 0.1,
                    max_step: 0.01,
                    tolerance: 0.01,
                })
            },
            "min_step",
        );
        bad(
            |s| s.bounds = Some(Aabb::new(DVec3::ZERO, DVec3::new(1.0, 0.0, 1.0))),
            "bounds",
        );
        bad(
            |s| {
                s.multiscatter = Some(MultiScatter {
                    octaves: 0,
                    ..MultiScatter::default()
                })
            },
            "octaves",
        );
    }
}
