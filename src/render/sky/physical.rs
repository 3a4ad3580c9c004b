//! A clear daylight sky and its sun from a sun direction and a turbidity: Preetham, Shirley and
//! Smits, "A Practical Analytic Model for Daylight" (SIGGRAPH 1999).
//!
//! The sky's luminance `Y` and chromaticity `x`, `y` each follow Perez's distribution,
//! `F(θ, γ) = (1 + A·e^{B/cos θ})(1 + C·e^{Dγ} + E·cos²γ)`, scaled to their zenith values:
//! `Y(θ, γ) = Y_z·F(θ, γ)/F(0, θ_s)`, with `θ` a direction's angle from the zenith, `γ` its
//! angle from the sun, `θ_s` the sun's; the coefficients and zenith values are the paper's
//! fits in the turbidity `T` (Appendix A.2), valid for `T` from 2 (very clear) to 10 (hazy)
//! and a sun at or above the horizon. Below the horizon the sky shows the horizon's values
//! (`θ` is clamped just above it, as Cycles does for the same model), so a cloud is lit from
//! below as from a sky-coloured ground. The sun is a distant light (`sun`) whose colour is
//! its spectrum at the ground (`sun.rs`).
//!
//! The one key decision, the absolute scale: felt radiance 1 is 30 000 cd/m², and irradiance 1
//! is 30 000 lux, times `intensity`. A high sun gives about 3 (90 000 lux), so a sunlit
//! white cloud (reflecting like a surface of albedo ~0.7, `0.7·3/π`) shows about 0.7 at the
//! default exposure and the clear sky around it 0.2 to 0.5; a low sun is dimmer and redder.

use super::latlong::{self, LatLongSampler};
use super::sun;
use crate::base::failure::{Failure, Outcome};
use crate::render::light::Light;
use crate::render::working_space;
use glam::{DMat3, DVec3};
use std::f64::consts::FRAC_PI_2;

/// Luminance, cd/m², of felt radiance 1 (and illuminance, lux, of felt irradiance 1).
pub const CANDELAS_PER_UNIT: f64 = 30_000.0;

/// The turbidities the paper's fits cover.
pub const TURBIDITY_RANGE: (f64, f64) = (2.0, 10.0);

/// Columns of the lat-long grid directions are drawn over (its rows are half as many).
const SAMPLING_COLUMNS: usize = 256;

/// Perez's five coefficients of one quantity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perez {
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub d: f64,
    pub e: f64,
}

impl Perez {
    /// `F(θ, γ)` for `cos θ > 0`.
    pub fn at(&self, cos_theta: f64, gamma: f64) -> f64 {
        (1.0 + self.a * (self.b / cos_theta).exp())
            * (1.0 + self.c * (self.d * gamma).exp() + self.e * gamma.cos().powi(2))
    }
}

/// The paper's coefficients for luminance `Y` and chromaticities `x`, `y` at turbidity `t`.
pub fn coefficients(t: f64) -> [Perez; 3] {
    let p = |a: (f64, f64), b: (f64, f64), c: (f64, f64), d: (f64, f64), e: (f64, f64)| Perez {
        a: a.0 * t + a.1,
        b: b.0 * t + b.1,
        c: c.0 * t + c.1,
        d: d.0 * t + d.1,
        e: e.0 * t + e.1,
    };
    [
        p(
            (0.1787, -1.4630),
            (-0.3554, 0.4275),
            (-0.0227, 5.3251),
            (0.1206, -2.5771),
            (-0.0670, 0.3703),
        ),
        p(
            (-0.0193, -0.2592),
            (-0.0665, 0.0008),
            (-0.0004, 0.2125),
            (-0.0641, -0.8989),
            (-0.0033, 0.0452),
        ),
        p(
            (-0.0167, -0.2608),
            (-0.0950, 0.0092),
            (-0.0079, 0.2102),
            (-0.0441, -1.6537),
            (-0.0109, 0.0529),
        ),
    ]
}

/// The zenith's luminance (cd/m²) and chromaticity `(Y, x, y)` for a sun `theta_s` radians
/// from the zenith at turbidity `t` (the paper's zenith fits; its `Y_z` is in kcd/m²).
pub fn zenith(t: f64, theta_s: f64) -> DVec3 {
    let chi = (4.0 / 9.0 - t / 120.0) * (std::f64::consts::PI - 2.0 * theta_s);
    let luminance = (4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192;
    let powers = DVec3::new(t * t, t, 1.0);
    let (s1, s2, s3) = (theta_s, theta_s * theta_s, theta_s * theta_s * theta_s);
    let x = DVec3::new(
        0.00166 * s3 - 0.00375 * s2 + 0.00209 * s1,
        -0.02903 * s3 + 0.06377 * s2 - 0.03202 * s1 + 0.00394,
        0.11693 * s3 - 0.21196 * s2 + 0.06052 * s1 + 0.25886,
    );
    let y = DVec3::new(
        0.00275 * s3 - 0.00610 * s2 + 0.00317 * s1,
        -0.04214 * s3 + 0.08970 * s2 - 0.04153 * s1 + 0.00516,
        0.15346 * s3 - 0.26756 * s2 + 0.06670 * s1 + 0.26688,
    );
    DVec3::new(1000.0 * luminance, powers.dot(x), powers.dot(y))
}

/// A Preetham daylight sky.
pub struct PhysicalSky {
    /// Unit direction from the scene towards the sun.
    to_sun: DVec3,
    theta_s: f64,
    pub turbidity: f64,
    pub intensity: f64,
    perez: [Perez; 3],
    /// `(Y, x, y)` at the zenith over `F(0, θ_s)` of each.
    scale: DVec3,
    xyz_to_working: DMat3,
    sampler: Option<LatLongSampler>,
    sun: Light,
}

impl std::fmt::Debug for PhysicalSky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "PhysicalSky(sun {}, turbidity {}, intensity {})",
            -self.to_sun, self.turbidity, self.intensity
        )
    }
}

impl PhysicalSky {
    /// The sky and its sun for sunlight travelling along `sun` (as for `distantlight`), at
    /// `turbidity`, scaled by `intensity`.
    pub fn new(sun: DVec3, turbidity: f64, intensity: f64) -> Outcome<PhysicalSky> {
        if !sun.is_finite() || sun.length() == 0.0 {
            return Err(Failure::new(format!(
                "the sun's direction must be a non-zero vector, got {sun}"
            ))
            .with_help("give the direction sunlight travels, e.g. (0, -1, 0) for a sun overhead"));
        }
        let to_sun = -sun.normalize();
        if to_sun.y < 0.0 {
            return Err(Failure::new(format!(
                "the sun is {:.1}° below the horizon; the daylight sky needs it at or above",
                -to_sun.y.asin().to_degrees()
            ))
            .with_help("sunlight travels down: give a direction with y ≤ 0, e.g. (1, -0.2, 0)"));
        }
        let (lo, hi) = TURBIDITY_RANGE;
        if !(lo..=hi).contains(&turbidity) {
            return Err(Failure::new(format!(
                "turbidity must be between {lo} and {hi}, got {turbidity}"
            ))
            .with_help("2 is a very clear sky, 3 a clear one (the default), 10 a hazy one"));
        }
        if !intensity.is_finite() || intensity < 0.0 {
            return Err(Failure::new(format!(
                "the sky's intensity must be finite and non-negative, got {intensity}"
            )));
        }
        let theta_s = to_sun.y.clamp(-1.0, 1.0).acos();
        let perez = coefficients(turbidity);
        let z = zenith(turbidity, theta_s);
        let scale = DVec3::new(
            z.x / perez[0].at(1.0, theta_s),
            z.y / perez[1].at(1.0, theta_s),
            z.z / perez[2].at(1.0, theta_s),
        );
        let xyz_to_working = working_space::xyz_to_working();
        let sun_color = xyz_to_working * sun::illuminance_xyz(theta_s, turbidity) * intensity
            / CANDELAS_PER_UNIT;
        let mut sky = PhysicalSky {
            to_sun,
            theta_s,
            turbidity,
            intensity,
            perez,
            scale,
            xyz_to_working,
            sampler: None,
            sun: Light::distant(-to_sun, sun_color.max(DVec3::ZERO))?,
        };
        let rows = SAMPLING_COLUMNS / 2;
        sky.sampler = LatLongSampler::new(SAMPLING_COLUMNS, rows, |i, j| {
            let u = (i as f64 + 0.5) / SAMPLING_COLUMNS as f64;
            let v = (j as f64 + 0.5) / rows as f64;
            sky.xy_luminance(latlong::direction(u, v)).x
        });
        Ok(sky)
    }

    /// The sun: a distant light travelling from the sun's direction, of the sun's colour.
    pub fn sun(&self) -> &Light {
        &self.sun
    }

    /// The direction sunlight travels.
    pub fn sun_travel(&self) -> DVec3 {
        -self.to_sun
    }

    /// The sun's angle from the zenith, radians.
    pub fn sun_zenith_angle(&self) -> f64 {
        self.theta_s
    }

    /// Luminance (cd/m², before `intensity`) and chromaticity `(Y, x, y)` along the unit
    /// `direction`.
    pub fn xy_luminance(&self, direction: DVec3) -> DVec3 {
        // Just above the horizon at most: below it the sky repeats the horizon.
        let cos_theta = direction.y.max((FRAC_PI_2 - 0.001).cos());
        let gamma = direction.dot(self.to_sun).clamp(-1.0, 1.0).acos();
        DVec3::new(
            self.scale.x * self.perez[0].at(cos_theta, gamma),
            self.scale.y * self.perez[1].at(cos_theta, gamma),
            self.scale.z * self.perez[2].at(cos_theta, gamma),
        )
    }

    /// The radiance arriving along the unit direction `direction` leaves the scene by.
    pub fn radiance(&self, direction: DVec3) -> DVec3 {
        let yxy = self.xy_luminance(direction);
        let (luminance, x, y) = (yxy.x, yxy.y, yxy.z);
        if y <= 0.0 || luminance <= 0.0 {
            return DVec3::ZERO;
        }
        let xyz = DVec3::new(x / y, 1.0, (1.0 - x - y) / y) * luminance;
        (self.xyz_to_working * xyz * (self.intensity / CANDELAS_PER_UNIT)).max(DVec3::ZERO)
    }

    /// A direction drawn in proportion to the sky's luminance on a 256 × 128 lat-long grid, its
    /// radiance and its density per steradian.
    pub fn sample(&self, u1: f64, u2: f64) -> Option<(DVec3, DVec3, f64)> {
        let drawn = self.sampler.as_ref()?.sample(u1, u2)?;
        Some((drawn.direction, self.radiance(drawn.direction), drawn.pdf))
    }

    /// The density with which `sample` draws `direction`.
    pub fn pdf(&self, direction: DVec3) -> f64 {
        self.sampler.as_ref().map_or(0.0, |s| s.pdf(direction))
    }

    /// Whether the sky gives no light (intensity 0).
    pub fn is_black(&self) -> bool {
        self.intensity == 0.0
    }
}
