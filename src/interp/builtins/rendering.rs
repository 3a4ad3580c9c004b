//! Rendering builtins (docs/language.md, Rendering): cameras, lights, `render` and `transmissivity`.
//!
//! `render` is an output: it compiles the density (and colour, emission, holdout) fields and
//! hands them to the raymarcher, which asks for values only inside the box the density reports
//! (or `bounds = domain`). Every option of the raymarcher is a keyword argument with the
//! raymarcher's default, so `render("out.exr", density = rho, camera = cam)` is a complete call.

use crate::base::failure::{Failure, Outcome};
use crate::field::{CompiledField, Field};
use crate::grid::cache::Cache;
use crate::interp::Interpreter;
use crate::interp::registry::{Args, Registry};
use crate::interp::value::Value;
use crate::render::keywords::{self, Keyword, KeywordType, RenderOptions, Setting};
use crate::render::transmittance::TransmissivityMethod;
use crate::render::{self, Camera, Light, Scene};
use crate::space::GridSource;
use crate::syntax::diagnostic::{Diagnostic, Stage};
use glam::DVec3;
use std::rc::Rc;
use std::sync::Arc;

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
    let forms = keywords::signatures();
    let forms: Vec<&str> = forms.iter().map(String::as_str).collect();
    r.add(
        "rendering",
        &forms,
        "raymarches density (lit by lights, coloured by color, glowing with emission) into an \
         OpenEXR image, or a PNG preview when path ends in .png; tonemap = \"max1\" or \"log\" \
         (brightness, gamma) compresses emission-only particle renders; view = \"standard\" \
         (clip at 1, the default) or \"agx\" (highlights roll off to white) is how a PNG shows it",
        run_render,
    );
    // The keywords' allowed strings, aliases and meanings come from their table.
    for keyword in keywords::KEYWORDS {
        if let Some((noun, values)) = keyword.choices {
            r.choices("render", keyword.name, noun, values);
        }
        if !keyword.aliases.is_empty() {
            r.aliases("render", keyword.name, keyword.aliases);
        }
    }
    r.details("render", keywords::doc_text());
    r.add(
        "rendering",
        &["transmissivity(scalarfield density, light l, domain d, float kappa) -> scalarfield"],
        "the fraction of l's light reaching each point through density (1 outside d), sampled at d's cells",
        |_, a| {
            let density = CompiledField::prepared(&a.get("density")?.as_field()?)?;
            let light = match a.get("l")? {
                Value::Light(light) => light,
                Value::Sky(_) => return Err(Failure::new("transmissivity takes a distant or point light, not a sky")),
                _ => return Err(Failure::new("expected a light")),
            };
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

/// The value given for `keyword`, converted as its row's type says (`None` when not given).
fn setting(a: &Args, keyword: &Keyword) -> Outcome<Option<Setting>> {
    let name = keyword.name;
    let Some(value) = a.opt(name) else {
        return Ok(None);
    };
    Ok(Some(match keyword.kind {
        KeywordType::Count => Setting::Int(a.opt_positive_int(name)?.unwrap_or(1) as i64),
        KeywordType::Int => Setting::Int(value.as_int()?),
        KeywordType::Float => Setting::Float(value.as_float()?),
        KeywordType::PositiveFloat => {
            Setting::Float(a.opt_positive_float(name)?.unwrap_or(f64::NAN))
        }
        KeywordType::Vector => Setting::Vector(value.as_vector()?),
        KeywordType::FloatOrVector => match value {
            Value::Vector(v) => Setting::Vector(*v),
            other => Setting::Float(other.as_float()?),
        },
        KeywordType::Sky => Setting::Sky(super::sky::sky_setting(value)?),
        KeywordType::Bool => Setting::Bool(matches!(value, Value::Bool(true))),
        KeywordType::Str => Setting::Str(value.as_str()?.to_string()),
        KeywordType::Strings => match value {
            Value::Array(items, _) => Setting::Strings(
                items
                    .iter()
                    .map(|v| v.as_str().map(str::to_string))
                    .collect::<Outcome<_>>()?,
            ),
            _ => return Ok(None),
        },
        KeywordType::Domain => match value {
            Value::Domain(d) => Setting::Box(d.bounds()),
            _ => return Ok(None),
        },
        KeywordType::ScalarField | KeywordType::VectorField => return Ok(None),
    }))
}

fn run_render(interp: &mut Interpreter, a: Args) -> Outcome<Value> {
    let written = a.string("path")?;
    let path = interp.files.writing(written)?;
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
                Value::Sky(_) => Err(super::sky::sky_in_lights()),
                other => Err(Failure::new(format!(
                    "lights must be lights, found {}",
                    other.type_of()
                ))),
            })
            .collect::<Outcome<_>>()?,
        _ => Vec::new(),
    };
    let velocity = opt_field(&a, "velocity")?;
    let options = RenderOptions::from_keywords(velocity.is_some(), |keyword| setting(&a, keyword))?;
    let exr = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if options.settings.deep.is_some() && !exr {
        // docs/language.md, "Deep images": only OpenEXR holds deep samples.
        return Err(Failure::new(format!(
            "deep = true writes a deep OpenEXR file, and '{written}' is not one"
        ))
        .with_help("end the file name in .exr, or leave out deep = true for a PNG preview"));
    }
    let settings = options.settings;
    let scene = Scene {
        density: &density,
        color: color.as_ref().map(|c| c as &dyn crate::space::FieldSampler),
        emission: emission
            .as_ref()
            .map(|c| c as &dyn crate::space::FieldSampler),
        holdout: holdout
            .as_ref()
            .map(|c| c as &dyn crate::space::FieldSampler),
        velocity: velocity
            .as_ref()
            .map(|c| c as &dyn crate::space::FieldSampler),
        camera,
        lights,
    };
    let label = format!("render at {}", interp.location(interp.call_span));
    let started = std::time::Instant::now();
    crate::io::output::check_writable(&path).map_err(|e| {
        Failure::new(format!("cannot write image '{}': {e}", path.display()))
            .with_help("write somewhere else, or move what is in the way")
    })?;
    let half = options.exr_half;
    let header = render::exr_header::options(
        &scene.camera,
        settings.width,
        settings.height,
        half,
        crate::interp::provenance::of(interp),
    );
    let (image, render_stats, clamped) = if settings.deep.is_some() {
        let (image, deep, stats) = render::render_deep(&scene, &settings)?;
        render::deep_exr::write_deep(&path, &deep, &header)?;
        (image, stats, 0)
    } else {
        let (mut image, stats) = render::render_with_stats(&scene, &settings)?;
        if let Some(map) = &options.tonemap {
            map.apply(&mut image);
        }
        let clamped = render::write_image_viewed(&path, &image, &header, options.view)?;
        (image, stats, clamped)
    };
    if clamped > 0 {
        interp.warnings.push(
            Diagnostic::warning(
                Stage::Runtime,
                interp.call_span,
                format!(
                    "{} sample{} above 65504, the largest half float, written as 65504",
                    crate::base::failure::grouped(clamped),
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
    let stats = crate::engine::profile::register("render", &label);
    stats.add_instance(0);
    stats.add_evaluated();
    stats.add_work(
        started.elapsed().as_nanos() as u64,
        (image.width * image.height * 16) as u64,
    );
    Ok(Value::Void)
}
