//! The sun's colour and strength at the ground: the extraterrestrial solar spectrum attenuated
//! along the sun's path through the air by Rayleigh scattering, aerosols (Ångström's law),
//! ozone, mixed gases and water vapour, as Preetham, Shirley and Smits (1999, Appendix A.1)
//! give it, integrated against the CIE 1931 observer (`cie1931`).
//!
//! Provenance of the tables: the solar spectral radiance outside the atmosphere from 380 to
//! 750 nm and the absorption coefficients of ozone, mixed gases and water vapour are those
//! of Iqbal, "An Introduction to Solar Radiation" (1983, pp. 127–130), which the paper uses.
//! The one key decision: the integration is over the paper's own 10 nm samples of the
//! solar spectrum, the colour-matching functions taken at the same wavelengths, so nothing
//! is interpolated but the sparse absorption tables, linearly, as the paper's code does.

use crate::render::cie1931;
use glam::DVec3;

/// The first wavelength of `SOLAR`, nm, and its spacing.
const SOLAR_FIRST_NM: f64 = 380.0;
const SOLAR_STEP_NM: f64 = 10.0;

/// The sun's spectral radiance outside the atmosphere, W·m⁻²·sr⁻¹·nm⁻¹, 380 to 750 nm.
#[rustfmt::skip]
const SOLAR: [f64; 38] = [
    16559.0, 16233.7, 21127.5, 25888.2, 25829.1, 24232.3, 26760.5, 29658.3, 30545.4, 30057.5,
    30663.7, 28830.4, 28712.1, 27825.0, 27100.6, 27233.6, 26361.3, 25503.8, 25060.2, 25311.6,
    25355.9, 25134.2, 24631.5, 24173.2, 23685.3, 23212.1, 22827.7, 22339.8, 21970.2, 21526.7,
    21097.9, 20728.3, 20240.4, 19870.8, 19427.2, 19072.4, 18628.9, 18259.2,
];

/// Ozone's absorption coefficient, cm⁻¹, at (nm, k) points (Iqbal p. 127).
#[rustfmt::skip]
const OZONE: [(f64, f64); 64] = [
    (300.0, 10.0), (305.0, 4.8), (310.0, 2.7), (315.0, 1.35), (320.0, 0.8), (325.0, 0.38),
    (330.0, 0.16), (335.0, 0.075), (340.0, 0.04), (345.0, 0.019), (350.0, 0.007), (355.0, 0.0),
    (445.0, 0.003), (450.0, 0.003), (455.0, 0.004), (460.0, 0.006), (465.0, 0.008),
    (470.0, 0.009), (475.0, 0.012), (480.0, 0.014), (485.0, 0.017), (490.0, 0.021),
    (495.0, 0.025), (500.0, 0.03), (505.0, 0.035), (510.0, 0.04), (515.0, 0.045),
    (520.0, 0.048), (525.0, 0.057), (530.0, 0.063), (535.0, 0.07), (540.0, 0.075),
    (545.0, 0.08), (550.0, 0.085), (555.0, 0.095), (560.0, 0.103), (565.0, 0.11),
    (570.0, 0.12), (575.0, 0.122), (580.0, 0.12), (585.0, 0.118), (590.0, 0.115),
    (595.0, 0.12), (600.0, 0.125), (605.0, 0.13), (610.0, 0.12), (620.0, 0.105),
    (630.0, 0.09), (640.0, 0.079), (650.0, 0.067), (660.0, 0.057), (670.0, 0.048),
    (680.0, 0.036), (690.0, 0.028), (700.0, 0.023), (710.0, 0.018), (720.0, 0.014),
    (730.0, 0.011), (740.0, 0.01), (750.0, 0.009), (760.0, 0.007), (770.0, 0.004),
    (780.0, 0.0), (790.0, 0.0),
];

/// Mixed gases' (oxygen's) absorption coefficient, cm⁻¹ (Iqbal p. 130).
const MIXED_GASES: [(f64, f64); 4] = [(759.0, 0.0), (760.0, 3.0), (770.0, 0.21), (771.0, 0.0)];

/// Water vapour's absorption coefficient, cm⁻¹ (Iqbal p. 130).
#[rustfmt::skip]
const WATER_VAPOUR: [(f64, f64); 13] = [
    (689.0, 0.0), (690.0, 0.016), (700.0, 0.024), (710.0, 0.0125), (720.0, 1.0),
    (730.0, 0.87), (740.0, 0.061), (750.0, 0.001), (760.0, 0.00001), (770.0, 0.00001),
    (780.0, 0.0006), (790.0, 0.0175), (800.0, 0.036),
];

/// The ozone column, cm (the paper's 0.35), and precipitable water, cm (its 2).
const OZONE_CM: f64 = 0.35;
const WATER_CM: f64 = 2.0;

/// The sun's angular radius, 0.2667°, and so its solid angle `2π(1 − cos r)` in sr.
pub fn sun_solid_angle() -> f64 {
    2.0 * std::f64::consts::PI * (1.0 - 0.2667f64.to_radians().cos())
}

/// Luminous efficacy of radiation at 555 nm, lm/W, which turns ∫ȳ·E into lux.
const LUMENS_PER_WATT: f64 = 683.0;

/// Linear interpolation in a table of (nm, value) points, 0 outside it.
fn table(points: &[(f64, f64)], nm: f64) -> f64 {
    let i = points.partition_point(|&(x, _)| x <= nm);
    if i == 0 || i == points.len() {
        return if points.last().is_some_and(|&(x, _)| x == nm) {
            points[points.len() - 1].1
        } else {
            0.0
        };
    }
    let ((x0, y0), (x1, y1)) = (points[i - 1], points[i]);
    y0 + (y1 - y0) * (nm - x0) / (x1 - x0)
}

/// The relative optical mass of air towards a sun `theta_s` radians from the zenith
/// (Kasten's formula, as the paper has it).
pub fn optical_mass(theta_s: f64) -> f64 {
    1.0 / (theta_s.cos() + 0.15 * (93.885 - theta_s.to_degrees()).powf(-1.253))
}

/// The sun's spectral radiance at the ground, W·m⁻²·sr⁻¹·nm⁻¹, at `SOLAR`'s wavelengths.
pub fn spectral_radiance(theta_s: f64, turbidity: f64) -> [f64; 38] {
    let m = optical_mass(theta_s);
    // Ångström's turbidity coefficient from the turbidity, and his wavelength exponent.
    let beta = 0.046_083_658_22 * turbidity - 0.045_860_259_28;
    let alpha = 1.3;
    let mut out = [0.0; 38];
    for (i, value) in out.iter_mut().enumerate() {
        let nm = SOLAR_FIRST_NM + SOLAR_STEP_NM * i as f64;
        let um = nm / 1000.0;
        let rayleigh = (-m * 0.008735 * um.powf(-4.08)).exp();
        let aerosol = (-m * beta * um.powf(-alpha)).exp();
        let ozone = (-m * table(&OZONE, nm) * OZONE_CM).exp();
        let kg = table(&MIXED_GASES, nm) * m;
        let gases = (-1.41 * kg / (1.0 + 118.93 * kg).powf(0.45)).exp();
        let kwa = table(&WATER_VAPOUR, nm) * WATER_CM * m;
        let water = (-0.2385 * kwa / (1.0 + 20.07 * kwa).powf(0.45)).exp();
        *value = SOLAR[i] * rayleigh * aerosol * ozone * gases * water;
    }
    out
}

/// The sun's illuminance on a surface facing it, as CIE XYZ in lux (Y is the illuminance):
/// `683 · Ω · ∫ L(λ) (x̄, ȳ, z̄) dλ` by the trapezoid rule over `SOLAR`'s wavelengths.
pub fn illuminance_xyz(theta_s: f64, turbidity: f64) -> DVec3 {
    let radiance = spectral_radiance(theta_s, turbidity);
    let offset = ((SOLAR_FIRST_NM - cie1931::FIRST_NM) / cie1931::STEP_NM) as usize;
    let stride = (SOLAR_STEP_NM / cie1931::STEP_NM) as usize;
    let mut sum = DVec3::ZERO;
    for (i, l) in radiance.iter().enumerate() {
        let cmf = cie1931::CMF[offset + stride * i];
        let end = i == 0 || i == radiance.len() - 1;
        let weight = if end { 0.5 } else { 1.0 } * SOLAR_STEP_NM;
        sum += DVec3::from_array(cmf) * (l * weight);
    }
    sum * (LUMENS_PER_WATT * sun_solid_angle())
}
