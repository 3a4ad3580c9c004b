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

use super::RenderSettings;
use super::settings::{Adaptive, Integrator};
use super::sky::Sky;
use super::tonemap::ToneMap;
use super::view::View;
use crate::base::failure::{Failure, Outcome};
use crate::space::Aabb;
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
    /// A uniform radiance as a vector, or an environment light (`envmap`, `physicalsky`).
    Sky,
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
            KeywordType::Sky => &["vector", "light"],
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
            KeywordType::Sky => "vector or light",
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
    Sky(Sky),
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

    /// A sky given as a light (`envmap`, `physicalsky`) or as a uniform radiance.
    fn sky(&self) -> Sky {
        match self {
            Setting::Sky(sky) => sky.clone(),
            other => Sky::Uniform(other.vector()),
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
    deep: bool,
    deep_samples: usize,
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
            deep: false,
            deep_samples: 32,
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
        if !self.motion && self.settings.aovs.motion {
            return Err(Failure::new(
                "the motion AOV is the medium's motion on screen, and this render has no velocity",
            )
            .with_help("pass velocity = the medium's velocity field (world units per frame)"));
        }
        // The march's sky, bounces and grid size all belong to its indirect grid: a control
        // that would silently do nothing is refused.
        let grid_controls = ["sky", "bounces", "indirectcells", "indirectpaths"];
        let march_without_grid = self.settings.integrator == Integrator::March
            && self.settings.indirect_grid().is_none();
        if march_without_grid && let Some(name) = grid_controls.iter().find(|n| self.given(n)) {
            return Err(Failure::new(format!(
                "{name} belongs to the indirect grid, which this march does not have"
            ))
            .with_help(
                "the grid needs albedo = ... and no multiscatter; or add integrator = \"path\"",
            ));
        }
        if self.settings.integrator == Integrator::Path
            && let Some(name) = ["indirectcells", "indirectpaths"]
                .iter()
                .find(|n| self.given(n))
        {
            return Err(Failure::new(format!(
                "{name} belongs to the march's indirect grid, not integrator = \"path\""
            ))
            .with_help("the path tracer traces every path from the camera: leave it out"));
        }
        self.deep_rules()?;
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

impl RenderOptions {
    /// What a deep image can be made from: the march's per-depth colour, one part, no extra
    /// channels. Anything the deep file would silently drop is refused.
    fn deep_rules(&mut self) -> Outcome<()> {
        if !self.deep {
            if self.given("deepsamples") {
                return Err(Failure::new(
                    "deepsamples sets the deep image's samples, and this render is flat",
                )
                .with_help("add deep = true, or leave deepsamples out"));
            }
            return Ok(());
        }
        if self.settings.integrator == Integrator::Path {
            return Err(Failure::new(
                "deep = true needs colour per depth along each ray, which the path tracer does \
                 not keep",
            )
            .with_help("render deep images with the march: leave out integrator = \"path\""));
        }
        if self.settings.background.is_some() {
            // The background lies at no depth, so samples that flatten to the flat image
            // would have nowhere to put it.
            return Err(Failure::new(
                "a deep image holds the medium alone, and background puts the sky behind it",
            )
            .with_help("leave out background and put the sky behind the volume in compositing"));
        }
        let dropped = [
            ("aovs", self.settings.aovs != super::Aovs::default()),
            ("tonemap", self.tonemap_name.is_some()),
            ("exr_half", self.exr_half),
        ];
        if let Some((name, _)) = dropped.iter().find(|(_, on)| *on) {
            return Err(Failure::new(format!(
                "{name} is not carried in a deep image, which holds only R, G, B, A, Z and ZBack"
            ))
            .with_help(format!(
                "leave {name} out, or write it from a second, flat render"
            )));
        }
        if let Some(band) = crate::engine::band::active() {
            return Err(Failure::new(format!(
                "deep images cannot be rendered in bands (this is band {} of {}): felt merge \
                 joins flat images only",
                band.index, band.count
            ))
            .with_help("render the deep frame whole: leave out --tile for it"));
        }
        self.settings.deep = Some(self.deep_samples);
        Ok(())
    }
}

/// `render(...)`'s signatures: the scene's inputs, then every row of the table (a row of two
/// types makes a form for each, in every combination with the other such rows).
pub fn signatures() -> Vec<String> {
    let variants: usize = KEYWORDS
        .iter()
        .map(|k| k.kind.signature_types().len())
        .product();
    (0..variants)
        .map(|form| {
            // The form's number, read digit by digit in the bases of the rows' type counts.
            let mut digits = form;
            let rows: Vec<String> = KEYWORDS
                .iter()
                .map(|k| {
                    let types = k.kind.signature_types();
                    let choice = digits % types.len();
                    digits /= types.len();
                    format!("{} {}?", types[choice], k.name)
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

mod table;
#[cfg(test)]
mod tests;

pub use table::KEYWORDS;
