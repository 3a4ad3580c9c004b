//! Shapes as fields: closed-form profiles built from field nodes, so interval evaluation
//! bounds them like any other expression and pruning finds them zero away from the shape.

use super::Field;
use super::node::MathFn;
use crate::base::failure::Outcome;

/// The cloud regions' ellipsoid profile (`cloud::ellipsoid_profile`) as a field, `max(0, 1 − √Σ((p − c)/r)²)`, built from field nodes
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
