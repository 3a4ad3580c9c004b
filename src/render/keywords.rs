//! `render`'s keywords, declared once: one row per keyword with its type, its default as the
//! docs state it, its allowed strings, its aliases, one line of meaning, and the function that
//! applies a given value to the render's options.
//!
//! Everything that needs to know the keywords reads this table: the builtin's signature and
//! its loop over given keywords (`interp/builtins/rendering.rs`), the checker's choices and
//! aliases, `felt doc render`, and the defaults table in docs/language.md (a test compares
//! them). The one key decision: rows are applied in the table's order, not the call's, and a
//! rule between keywords (`shadowcell` with `shadows = "march"`, `sky` without the path
//! tracer) is checked once, after every row, in `RenderOptions::finish`; so adding a keyword
//! is one row here plus the code that reads its field.
//!
//! The table stays below the interpreter: values arrive as [`Setting`]s, converted by the
//! builtin according to each row's [`KeywordType`].

use super::motion::ShutterPosition;
use super::settings::{Adaptive, Aovs, Integrator, MAX_BOUNCES, MultiScatter, Shadows};
use super::tonemap::ToneMap;
use super::transmittance::TransmissivityMethod;
use super::view::View;
use super::{Phase, RenderSettings};
use crate::failure::{Failure, Outcome};
use crate::sample::Aabb;
use glam::DVec3;

/// A keyword's type in `render`'s signature, and how the builtin converts its value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KeywordType {
    /// A whole number above zero.
    Count,
    Int,
    Float,
    /// A float that must be finite and above zero.
    PositiveFloat,
    Vector,
    /// A float, or a vector with one value per colour channel.
    FloatOrVector,
    Bool,
    Str,
    Strings,
    /// A domain, handed on as its box.
    Domain,
    /// A scalar field: an input of the scene, not a setting (the builtin reads it itself).
    ScalarField,
    /// A vector field, an input of the scene like `ScalarField`.
    VectorField,
}

impl KeywordType {
    /// The types as `render`'s signature writes them (two for a float-or-vector keyword).
    fn signature_types(self) -> &'static [&'static str] {
        match self {
            KeywordType::Count | KeywordType::Int => &["int"],
            KeywordType::Float | KeywordType::PositiveFloat => &["float"],
            KeywordType::Vector => &["vector"],
            KeywordType::FloatOrVector => &["float", "vector"],
            KeywordType::Bool => &["bool"],
            KeywordType::Str => &["string"],
            KeywordType::Strings => &["string[]"],
            KeywordType::Domain => &["domain"],
            KeywordType::ScalarField => &["scalarfield"],
            KeywordType::VectorField => &["vectorfield"],
        }
    }

    /// The type as the docs' table names it.
    fn doc_name(self) -> &'static str {
        match self {
            KeywordType::Count => "int > 0",
            KeywordType::Int => "int",
            KeywordType::Float => "float",
            KeywordType::PositiveFloat => "float > 0",
            KeywordType::Vector => "vector",
            KeywordType::FloatOrVector => "float or vector",
            KeywordType::Bool => "bool",
            KeywordType::Str => "string",
            KeywordType::Strings => "string[]",
            KeywordType::Domain => "domain",
            KeywordType::ScalarField => "scalarfield",
            KeywordType::VectorField => "vectorfield",
        }
    }
}

/// A keyword's value, converted by the builtin according to the row's type.
#[derive(Clone, Debug, PartialEq)]
pub enum Setting {
    Int(i64),
    Float(f64),
    Vector(DVec3),
    Bool(bool),
    Str(String),
    Strings(Vec<String>),
    Box(Aabb),
}

impl Setting {
    fn int(&self) -> i64 {
        match self {
            Setting::Int(n) => *n,
            Setting::Float(v) => *v as i64,
            _ => 0,
        }
    }

    fn float(&self) -> f64 {
        match self {
            Setting::Float(v) => *v,
            Setting::Int(n) => *n as f64,
            _ => f64::NAN,
        }
    }

    fn vector(&self) -> DVec3 {
        match self {
            Setting::Vector(v) => *v,
            other => DVec3::splat(other.float()),
        }
    }

    fn text(&self) -> &str {
        match self {
            Setting::Str(s) => s,
            _ => "",
        }
    }
}

/// Allowed strings of a keyword: the noun the checker uses in its messages, and the values.
pub type Choices = (&'static str, &'static [&'static str]);

/// One keyword of `render`.
pub struct Keyword {
    pub name: &'static str,
    pub kind: KeywordType,
    /// The default, as the docs state it.
    pub default: &'static str,
    pub choices: Option<Choices>,
    /// What other renderers call it, so a TD's habit finds felt's word.
    pub aliases: &'static [&'static str],
    pub doc: &'static str,
    /// Applies a given value; `None` for a scene input the builtin reads itself.
    pub apply: Option<fn(&mut RenderOptions, &Setting) -> Outcome<()>>,
}

/// The settings a `render` call makes: the renderer's, and how the image is written.
pub struct RenderOptions {
    pub settings: RenderSettings,
    pub tonemap: Option<ToneMap>,
    pub view: View,
    pub exr_half: bool,
    tonemap_name: Option<String>,
    brightness: Option<f64>,
    gamma: Option<f64>,
    adaptive: bool,
    /// Whether the call gave a velocity (motion blur); the builtin says so.
    pub motion: bool,
    given: Vec<&'static str>,
}

impl Default for RenderOptions {
    fn default() -> RenderOptions {
        RenderOptions {
            settings: RenderSettings::default(),
            tonemap: None,
            view: View::Standard,
            exr_half: false,
            tonemap_name: None,
            brightness: None,
            gamma: None,
            adaptive: false,
            motion: false,
            given: Vec::new(),
        }
    }
}

impl RenderOptions {
    /// The options from the keywords given: `value` converts the named keyword's argument
    /// (`None` when it was not given). Rows apply in the table's order, then the rules
    /// between keywords are checked.
    pub fn from_keywords(
        motion: bool,
        mut value: impl FnMut(&Keyword) -> Outcome<Option<Setting>>,
    ) -> Outcome<RenderOptions> {
        let mut options = RenderOptions {
            motion,
            ..RenderOptions::default()
        };
        for keyword in KEYWORDS {
            let Some(apply) = keyword.apply else { continue };
            if let Some(setting) = value(keyword)? {
                apply(&mut options, &setting)?;
                options.given.push(keyword.name);
            }
        }
        options.finish()?;
        Ok(options)
    }

    fn given(&self, name: &str) -> bool {
        self.given.contains(&name)
    }

    /// The rules between keywords, checked once every row is applied.
    fn finish(&mut self) -> Outcome<()> {
        let s = &mut self.settings;
        if self.adaptive {
            // Adaptive stepping takes the step as its longest step.
            let step = s.step.ok_or_else(|| {
                Failure::new("adaptive stepping needs a step")
                    .with_help("pass step = the longest step to take")
            })?;
            s.adaptive = Some(Adaptive::around(step));
        }
        if !self.motion && (self.given("shutter") || self.given("shutterposition")) {
            return Err(Failure::new("shutter and shutterposition need a velocity")
                .with_help("pass velocity = the medium's velocity field (world units per frame)"));
        }
        if self.settings.integrator == Integrator::March
            && (self.given("bounces") || self.given("sky"))
        {
            return Err(Failure::new("bounces and sky belong to the path tracer")
                .with_help("add integrator = \"path\""));
        }
        self.tonemap = match &self.tonemap_name {
            Some(name) => Some(ToneMap::parse(name, self.brightness, self.gamma)?),
            None if self.brightness.is_some() || self.gamma.is_some() => {
                return Err(
                    Failure::new("brightness and gamma belong to tonemap = \"log\"")
                        .with_help("add tonemap = \"log\""),
                );
            }
            None => None,
        };
        Ok(())
    }
}

/// `render(...)`'s signatures: the scene's inputs, then every row of the table (a
/// float-or-vector row makes one form per type).
pub fn signatures() -> Vec<String> {
    let variants = KEYWORDS
        .iter()
        .map(|k| k.kind.signature_types().len())
        .max()
        .unwrap_or(1);
    (0..variants)
        .map(|form| {
            let rows: Vec<String> = KEYWORDS
                .iter()
                .map(|k| {
                    let types = k.kind.signature_types();
                    format!("{} {}?", types[form.min(types.len() - 1)], k.name)
                })
                .collect();
            format!(
                "render(string path, scalarfield density, vectorfield color?, \
                 vectorfield emission?, camera camera, light[] lights?, {}) -> void",
                rows.join(", ")
            )
        })
        .collect()
}

/// The keywords as a Markdown table: keyword, type, default, meaning (and allowed strings).
pub fn markdown_table() -> String {
    let mut text = String::from("| keyword | type | default | meaning |\n|---|---|---|---|\n");
    for k in KEYWORDS {
        let mut meaning = k.doc.to_string();
        if let Some((_, values)) = k.choices {
            let quoted: Vec<String> = values.iter().map(|v| format!("`\"{v}\"`")).collect();
            meaning.push_str(&format!(" ({})", quoted.join(", ")));
        }
        text.push_str(&format!(
            "| `{}` | {} | {} | {} |\n",
            k.name,
            k.kind.doc_name(),
            k.default,
            meaning
        ));
    }
    text
}

/// The keywords as `felt doc render` lists them.
pub fn doc_text() -> String {
    let mut text = String::from("    keywords (name, type, default: meaning):\n");
    for k in KEYWORDS {
        text.push_str(&format!(
            "      {:<13} {:<16} {}: {}",
            k.name,
            k.kind.doc_name(),
            k.default,
            k.doc
        ));
        if let Some((_, values)) = k.choices {
            text.push_str(&format!(" ({})", values.join(", ")));
        }
        text.push('\n');
    }
    text
}

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
        kind: KeywordType::Vector,
        default: "(0, 0, 0)",
        choices: None,
        aliases: &[],
        doc: "path tracer: radiance of a uniform sky, shadowed by the medium",
        apply: Some(|o, v| {
            o.settings.sky = v.vector();
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_row_has_a_distinct_name_and_a_meaning() {
        let mut names: Vec<&str> = KEYWORDS.iter().map(|k| k.name).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), KEYWORDS.len());
        assert!(
            KEYWORDS
                .iter()
                .all(|k| !k.doc.is_empty() && !k.default.is_empty())
        );
    }

    /// The reference's table is this table: a keyword added here and not there fails.
    #[test]
    fn the_language_reference_lists_every_keyword_with_its_default() {
        let reference = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/language.md"));
        let table = markdown_table();
        assert!(
            reference.contains(&table),
            "docs/language.md should hold render's keyword table as generated:\n{table}"
        );
    }

    #[test]
    fn rules_between_keywords_hold_whatever_the_call_order() {
        let given = |pairs: Vec<(&'static str, Setting)>| {
            RenderOptions::from_keywords(false, |k| {
                Ok(pairs
                    .iter()
                    .find(|(name, _)| *name == k.name)
                    .map(|(_, v)| v.clone()))
            })
        };
        // shadowcell after shadows in the call or before it: the table's order decides.
        let cell = given(vec![
            ("shadowcell", Setting::Float(0.1)),
            ("shadows", Setting::Str("sweep".into())),
        ])
        .unwrap();
        assert_eq!(
            cell.settings.shadows,
            Shadows::Cache {
                cell_size: Some(0.1),
                method: TransmissivityMethod::Sweep
            }
        );
        let Err(err) = given(vec![
            ("shadowcell", Setting::Float(0.1)),
            ("shadows", Setting::Str("march".into())),
        ]) else {
            panic!("shadowcell with shadows = \"march\" was accepted");
        };
        assert!(err.message.contains("no meaning"), "{}", err.message);
        assert!(given(vec![("sky", Setting::Vector(DVec3::ONE))]).is_err());
        assert!(given(vec![("adaptive", Setting::Bool(true))]).is_err());
        let adaptive = given(vec![
            ("adaptive", Setting::Bool(true)),
            ("step", Setting::Float(0.02)),
        ])
        .unwrap();
        assert_eq!(adaptive.settings.adaptive, Some(Adaptive::around(0.02)));
        let off = given(vec![("adaptive", Setting::Bool(false))]).unwrap();
        assert_eq!(off.settings.adaptive, None);
        assert!(given(vec![("gamma", Setting::Float(2.0))]).is_err());
    }
}
