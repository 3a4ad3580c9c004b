//! Where a path's light comes from: the scene's lights, reached by next-event estimation, and
//! the sky, reached by leaving the box.
//!
//! One interface for every source, the two questions a path tracer asks of it: what arrives
//! at a point from the source along a direction the source picks (`incident`: a delta light
//! answers with its one direction; a source with area would sample it and give a pdf), and what
//! a path sees when it leaves the render box along a direction (`escaping`: the sky's radiance;
//! nothing for a delta light, which no ray can hit). The one key decision: the uniform sky is
//! found only by escaping paths, so no sample of it needs weighing against another; a sky
//! that varies with direction (an environment map, the daylight sky) answers both, and each
//! answer is weighed by multiple importance sampling with the power heuristic (Veach 1997,
//! §9.2.4) against phase sampling, the strategy that finds it by escaping:
//!
//! ```text
//! w_light(ω) = p_light(ω)² / (p_light(ω)² + p_phase(ω)²),   w_phase(ω) = 1 − w_light(ω)
//! ```
//!
//! with both densities per steradian, so light the sky sends along a narrow bright patch is
//! found by sampling the sky, and light along a sharp forward phase lobe by sampling the phase.

use super::sampling::PathRandom;
use crate::render::light::Light;
use crate::render::sky::Sky;
use glam::DVec3;

/// Light arriving at a point from one source, unshadowed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Incident {
    /// Unit direction from the point towards the source.
    pub towards: DVec3,
    /// How far the source is along it (infinite for a distant light).
    pub distance: f64,
    /// Unit direction the light travels (`−towards`).
    pub travelling: DVec3,
    /// Irradiance per channel at the point, divided by the pdf of having picked this
    /// direction (for a delta light that pdf is a delta, and cancels).
    pub strength: DVec3,
    /// The density per steradian the direction was drawn with, for a source escaping paths
    /// also find (`None` for a delta light).
    pub pdf: Option<f64>,
}

/// The power heuristic's weight of a sample drawn with density `chosen` against another
/// strategy that draws the same direction with density `other`.
pub fn power_heuristic(chosen: f64, other: f64) -> f64 {
    let (a, b) = (chosen * chosen, other * other);
    if a + b > 0.0 { a / (a + b) } else { 0.0 }
}

/// The weight of a next-event sample of density `light_pdf` (`None`: a delta light, not
/// weighed) against phase sampling, whose density for the same direction is `phase_pdf`.
pub fn light_weight(light_pdf: Option<f64>, phase_pdf: f64) -> f64 {
    light_pdf.map_or(1.0, |pdf| power_heuristic(pdf, phase_pdf))
}

/// A source of light for the path tracer.
#[derive(Clone, Copy, Debug)]
pub enum Emitter<'a> {
    /// A distant or point light of the scene.
    Delta(&'a Light),
    /// A uniform sky of this radiance all around the box.
    Sky(DVec3),
    /// A sky that varies with direction, sampled and weighed.
    Environment(&'a Sky),
}

impl Emitter<'_> {
    /// What next-event estimation toward this source gives at `p`, if it is sampled that way.
    pub fn incident(&self, p: DVec3, random: &mut PathRandom) -> Option<Incident> {
        match self {
            Emitter::Delta(light) => {
                let (towards, distance) = light.towards(p);
                let (travelling, strength) = light.arriving(p);
                Some(Incident {
                    towards,
                    distance,
                    travelling,
                    strength,
                    pdf: None,
                })
            }
            Emitter::Sky(_) => None,
            Emitter::Environment(sky) => {
                let drawn = sky.sample(random.uniform(), random.uniform())?;
                Some(Incident {
                    towards: drawn.direction,
                    distance: f64::INFINITY,
                    travelling: -drawn.direction,
                    strength: drawn.radiance / drawn.pdf,
                    pdf: Some(drawn.pdf),
                })
            }
        }
    }

    /// The radiance a path leaving the box along `direction` sees from this source, weighed
    /// against next-event estimation where the source has it; `phase_pdf` is the density per
    /// steradian with which phase sampling drew `direction`, or `None` where the direction
    /// left a point no next-event estimate was made from (it then counts in full).
    pub fn escaping(&self, direction: DVec3, phase_pdf: Option<f64>) -> DVec3 {
        match self {
            Emitter::Delta(_) => DVec3::ZERO,
            Emitter::Sky(radiance) => *radiance,
            Emitter::Environment(sky) => match phase_pdf {
                Some(pdf) => sky.radiance(direction) * power_heuristic(pdf, sky.pdf(direction)),
                None => sky.radiance(direction),
            },
        }
    }
}
