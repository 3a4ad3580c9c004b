//! The colour of a black body: Planck's law integrated against the CIE 1931 colour-matching
//! functions, then taken from XYZ to linear Rec.709 (felt's working space, D65 white).
//!
//! The key decision: a plain temperature is integrated exactly (95 wavelengths), while a
//! temperature *field* reads a table in reciprocal temperature `u = 1/T` (mired-like), linearly
//! interpolated. A black body's colour is smooth in `u` and the table covers `u ∈ [0, 1/800]`,
//! that is every temperature from 800 K to infinity, so 2048 intervals keep the table within
//! 2.1e-6 of the exact colour and 7.9e-6 (relative) of the absolute one (a test here holds
//! them under 1e-5). The table stores the colour normalised
//! to Y = 1 and `ln(Y / T)`, which stays finite as T grows, so the absolute radiance is
//! `colour · exp(ln(Y/T)) · T`. The table is read through the grid machinery (a one-dimensional
//! grid whose x coordinate is the temperature), so ranges and derivatives come with it.
//!
//! Below 800 K, at T ≤ 0, and for a temperature that is not a finite number, the colour is
//! black (docs/language.md, Fields: blackbody). Temperatures above 10^12 K read as 10^12 K.

use crate::grid::next_identity;
use crate::render::cie1931::{CMF, FIRST_NM, STEP_NM};
use crate::space::{Aabb, GridSource, Interp};
use glam::{DMat3, DVec3};
use std::sync::{Arc, OnceLock};

/// Below this temperature a black body is black here.
pub const COLDEST: f64 = 800.0;
/// Temperatures above this read as this (keeps the absolute radiance finite).
pub const HOTTEST: f64 = 1e12;

/// Planck constant (J·s), speed of light (m/s), Boltzmann constant (J/K): SI 2019, exact.
const H: f64 = 6.626_070_15e-34;
const C: f64 = 299_792_458.0;
const K: f64 = 1.380_649e-23;

/// XYZ → linear Rec.709, felt's working space (`working_space`).
pub fn xyz_to_rec709() -> DMat3 {
    super::working_space::xyz_to_working()
}

/// Spectral radiance of a black body (W·sr⁻¹·m⁻³) at wavelength `lambda` metres.
fn planck(lambda: f64, t: f64) -> f64 {
    2.0 * H * C * C / lambda.powi(5) / (H * C / (lambda * K * t)).exp_m1()
}

/// CIE XYZ of a black body at `t` kelvin: ∫ L_λ(λ, T) · (x̄, ȳ, z̄)(λ) dλ over 360–830 nm by the
/// trapezoid rule on the 5 nm table, in W·sr⁻¹·m⁻² (Y times 683 lm/W is the luminance in
/// cd/m²). `t` must be positive and finite.
pub fn xyz(t: f64) -> DVec3 {
    let step = STEP_NM * 1e-9;
    let last = CMF.len() - 1;
    let mut sum = DVec3::ZERO;
    for (i, cmf) in CMF.iter().enumerate() {
        let lambda = (FIRST_NM + STEP_NM * i as f64) * 1e-9;
        let weight = if i == 0 || i == last { 0.5 } else { 1.0 };
        sum += DVec3::from_array(*cmf) * (weight * step * planck(lambda, t));
    }
    sum
}

/// Whether `t` has a colour here (finite, at least `COLDEST`).
fn glows(t: f64) -> bool {
    t.is_finite() && t >= COLDEST
}

/// The exact colour of a black body at `t` kelvin in linear Rec.709: normalised to Y = 1, or
/// the absolute CMF-weighted radiance in W·sr⁻¹·m⁻² (`normalize` false). Black where `t` is
/// below 800 K or not finite.
pub fn blackbody(t: f64, normalize: bool) -> DVec3 {
    if !glows(t) {
        return DVec3::ZERO;
    }
    let xyz = xyz(t.min(HOTTEST));
    let rgb = xyz_to_rec709() * xyz;
    if normalize { rgb / xyz.y } else { rgb }
}

/// Intervals of the table in `u = 1/T`, over `[0, 1/COLDEST]`.
const INTERVALS: usize = 2048;
const DU: f64 = 1.0 / COLDEST / INTERVALS as f64;

/// One table node: the colour normalised to Y = 1, and `ln(Y / T)`.
#[derive(Clone, Copy, Debug)]
struct Node {
    rgb: DVec3,
    log_y_per_t: f64,
}

/// The colour of the black body at infinite temperature, where Planck's law becomes
/// Rayleigh–Jeans (`L_λ ∝ T / λ⁴`), and the limit of `Y / T`.
fn rayleigh_jeans() -> (DVec3, f64) {
    let step = STEP_NM * 1e-9;
    let last = CMF.len() - 1;
    let mut sum = DVec3::ZERO;
    for (i, cmf) in CMF.iter().enumerate() {
        let lambda = (FIRST_NM + STEP_NM * i as f64) * 1e-9;
        let weight = if i == 0 || i == last { 0.5 } else { 1.0 };
        sum += DVec3::from_array(*cmf) * (weight * step * 2.0 * C * K / lambda.powi(4));
    }
    (xyz_to_rec709() * sum / sum.y, sum.y.ln())
}

/// The blackbody table, read as a grid of width 3 whose x coordinate is the temperature.
#[derive(Debug)]
pub struct BlackbodyTable {
    nodes: Vec<Node>,
    normalize: bool,
    identity: u64,
}

impl BlackbodyTable {
    fn build(normalize: bool) -> BlackbodyTable {
        let nodes = (0..=INTERVALS)
            .map(|i| {
                if i == 0 {
                    let (rgb, log_y_per_t) = rayleigh_jeans();
                    return Node { rgb, log_y_per_t };
                }
                let t = 1.0 / (i as f64 * DU);
                let xyz = xyz(t);
                Node {
                    rgb: xyz_to_rec709() * xyz / xyz.y,
                    log_y_per_t: (xyz.y / t).ln(),
                }
            })
            .collect();
        BlackbodyTable {
            nodes,
            normalize,
            identity: next_identity(),
        }
    }

    /// The shared table: normalised to Y = 1, or absolute.
    pub fn shared(normalize: bool) -> Arc<BlackbodyTable> {
        static TABLES: [OnceLock<Arc<BlackbodyTable>>; 2] = [OnceLock::new(), OnceLock::new()];
        TABLES[normalize as usize]
            .get_or_init(|| Arc::new(BlackbodyTable::build(normalize)))
            .clone()
    }

    /// The interval holding `t` and the position within it.
    fn locate(t: f64) -> (usize, f64) {
        let s = 1.0 / (t.min(HOTTEST) * DU);
        let i = (s.floor() as usize).min(INTERVALS - 1);
        (i, s - i as f64)
    }

    /// The interpolated value at `t`, and its derivative in `t`.
    pub fn at(&self, t: f64) -> (DVec3, DVec3) {
        if !glows(t) {
            return (DVec3::ZERO, DVec3::ZERO);
        }
        let (i, f) = BlackbodyTable::locate(t);
        let (a, b) = (self.nodes[i], self.nodes[i + 1]);
        let rgb = a.rgb.lerp(b.rgb, f);
        let t = t.min(HOTTEST);
        let u = 1.0 / t;
        // d/dT = d/du · (−u²); above HOTTEST the value no longer changes.
        let du_dt = if t < HOTTEST { -u * u } else { 0.0 };
        let drgb_dt = (b.rgb - a.rgb) / DU * du_dt;
        if self.normalize {
            return (rgb, drgb_dt);
        }
        let v = a.log_y_per_t + (b.log_y_per_t - a.log_y_per_t) * f;
        let dv_dt = (b.log_y_per_t - a.log_y_per_t) / DU * du_dt;
        let y = v.exp() * t;
        let dy_dt = if t < HOTTEST {
            v.exp() + y * dv_dt
        } else {
            0.0
        };
        (rgb * y, drgb_dt * y + rgb * dy_dt)
    }
}

impl GridSource for BlackbodyTable {
    fn width(&self) -> usize {
        3
    }

    fn identity(&self) -> u64 {
        self.identity
    }

    fn label(&self) -> String {
        let kind = if self.normalize { "" } else { " (absolute)" };
        format!("blackbody table{kind}")
    }

    fn sample(&self, _: Interp, xs: &[f64], _: &[f64], _: &[f64], out: &mut [f64]) {
        let n = xs.len();
        for (i, &t) in xs.iter().enumerate() {
            let (v, _) = self.at(t);
            for c in 0..3 {
                out[c * n + i] = v[c];
            }
        }
    }

    fn sample_gradient(&self, _: Interp, xs: &[f64], _: &[f64], _: &[f64], out: &mut [f64]) {
        let n = xs.len();
        for (i, &t) in xs.iter().enumerate() {
            let (_, d) = self.at(t);
            for c in 0..3 {
                out[c * 3 * n + i] = d[c];
                out[(c * 3 + 1) * n + i] = 0.0;
                out[(c * 3 + 2) * n + i] = 0.0;
            }
        }
    }

    fn bounds(&self) -> Aabb {
        Aabb::new(
            DVec3::new(COLDEST, f64::MIN, f64::MIN),
            DVec3::new(f64::MAX, f64::MAX, f64::MAX),
        )
    }

    fn background(&self) -> Vec<f64> {
        vec![0.0; 3]
    }

    fn cell_size(&self) -> DVec3 {
        DVec3::ONE
    }

    /// Between two nodes every value lies between theirs (linear interpolation), so the nodes
    /// spanning `[lo, hi]` bound the colour; the absolute form multiplies that by Y, which
    /// grows with T.
    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        let (lo, hi) = (region.min.x.max(COLDEST), region.max.x);
        let mut ranges = vec![(f64::INFINITY, f64::NEG_INFINITY); 3];
        if region.min.x < COLDEST || !region.max.x.is_finite() {
            ranges.fill((0.0, 0.0));
        }
        if hi.is_nan() || hi < lo {
            return ranges;
        }
        let (first, _) = BlackbodyTable::locate(hi);
        let (last, _) = BlackbodyTable::locate(lo);
        let (mut rgb_lo, mut rgb_hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for node in &self.nodes[first..=last + 1] {
            rgb_lo = rgb_lo.min(node.rgb);
            rgb_hi = rgb_hi.max(node.rgb);
        }
        let (y_lo, y_hi) = if self.normalize {
            (1.0, 1.0)
        } else {
            (y_of(self, lo), y_of(self, hi))
        };
        for (c, r) in ranges.iter_mut().enumerate() {
            let products = [
                rgb_lo[c] * y_lo,
                rgb_lo[c] * y_hi,
                rgb_hi[c] * y_lo,
                rgb_hi[c] * y_hi,
            ];
            let (p_lo, p_hi) = products
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &p| {
                    (a.min(p), b.max(p))
                });
            *r = (r.0.min(p_lo), r.1.max(p_hi));
        }
        ranges
    }
}

/// The interpolated Y of the absolute table at `t` (glowing, finite), which grows with `t`.
fn y_of(table: &BlackbodyTable, t: f64) -> f64 {
    let (i, f) = BlackbodyTable::locate(t);
    let (a, b) = (table.nodes[i], table.nodes[i + 1]);
    (a.log_y_per_t + (b.log_y_per_t - a.log_y_per_t) * f).exp() * t.min(HOTTEST)
}

#[cfg(test)]
#[path = "blackbody_tests.rs"]
mod tests;
