//! Pruning (`field::prune`) keeps values bit for bit: a field specialised to a box gives, at
//! every point of the box, exactly the bits of the whole field, signed zeros included. Random
//! fields are drawn from a small grammar rich in `max`, `min`, `select`, negation and zeros of
//! both signs (the cases the pruning rules reason about), over random boxes that often sit on
//! one side of a zero; and the maximum of many `max(profile, 0)` ellipsoids, the shape of cloud
//! region volumes, must actually shrink to the one ellipsoid that reaches a box.

use crate::base::test_random::SplitMix;
use crate::field::node::MathFn;
use crate::field::{CompiledField, Field};
use crate::space::{Aabb, FieldSampler};
use glam::DVec3;

fn coordinate(i: usize) -> Field {
    Field::identity().component(i).unwrap()
}

/// A random scalar field of about `depth` levels.
fn random_field(random: &mut SplitMix, depth: usize) -> Field {
    if depth == 0 || random.below(5) == 0 {
        return match random.below(5) {
            0 => Field::constant_scalar(0.0),
            1 => Field::constant_scalar(-0.0),
            2 => Field::constant_scalar(random.range(-2.0, 2.0)),
            _ => coordinate(random.below(3)),
        };
    }
    let a = random_field(random, depth - 1);
    let b = random_field(random, depth - 1);
    match random.below(11) {
        0 | 1 => Field::max(&a, &b).unwrap(),
        2 | 3 => Field::min(&a, &b).unwrap(),
        4 => Field::select(&random_field(random, depth - 1), &a, &b).unwrap(),
        5 => a.neg(),
        6 => a.mul(&b).unwrap(),
        7 => a.add(&b).unwrap(),
        8 => a.sub(&b).unwrap(),
        9 => a.math(MathFn::Sqrt).unwrap(),
        _ => a.math(MathFn::Abs).unwrap(),
    }
}

/// A box that often has a coordinate range on one side of zero or touching it.
fn random_box(random: &mut SplitMix) -> Aabb {
    let mut lo = DVec3::ZERO;
    let mut hi = DVec3::ZERO;
    for a in 0..3 {
        let (l, h) = match random.below(4) {
            0 => (0.0, random.range(0.0, 2.0)),
            1 => (-random.range(0.0, 2.0), 0.0),
            2 => {
                let c = random.range(-2.0, 2.0);
                (c, c + random.range(0.0, 0.2))
            }
            _ => (random.range(-2.0, 0.0), random.range(0.0, 2.0)),
        };
        lo[a] = l;
        hi[a] = h;
    }
    Aabb::new(lo, hi)
}

/// Values at `points` as raw bits.
fn bits(field: &CompiledField, points: &[DVec3]) -> Vec<u64> {
    let xs: Vec<f64> = points.iter().map(|p| p.x).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.y).collect();
    let zs: Vec<f64> = points.iter().map(|p| p.z).collect();
    let mut out = vec![0.0; points.len()];
    field.evaluator().eval_f64(&xs, &ys, &zs, &mut out);
    out.iter().map(|v| v.to_bits()).collect()
}

/// Corners, centre, zeros on the box's faces and random points of `region`.
fn points_in(random: &mut SplitMix, region: &Aabb) -> Vec<DVec3> {
    let mut points = Vec::new();
    for n in 0..8 {
        let pick = |bit: usize, a: usize| {
            if n & bit != 0 {
                region.max[a]
            } else {
                region.min[a]
            }
        };
        points.push(DVec3::new(pick(1, 0), pick(2, 1), pick(4, 2)));
    }
    points.push((region.min + region.max) * 0.5);
    // Where a face lies on zero, both signs of zero.
    for a in 0..3 {
        for zero in [0.0, -0.0] {
            if region.min[a] <= 0.0 && region.max[a] >= 0.0 {
                let mut p = (region.min + region.max) * 0.5;
                p[a] = zero;
                points.push(p);
            }
        }
    }
    while points.len() < 64 {
        let t = DVec3::new(random.unit(), random.unit(), random.unit());
        points.push(region.min + (region.max - region.min) * t);
    }
    points
}

#[test]
fn pruned_fields_give_the_same_bits_inside_their_box() {
    let mut random = SplitMix(41);
    let mut pruned_count = 0;
    for case in 0..400 {
        let field = random_field(&mut random, 5);
        let compiled = CompiledField::new(&field);
        for _ in 0..6 {
            let region = random_box(&mut random);
            let Some(pruned) = compiled.pruned(&region) else {
                continue;
            };
            pruned_count += 1;
            assert!(
                pruned.len() < compiled.len(),
                "case {case}: pruning made it longer"
            );
            let points = points_in(&mut random, &region);
            assert_eq!(
                bits(&pruned, &points),
                bits(&compiled, &points),
                "case {case}, box {region:?}"
            );
        }
    }
    // The grammar's fields are small; a good share of them must still prune somewhere.
    assert!(
        pruned_count > 300,
        "only {pruned_count} boxes pruned anything"
    );
}

#[test]
fn a_maximum_of_ellipsoids_prunes_to_the_one_that_reaches_a_box() {
    // Twelve ellipsoid profiles max(1 − |(x − c)/r|, 0), in a row along x, 3 apart.
    let mut region_volume = Field::constant_scalar(0.0);
    for i in 0..12 {
        let centre = DVec3::new(3.0 * i as f64, 0.0, 0.0);
        let radii = DVec3::new(1.0, 0.5, 0.8);
        let profile = crate::field::shapes::ellipsoid_field(centre, radii).unwrap();
        region_volume = Field::max(&region_volume, &profile).unwrap();
    }
    let compiled = CompiledField::new(&region_volume);
    // A box inside the fifth ellipsoid's reach and nobody else's.
    let region = Aabb::new(DVec3::new(11.6, -0.2, -0.3), DVec3::new(12.5, 0.2, 0.3));
    let pruned = compiled
        .pruned(&region)
        .expect("the box decides the other eleven");
    assert!(
        pruned.len() * 5 < compiled.len(),
        "{} of {} instructions kept",
        pruned.len(),
        compiled.len()
    );
    let mut random = SplitMix(7);
    let points = points_in(&mut random, &region);
    assert_eq!(bits(&pruned, &points), bits(&compiled, &points));
}
