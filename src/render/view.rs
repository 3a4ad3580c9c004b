//! Views: how a PNG preview shows scene-linear colour (docs/language.md, Rendering: view).
//! EXR files stay scene-linear whatever the view.
//!
//! The key decision: a view maps a premultiplied linear Rec.709 colour to a display-linear one
//! in [0, 1], and the PNG writer then does what it always did (raise alpha to the largest
//! channel, divide, sRGB curve). So `"standard"`, which is the identity here and leaves the
//! clip at 1 to the writer, gives the same bytes as before views existed.
//!
//! `"agx"` is AgX as published in three.js (MIT licence, `AgXToneMapping` in its
//! `tonemapping_pars_fragment` shader chunk, after Troy Sobotka's AgX and the Filament and
//! iolite ports): the colour goes to linear Rec.2020, through the inset matrix, to log2 over
//! [-12.47393, 4.026069] EV clamped to [0, 1], through the 6th-degree polynomial fit of AgX's
//! default sigmoid, through the outset matrix, to the power 2.2, and back to Rec.709, clipped.
//! Values above 1 are not clipped but rolled off: a grey of 0.18 shows as 0.21 (display-linear),
//! 1 as 0.59, 4 as 0.86, and 16 (the top of the encoding) and above as 0.995 to 0.997.

use super::working_space::{PRIMARIES, REC2020_PRIMARIES, rgb_to_xyz};
use crate::base::failure::{Failure, Outcome};
use glam::{DMat3, DVec3};

/// How a PNG preview shows scene-linear colour.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum View {
    /// The sRGB curve on the colour clipped to [0, 1].
    #[default]
    Standard,
    /// AgX: a log encoding and a sigmoid that roll highlights off towards white.
    Agx,
    /// Blender's Filmic, from the tables of the OpenColorIO configuration `$OCIO` names
    /// (`filmic.rs`).
    Filmic,
}

impl View {
    pub fn parse(name: &str) -> Outcome<View> {
        match name {
            "standard" => Ok(View::Standard),
            "agx" => Ok(View::Agx),
            "filmic" => super::filmic::tables().map(|_| View::Filmic),
            other => Err(Failure::new(format!(
                "view must be \"standard\", \"agx\" or \"filmic\", found \"{other}\""
            ))),
        }
    }

    /// The display-linear colour for a premultiplied scene-linear one; the alpha is kept.
    pub fn apply(self, rgba: [f32; 4]) -> [f32; 4] {
        match self {
            View::Standard => rgba,
            View::Agx => {
                let rgb = [rgba[0], rgba[1], rgba[2]].map(|c| if c.is_finite() { c } else { 0.0 });
                let out = agx(DVec3::new(rgb[0] as f64, rgb[1] as f64, rgb[2] as f64));
                [out.x as f32, out.y as f32, out.z as f32, rgba[3]]
            }
            // `parse` loaded the tables, so they are there.
            View::Filmic => match super::filmic::tables() {
                Ok(tables) => {
                    let rgb = [rgba[0], rgba[1], rgba[2]]
                        .map(|c| if c.is_finite() { c as f64 } else { 0.0 });
                    let shown = tables.encode(rgb).map(|v| srgb_to_linear(v) as f32);
                    [shown[0], shown[1], shown[2], rgba[3]]
                }
                Err(_) => rgba,
            },
        }
    }
}

/// The display-linear value of an sRGB-encoded one (the inverse of the PNG writer's curve), so
/// that a view whose tables end in sRGB (Filmic) hands the writer what it encodes back.
fn srgb_to_linear(encoded: f64) -> f64 {
    let v = encoded.clamp(0.0, 1.0);
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear Rec.709 → linear Rec.2020 (both D65), from the two sets of primaries.
fn rec709_to_rec2020() -> DMat3 {
    rgb_to_xyz(REC2020_PRIMARIES).inverse() * rgb_to_xyz(PRIMARIES)
}

/// The ends of AgX's log2 encoding, in EV: log2(2^-10 · 0.18) and log2(2^6.5 · 0.18).
const MIN_EV: f64 = -12.47393;
const MAX_EV: f64 = 4.026069;

/// AgX of one linear Rec.709 colour, display-linear Rec.709 in [0, 1].
pub fn agx(rgb: DVec3) -> DVec3 {
    // Columns as three.js lists them (GLSL `mat3` takes columns).
    let inset = DMat3::from_cols(
        DVec3::new(0.856627153315983, 0.137318972929847, 0.11189821299995),
        DVec3::new(0.0951212405381588, 0.761241990602591, 0.0767994186031903),
        DVec3::new(0.0482516061458583, 0.101439036467562, 0.811302368396859),
    );
    let outset = DMat3::from_cols(
        DVec3::new(
            1.1271005818144368,
            -0.1413297634984383,
            -0.14132976349843826,
        ),
        DVec3::new(
            -0.11060664309660323,
            1.157823702216272,
            -0.11060664309660294,
        ),
        DVec3::new(
            -0.016493938717834573,
            -0.016493938717834257,
            1.2519364065950405,
        ),
    );
    let to_2020 = rec709_to_rec2020();
    let encoded = (inset * (to_2020 * rgb)).max(DVec3::splat(1e-10));
    let log = encoded.to_array().map(|c| {
        let x = ((c.log2() - MIN_EV) / (MAX_EV - MIN_EV)).clamp(0.0, 1.0);
        sigmoid(x)
    });
    let shown = (outset * DVec3::from_array(log))
        .max(DVec3::ZERO)
        .to_array()
        .map(|c| c.powf(2.2));
    (to_2020.inverse() * DVec3::from_array(shown)).clamp(DVec3::ZERO, DVec3::ONE)
}

/// The polynomial fit of AgX's default-contrast sigmoid on [0, 1] (mean squared error 3.7e-6).
fn sigmoid(x: f64) -> f64 {
    let (x2, x4) = (x * x, x * x * x * x);
    15.5 * x4 * x2 - 40.14 * x4 * x + 31.96 * x4 - 6.868 * x2 * x + 0.4298 * x2 + 0.1191 * x
        - 0.00232
}
