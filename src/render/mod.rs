//! Rendering: the built-in raymarcher and the image writers.
//!
//! `render` takes a `Scene` (density, optional colour, emission and holdout fields, a camera,
//! lights) and `RenderSettings`, and returns an `Image`; `write_image` stores it as OpenEXR or a
//! PNG preview. Fields are consumed only through `sample::FieldSampler`, in blocks. The pieces,
//! one physical idea each: `camera` (rays), `light` (sources), `phase` (angular scattering),
//! `transmittance` and `sweep` (light reaching each point through the volume, precomputed on
//! grids), `lighting` (illumination at a sample), `space` (empty-space skipping), `march` (the
//! integrator, eqs. 1.1–1.4 of the course notes), `adaptive` (step control), `tile` (ray state
//! and pixels), `settings`, `image` (files), `deep` and `deep_exr` (per-depth samples and the
//! deep OpenEXR files they are written to).
//!
//! The one key decision: the march needs a finite box — the `bounds` setting, else the
//! density's own bounds — and everything (step default, shadow grids, empty-space bricks) is
//! laid over that box in world units.

mod adaptive;
pub mod band;
pub mod blackbody;
pub mod camera;
pub mod cie1931;
pub mod deep;
pub mod deep_exr;
pub mod exr_header;
pub mod exr_order;
pub mod filmic;
pub mod image;
pub mod indirect;
pub mod keywords;
pub mod light;
mod lighting;
mod march;
pub mod motion;
pub mod path;
pub mod phase;
mod photons;
pub mod progress;
pub mod settings;
pub mod sky;
mod space;
pub mod surface;
mod sweep;
mod tile;
pub mod tonemap;
pub mod transmittance;
pub mod view;
pub mod working_space;

#[cfg(test)]
mod frustum_tests;
#[cfg(test)]
mod testing;
#[cfg(test)]
mod tests;

pub use camera::Camera;
pub use image::{
    ExrOptions, HeaderValue, Image, write_image, write_image_viewed, write_image_with,
};
pub use light::{DistantLight, Light, PointLight};
pub use phase::Phase;
pub use settings::{Adaptive, Aovs, Integrator, MultiScatter, RenderSettings, Shadows};
pub use tile::{InputCounts, MarchStats};
pub use transmittance::{TransmissivityMethod, transmissivity};

use crate::base::failure::{Failure, Outcome};
use crate::base::failure::{grouped, vector_text};
use crate::space::{Aabb, FieldSampler};
use glam::DVec3;
use lighting::Illumination;
use march::{Frame, Worker, side_rays, tile_side};
use progress::Progress;
use rayon::prelude::*;
use space::Occupancy;
use std::time::Instant;
use tile::TileOutput;

/// What to render.
///
/// Values the march cannot use are read by one rule: a sample that is NaN or infinite
/// contributes nothing (density, colour and emission read as 0, a holdout as 1, no holdout),
/// and a negative sample is clamped to 0 (a holdout above 1 is read as 1). So an infinite
/// density is empty, not opaque: the largest finite density is the way to say opaque. Every
/// such sample is counted per input (`MarchStats`), and `RenderStats::warnings` says so.
pub struct Scene<'a> {
    /// Scalar density (width 1).
    pub density: &'a dyn FieldSampler,
    /// Colour (width 3) scattering the light; white when absent.
    pub color: Option<&'a dyn FieldSampler>,
    /// Light emitted per unit length (width 3), for fire.
    pub emission: Option<&'a dyn FieldSampler>,
    /// Holdout transmittance (width 1): how visible each point is to the camera, 1 = fully.
    pub holdout: Option<&'a dyn FieldSampler>,
    /// Velocity (width 3, world units per frame) for motion blur over `RenderSettings::shutter`.
    pub velocity: Option<&'a dyn FieldSampler>,
    pub camera: Camera,
    pub lights: Vec<Light>,
}

/// What a render computed, for `--profile`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderStats {
    pub march: MarchStats,
    /// The step used, in world units.
    pub step: f64,
    /// Empty-space bricks, and how many were proven empty.
    pub bricks: usize,
    pub empty_bricks: usize,
    /// Seconds spent on shadow grids and on the march.
    pub shadow_seconds: f64,
    pub march_seconds: f64,
    /// Whether the density reads a grid (a cache read's `outside` can then matter).
    pub density_reads_grids: bool,
    /// Path tracer: density samples above the majorant of their cell (where the tracking is
    /// biased), and where the first was.
    pub above_majorant: u64,
    pub first_above_majorant: Option<glam::DVec3>,
    /// March: the indirect grid's cells and those estimated, and its seconds (within
    /// `shadow_seconds`); or why the render has none although its settings ask for one.
    pub indirect_cells: (usize, usize),
    pub indirect_seconds: f64,
    pub indirect_skipped: Option<String>,
    /// March: multiscatter octaves whose contribution exceeds their attenuation (b > a), which
    /// add more light than the medium scatters.
    pub octaves_gain_energy: bool,
}

/// A render's warning for the script author: what went wrong, and what might fix it.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderWarning {
    pub message: String,
    pub help: &'static str,
}

impl RenderStats {
    /// One warning for each input field that gave NaN, infinite or negative samples (named by
    /// its `render` argument, with the counts and what they were read as), and one for pixels
    /// that overflowed.
    pub fn warnings(&self) -> Vec<RenderWarning> {
        let m = &self.march;
        let inputs = [
            ("density", &m.density, "treated as 0: empty"),
            ("color", &m.color, "treated as 0: black"),
            ("emission", &m.emission, "treated as 0: no light"),
            ("holdout", &m.holdout, "treated as 1: not held out"),
        ];
        let mut warnings = Vec::new();
        for (name, counts, treated) in inputs {
            if counts.is_clean() {
                continue;
            }
            let total = grouped(counts.samples);
            let negative = grouped(counts.negative);
            let message = match counts.first_non_finite {
                Some(at) => {
                    let mut text = format!(
                        "render: {name} was NaN or infinite at {} of {total} samples ({treated}), \
                         the first at {}",
                        grouped(counts.non_finite),
                        vector_text(at)
                    );
                    if counts.negative > 0 {
                        text += &format!(", and negative at {negative} (clamped to 0)");
                    }
                    text
                }
                None => {
                    format!(
                        "render: {name} was negative at {negative} of {total} samples (clamped to 0)"
                    )
                }
            };
            let help = if counts.non_finite > 0 {
                "a division by a field that is zero somewhere gives infinities or NaN; guard it \
                 with select or max"
            } else if name == "density" && self.density_reads_grids {
                "negative values have no meaning here; a cache read extrapolates linearly in the \
                 half cell inside its faces, so a steep density there reads below zero, and \
                 advection carries that into the next cache: read caches with \
                 outside = \"hold\", or say what the density should be with max(field, 0)"
            } else {
                "negative values have no meaning here; say what they should be with \
                 max(field, 0) or clamp"
            };
            warnings.push(RenderWarning { message, help });
        }
        if let Some(at) = self.first_above_majorant {
            warnings.push(RenderWarning {
                message: format!(
                    "render: the density exceeded its path-tracing bound at {} samples, the \
                     first at {}; the image is biased there",
                    grouped(self.above_majorant),
                    vector_text(at)
                ),
                help: "the density's interval bounds are wrong somewhere: render with the march \
                       to compare, and report the field",
            });
        }
        if self.octaves_gain_energy {
            warnings.push(RenderWarning {
                message: "render: the multiscatter octaves add more light than the medium \
                          scatters: mscontribution is above msattenuation"
                    .to_string(),
                help: "keep mscontribution ≤ msattenuation, or leave out multiscatter for the \
                       indirect grid, which conserves energy",
            });
        }
        if let Some(why) = &self.indirect_skipped {
            warnings.push(RenderWarning {
                message: format!(
                    "render: {why}, so this image has single scattering only: no light \
                     scattered more than once"
                ),
                help: "read the density from a cache, or pass multiscatter = 0 to ask for \
                       single scattering",
            });
        }
        if m.bad_pixels > 0 {
            warnings.push(RenderWarning {
                message: format!(
                    "render: {} pixel values overflowed the 32-bit image (infinite ones are \
                     written as infinity, NaN ones as 0)",
                    grouped(m.bad_pixels)
                ),
                help: "the density, colour, emission or light strengths are near the largest \
                       floats; scale them down",
            });
        }
        warnings
    }
}

/// Renders `scene` with `settings`.
pub fn render(scene: &Scene, settings: &RenderSettings) -> Outcome<Image> {
    render_with_stats(scene, settings).map(|(image, _)| image)
}

/// Renders and reports what was computed.
pub fn render_with_stats(
    scene: &Scene,
    settings: &RenderSettings,
) -> Outcome<(Image, RenderStats)> {
    render_layers(scene, settings).map(|(image, _, stats)| (image, stats))
}

/// Renders the flat image and, for `settings.deep`, the deep image whose samples composite to
/// it (see `deep`).
pub fn render_deep(
    scene: &Scene,
    settings: &RenderSettings,
) -> Outcome<(Image, deep::DeepImage, RenderStats)> {
    if settings.deep.is_none() {
        return Err(Failure::internal("render_deep without deep settings"));
    }
    let (image, deep, stats) = render_layers(scene, settings)?;
    let deep = deep.ok_or_else(|| Failure::internal("the march made no deep image"))?;
    Ok((image, deep, stats))
}

fn render_layers(
    scene: &Scene,
    settings: &RenderSettings,
) -> Outcome<(Image, Option<deep::DeepImage>, RenderStats)> {
    settings.validate()?;
    check_width("density", scene.density, 1)?;
    for (what, field, width) in [
        ("color", scene.color, 3),
        ("emission", scene.emission, 3),
        ("holdout", scene.holdout, 1),
    ] {
        if let Some(f) = field {
            check_width(what, f, width)?;
        }
    }
    if let Some(v) = scene.velocity {
        check_width("velocity", v, 3)?;
    }
    let still = march_box(scene, settings)?;
    // Under motion blur the box widens by how far the medium moves in the shutter.
    let (open, close) = settings.shutter_interval();
    let motion = match scene.velocity {
        Some(v) => Some(motion::Motion::new(v, open, close, &still)?),
        None => None,
    };
    let reach = motion.as_ref().map_or(DVec3::ZERO, |m| m.reach);
    let bounds = Aabb::new(still.min - reach, still.max + reach);
    let swept_density = motion::Swept {
        inner: scene.density,
        reach,
    };
    let swept_emission = scene.emission.map(|e| motion::Swept { inner: e, reach });
    let seen_density: &dyn FieldSampler = if motion.is_some() {
        &swept_density
    } else {
        scene.density
    };
    let seen_emission: Option<&dyn FieldSampler> = match (&motion, &swept_emission) {
        (Some(_), Some(e)) => Some(e),
        _ => scene.emission,
    };
    if settings.integrator == Integrator::Path {
        let channels = path::aov_names(settings).len();
        let bytes = settings.width as f64 * settings.height as f64 * (16.0 + 4.0 * channels as f64);
        let _framebuffer = crate::engine::budget::reserve(
            2.0 * bytes,
            &format!(
                "a {} x {} image with {} channels (its rows and the image)",
                settings.width,
                settings.height,
                4 + channels
            ),
        )?;
        let (image, stats) = path::render(
            scene,
            settings,
            bounds,
            motion.as_ref(),
            seen_density,
            seen_emission,
        )?;
        return Ok((image, None, stats));
    }
    let step = settings.step.unwrap_or(bounds.size().max_element() / 256.0);
    let smallest = settings.adaptive.map_or(step, |a| a.min_step.min(step));
    let diagonal = bounds.size().length();
    if diagonal / smallest > settings::MAX_STEPS_PER_RAY {
        return Err(Failure::new(format!(
            "a step of {smallest} needs {:.0} samples to cross the {diagonal:.3}-unit render box",
            diagonal / smallest
        ))
        .with_help("use a larger step (it is a world-space length) or a smaller bounds box"));
    }
    let precision = scene.camera.precision_over(&bounds);
    if precision > 0.1 * smallest {
        return Err(Failure::new(format!(
            "the camera eye {} is so far from the render box that positions along its rays are \
             only accurate to {precision:e}, too coarse for a step of {smallest}",
            vector_text(scene.camera.eye)
        ))
        .with_help("move the camera nearer the box (a smaller fov keeps the framing)"));
    }
    let aov_names = aov_names(settings, &scene.lights)?;
    let pixels = settings.width as f64 * settings.height as f64;
    // The tiles and the image they are gathered into, from the budget before any ray is
    // marched: a framebuffer too large for memory fails here, not after the render.
    let bytes = pixels * (16.0 + 4.0 * aov_names.len() as f64);
    let _framebuffer = crate::engine::budget::reserve(
        2.0 * bytes,
        &format!(
            "a {} x {} image with {} channels (its tiles and the image)",
            settings.width,
            settings.height,
            4 + aov_names.len()
        ),
    )?;

    // Deep output: every worker's curves, one tile of rays each (`deep::curve_points`).
    let _curves = match settings.deep {
        Some(most) => Some(crate::engine::budget::reserve(
            (rayon::current_num_threads() * deep::curve_bytes(most, side_rays(settings.spp)))
                as f64,
            "the deep image's curves along each worker's rays",
        )?),
        None => None,
    };
    let started = Instant::now();
    let illumination = Illumination::new(scene.density, &scene.lights, settings, bounds, step)?;
    let indirect_started = Instant::now();
    let (indirect, indirect_skipped) =
        match indirect::IndirectGrid::for_render(scene, settings, still) {
            Ok(grid) => (grid, None),
            // A density whose range is unknown cannot be path-traced; with no sky asked for, the
            // march still renders its exact single scattering, and says what it left out.
            Err(failure) if !failure.internal && settings.sky.is_black() => {
                (None, Some(failure.message))
            }
            Err(failure) => return Err(failure),
        };
    let indirect_seconds = indirect_started.elapsed().as_secs_f64();
    let shadow_seconds = started.elapsed().as_secs_f64();
    let occupancy = Occupancy::build(seen_density, seen_emission, bounds, step);
    let frame = Frame {
        density: scene.density,
        color: scene.color,
        emission: scene.emission,
        holdout: scene.holdout,
        camera: &scene.camera,
        raster: scene.camera.raster(settings.width, settings.height),
        bounds,
        occupancy: &occupancy,
        illumination: &illumination,
        indirect: indirect.as_ref(),
        settings,
        step,
        aov_count: aov_names.len(),
        motion: motion.as_ref(),
    };
    let side = tile_side(settings.spp);
    // Under `--tile I/N` only the band's rows are marched; band edges fall on tile edges.
    let rows = band::rows(settings.height)?;
    let tiles_across = settings.width.div_ceil(side);
    let tiles = rows.start / side * tiles_across..rows.end.div_ceil(side) * tiles_across;
    let progress = Progress::new(tiles.len() as u64);
    let marching = Instant::now();
    let outputs: Vec<TileOutput> = tiles
        .into_par_iter()
        .map_init(
            || Worker::new(&frame),
            |worker, tile| {
                // A Ctrl-C at the REPL abandons the remaining tiles.
                if crate::engine::interrupt::requested() {
                    return None;
                }
                let out = worker.tile(&frame, tile);
                progress.tick();
                Some(out)
            },
        )
        .collect::<Vec<Option<TileOutput>>>()
        .into_iter()
        .collect::<Option<Vec<TileOutput>>>()
        .ok_or_else(|| Failure::new("interrupted"))?;
    progress.finish();
    let march_seconds = marching.elapsed().as_secs_f64();

    let mut image = Image::new(settings.width, settings.height);
    image.aovs = aov_names
        .into_iter()
        .map(|name| (name, vec![0.0; settings.width * settings.height]))
        .collect();
    let mut stats = RenderStats {
        step,
        bricks: occupancy.bricks(),
        empty_bricks: occupancy.empty_bricks,
        shadow_seconds,
        march_seconds,
        indirect_cells: indirect
            .as_ref()
            .map_or((0, 0), |g| (g.cells(), g.estimated)),
        indirect_seconds,
        indirect_skipped,
        octaves_gain_energy: settings
            .multiscatter
            .is_some_and(|ms| ms.octaves > 1 && ms.contribution > ms.attenuation),
        ..RenderStats::default()
    };
    let channels = image.aovs.len();
    for tile in &outputs {
        for ty in 0..tile.height {
            for tx in 0..tile.width {
                let local = ty * tile.width + tx;
                let pixel = (tile.y0 + ty) * settings.width + tile.x0 + tx;
                image.rgba[pixel] = tile.rgba[local];
                for (c, (_, values)) in image.aovs.iter_mut().enumerate() {
                    values[pixel] = tile.aovs[local * channels + c];
                }
            }
        }
        stats.march.merge(&tile.stats);
    }
    let m = &mut stats.march;
    for (counts, field) in [
        (&mut m.density, Some(scene.density)),
        (&mut m.color, scene.color),
        (&mut m.emission, scene.emission),
    ] {
        if let Some(field) = field
            && counts.negative > 0
        {
            // A cache read extrapolates linearly in the half cell inside each face, so a
            // cache whose cells are all at least zero can still read below zero there; the
            // clamp to zero is then the right reading, not a mistake to warn about.
            counts.negative_only_at_faces = field.range_held(&bounds).iter().all(|r| r.0 >= 0.0);
        }
    }
    stats.density_reads_grids = !scene.density.grids().is_empty();
    let deep = match settings.deep {
        Some(_) => Some(deep::gather(&outputs, settings.width, settings.height)?),
        None => None,
    };
    Ok((image, deep, stats))
}

fn check_width(what: &str, field: &dyn FieldSampler, width: usize) -> Outcome<()> {
    if field.width() == width {
        return Ok(());
    }
    let kind = |w: usize| match w {
        1 => "a scalar field".to_string(),
        3 => "a vector field".to_string(),
        9 => "a matrix field".to_string(),
        w => format!("a field with {w} components"),
    };
    Err(Failure::new(format!(
        "render {what} must be {}, got {}",
        kind(width),
        kind(field.width())
    )))
}

/// The box the march covers.
fn march_box(scene: &Scene, settings: &RenderSettings) -> Outcome<Aabb> {
    let bounds = match settings.bounds {
        Some(b) => b,
        None => {
            match scene.density.bounds() {
                Some(b) if b.is_finite() => b,
                _ => {
                    return Err(Failure::new(
                    "render cannot tell where the density is: it has no finite bounds",
                )
                .with_help("pass bounds = some domain, e.g. bounds = domain(origin, lengths, orientation)"));
                }
            }
        }
    };
    if bounds.is_empty() || bounds.size().min_element() <= 0.0 {
        return Err(Failure::new(format!(
            "the render box from {} to {} is empty",
            bounds.min, bounds.max
        ))
        .with_help("pass bounds = some domain that contains the density"));
    }
    Ok(bounds)
}

/// AOV channel names in the order the march writes them.
fn aov_names(settings: &RenderSettings, lights: &[Light]) -> Outcome<Vec<String>> {
    let a = &settings.aovs;
    let mut names = Vec::new();
    if a.depth {
        names.push("depth.Z".to_string());
    }
    if a.transmittance {
        names.push("transmittance.Y".to_string());
    }
    if a.emission {
        names.extend(["emission.R", "emission.G", "emission.B"].map(String::from));
    }
    if a.lights {
        let mut layers: Vec<String> = Vec::new();
        for (i, light) in lights.iter().enumerate() {
            let layer = light.aov_name(i);
            if layers.contains(&layer)
                || [
                    "depth",
                    "transmittance",
                    "emission",
                    "position",
                    "normal",
                    "forward",
                ]
                .contains(&layer.as_str())
            {
                return Err(Failure::new(format!(
                    "two AOV layers are called '{layer}' (light {i} and an earlier light or AOV)"
                ))
                .with_help(
                    "give each light its own name: distantlight(dir, color, name = \"key\")",
                ));
            }
            names.extend(["R", "G", "B"].map(|c| format!("{layer}.{c}")));
            layers.push(layer);
        }
    }
    names.extend(surface::channel_names(a));
    Ok(names)
}
