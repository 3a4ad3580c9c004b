//! Region volumes (seed 003, §4.3): the per-cell probabilities `p_hum`, `p_act` and `p_ext`
//! that say where clouds form, grow and fade.
//!
//! A region is any felt scalar field sampled at the automaton's cell centres — the source's
//! ellipsoids (1 at the centre falling linearly to 0 on the surface, combined by maximum) are
//! one such field, `cloudellipsoid`. The one key decision: sampled probabilities are stored as
//! 16-bit thresholds beside a bit plane of the cells where they are non-zero, so a step draws
//! random numbers only where an event can happen, and a field that is zero over most of the
//! sky costs nothing there.

use super::bits::Planes;
use super::random::threshold;
use crate::failure::Outcome;
use crate::field::{Field, MathFn};
use crate::grid::domain::Domain;
use crate::render::transmittance::sample_centres;
use crate::sample::FieldSampler;

/// One probability over the cells.
#[derive(Clone, Debug)]
pub enum Probability {
    /// The same threshold everywhere.
    Uniform(u16),
    /// Per cell, index `i + nx·(j + ny·k)`, with `nonzero` the plane of cells where the
    /// threshold is above zero.
    Cells {
        thresholds: Vec<u16>,
        nonzero: Vec<u64>,
    },
}

impl Probability {
    pub fn uniform(p: f64) -> Probability {
        Probability::Uniform(threshold(p))
    }

    /// Probabilities at the cell centres, index `i + nx·(j + ny·k)`; clamped to [0, 1].
    pub fn from_cells(planes: &Planes, values: &[f32]) -> Probability {
        let thresholds: Vec<u16> = values.iter().map(|&v| threshold(v as f64)).collect();
        let mut nonzero = vec![0u64; planes.len()];
        for k in 0..planes.nz {
            for j in 0..planes.ny {
                let row = planes.row(j, k);
                let first = planes.nx * row;
                for (i, t) in thresholds[first..first + planes.nx].iter().enumerate() {
                    if *t > 0 {
                        nonzero[row * planes.words + i / 64] |= 1 << (i % 64);
                    }
                }
            }
        }
        Probability::Cells {
            thresholds,
            nonzero,
        }
    }

    /// A region volume: `field` sampled at `domain`'s cell centres (bricks where its range is
    /// certainly zero are not evaluated; negative and non-finite values read as 0).
    pub fn sample(field: &dyn FieldSampler, domain: &Domain, planes: &Planes) -> Probability {
        let values = sample_centres(field, domain, [planes.nx, planes.ny, planes.nz]);
        Probability::from_cells(planes, &values)
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        match self {
            Probability::Uniform(_) => 0,
            Probability::Cells {
                thresholds,
                nonzero,
            } => thresholds.len() * 2 + nonzero.len() * 8,
        }
    }

    /// The cells of plane word `word` where the event may happen.
    #[inline]
    pub fn nonzero(&self, word: usize) -> u64 {
        match self {
            Probability::Uniform(0) => 0,
            Probability::Uniform(_) => u64::MAX,
            Probability::Cells { nonzero, .. } => nonzero[word],
        }
    }

    /// The threshold of cell `cell` (bit `bit` of plane word `word`).
    #[inline]
    pub fn at(&self, word: usize, bit: usize, cell: usize) -> u16 {
        match self {
            Probability::Uniform(t) => *t,
            Probability::Cells {
                thresholds,
                nonzero,
            } => {
                if nonzero[word] >> bit & 1 == 0 {
                    0
                } else {
                    thresholds[cell]
                }
            }
        }
    }
}

/// The three probabilities of a step.
#[derive(Clone, Debug)]
pub struct Probabilities {
    pub hum: Probability,
    pub act: Probability,
    pub ext: Probability,
}

impl Probabilities {
    /// No random events: the deterministic rules alone.
    pub fn none() -> Probabilities {
        Probabilities {
            hum: Probability::Uniform(0),
            act: Probability::Uniform(0),
            ext: Probability::Uniform(0),
        }
    }
}

/// The source's ellipsoid profile: 1 at `center`, falling linearly along each ray from it to
/// 0 on the surface `Σ ((p − c)/r)² = 1`, and 0 outside.
pub fn ellipsoid_profile(p: [f64; 3], center: [f64; 3], radii: [f64; 3]) -> f64 {
    let s: f64 = (0..3)
        .map(|a| ((p[a] - center[a]) / radii[a]).powi(2))
        .sum();
    (1.0 - s.sqrt()).max(0.0)
}

/// `ellipsoid_profile` as a felt field, `max(0, 1 − √Σ((p − c)/r)²)`, built from field nodes
/// so that interval evaluation finds it zero away from the ellipsoid.
pub fn ellipsoid_field(center: glam::DVec3, radii: glam::DVec3) -> Outcome<Field> {
    let p = Field::identity();
    let mut sum = Field::constant_scalar(0.0);
    for axis in 0..3 {
        let d = p
            .component(axis)?
            .sub(&Field::constant_scalar(center[axis]))?
            .div(&Field::constant_scalar(radii[axis]))?;
        sum = sum.add(&d.mul(&d)?)?;
    }
    let profile = Field::constant_scalar(1.0).sub(&sum.math(MathFn::Sqrt)?)?;
    Field::max(&profile, &Field::constant_scalar(0.0))
}
