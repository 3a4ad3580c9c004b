//! The rows of `render`'s keyword table, in the order of its signature, and the functions that
//! apply the keywords whose values need more than a field assignment (ranges, choices, a rule
//! with a keyword before them).

use super::{Keyword, KeywordType, RenderOptions, Setting};
use crate::base::failure::{Failure, Outcome};
use crate::render::Phase;
use crate::render::motion::ShutterPosition;
use crate::render::settings::{Aovs, Integrator, MAX_BOUNCES, MultiScatter, Shadows};
use crate::render::transmittance::TransmissivityMethod;
use crate::render::view::View;

fn multiscatter(o: &mut RenderOptions, v: &Setting) -> Outcome<()> {
    let octaves = v.int();
    if !(0..=16).contains(&octaves) {
        return Err(Failure::new(format!(
            "multiscatter takes 0 (single scattering) or 1 to 16 octaves, found {octaves}"
        ))
        .with_help("leave multiscatter out for the indirect grid, which matches a path tracer"));
    }
    if octaves == 0 {
        o.settings.indirect = None;
    } else {
        o.settings.multiscatter = Some(MultiScatter {
            octaves: octaves as u32,
            ..MultiScatter::default()
        });
    }
    Ok(())
}

/// One of the octaves' shape parameters (`a`, `b` or `c`): it needs the octaves.
fn octave_shape(
    o: &mut RenderOptions,
    v: &Setting,
    name: &str,
    field: fn(&mut MultiScatter) -> &mut f64,
) -> Outcome<()> {
    let Some(ms) = o.settings.multiscatter.as_mut() else {
        return Err(Failure::new(format!(
            "{name} shapes the multiscatter octaves, which are not on"
        ))
        .with_help("add multiscatter = 3 (or more octaves)"));
    };
    *field(ms) = v.float();
    Ok(())
}

fn indirect_size(o: &mut RenderOptions, v: &Setting, cells: bool) -> Outcome<()> {
    let n = v.int();
    let (name, most) = if cells {
        ("indirectcells", 256)
    } else {
        ("indirectpaths", 65_536)
    };
    if !(1..=most).contains(&n) {
        return Err(Failure::new(format!(
            "{name} must be between 1 and {most}, found {n}"
        )));
    }
    if let Some(grid) = o.settings.indirect.as_mut() {
        if cells {
            grid.cells = n as usize;
        } else {
            grid.paths = n as u32;
        }
    }
    Ok(())
}

fn aovs(o: &mut RenderOptions, v: &Setting) -> Outcome<()> {
    if let Setting::Strings(names) = v {
        o.settings.aovs = Aovs::parse(names)?;
    }
    Ok(())
}

/// The most samples per pixel a deep image may hold.
const MAX_DEEP_SAMPLES: i64 = 1024;

fn deep_samples(o: &mut RenderOptions, v: &Setting) -> Outcome<()> {
    let n = v.int();
    if !(1..=MAX_DEEP_SAMPLES).contains(&n) {
        return Err(Failure::new(format!(
            "deepsamples must be between 1 and {MAX_DEEP_SAMPLES}, found {n}"
        ))
        .with_help("32 samples hold a cloud's depth well; 1 gives one sample per pixel"));
    }
    o.deep_samples = n as usize;
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
        default: "none (the indirect grid, with albedo)",
        choices: None,
        aliases: &[],
        doc: "march: 0 for single scattering, or 1 to 16 octaves of the artistic approximation",
        apply: Some(multiscatter),
    },
    Keyword {
        name: "msattenuation",
        kind: KeywordType::Float,
        default: "0.5",
        choices: None,
        aliases: &[],
        doc: "octaves: `a` in [0, 1], how much thinner each further octave sees the medium",
        apply: Some(|o, v| octave_shape(o, v, "msattenuation", |m| &mut m.attenuation)),
    },
    Keyword {
        name: "mscontribution",
        kind: KeywordType::Float,
        default: "0.5",
        choices: None,
        aliases: &[],
        doc: "octaves: `b` in [0, 1], how much each further octave adds (energy needs b ≤ a)",
        apply: Some(|o, v| octave_shape(o, v, "mscontribution", |m| &mut m.contribution)),
    },
    Keyword {
        name: "mseccentricity",
        kind: KeywordType::Float,
        default: "0.5",
        choices: None,
        aliases: &[],
        doc: "octaves: `c` in [0, 1], how much less directional each further octave scatters",
        apply: Some(|o, v| octave_shape(o, v, "mseccentricity", |m| &mut m.eccentricity)),
    },
    Keyword {
        name: "indirectcells",
        kind: KeywordType::Count,
        default: "32",
        choices: None,
        aliases: &[],
        doc: "march with albedo: cells of the indirect grid along the box's longest side",
        apply: Some(|o, v| indirect_size(o, v, true)),
    },
    Keyword {
        name: "indirectpaths",
        kind: KeywordType::Count,
        default: "64",
        choices: None,
        aliases: &[],
        doc: "march with albedo: most paths gathered per cell of the indirect grid (sky, emission); the lights' photons number a sixteenth to four times as many",
        apply: Some(|o, v| indirect_size(o, v, false)),
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
        choices: Some(("AOV", Aovs::NAMES)),
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
        default: "the step (a density grid's own cells where they are no finer)",
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
        name: "deep",
        kind: KeywordType::Bool,
        default: "false",
        choices: None,
        aliases: &[],
        doc: "the `.exr` is a deep scanline image: per-depth samples a compositor holds out against",
        apply: Some(|o, v| {
            o.deep = *v == Setting::Bool(true);
            Ok(())
        }),
    },
    Keyword {
        name: "deepsamples",
        kind: KeywordType::Int,
        default: "32",
        choices: None,
        aliases: &[],
        doc: "deep: the most samples per pixel (1 to 1024)",
        apply: Some(deep_samples),
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
        doc: "the most scattering events along a path (0 to 4096); the march's for its grid",
        apply: Some(bounces),
    },
    Keyword {
        name: "sky",
        kind: KeywordType::Sky,
        default: "(0, 0, 0)",
        choices: None,
        aliases: &[],
        doc: "radiance of a uniform sky, or an `envmap` or `physicalsky`, shadowed by the \
              medium (march: needs albedo)",
        apply: Some(|o, v| {
            o.settings.sky = v.sky();
            Ok(())
        }),
    },
    Keyword {
        name: "background",
        kind: KeywordType::Sky,
        default: "none (transparent)",
        choices: None,
        aliases: &[],
        doc: "what the camera sees behind the medium: a radiance, or an `envmap` or \
              `physicalsky` (usually the `sky`); alpha is then 1",
        apply: Some(|o, v| {
            o.settings.background = Some(v.sky());
            Ok(())
        }),
    },
    Keyword {
        name: "view",
        kind: KeywordType::Str,
        default: "`\"standard\"`",
        choices: Some(("view", &["standard", "agx", "filmic"])),
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
