//! An environment map: the sky as a latitude–longitude OpenEXR image of scene-linear radiance
//! in felt's working space, scaled by `intensity` and turned by `rotate` degrees about +y.
//!
//! The layout is `latlong`'s (Mitsuba 3's): the top row is the zenith, `u = 0` looks along −z
//! and `u = ¼` along +x. `rotate` turns the map right-handedly about +y: with `rotate = 90`
//! what the file has along −z lights the scene from −x. The one key decision: radiance is the
//! texel's value, constant over the texel's cell (nearest lookup), the same cells the
//! sampler's density is constant over, so an estimate `radiance/pdf` over a map is unbiased
//! with no interpolation to reconcile. Negative texels (a camera's noise floor) read as 0;
//! NaN and infinite texels are refused with where the first is.

use super::latlong::{self, DrawnDirection, LatLongSampler};
use crate::base::failure::{Failure, Outcome};
use glam::{DQuat, DVec3};
use std::path::Path;

/// The largest map accepted, in texels (a 16k × 8k map).
const MOST_TEXELS: usize = 16384 * 8192;

/// Rec.709's luminance weights: how bright a texel counts when directions are drawn.
const LUMINANCE: DVec3 = DVec3::new(0.2126, 0.7152, 0.0722);

/// The bytes a map of `texels` holds: RGB as `f32`, and the sampler's cumulative sums
/// (`f64`, one per texel and one per row).
fn bytes_for(texels: usize) -> f64 {
    texels as f64 * (3.0 * 4.0 + 8.0) + (texels as f64).sqrt() * 8.0
}

/// A lat-long environment map, ready to be looked up and sampled.
pub struct EnvMap {
    width: usize,
    height: usize,
    /// Radiance per texel, row by row from the top, intensity applied.
    texels: Vec<[f32; 3]>,
    /// Turns world directions into the map's.
    to_map: DQuat,
    sampler: Option<LatLongSampler>,
    /// The run's memory budget held for the texels and the sampler's sums.
    _reservation: Option<crate::engine::budget::Reservation>,
    /// What the map was made from, for messages and printing.
    pub source: String,
    pub intensity: f64,
    pub rotate: f64,
}

impl std::fmt::Debug for EnvMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "EnvMap({}, {}×{})", self.source, self.width, self.height)
    }
}

impl EnvMap {
    /// The map in the EXR file at `path`, called `name` in messages (RGB or RGBA; alpha is
    /// ignored).
    pub fn load(path: &Path, name: &str, intensity: f64, rotate: f64) -> Outcome<EnvMap> {
        // The budget is asked before the texels are allocated; a refusal leaves them empty
        // and is reported once the reader returns.
        let image = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |size, _| {
                let texels = size.width().saturating_mul(size.height());
                let refusal =
                    crate::engine::budget::check(bytes_for(texels), "an environment map").err();
                let fits = texels <= MOST_TEXELS && refusal.is_none();
                let storage = if fits { texels } else { 0 };
                (size.width(), vec![[0f32; 3]; storage], refusal)
            },
            |(width, texels, _), at, (r, g, b, _a): (f32, f32, f32, f32)| {
                if let Some(t) = texels.get_mut(at.y() * *width + at.x()) {
                    *t = [r, g, b];
                }
            },
        )
        .map_err(|e| {
            Failure::new(format!("cannot read environment map '{name}': {e}"))
                .with_help("give a lat-long OpenEXR image with R, G and B channels")
        })?;
        let size = image.layer_data.size;
        let (width, texels, refusal) = image.layer_data.channel_data.pixels;
        if let Some(refusal) = refusal {
            return Err(refusal);
        }
        EnvMap::new(
            width,
            size.height(),
            texels,
            intensity,
            rotate,
            name.to_string(),
        )
    }

    /// A map of `width × height` texels (row by row from the top).
    pub fn new(
        width: usize,
        height: usize,
        mut texels: Vec<[f32; 3]>,
        intensity: f64,
        rotate: f64,
        source: String,
    ) -> Outcome<EnvMap> {
        if !intensity.is_finite() || intensity < 0.0 {
            return Err(Failure::new(format!(
                "an environment map's intensity must be finite and non-negative, got {intensity}"
            )));
        }
        if !rotate.is_finite() {
            return Err(Failure::new(format!(
                "an environment map's rotate must be finite, got {rotate}"
            )));
        }
        if width.saturating_mul(height) > MOST_TEXELS || texels.len() != width * height {
            return Err(Failure::new(format!(
                "environment map '{source}' is {width}×{height}, more than the {} texels felt reads",
                MOST_TEXELS
            ))
            .with_help("downsize it to 16384×8192 or less; sky light is smooth"));
        }
        if width == 0 || height == 0 || width != 2 * height {
            return Err(Failure::new(format!(
                "environment map '{source}' is {width}×{height}, not a lat-long image twice as wide as high"
            ))
            .with_help("give an equirectangular (latitude–longitude) map, 2:1, e.g. 2048×1024"));
        }
        if let Some(bad) = texels.iter().position(|t| t.iter().any(|c| !c.is_finite())) {
            return Err(Failure::new(format!(
                "environment map '{source}' has a NaN or infinite texel at column {}, row {} (from the top)",
                bad % width,
                bad / width
            ))
            .with_help("repair or clamp the image before lighting with it"));
        }
        let reservation =
            crate::engine::budget::reserve(bytes_for(texels.len()), "an environment map")?;
        for t in &mut texels {
            for c in t.iter_mut() {
                *c = (c.max(0.0) as f64 * intensity) as f32;
            }
        }
        let sampler = LatLongSampler::new(width, height, |i, j| {
            let t = texels[j * width + i];
            LUMINANCE.dot(DVec3::new(t[0].into(), t[1].into(), t[2].into()))
        });
        Ok(EnvMap {
            width,
            height,
            texels,
            to_map: DQuat::from_rotation_y(-rotate.to_radians()),
            sampler,
            _reservation: Some(reservation),
            source,
            intensity,
            rotate,
        })
    }

    /// The texel value seen along the map's own unit direction `d`.
    fn lookup(&self, d: DVec3) -> DVec3 {
        let (u, v) = latlong::coordinates(d);
        let i = ((u * self.width as f64) as usize).min(self.width - 1);
        let j = ((v * self.height as f64) as usize).min(self.height - 1);
        let t = self.texels[j * self.width + i];
        DVec3::new(t[0].into(), t[1].into(), t[2].into())
    }

    /// The radiance arriving from the sky along the unit world direction `direction` (the way
    /// a ray leaves the scene).
    pub fn radiance(&self, direction: DVec3) -> DVec3 {
        self.lookup(self.to_map * direction)
    }

    /// A world direction drawn in proportion to luminance, its radiance and its density.
    pub fn sample(&self, u1: f64, u2: f64) -> Option<(DVec3, DVec3, f64)> {
        let DrawnDirection { direction, pdf } = self.sampler.as_ref()?.sample(u1, u2)?;
        let world = self.to_map.inverse() * direction;
        Some((world, self.lookup(direction), pdf))
    }

    /// The density per steradian with which `sample` draws the world `direction`.
    pub fn pdf(&self, direction: DVec3) -> f64 {
        match &self.sampler {
            Some(sampler) => sampler.pdf(self.to_map * direction),
            None => 0.0,
        }
    }

    /// Whether every texel is black.
    pub fn is_black(&self) -> bool {
        self.sampler.is_none()
    }
}
