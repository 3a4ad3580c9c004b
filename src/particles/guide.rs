//! Guide particles: the frame, scale and noise offset that wisps and flame wisps are built
//! around (seed 004, wisp step 5).
//!
//! The key decision: every guide attribute is optional, with the default that leaves a dot
//! where the generator put it: `N`, `right`, `tangent` default to the x, y and z axes (the
//! thesis maps a dot's local x, y, z onto N, right, tangent), `scale` and `scale2` to 1 and
//! `offset` (added to noise lookups, so guides sharing one noise field still differ) to 0.

use super::Particles;
use crate::base::failure::Outcome;
use glam::DVec3;

/// One guide's frame and parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Guide {
    pub position: DVec3,
    pub normal: DVec3,
    pub right: DVec3,
    pub tangent: DVec3,
    pub scale: f64,
    pub scale2: f64,
    pub offset: DVec3,
}

impl Guide {
    /// A dot's guide-local point `p` in world space: `X₀ + (p.x N + p.y r + p.z t) S`.
    pub fn place(&self, p: DVec3) -> DVec3 {
        self.position + (self.normal * p.x + self.right * p.y + self.tangent * p.z) * self.scale
    }

    /// Does `place` leave finite points where they are (up to the sign of zero)? For such a
    /// guide `place(p)` is `p + 0`, bit for bit: the frame's zero terms add zeros, the scale
    /// multiplies by one and the position adds +0, which turns −0 into +0.
    pub fn is_identity(&self) -> bool {
        self.position == DVec3::ZERO
            && (self.normal, self.right, self.tangent) == (DVec3::X, DVec3::Y, DVec3::Z)
            && self.scale == 1.0
    }
}

fn vector(v: [f32; 3]) -> DVec3 {
    DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)
}

/// The guides of a particle set.
pub fn guides(set: &Particles) -> Outcome<Vec<Guide>> {
    set.check_finite("guide particles")?;
    let vectors = |name: &str, default: DVec3| -> Outcome<Vec<DVec3>> {
        Ok(match set.attribute(name) {
            None => vec![default; set.len()],
            Some(_) => set.vectors(name)?.iter().map(|v| vector(*v)).collect(),
        })
    };
    let floats = |name: &str| -> Outcome<Vec<f64>> {
        Ok(match set.attribute(name) {
            None => vec![1.0; set.len()],
            Some(_) => set.floats(name)?.iter().map(|&v| v as f64).collect(),
        })
    };
    let normal = vectors("N", DVec3::X)?;
    let right = vectors("right", DVec3::Y)?;
    let tangent = vectors("tangent", DVec3::Z)?;
    let offset = vectors("offset", DVec3::ZERO)?;
    let (scale, scale2) = (floats("scale")?, floats("scale2")?);
    Ok((0..set.len())
        .map(|i| Guide {
            position: vector(set.positions[i]),
            normal: normal[i],
            right: right[i],
            tangent: tangent[i],
            scale: scale[i],
            scale2: scale2[i],
            offset: offset[i],
        })
        .collect())
}
