//! Rendering builtins (LANGUAGE.md §8): cameras, lights, `render` and `transmissivity`.
//!
//! `render` is an output: it compiles the density (and colour, emission, holdout) fields and
//! hands them to the raymarcher, which asks for values only inside the box the density reports
//! (or `bounds = domain`). Every option of the raymarcher is a keyword argument with the
//! raymarcher's default, so `render("out.exr", density = rho, camera = cam)` is a complete call.

use crate::diagnostic::{Diagnostic, Stage};
use crate::failure::{Failure, Outcome};
use crate::field::{CompiledField, Field};
use crate::grid::cache::Cache;
use crate::interp::Interpreter;
use crate::interp::registry::{Args, Registry};
use crate::interp::value::Value;
use crate::render::settings::{Adaptive, Aovs, MultiScatter, Shadows};
use crate::render::tonemap::ToneMap;
use crate::render::transmittance::TransmissivityMethod;
use crate::render::{self, Camera, Light, Phase, RenderSettings, Scene};
use crate::sample::GridSource;
use glam::DVec3;
use std::rc::Rc;
use std::sync::Arc;

/// The form of `render` with `kappa` of the given type (a float, or a vector per channel).
macro_rules! render_form {
    ($kappa:literal) => {
        concat!(
            "render(string path, scalarfield density, vectorfield color?, vectorfield emission?, ",
            "camera camera, light[] lights?, ",
            $kappa,
            " kappa?, float step?, int width?, int height?, int spp?, int seed?, ",
            "domain bounds?, float threshold?, float phase?, vector phase2?, scalarfield holdout?, ",
            "vector ambient?, int multiscatter?, bool adaptive?, string[] aovs?, string shadows?, ",
            "float powder?, float shadowcell?, float albedo?, string tonemap?, float brightness?, float gamma?, bool exr_half?) -> void"
        )
    };
}

const COLOR: usize = 2;
const EMISSION: usize = 3;
const CAMERA: usize = 4;
const LIGHTS: usize = 5;
const KAPPA: usize = 6;
const STEP: usize = 7;
const WIDTH: usize = 8;
const HEIGHT: usize = 9;
const SPP: usize = 10;
const SEED: usize = 11;
const BOUNDS: usize = 12;
const THRESHOLD: usize = 13;
const PHASE: usize = 14;
const PHASE2: usize = 15;
const HOLDOUT: usize = 16;
const AMBIENT: usize = 17;
const MULTISCATTER: usize = 18;
const ADAPTIVE: usize = 19;
const AOVS: usize = 20;
const SHADOWS: usize = 21;
const POWDER: usize = 22;
const SHADOW_CELL: usize = 23;
const ALBEDO: usize = 24;

pub fn register(r: &mut Registry) {
    r.add(
        "rendering",
        &[
            "camera(vector eye, vector lookat, vector up, float fov) -> camera",
            "camera(vector eye, vector lookat, vector up, float fov, float aspect?, float ortho?) -> camera",
        ],
        "a camera at eye looking at lookat; fov is the horizontal field of view in degrees; \
         aspect fixes width/height, ortho = view width makes it orthographic",
        |_, a| {
            let (eye, lookat, up) = (a.get(0)?.as_vector()?, a.get(1)?.as_vector()?, a.get(2)?.as_vector()?);
            let mut camera = Camera::new(eye, lookat, up, a.float(3)?)?;
            if let Some(aspect) = opt_float(&a, 4)? {
                camera = camera.with_aspect(aspect)?;
            }
            if let Some(width) = opt_float(&a, 5)? {
                camera = camera.orthographic(width)?;
            }
            Ok(Value::Camera(Rc::new(camera)))
        },
    );
    r.add(
        "rendering",
        &["distantlight(vector direction, vector color?, string name?) -> light"],
        "parallel light travelling along direction ((0, -1, 0) is the sun overhead); color \
         defaults to white; name is what its AOV channels are called (default light0, light1, ... \
         by its place in the render's lights)",
        |_, a| {
            let color = opt_vector(&a, 1)?.unwrap_or(DVec3::ONE);
            named(Light::distant(a.get(0)?.as_vector()?, color)?, &a)
        },
    );
    r.add(
        "rendering",
        &["pointlight(vector position, vector color?, string name?) -> light"],
        "light from a point, falling off as 1/r^2 (color is the strength at distance 1); name \
         as for distantlight",
        |_, a| {
            let color = opt_vector(&a, 1)?.unwrap_or(DVec3::ONE);
            named(Light::point(a.get(0)?.as_vector()?, color)?, &a)
        },
    );
    r.add(
        "rendering",
        &[render_form!("float"), render_form!("vector")],
        "raymarches density (lit by lights, coloured by color, glowing with emission) into an \
         OpenEXR image, or a PNG preview when path ends in .png; tonemap = \"max1\" or \"log\" \
         (brightness, gamma) compresses emission-only particle renders",
        run_render,
    );
    r.choices(
        "render",
        "shadows",
        "shadows mode",
        &["cache", "march", "sweep"],
    );
    r.choices("render", "tonemap", "tone map", &["max1", "log"]);
    r.choices(
        "render",
        "aovs",
        "AOV",
        &["depth", "transmittance", "emission", "lights"],
    );
    // What other renderers call these options, so a TD's habit finds felt's word.
    r.aliases("render", "spp", &["samples", "pixelsamples", "aa_samples"]);
    r.aliases("render", "step", &["stepsize", "step_size", "volumestep"]);
    r.aliases(
        "render",
        "kappa",
        &["extinction", "densityscale", "density_scale"],
    );
    r.aliases("render", "width", &["resx", "xres"]);
    r.aliases("render", "height", &["resy", "yres"]);
    r.add(
        "rendering",
        &["transmissivity(scalarfield density, light l, domain d, float kappa) -> scalarfield"],
        "the fraction of l's light reaching each point through density (1 outside d), sampled at d's cells",
        |_, a| {
            let density = CompiledField::prepared(&a.get(0)?.as_field()?)?;
            let Value::Light(light) = a.get(1)? else { return Err(Failure::new("expected a light")) };
            let Value::Domain(domain) = a.get(2)? else { return Err(Failure::new("expected a domain")) };
            if domain.resolution.is_none() {
                return Err(Failure::new("transmissivity needs a domain with a cell size"));
            }
            let values = render::transmittance::transmissivity(&density, light, domain, a.float(3)?, TransmissivityMethod::Auto)?;
            let cache = Cache::from_dense((**domain).clone(), 1, vec![values], vec![1.0])?
                .with_label("transmissivity".to_string())
                .with_profile("transmissivity");
            let grid: Arc<dyn GridSource> = Arc::new(cache);
            Ok(Value::Field(Field::from_linear_grid(grid)?))
        },
    );
}

/// The light with the `name` argument, when one was given.
fn named(light: Light, a: &Args) -> Outcome<Value> {
    let light = match a.opt("name") {
        Some(name) => light.named(name.as_str()?)?,
        None => light,
    };
    Ok(Value::Light(Rc::new(light)))
}

fn opt_float(a: &Args, i: usize) -> Outcome<Option<f64>> {
    a.opt(i).map(|v| v.as_float()).transpose()
}

fn opt_vector(a: &Args, i: usize) -> Outcome<Option<DVec3>> {
    a.opt(i).map(|v| v.as_vector()).transpose()
}

fn opt_field(a: &Args, i: usize) -> Outcome<Option<CompiledField>> {
    Ok(match a.opt(i) {
        Some(v) => Some(CompiledField::prepared(&v.as_field()?)?),
        None => None,
    })
}

fn count(a: &Args, i: usize, what: &str, default: usize) -> Outcome<usize> {
    match a.opt(i) {
        None => Ok(default),
        Some(v) => {
            let n = v.as_int()?;
            usize::try_from(n).ok().filter(|&n| n > 0).ok_or_else(|| {
                Failure::new(format!("{what} must be a positive whole number, found {n}"))
            })
        }
    }
}

fn run_render(interp: &mut Interpreter, a: Args) -> Outcome<Value> {
    let path = interp.files.writing(a.string(0)?)?;
    let density = CompiledField::prepared(&a.get(1)?.as_field()?)?;
    let (color, emission, holdout) = (
        opt_field(&a, COLOR)?,
        opt_field(&a, EMISSION)?,
        opt_field(&a, HOLDOUT)?,
    );
    let camera = match a.opt(CAMERA) {
        Some(Value::Camera(c)) => (**c).clone(),
        _ => {
            return Err(Failure::new("render needs a camera")
                .with_help("pass camera = camera(eye, lookat, up, fov)"));
        }
    };
    let lights: Vec<Light> = match a.opt(LIGHTS) {
        Some(Value::Array(items, _)) => items
            .iter()
            .map(|v| match v {
                Value::Light(l) => Ok((**l).clone()),
                other => Err(Failure::new(format!(
                    "lights must be lights, found {}",
                    other.type_of()
                ))),
            })
            .collect::<Outcome<_>>()?,
        _ => Vec::new(),
    };
    let mut settings = RenderSettings::default();
    settings.width = count(&a, WIDTH, "width", settings.width)?;
    settings.height = count(&a, HEIGHT, "height", settings.height)?;
    settings.spp = count(&a, SPP, "spp", settings.spp as usize)? as u32;
    if let Some(seed) = a.opt(SEED) {
        settings.seed = seed.as_int()? as u64;
    }
    match a.opt(KAPPA) {
        Some(Value::Vector(k)) => settings.kappa = *k,
        Some(v) => settings.kappa = DVec3::splat(v.as_float()?),
        None => {}
    }
    settings.step = opt_float(&a, STEP)?;
    if let Some(t) = opt_float(&a, THRESHOLD)? {
        settings.threshold = t;
    }
    if let Some(g) = opt_float(&a, PHASE)? {
        settings.phase = Phase::HenyeyGreenstein { g };
    }
    if let Some(p) = opt_vector(&a, PHASE2)? {
        settings.phase = Phase::TwoLobe {
            g1: p.x,
            g2: p.y,
            weight: p.z,
        };
    }
    if let Some(Value::Domain(d)) = a.opt(BOUNDS) {
        settings.bounds = Some(d.bounds());
    }
    if let Some(ambient) = opt_vector(&a, AMBIENT)? {
        settings.ambient = ambient;
    }
    if let Some(octaves) = a.opt(MULTISCATTER) {
        let octaves = octaves.as_int()?;
        if !(1..=16).contains(&octaves) {
            return Err(Failure::new(format!(
                "multiscatter takes 1 to 16 octaves, found {octaves}"
            )));
        }
        settings.multiscatter = Some(MultiScatter {
            octaves: octaves as u32,
            ..MultiScatter::default()
        });
    }
    if let Some(p) = opt_float(&a, POWDER)? {
        settings.powder = Some(p);
    }
    settings.albedo = opt_float(&a, ALBEDO)?;
    if let Some(Value::Bool(true)) = a.opt(ADAPTIVE) {
        let step = settings.step.ok_or_else(|| {
            Failure::new("adaptive stepping needs a step")
                .with_help("pass step = the longest step to take")
        })?;
        settings.adaptive = Some(Adaptive::around(step));
    }
    if let Some(Value::Array(names, _)) = a.opt(AOVS) {
        let mut aovs = Aovs::default();
        for name in names.iter() {
            match name.as_str()? {
                "depth" => aovs.depth = true,
                "transmittance" => aovs.transmittance = true,
                "emission" => aovs.emission = true,
                "lights" => aovs.lights = true,
                other => {
                    return Err(Failure::new(format!("unknown AOV \"{other}\"")).with_help(
                        "the AOVs are \"depth\", \"transmittance\", \"emission\" and \"lights\"",
                    ));
                }
            }
        }
        settings.aovs = aovs;
    }
    if let Some(mode) = a.opt(SHADOWS) {
        settings.shadows = match mode.as_str()? {
            "cache" => Shadows::default(),
            "march" => Shadows::March,
            "sweep" => Shadows::Cache {
                cell_size: None,
                method: TransmissivityMethod::Sweep,
            },
            other => {
                return Err(Failure::new(format!(
                    "shadows must be \"cache\", \"sweep\" or \"march\", found \"{other}\""
                )));
            }
        };
    }
    if let Some(cell) = opt_float(&a, SHADOW_CELL)? {
        if !(cell.is_finite() && cell > 0.0) {
            return Err(Failure::new(format!(
                "shadowcell must be a positive length, found {cell}"
            )));
        }
        if settings.shadows == Shadows::March {
            return Err(Failure::new(
                "shadowcell sets the light cache; it has no meaning with shadows = \"march\"",
            ));
        }
        let method = match settings.shadows {
            Shadows::Cache { method, .. } => method,
            Shadows::March => TransmissivityMethod::Auto,
        };
        settings.shadows = Shadows::Cache {
            cell_size: Some(cell),
            method,
        };
    }
    let tonemap = match a.opt("tonemap") {
        Some(name) => Some(ToneMap::parse(
            name.as_str()?,
            a.opt_float("brightness")?,
            a.opt_float("gamma")?,
        )?),
        None if a.given("brightness") || a.given("gamma") => {
            return Err(
                Failure::new("brightness and gamma belong to tonemap = \"log\"")
                    .with_help("add tonemap = \"log\""),
            );
        }
        None => None,
    };
    let scene = Scene {
        density: &density,
        color: color
            .as_ref()
            .map(|c| c as &dyn crate::sample::FieldSampler),
        emission: emission
            .as_ref()
            .map(|c| c as &dyn crate::sample::FieldSampler),
        holdout: holdout
            .as_ref()
            .map(|c| c as &dyn crate::sample::FieldSampler),
        camera,
        lights,
    };
    let label = format!("render at {}", interp.location(interp.call_span));
    let started = std::time::Instant::now();
    crate::output::check_writable(&path).map_err(|e| {
        Failure::new(format!("cannot write image '{}': {e}", path.display()))
            .with_help("write somewhere else, or move what is in the way")
    })?;
    let half = matches!(a.opt("exr_half"), Some(Value::Bool(true)));
    let header = render::exr_header::options(
        &scene.camera,
        settings.width,
        settings.height,
        half,
        crate::provenance::of(interp),
    );
    let (mut image, render_stats) = render::render_with_stats(&scene, &settings)?;
    if let Some(map) = tonemap {
        map.apply(&mut image);
    }
    let clamped = render::write_image_with(&path, &image, &header)?;
    if clamped > 0 {
        interp.warnings.push(
            Diagnostic::warning(
                Stage::Runtime,
                interp.call_span,
                format!(
                    "{} sample{} above 65504, the largest half float, written as 65504",
                    crate::diagnostic::grouped(clamped),
                    if clamped == 1 { "" } else { "s" }
                ),
            )
            .with_help("leave out exr_half = true to keep full floats"),
        );
    }
    for warning in render_stats.warnings() {
        interp.warnings.push(
            Diagnostic::warning(Stage::Runtime, interp.call_span, warning.message)
                .with_help(warning.help),
        );
    }
    let stats = crate::grid::profile::register("render", &label);
    stats.add_instance(0);
    stats.add_work(
        started.elapsed().as_nanos() as u64,
        (image.width * image.height * 16) as u64,
    );
    Ok(Value::Void)
}
