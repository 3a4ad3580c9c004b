//! The sky: light arriving at the scene from every direction, from far away.
//!
//! Three kinds answer the same questions: a uniform radiance (`sky = (r, g, b)`), an
//! environment map (`envmap`: a lat-long OpenEXR image) and a physical daylight sky
//! (`physical`: Preetham's model, with its sun). Every kind tells the radiance arriving along
//! a direction (`radiance(direction)`, `direction` the unit vector a ray leaves the scene by,
//! +y the zenith); the map and the daylight sky also draw directions in proportion to their
//! brightness (`sample`, `pdf`), so the path tracer can reach them by next-event estimation
//! and weigh that against phase sampling. The one key decision: the uniform sky is not
//! sampled (every direction is equally likely under it, so phase sampling alone is already the
//! best estimator and its images stay exactly what they were); only the kinds that vary with
//! direction are.

pub mod distribution;
pub mod envmap;
pub mod latlong;
pub mod physical;
pub mod sun;

#[cfg(test)]
mod tests;

use envmap::EnvMap;
use glam::DVec3;
use physical::PhysicalSky;
use std::sync::Arc;

/// A direction drawn towards the sky: where it leads, the radiance arriving from there, and
/// the density per steradian with which it was drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkySample {
    pub direction: DVec3,
    pub radiance: DVec3,
    pub pdf: f64,
}

/// The light around the scene.
#[derive(Clone, Debug)]
pub enum Sky {
    /// The same radiance from every direction.
    Uniform(DVec3),
    /// A lat-long environment map.
    Environment(Arc<EnvMap>),
    /// Preetham's daylight sky (its sun is a separate distant light).
    Physical(Arc<PhysicalSky>),
}

impl Default for Sky {
    fn default() -> Sky {
        Sky::Uniform(DVec3::ZERO)
    }
}

impl PartialEq for Sky {
    fn eq(&self, other: &Sky) -> bool {
        match (self, other) {
            (Sky::Uniform(a), Sky::Uniform(b)) => a == b,
            (Sky::Environment(a), Sky::Environment(b)) => Arc::ptr_eq(a, b),
            (Sky::Physical(a), Sky::Physical(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }
}

impl From<DVec3> for Sky {
    fn from(radiance: DVec3) -> Sky {
        Sky::Uniform(radiance)
    }
}

impl Sky {
    /// The radiance arriving along the unit `direction` a ray leaves the scene by.
    pub fn radiance(&self, direction: DVec3) -> DVec3 {
        match self {
            Sky::Uniform(radiance) => *radiance,
            Sky::Environment(map) => map.radiance(direction),
            Sky::Physical(sky) => sky.radiance(direction),
        }
    }

    /// A direction drawn from two uniform numbers in [0, 1), in proportion to the sky's
    /// brightness; `None` for the uniform sky (never sampled) and for a draw of density zero.
    pub fn sample(&self, u1: f64, u2: f64) -> Option<SkySample> {
        let (direction, radiance, pdf) = match self {
            Sky::Uniform(_) => return None,
            Sky::Environment(map) => map.sample(u1, u2)?,
            Sky::Physical(sky) => sky.sample(u1, u2)?,
        };
        (pdf > 0.0 && pdf.is_finite()).then_some(SkySample {
            direction,
            radiance,
            pdf,
        })
    }

    /// The density per steradian with which `sample` draws the unit `direction` (0 for the
    /// uniform sky, which is never sampled).
    pub fn pdf(&self, direction: DVec3) -> f64 {
        match self {
            Sky::Uniform(_) => 0.0,
            Sky::Environment(map) => map.pdf(direction),
            Sky::Physical(sky) => sky.pdf(direction),
        }
    }

    /// Whether the sky is sampled by next-event estimation (every kind but the uniform one).
    pub fn is_sampled(&self) -> bool {
        !matches!(self, Sky::Uniform(_))
    }

    /// Whether the sky gives no light at all.
    pub fn is_black(&self) -> bool {
        match self {
            Sky::Uniform(radiance) => *radiance == DVec3::ZERO,
            Sky::Environment(map) => map.is_black(),
            Sky::Physical(sky) => sky.is_black(),
        }
    }
}
