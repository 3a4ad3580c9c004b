//! Free flights and shadow rays through the medium: spectral delta tracking and ratio tracking
//! over the majorant grid.
//!
//! The medium is the albedo model: per channel `σt = κρ`, `σs = albedo·color·σt`,
//! `σa = σt − σs`. With the majorant `μ̄ = max(κ)·ρ̄` of the cell a ray is in, tentative
//! collisions are drawn at rate `μ̄` and the null coefficient is `σn = μ̄ − σt`. The one key
//! decision: a collision is classified by spectral tracking (Kutz et al. 2017, "Spectral and
//! Decomposition Tracking", the history-aware form): the event `x ∈ {a, s, n}` is taken with
//! probability `P_x = Σ_c w_c·σx_c / Σ_c w_c·μ̄` and the path weight becomes
//! `w_c·σx_c / (μ̄·P_x)`. Where κ and colour are the same in every channel the weights stay
//! exactly 1 and this is plain delta tracking; where they differ it stays unbiased and the
//! weights stay finite (`σx_c/(μ̄·P_x) ≤ max_c w / mean_c w` per event). Emission, a source per
//! unit length, is collected at every tentative collision as `w·ε/μ̄` (the expected number of
//! tentative collisions per unit length before the real one is `μ̄·T`, so the sum estimates
//! `∫T·ε ds`; in cells that may glow the rate is at least a few per cell, so emission in
//! empty space is found too). A density sample above its cell's bound is counted, never hidden: there the
//! tracking is biased, and the render warns.

use super::majorant::Majorants;
use super::sampling::PathRandom;
use crate::render::camera::Ray;
use crate::render::tile::InputCounts;
use crate::space::{BlockEval, FieldSampler};
use glam::DVec3;

/// The medium's fields and constants, with one thread's evaluators.
pub struct Medium<'a> {
    density: Box<dyn BlockEval + 'a>,
    color: Option<Box<dyn BlockEval + 'a>>,
    emission: Option<Box<dyn BlockEval + 'a>>,
    /// Motion blur: the velocity, and the time in the shutter of the path being traced;
    /// every point is read where the medium was at that time.
    velocity: Option<Box<dyn BlockEval + 'a>>,
    pub time: f64,
    /// The last point shifted and where it went (density, colour and emission are read at
    /// one point in turn).
    shifted: (DVec3, DVec3),
    pub majorants: &'a Majorants,
    pub kappa: DVec3,
    /// `max(κ)`: the majorant of extinction is this times the cell's density bound.
    kappa_max: f64,
    pub albedo: f64,
    scratch: [f32; 3],
    pub counts: MediumCounts,
}

/// What one thread's samples of the medium met.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MediumCounts {
    pub density: InputCounts,
    pub color: InputCounts,
    pub emission: InputCounts,
    /// Density samples above their majorant cell's bound, and where the first was.
    pub above_majorant: u64,
    pub first_above_majorant: Option<DVec3>,
}

impl MediumCounts {
    pub fn merge(&mut self, other: &MediumCounts) {
        self.density.merge(&other.density);
        self.color.merge(&other.color);
        self.emission.merge(&other.emission);
        self.above_majorant += other.above_majorant;
        if self.first_above_majorant.is_none() {
            self.first_above_majorant = other.first_above_majorant;
        }
    }
}

/// How a free flight ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Flight {
    /// Left the box without a real collision.
    Escaped,
    /// Scattered at this distance along the ray.
    Scattered(f64),
    /// Absorbed (or every channel's weight reached 0).
    Absorbed,
}

/// Reads `width` components at `p`, NaN and infinities as 0 and negatives clamped to 0, each
/// counted.
fn read(eval: &mut dyn BlockEval, p: DVec3, out: &mut [f32], counts: &mut InputCounts) {
    eval.eval_f32(&[p.x], &[p.y], &[p.z], out);
    counts.samples += 1;
    let (mut non_finite, mut negative) = (false, false);
    for v in out.iter_mut() {
        if !v.is_finite() {
            *v = 0.0;
            non_finite = true;
        } else if *v < 0.0 {
            *v = 0.0;
            negative = true;
        }
    }
    if non_finite {
        counts.non_finite += 1;
        counts.first_non_finite.get_or_insert(p);
    } else if negative {
        counts.negative += 1;
    }
}

impl<'a> Medium<'a> {
    pub fn new(
        density: &'a dyn FieldSampler,
        color: Option<&'a dyn FieldSampler>,
        emission: Option<&'a dyn FieldSampler>,
        majorants: &'a Majorants,
        kappa: DVec3,
        albedo: f64,
        motion: Option<&super::super::motion::Motion<'a>>,
    ) -> Medium<'a> {
        Medium {
            density: density.evaluator(),
            color: color.map(|c| c.evaluator()),
            emission: emission.map(|e| e.evaluator()),
            velocity: motion.map(|m| m.evaluator()),
            time: 0.0,
            shifted: (DVec3::NAN, DVec3::NAN),
            majorants,
            kappa,
            kappa_max: kappa.max_element(),
            albedo,
            scratch: [0.0; 3],
            counts: MediumCounts::default(),
        }
    }

    /// Where the medium at `p` was at the path's time: `p − v(p)·time` (`p` without motion).
    fn source_of(&mut self, p: DVec3) -> DVec3 {
        let Some(velocity) = self.velocity.as_mut() else {
            return p;
        };
        if self.shifted.0 == p {
            return self.shifted.1;
        }
        let mut v = [0.0; 3];
        velocity.eval_f64(&[p.x], &[p.y], &[p.z], &mut v);
        let v = DVec3::from_array(v);
        // A velocity that is not finite moves nothing.
        let q = if v.is_finite() { p - v * self.time } else { p };
        self.shifted = (p, q);
        q
    }

    /// The density at `p`, checked against the bound of its cell `bound`.
    fn density_at(&mut self, p: DVec3, bound: f64) -> f64 {
        let p = self.source_of(p);
        read(
            self.density.as_mut(),
            p,
            &mut self.scratch[..1],
            &mut self.counts.density,
        );
        let rho = f64::from(self.scratch[0]);
        if rho > bound {
            self.counts.above_majorant += 1;
            self.counts.first_above_majorant.get_or_insert(p);
        }
        rho
    }

    fn vector_at(&mut self, which: Field, p: DVec3) -> DVec3 {
        let p = self.source_of(p);
        let (eval, counts) = match which {
            Field::Color => (self.color.as_mut(), &mut self.counts.color),
            Field::Emission => (self.emission.as_mut(), &mut self.counts.emission),
        };
        match eval {
            Some(e) => {
                read(e.as_mut(), p, &mut self.scratch, counts);
                DVec3::new(
                    f64::from(self.scratch[0]),
                    f64::from(self.scratch[1]),
                    f64::from(self.scratch[2]),
                )
            }
            None => match which {
                Field::Color => DVec3::ONE,
                Field::Emission => DVec3::ZERO,
            },
        }
    }

    /// A free flight along `ray` over `[t0, t1]` (inside the box) by spectral delta tracking:
    /// updates the path weight `weight`, adds the emission it collects (times the weight) to
    /// `emitted`, and says how it ended.
    pub fn fly(
        &mut self,
        ray: &Ray,
        t0: f64,
        t1: f64,
        weight: &mut DVec3,
        emitted: &mut DVec3,
        random: &mut PathRandom,
    ) -> Flight {
        let majorants = self.majorants;
        let emission_rate = majorants.emission_rate();
        for segment in majorants.walk(ray, t0, t1) {
            let mut majorant = self.kappa_max * segment.density;
            if segment.emissive {
                majorant = majorant.max(emission_rate);
            }
            if majorant <= 0.0 {
                continue;
            }
            // Exponential flights are memoryless: each cell starts its own.
            let mut t = segment.t0;
            loop {
                t += random.optical_depth() / majorant;
                if t >= segment.t1 {
                    break;
                }
                let p = ray.at(t);
                let rho = self.density_at(p, segment.density);
                if self.emission.is_some() {
                    *emitted += *weight * self.vector_at(Field::Emission, p) / majorant;
                }
                let extinction = self.kappa * rho;
                let scattering = if rho > 0.0 && self.albedo > 0.0 {
                    extinction * self.albedo * self.vector_at(Field::Color, p)
                } else {
                    DVec3::ZERO
                };
                let absorption = (extinction - scattering).max(DVec3::ZERO);
                let null = (DVec3::splat(majorant) - extinction).max(DVec3::ZERO);
                let (ca, cs, cn) = (
                    weight.dot(absorption),
                    weight.dot(scattering),
                    weight.dot(null),
                );
                let total = ca + cs + cn;
                if total.is_nan() || total <= 0.0 {
                    return Flight::Absorbed;
                }
                // The event's probability `P_x = c_x / total`; the weight's factor
                // `σx/(μ̄·P_x) = σx·total/(μ̄·c_x)`.
                let u = random.uniform() * total;
                if u < ca {
                    return Flight::Absorbed;
                }
                if u < ca + cs {
                    *weight *= scattering * (total / (majorant * cs));
                    return Flight::Scattered(t);
                }
                *weight *= null * (total / (majorant * cn));
            }
        }
        Flight::Escaped
    }

    /// The transmittance per channel along `ray` over `[t0, t1]` (inside the box) by ratio
    /// tracking: the product of `1 − σt/μ̄` over tentative collisions, with Russian roulette
    /// once it is small (unbiased: a survivor's estimate is divided by its chance).
    pub fn transmittance(&mut self, ray: &Ray, t0: f64, t1: f64, random: &mut PathRandom) -> DVec3 {
        let mut transmittance = DVec3::ONE;
        let majorants = self.majorants;
        for segment in majorants.walk(ray, t0, t1) {
            let majorant = self.kappa_max * segment.density;
            if majorant <= 0.0 {
                continue;
            }
            let mut t = segment.t0;
            loop {
                t += random.optical_depth() / majorant;
                if t >= segment.t1 {
                    break;
                }
                let rho = self.density_at(ray.at(t), segment.density);
                transmittance *= DVec3::ONE - self.kappa * (rho / majorant);
                if transmittance.abs().max_element() < ROULETTE_BELOW {
                    if random.uniform() >= ROULETTE_SURVIVAL {
                        return DVec3::ZERO;
                    }
                    transmittance /= ROULETTE_SURVIVAL;
                }
            }
        }
        transmittance
    }
}

/// Ratio tracking plays Russian roulette below this transmittance...
const ROULETTE_BELOW: f64 = 0.1;
/// ...and a shadow ray survives it with this chance.
const ROULETTE_SURVIVAL: f64 = 0.5;

#[derive(Clone, Copy)]
enum Field {
    Color,
    Emission,
}
