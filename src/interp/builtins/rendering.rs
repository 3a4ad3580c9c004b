//! Rendering builtins (docs/language.md, Rendering): cameras, lights, `render` and `transmissivity`.
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
use crate::render::settings::{Adaptive, Aovs, Integrator, MAX_BOUNCES, MultiScatter, Shadows};
use crate::render::tonemap::ToneMap;
use crate::render::transmittance::TransmissivityMethod;
use crate::render::view::View;
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
            "float powder?, float shadowcell?, float albedo?, string tonemap?, float brightness?, float gamma?, bool exr_half?, ",
            "string integrator?, int bounces?, vector sky?, string view?) -> void"
        )
    };
}

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
            let (eye, lookat, up) = (a.get("eye")?.as_vector()?, a.get("lookat")?.as_vector()?, a.get("up")?.as_vector()?);
            let mut camera = Camera::new(eye, lookat, up, a.float("fov")?)?;
            if let Some(aspect) = a.opt_float("aspect")? {
                camera = camera.with_aspect(aspect)?;
            }
            if let Some(width) = a.opt_float("ortho")? {
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
            let color = opt_vector(&a, "color")?.unwrap_or(DVec3::ONE);
            named(Light::distant(a.get("direction")?.as_vector()?, color)?, &a)
        },
    );
    r.add(
        "rendering",
        &["pointlight(vector position, vector color?, string name?) -> light"],
        "light from a point, falling off as 1/r^2 (color is the strength at distance 1); name \
         as for distantlight",
        |_, a| {
            let color = opt_vector(&a, "color")?.unwrap_or(DVec3::ONE);
            named(Light::point(a.get("position")?.as_vector()?, color)?, &a)
        },
    );
    r.add(
        "rendering",
        &[render_form!("float"), render_form!("vector")],
        "raymarches density (lit by lights, coloured by color, glowing with emission) into an \
         OpenEXR image, or a PNG preview when path ends in .png; tonemap = \"max1\" or \"log\" \
         (brightness, gamma) compresses emission-only particle renders; view = \"standard\" \
         (clip at 1, the default) or \"agx\" (highlights roll off to white) is how a PNG shows it",
        run_render,
    );
    r.choices(
        "render",
        "shadows",
        "shadows mode",
        &["cache", "march", "sweep"],
    );
    r.choices("render", "tonemap", "tone map", &["max1", "log"]);
    r.choices("render", "integrator", "integrator", &["march", "path"]);
    r.choices("render", "view", "view", &["standard", "agx"]);
    r.choices(
        "render",
        "aovs",
        "AOV",
        &["depth", "transmittance", "emission", "lights", "variance"],
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
            let density = CompiledField::prepared(&a.get("density")?.as_field()?)?;
            let Value::Light(light) = a.get("l")? else { return Err(Failure::new("expected a light")) };
            let Value::Domain(domain) = a.get("d")? else { return Err(Failure::new("expected a domain")) };
            if domain.resolution.is_none() {
                return Err(Failure::new("transmissivity needs a domain with a cell size"));
            }
            let values = render::transmittance::transmissivity(&density, light, domain, a.float("kappa")?, TransmissivityMethod::Auto)?;
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

fn opt_vector(a: &Args, key: &str) -> Outcome<Option<DVec3>> {
    a.opt(key).map(|v| v.as_vector()).transpose()
}

fn opt_field(a: &Args, key: &str) -> Outcome<Option<CompiledField>> {
    Ok(match a.opt(key) {
        Some(v) => Some(CompiledField::prepared(&v.as_field()?)?),
        None => None,
    })
}

fn run_render(interp: &mut Interpreter, a: Args) -> Outcome<Value> {
    let path = interp.files.writing(a.string("path")?)?;
    let density = CompiledField::prepared(&a.get("density")?.as_field()?)?;
    let (color, emission, holdout) = (
        opt_field(&a, "color")?,
        opt_field(&a, "emission")?,
        opt_field(&a, "holdout")?,
    );
    let camera = match a.opt("camera") {
        Some(Value::Camera(c)) => (**c).clone(),
        _ => {
            return Err(Failure::new("render needs a camera")
                .with_help("pass camera = camera(eye, lookat, up, fov)"));
        }
    };
    let lights: Vec<Light> = match a.opt("lights") {
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
    settings.width = a.opt_positive_int("width")?.unwrap_or(settings.width);
    settings.height = a.opt_positive_int("height")?.unwrap_or(settings.height);
    settings.spp = a.opt_positive_int("spp")?.unwrap_or(settings.spp as usize) as u32;
    if let Some(seed) = a.opt("seed") {
        settings.seed = seed.as_int()? as u64;
    }
    match a.opt("kappa") {
        Some(Value::Vector(k)) => settings.kappa = *k,
        Some(v) => settings.kappa = DVec3::splat(v.as_float()?),
        None => {}
    }
    settings.step = a.opt_float("step")?;
    if let Some(t) = a.opt_float("threshold")? {
        settings.threshold = t;
    }
    if let Some(g) = a.opt_float("phase")? {
        settings.phase = Phase::HenyeyGreenstein { g };
    }
    if let Some(p) = opt_vector(&a, "phase2")? {
        settings.phase = Phase::TwoLobe {
            g1: p.x,
            g2: p.y,
            weight: p.z,
        };
    }
    if let Some(Value::Domain(d)) = a.opt("bounds") {
        settings.bounds = Some(d.bounds());
    }
    if let Some(ambient) = opt_vector(&a, "ambient")? {
        settings.ambient = ambient;
    }
    if let Some(octaves) = a.opt("multiscatter") {
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
    if let Some(p) = a.opt_float("powder")? {
        settings.powder = Some(p);
    }
    settings.albedo = a.opt_float("albedo")?;
    if let Some(Value::Bool(true)) = a.opt("adaptive") {
        let step = settings.step.ok_or_else(|| {
            Failure::new("adaptive stepping needs a step")
                .with_help("pass step = the longest step to take")
        })?;
        settings.adaptive = Some(Adaptive::around(step));
    }
    if let Some(Value::Array(names, _)) = a.opt("aovs") {
        let mut aovs = Aovs::default();
        for name in names.iter() {
            match name.as_str()? {
                "depth" => aovs.depth = true,
                "transmittance" => aovs.transmittance = true,
                "emission" => aovs.emission = true,
                "lights" => aovs.lights = true,
                "variance" => aovs.variance = true,
                other => {
                    return Err(Failure::new(format!("unknown AOV \"{other}\"")).with_help(
                        "the AOVs are \"depth\", \"transmittance\", \"emission\", \"lights\" \
                         and, with integrator = \"path\", \"variance\"",
                    ));
                }
            }
        }
        settings.aovs = aovs;
    }
    if let Some(mode) = a.opt("shadows") {
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
    if let Some(cell) = a.opt_positive_float("shadowcell")? {
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
    if let Some(name) = a.opt("integrator") {
        settings.integrator = match name.as_str()? {
            "march" => Integrator::March,
            "path" => Integrator::Path,
            other => {
                return Err(Failure::new(format!(
                    "integrator must be \"march\" or \"path\", found \"{other}\""
                )));
            }
        };
    }
    if let Some(bounces) = a.opt("bounces") {
        let bounces = bounces.as_int()?;
        if !(0..=i64::from(MAX_BOUNCES)).contains(&bounces) {
            return Err(Failure::new(format!(
                "bounces must be between 0 and {MAX_BOUNCES}, found {bounces}"
            )));
        }
        settings.bounces = bounces as u32;
    }
    if let Some(sky) = opt_vector(&a, "sky")? {
        settings.sky = sky;
    }
    if settings.integrator == Integrator::March && (a.given("bounces") || a.given("sky")) {
        return Err(Failure::new("bounces and sky belong to the path tracer")
            .with_help("add integrator = \"path\""));
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
    let view = match a.opt("view") {
        Some(name) => View::parse(name.as_str()?)?,
        None => View::Standard,
    };
    let clamped = render::write_image_viewed(&path, &image, &header, view)?;
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
    stats.add_evaluated();
    stats.add_work(
        started.elapsed().as_nanos() as u64,
        (image.width * image.height * 16) as u64,
    );
    Ok(Value::Void)
}
