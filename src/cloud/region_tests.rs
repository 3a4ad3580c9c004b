//! Region volumes and their thresholds: a probability becomes the nearest 16-bit threshold,
//! and the one-pass, pruned sampling of a region field equals the whole field's values cell by
//! cell and the closed-form ellipsoid profiles.

use super::bits::Planes;
use super::region::{Probabilities, Probability};
use super::tests::each_cell;
use crate::space::FieldSampler;
use crate::space::domain::Domain;
use glam::DVec3;

#[test]
fn a_probability_becomes_the_nearest_sixteen_bit_threshold() {
    use super::random::threshold;
    // The batch form agrees with the single one on every f32 it may meet, halves included.
    let mut batch = Vec::new();
    let values: Vec<f32> = (0..=65535u32 * 2)
        .map(|t| t as f32 / 131070.0)
        .chain([-1.0, 2.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e-30])
        .collect();
    super::random::thresholds(&values, &mut batch);
    for (&v, &t) in values.iter().zip(&batch) {
        assert_eq!(t, threshold(v as f64), "p = {v}");
    }
    for (p, t) in [
        (f64::NAN, 0),
        (-1.0, 0),
        (0.0, 0),
        (0.49 / 65535.0, 0),
        (0.5 / 65535.0, 1),
        (1.0, 65535),
        (7.0, 65535),
        (f64::INFINITY, 65535),
        (f64::NEG_INFINITY, 0),
    ] {
        assert_eq!(threshold(p), t, "p = {p}");
    }
    // Elsewhere in (0, 1) it is `p · 65535` rounded to the nearest whole number.
    let mut random = crate::base::test_random::SplitMix(11);
    for _ in 0..100_000 {
        let p = random.unit();
        assert_eq!(threshold(p), (p * 65535.0).round() as u16, "p = {p}");
    }
}

#[test]
fn region_volumes_sampled_in_one_pass_match_the_profiles_cell_by_cell() {
    // Five ellipsoids, two overlapping and one reaching past the domain; the three
    // probabilities of the cloud example: hum = r/4, act = r², ext = 0.02 + 0.3(1 − r)².
    let ellipsoids = [
        ([1.0, 0.5, 1.0], [0.8, 0.3, 0.6]),
        ([1.6, 0.5, 1.2], [0.7, 0.4, 0.5]),
        ([4.0, 0.6, 2.0], [1.0, 0.3, 1.0]),
        ([6.9, 0.4, 0.5], [0.6, 0.5, 0.9]),
        ([3.0, 0.5, 3.5], [0.4, 0.2, 0.3]),
    ];
    let mut r = crate::field::Field::constant_scalar(0.0);
    for (c, radii) in ellipsoids {
        let e =
            crate::field::shapes::ellipsoid_field(DVec3::from_array(c), DVec3::from_array(radii))
                .unwrap();
        r = crate::field::Field::max(&r, &e).unwrap();
    }
    let constant = crate::field::Field::constant_scalar;
    let one_minus = constant(1.0).sub(&r).unwrap();
    let hum = r.mul(&constant(0.25)).unwrap();
    let act = r.mul(&r).unwrap();
    let ext = constant(0.02)
        .add(
            &one_minus
                .mul(&one_minus)
                .unwrap()
                .mul(&constant(0.3))
                .unwrap(),
        )
        .unwrap();
    let joint = crate::field::Field::vector_from(&hum, &act, &ext).unwrap();
    let compiled = crate::field::CompiledField::prepared(&joint).unwrap();
    let n = [70, 10, 40];
    let d = Domain::with_cells(
        DVec3::ZERO,
        DVec3::new(7.0, 1.0, 4.0),
        DVec3::ZERO,
        0.1,
        0.1,
    )
    .unwrap();
    let planes = Planes::new(n);
    let sampled = Probabilities::sample(&compiled, &d, &planes);
    // Second route, unpruned: every cell centre through the whole field's evaluator.
    let mut values = [
        vec![0f32; planes.cells()],
        vec![0f32; planes.cells()],
        vec![0f32; planes.cells()],
    ];
    let mut eval = compiled.evaluator();
    for (cell, [i, j, k]) in each_cell(n).enumerate() {
        let p = d.cell_center(i, j, k);
        let mut out = [0f32; 3];
        eval.eval_f32(&[p.x], &[p.y], &[p.z], &mut out);
        for c in 0..3 {
            values[c][cell] = out[c];
        }
    }
    let mut inside = 0;
    for (c, probability) in [&sampled.hum, &sampled.act, &sampled.ext]
        .into_iter()
        .enumerate()
    {
        let Probability::Cells {
            thresholds,
            nonzero,
        } = probability
        else {
            panic!("component {c} is not per cell");
        };
        let Probability::Cells {
            thresholds: whole,
            nonzero: whole_nonzero,
        } = Probability::from_cells(&planes, &values[c])
        else {
            unreachable!()
        };
        assert_eq!(thresholds, &whole, "component {c}: pruned and whole differ");
        assert_eq!(nonzero, &whole_nonzero, "component {c}");
        // Third route, closed form in f64: within one unit of the 16-bit threshold.
        for (cell, [i, j, k]) in each_cell(n).enumerate() {
            let p = d.cell_center(i, j, k).to_array();
            let r = ellipsoids
                .iter()
                .map(|(centre, radii)| super::ellipsoid_profile(p, *centre, *radii))
                .fold(0.0, f64::max);
            let expected = [0.25 * r, r * r, 0.02 + 0.3 * (1.0 - r) * (1.0 - r)][c];
            let t = super::random::threshold(expected);
            assert!(
                thresholds[cell].abs_diff(t) <= 1,
                "component {c} cell {i} {j} {k}"
            );
            inside += (c == 0 && r > 0.0) as usize;
        }
    }
    assert!(inside > 500, "the ellipsoids cover {inside} cells");
}
