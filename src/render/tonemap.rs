//! Tone maps for emission-only particle renders, applied to the image after the march.
//!
//! The key decision: both maps scale a pixel's three channels by one factor, so hue and
//! saturation survive while the brightness is compressed.
//! - `MaxPlusOne` is the thesis's illuminance correction (seed 004 §3): `L / (max(L) + 1)`,
//!   which keeps dense clusters from washing out to white and never reaches 1.
//! - `LogDensity` follows flam3's log-density display: with `m = max(L)` the pixel is scaled
//!   by `log10(1 + k·m) / (k·m)`, so brightness grows as the logarithm of the accumulated
//!   emission (k is `brightness`, flam3's brightness·contrast knob; 1 by default), then flam3's
//!   gamma (`1/gamma` on the scaled value, 4 by default in flam3, given here as `gamma`).

use crate::base::failure::{Failure, Outcome};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToneMap {
    MaxPlusOne,
    LogDensity { brightness: f64, gamma: f64 },
}

impl ToneMap {
    pub fn parse(name: &str, brightness: Option<f64>, gamma: Option<f64>) -> Outcome<ToneMap> {
        for (what, v) in [("brightness", brightness), ("gamma", gamma)] {
            if let Some(v) = v
                && !(v.is_finite() && v > 0.0)
            {
                return Err(Failure::new(format!(
                    "the tone map's {what} must be a positive number, found {v}"
                )));
            }
        }
        match name {
            "max1" => Ok(ToneMap::MaxPlusOne),
            "log" => Ok(ToneMap::LogDensity {
                brightness: brightness.unwrap_or(1.0),
                gamma: gamma.unwrap_or(1.0),
            }),
            other => Err(Failure::new(format!(
                "tonemap must be \"max1\" or \"log\", found \"{other}\""
            ))),
        }
    }

    /// The factor one pixel's colour is multiplied by.
    pub fn factor(&self, rgb: [f32; 3]) -> f32 {
        let m = rgb[0].max(rgb[1]).max(rgb[2]) as f64;
        if !(m.is_finite() && m > 0.0) {
            return 0.0;
        }
        let f = match *self {
            ToneMap::MaxPlusOne => 1.0 / (m + 1.0),
            ToneMap::LogDensity { brightness, gamma } => {
                let scaled = (1.0 + brightness * m).log10() / (brightness * m) * m;
                scaled.powf(1.0 / gamma) / m
            }
        };
        f as f32
    }

    /// Applies the map to every pixel.
    pub fn apply(&self, image: &mut super::Image) {
        for p in image.rgba.iter_mut() {
            let f = self.factor([p[0], p[1], p[2]]);
            for c in &mut p[..3] {
                *c *= f;
            }
            p[3] = 1.0;
        }
    }
}
