//! The latitude–longitude (equirectangular) layout of a sky, and the importance sampling of
//! directions over it.
//!
//! The convention is Mitsuba 3's (`envmap`), so the same EXR lights a scene the same way in
//! both: `u = atan2(x, −z)/2π` (wrapped into [0, 1)) runs along a row and `v = acos(y)/π` down
//! the rows, so the top row is the zenith (+y), the left edge (`u = 0`) looks along −z, a
//! quarter of the way across (`u = ¼`) along +x, the middle (`u = ½`) along +z and
//! three quarters (`u = ¾`) along −x (Blender's Environment Texture reads the same file a
//! quarter turn apart: `rotate = 90` matches it). Texel `(i, j)` of a `W × H` image covers
//! `[i/W, (i+1)/W) × [j/H, (j+1)/H)` in `(u, v)`. The one key decision: directions are drawn
//! from a piecewise-constant density in `(u, v)` whose cells are the texels, weighted by the
//! texel's luminance times `sin θ` at its centre, and converted to solid angle with the exact
//! Jacobian `dω = 2π² sin θ du dv`; so `pdf` is exactly the density of what `sample` draws.

use super::distribution::Distribution2D;
use glam::DVec3;
use std::f64::consts::PI;

/// The unit direction at `(u, v)`.
pub fn direction(u: f64, v: f64) -> DVec3 {
    let (sin_theta, cos_theta) = (PI * v).sin_cos();
    let (sin_phi, cos_phi) = (2.0 * PI * u).sin_cos();
    DVec3::new(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi)
}

/// The `(u, v)` of a unit direction, each in [0, 1).
pub fn coordinates(direction: DVec3) -> (f64, f64) {
    let u = direction.x.atan2(-direction.z) / (2.0 * PI);
    let u = if u < 0.0 { u + 1.0 } else { u };
    let v = direction.y.clamp(-1.0, 1.0).acos() / PI;
    (u.min(1.0 - f64::EPSILON), v.min(1.0 - f64::EPSILON))
}

/// `sin θ` at the centre of row `j` of `height`.
pub fn row_sine(j: usize, height: usize) -> f64 {
    (PI * (j as f64 + 0.5) / height as f64).sin()
}

/// Directions drawn over the sphere in proportion to a lat-long grid of weights.
#[derive(Clone, Debug)]
pub struct LatLongSampler {
    distribution: Distribution2D,
}

/// A direction drawn by a [`LatLongSampler`] and its density per steradian.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrawnDirection {
    pub direction: DVec3,
    pub pdf: f64,
}

impl LatLongSampler {
    /// A sampler over `width × height` cells in proportion to `weight(column, row)` (finite,
    /// non-negative) times the row's `sin θ`; `None` when every weight is zero.
    pub fn new(
        width: usize,
        height: usize,
        weight: impl Fn(usize, usize) -> f64,
    ) -> Option<LatLongSampler> {
        let mut weights = Vec::with_capacity(width * height);
        for j in 0..height {
            let sine = row_sine(j, height);
            weights.extend((0..width).map(|i| weight(i, j) * sine));
        }
        Distribution2D::new(width, height, &weights)
            .map(|distribution| LatLongSampler { distribution })
    }

    /// A direction from two uniform numbers in [0, 1), or `None` for a draw at a pole (density
    /// infinite, measure zero) or in a cell of zero weight.
    pub fn sample(&self, u1: f64, u2: f64) -> Option<DrawnDirection> {
        let drawn = self.distribution.sample(u1, u2);
        let sin_theta = (PI * drawn.v).sin();
        if drawn.pdf <= 0.0 || sin_theta <= 0.0 {
            return None;
        }
        Some(DrawnDirection {
            direction: direction(drawn.u, drawn.v),
            pdf: drawn.pdf / (2.0 * PI * PI * sin_theta),
        })
    }

    /// The density per steradian with which `sample` draws the unit `direction`.
    pub fn pdf(&self, direction: DVec3) -> f64 {
        let sin_theta = (direction.x * direction.x + direction.z * direction.z).sqrt();
        if sin_theta <= 0.0 {
            return 0.0;
        }
        let (u, v) = coordinates(direction);
        self.distribution.pdf(u, v) / (2.0 * PI * PI * sin_theta)
    }
}
