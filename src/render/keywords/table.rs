//! The rows of `render`'s keyword table, in the order of its signature, and the functions that
//! apply the keywords whose values need more than a field assignment (ranges, choices, a rule
//! with a keyword before them).

use super::{Keyword, KeywordType, RenderOptions, Setting};
use crate::failure::{Failure, Outcome};
use crate::render::Phase;
use crate::render::motion::ShutterPosition;
use crate::render::settings::{Aovs, Integrator, MAX_BOUNCES, MultiScatter, Shadows};
use crate::render::sky::Sky;
use crate::render::transmittance::TransmissivityMethod;
use crate::render::view::View;

fn multiscatter(o: &mut RenderOptions, v: &Setting) -> Outcome<()> {
    let octaves = v.int();
    if !(1..=16).contains(&octaves) {
        return Err(Failure::new(format!(
            "multiscatter takes 1 to 16 octaves, found {octaves}"
        )));
    }
    o.settings.multiscatter = Some(MultiScatter {
        octaves: octaves as u32,
        ..MultiScatter::default()
    });
    Ok(())
}

fn aovs(o: &mut RenderOptions, v: &Setting) -> Outcome<()> {
    let Setting::Strings(names) = v else {
        return Ok(());
    };
    let mut aovs = Aovs::default();
    for name in names {
        match name.as_str() {
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
    o.settings.aovs = aovs;
    Ok(())
}

fn shadows(o: &mut RenderOptions, v: &Setting) -> Outcome<()> {
    o.settings.shadows = match v.text() {
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
    Ok(())
}

fn shadowcell(o: &mut RenderOptions, v: &Setting) -> Outcome<()> {
    let method = match o.settings.shadows {
        Shadows::Cache { method, .. } => method,
        Shadows::March => {
            return Err(Failure::new(
                "shadowcell sets the light cache; it has no meaning with shadows = \"march\"",
            ));
        }
    };
    o.settings.shadows = Shadows::Cache {
        cell_size: Some(v.float()),
        method,
    };
    Ok(())
}

fn integrator(o: &mut RenderOptions, v: &Setting) -> Outcome<()> {
    o.settings.integrator = match v.text() {
        "march" => Integrator::March,
        "path" => Integrator::Path,
        other => {
            return Err(Failure::new(format!(
                "integrator must be \"march\" or \"path\", found \"{other}\""
            )));
        }
    };
    Ok(())
}

fn bounces(o: &mut RenderOptions, v: &Setting) -> Outcome<()> {
    let bounces = v.int();
    if !(0..=i64::from(MAX_BOUNCES)).contains(&bounces) {
        return Err(Failure::new(format!(
            "bounces must be between 0 and {MAX_BOUNCES}, found {bounces}"
        )));
    }
    o.settings.bounces = bounces as u32;
    Ok(())
}

/// Every keyword of `render`, in the order of its signature.
pub const KEYWORDS: &[Keyword] = &[
    Keyword {
        name: "kappa",
        kind: KeywordType::FloatOrVector,
        default: "1",
        choices: None,
        aliases: &["extinction", "densityscale", "density_scale"],
        doc: "extinction per world unit at density 1, or one per colour channel",
        apply: Some(|o, v| {
            o.settings.kappa = v.vector();
            Ok(())
        }),
    },
    Keyword {
        name: "step",
        kind: KeywordType::Float,
        default: "1/256 of the box's longest side",
        choices: None,
        aliases: &["stepsize", "step_size", "volumestep"],
        doc: "the march's step in world units",
        apply: Some(|o, v| {
            o.settings.step = Some(v.float());
            Ok(())
        }),
    },
    Keyword {
        name: "width",
        kind: KeywordType::Count,
        default: "640",
        choices: None,
        aliases: &["resx", "xres"],
        doc: "image width in pixels",
        apply: Some(|o, v| {
            o.settings.width = v.int() as usize;
            Ok(())
        }),
    },
    Keyword {
        name: "height",
        kind: KeywordType::Count,
        default: "360",
        choices: None,
        aliases: &["resy", "yres"],
        doc: "image height in pixels",
        apply: Some(|o, v| {
            o.settings.height = v.int() as usize;
            Ok(())
        }),
    },
    Keyword {
        name: "spp",
        kind: KeywordType::Count,
        default: "1",
        choices: None,
        aliases: &["samples", "pixelsamples", "aa_samples"],
        doc: "samples (rays or paths) per pixel",
        apply: Some(|o, v| {
            o.settings.spp = v.int() as u32;
            Ok(())
        }),
    },
    Keyword {
        name: "seed",
        kind: KeywordType::Int,
        default: "0",
        choices: None,
        aliases: &[],
        doc: "seeds the pixel, march and path jitter; the same seed gives the same image",
        apply: Some(|o, v| {
            o.settings.seed = v.int() as u64;
            Ok(())
        }),
    },
    Keyword {
        name: "bounds",
        kind: KeywordType::Domain,
        default: "the density's bounds",
        choices: None,
        aliases: &[],
        doc: "the box to render",
        apply: Some(|o, v| {
            if let Setting::Box(b) = v {
                o.settings.bounds = Some(*b);
            }
            Ok(())
        }),
    },
    Keyword {
        name: "threshold",
        kind: KeywordType::Float,
        default: "0.001",
        choices: None,
        aliases: &[],
        doc: "transmittance at which a ray stops",
        apply: Some(|o, v| {
            o.settings.threshold = v.float();
            Ok(())
        }),
    },
    Keyword {
        name: "phase",
        kind: KeywordType::Float,
        default: "0 (isotropic)",
        choices: None,
        aliases: &[],
        doc: "Henyey–Greenstein g",
        apply: Some(|o, v| {
            o.settings.phase = Phase::HenyeyGreenstein { g: v.float() };
            Ok(())
        }),
    },
    Keyword {
        name: "phase2",
        kind: KeywordType::Vector,
        default: "none",
        choices: None,
        aliases: &[],
        doc: "two Henyey–Greenstein lobes, `(g1, g2, weight of g1)`",
        apply: Some(|o, v| {
            let p = v.vector();
            o.settings.phase = Phase::TwoLobe {
                g1: p.x,
                g2: p.y,
                weight: p.z,
            };
            Ok(())
        }),
    },
    Keyword {
        name: "holdout",
        kind: KeywordType::ScalarField,
        default: "none",
        choices: None,
        aliases: &[],
        doc: "how much of each point is held out (1: a matte that hides what is behind it)",
        apply: None,
    },
    Keyword {
        name: "ambient",
        kind: KeywordType::Vector,
        default: "(0, 0, 0)",
        choices: None,
        aliases: &[],
        doc: "unshadowed light added to every sample (march only)",
        apply: Some(|o, v| {
            o.settings.ambient = v.vector();
            Ok(())
        }),
    },
    Keyword {
        name: "multiscatter",
        kind: KeywordType::Int,
        default: "none",
        choices: None,
        aliases: &[],
        doc: "octaves (1 to 16) of the march's approximate multiple scattering",
        apply: Some(multiscatter),
    },
    Keyword {
        name: "adaptive",
        kind: KeywordType::Bool,
        default: "false",
        choices: None,
        aliases: &[],
        doc: "steps shorter where the density changes fast, up to `step`",
        apply: Some(|o, v| {
            // `finish` sets the stepping once `step` is known.
            o.adaptive = *v == Setting::Bool(true);
            Ok(())
        }),
    },
    Keyword {
        name: "aovs",
        kind: KeywordType::Strings,
        default: "none",
        choices: Some((
            "AOV",
            &["depth", "transmittance", "emission", "lights", "variance"],
        )),
        aliases: &[],
        doc: "extra image channels",
        apply: Some(aovs),
    },
    Keyword {
        name: "shadows",
        kind: KeywordType::Str,
        default: "`\"cache\"`",
        choices: Some(("shadows mode", &["cache", "march", "sweep"])),
        aliases: &[],
        doc: "how the march finds the light reaching each sample",
        apply: Some(shadows),
    },
    Keyword {
        name: "powder",
        kind: KeywordType::Float,
        default: "none",
        choices: None,
        aliases: &[],
        doc: "artistic darkening of the lit side of dense media, 0 to 1",
        apply: Some(|o, v| {
            o.settings.powder = Some(v.float());
            Ok(())
        }),
    },
    Keyword {
        name: "shadowcell",
        kind: KeywordType::PositiveFloat,
        default: "the step",
        choices: None,
        aliases: &[],
        doc: "cell size of the light cache",
        apply: Some(shadowcell),
    },
    Keyword {
        name: "albedo",
        kind: KeywordType::Float,
        default: "none (colour model); 1 with the path tracer",
        choices: None,
        aliases: &[],
        doc: "single-scattering albedo in [0, 1]: the physically based shading model",
        apply: Some(|o, v| {
            o.settings.albedo = Some(v.float());
            Ok(())
        }),
    },
    Keyword {
        name: "tonemap",
        kind: KeywordType::Str,
        default: "none",
        choices: Some(("tone map", &["max1", "log"])),
        aliases: &[],
        doc: "compresses an emission-only particle render",
        apply: Some(|o, v| {
            o.tonemap_name = Some(v.text().to_string());
            Ok(())
        }),
    },
    Keyword {
        name: "brightness",
        kind: KeywordType::Float,
        default: "1",
        choices: None,
        aliases: &[],
        doc: "the log tone map's brightness",
        apply: Some(|o, v| {
            o.brightness = Some(v.float());
            Ok(())
        }),
    },
    Keyword {
        name: "gamma",
        kind: KeywordType::Float,
        default: "1",
        choices: None,
        aliases: &[],
        doc: "the log tone map's gamma",
        apply: Some(|o, v| {
            o.gamma = Some(v.float());
            Ok(())
        }),
    },
    Keyword {
        name: "exr_half",
        kind: KeywordType::Bool,
        default: "false",
        choices: None,
        aliases: &[],
        doc: "16-bit half floats for the colour and every AOV but depth",
        apply: Some(|o, v| {
            o.exr_half = *v == Setting::Bool(true);
            Ok(())
        }),
    },
    Keyword {
        name: "integrator",
        kind: KeywordType::Str,
        default: "`\"march\"`",
        choices: Some(("integrator", &["march", "path"])),
        aliases: &[],
        doc: "the ray march, or the unbiased volumetric path tracer",
        apply: Some(integrator),
    },
    Keyword {
        name: "bounces",
        kind: KeywordType::Int,
        default: "64",
        choices: None,
        aliases: &[],
        doc: "path tracer: the most scattering events along a path (0 to 4096)",
        apply: Some(bounces),
    },
    Keyword {
        name: "sky",
        kind: KeywordType::Sky,
        default: "(0, 0, 0)",
        choices: None,
        aliases: &[],
        doc: "path tracer: radiance of a uniform sky, or an `envmap` or `physicalsky`, shadowed \
              by the medium",
        apply: Some(|o, v| {
            o.settings.sky = match v {
                Setting::Sky(sky) => sky.clone(),
                other => Sky::Uniform(other.vector()),
            };
            Ok(())
        }),
    },
    Keyword {
        name: "view",
        kind: KeywordType::Str,
        default: "`\"standard\"`",
        choices: Some(("view", &["standard", "agx"])),
        aliases: &[],
        doc: "how a PNG preview shows the scene-linear colour",
        apply: Some(|o, v| {
            o.view = View::parse(v.text())?;
            Ok(())
        }),
    },
    Keyword {
        name: "velocity",
        kind: KeywordType::VectorField,
        default: "none (no motion blur)",
        choices: None,
        aliases: &["vel", "v"],
        doc: "motion blur: the medium's velocity in world units per frame",
        apply: None,
    },
    Keyword {
        name: "shutter",
        kind: KeywordType::Float,
        default: "0.5",
        choices: None,
        aliases: &["shutter_length", "motionblur"],
        doc: "motion blur: how long the shutter is open, in frames (0 to 1000)",
        apply: Some(|o, v| {
            o.settings.shutter = v.float();
            Ok(())
        }),
    },
    Keyword {
        name: "shutterposition",
        kind: KeywordType::Str,
        default: "`\"center\"`",
        choices: Some(("shutter position", &["start", "center", "end"])),
        aliases: &["shutter_position"],
        doc: "motion blur: where the shutter opens relative to the frame",
        apply: Some(|o, v| {
            o.settings.shutter_position = ShutterPosition::parse(v.text())?;
            Ok(())
        }),
    },
];
