//! Where a path's light comes from: the scene's lights, reached by next-event estimation, and
//! the sky, reached by leaving the box.
//!
//! One interface for every source, the two questions a path tracer asks of it: what arrives
//! at a point from the source along a direction the source picks (`incident`: a delta light
//! answers with its one direction; a source with area would sample it and give a pdf), and what
//! a path sees when it leaves the render box along a direction (`escaping`: the sky's radiance;
//! nothing for a delta light, which no ray can hit). The one key decision: the uniform sky is
//! found only by escaping paths, so no sample of it needs weighing against another; an
//! environment map joins as a third kind that answers both and is weighed by multiple
//! importance sampling.

use crate::render::light::Light;
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
}

/// A source of light for the path tracer.
#[derive(Clone, Copy, Debug)]
pub enum Emitter<'a> {
    /// A distant or point light of the scene.
    Delta(&'a Light),
    /// A uniform sky of this radiance all around the box.
    Sky(DVec3),
}

impl Emitter<'_> {
    /// What next-event estimation toward this source gives at `p`, if it is sampled that way.
    pub fn incident(&self, p: DVec3) -> Option<Incident> {
        match self {
            Emitter::Delta(light) => {
                let (towards, distance) = light.towards(p);
                let (travelling, strength) = light.arriving(p);
                Some(Incident {
                    towards,
                    distance,
                    travelling,
                    strength,
                })
            }
            Emitter::Sky(_) => None,
        }
    }

    /// The radiance a path leaving the box along `direction` sees from this source.
    pub fn escaping(&self, _direction: DVec3) -> DVec3 {
        match self {
            Emitter::Delta(_) => DVec3::ZERO,
            Emitter::Sky(radiance) => *radiance,
        }
    }
}
