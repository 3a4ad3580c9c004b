//! Shapes as fields: closed-form profiles built from field nodes, so interval evaluation
//! bounds them like any other expression and pruning finds them zero away from the shape.

use super::Field;
use super::node::MathFn;
use crate::base::failure::Outcome;
use crate::grid::frustum::IndexMap;

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

/// The map from a frustum cache's index coordinates to world points as a field, so that a
/// cache fill evaluates `compose(f, map)` at its cell centres: the values of `f` at the centres
/// of the frustum's cells (DNB's back-interpolation at voxel centres).
pub fn frustum_cell_to_world(map: &IndexMap) -> Outcome<Field> {
    let v = &map.view;
    let q = Field::identity();
    let number = Field::constant_scalar;
    let linear = |axis: usize, (scale, offset): (f64, f64)| -> Outcome<Field> {
        q.component(axis)?.mul(&number(scale))?.add(&number(offset))
    };
    let depth = linear(2, map.depth)?;
    let across = linear(0, map.across)?;
    let upward = linear(1, map.upward)?;
    let (mut across, mut upward) = (
        across.mul(&number(v.half_width))?,
        upward.mul(&number(v.half_height))?,
    );
    if !v.orthographic {
        across = across.mul(&depth)?;
        upward = upward.mul(&depth)?;
    }
    Field::constant_vector(v.eye)
        .add(&Field::constant_vector(v.forward).mul(&depth)?)?
        .add(&Field::constant_vector(v.right).mul(&across)?)?
        .add(&Field::constant_vector(v.up).mul(&upward)?)
}

#[cfg(test)]
mod tests {
    use super::frustum_cell_to_world;
    use crate::base::test_random::SplitMix;
    use crate::field::CompiledField;
    use crate::grid::frustum::{Frustum, View};
    use crate::space::FieldSampler;
    use glam::DVec3;

    /// The field a frustum cache is filled through sends every index point where the frustum's
    /// own map does (computed there in plain arithmetic), for perspective and orthographic
    /// cameras, padded or not, inside the cells and beyond them.
    #[test]
    fn the_frustum_field_is_the_frustums_index_to_world_map() {
        let mut random = SplitMix(0xf7);
        for case in 0..24 {
            let eye = random.vector(-3.0, 3.0);
            let forward = random.vector(-1.0, 1.0).normalize();
            let right = forward.cross(DVec3::Y).normalize();
            let half_width = random.range(0.2, 1.5);
            let view = View {
                eye,
                right,
                up: right.cross(forward),
                forward,
                half_width,
                half_height: half_width * random.range(0.4, 1.0),
                orthographic: case % 3 == 0,
            };
            let pixels = [
                5 + random.below(20),
                4 + random.below(12),
                3 + random.below(30),
            ];
            let near = random.range(0.1, 2.0);
            let frustum = Frustum::new(
                view,
                near,
                near + random.range(0.5, 50.0),
                pixels,
                case % 3,
                1,
            )
            .unwrap();
            let map = frustum_cell_to_world(&frustum.index_map()).unwrap();
            let compiled = CompiledField::new(&map);
            let mut eval = compiled.evaluator();
            for _ in 0..50 {
                let q = random.vector(-2.0, 40.0);
                let mut out = [0.0; 3];
                eval.eval_f64(&[q.x], &[q.y], &[q.z], &mut out);
                let expected = frustum.index_to_world(q);
                let got = DVec3::from_array(out);
                assert!(
                    (got - expected).length() <= 1e-9 * (1.0 + expected.length()),
                    "case {case}, index {q}: field {got}, frustum {expected}"
                );
            }
        }
    }
}
