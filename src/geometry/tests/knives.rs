//! Cuts by several plane knives against the arrangement of their planes, counted without felt:
//! the distinct sign vectors of a dense lattice of points inside the ball, with their volumes.

use super::*;
use crate::field::Field;
use crate::geometry::knives::cut;

type Plane = (DVec3, DVec3);

fn knife((point, normal): Plane) -> Field {
    Field::identity()
        .sub(&Field::constant_vector(point))
        .unwrap()
        .mul(&Field::constant_vector(normal.normalize()))
        .unwrap()
}

fn unit_ball() -> Field {
    Field::constant_scalar(1.0)
        .sub(&Field::identity().length().unwrap())
        .unwrap()
}

/// The volume of every region of the planes' arrangement inside the unit ball, from the sign
/// vectors of `n³` lattice points.
fn arrangement(planes: &[Plane], n: usize) -> Vec<f64> {
    let mut counts = std::collections::HashMap::new();
    let h = 2.0 / n as f64;
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let p = DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * h - DVec3::ONE;
                if p.length() >= 1.0 {
                    continue;
                }
                let code = planes.iter().enumerate().fold(0u64, |code, (b, (q, m))| {
                    code | (((p - *q).dot(*m) >= 0.0) as u64) << b
                });
                *counts.entry(code).or_insert(0usize) += 1;
            }
        }
    }
    let mut volumes: Vec<f64> = counts.values().map(|&c| c as f64 * h * h * h).collect();
    volumes.sort_by(f64::total_cmp);
    volumes
}

/// Pieces and their total volume for a cut over the cube around the ball at `res` cells.
fn pieces_at(planes: &[Plane], res: usize) -> (usize, f64) {
    let knives: Vec<Field> = planes.iter().map(|&p| knife(p)).collect();
    let cell = 2.2 / res as f64;
    let d = Domain::with_cells(
        DVec3::splat(-1.1),
        DVec3::splat(2.2),
        DVec3::ZERO,
        cell,
        cell,
    )
    .unwrap();
    let result = cut(&unit_ball(), &knives, &d, 8.0 * cell * cell * cell).unwrap();
    for piece in &result.pieces {
        assert!(piece.is_closed(), "every piece is a closed mesh");
    }
    let total = result.pieces.iter().map(|p| p.volume()).sum();
    (result.pieces.len(), total)
}

fn plane(p: [f64; 3], n: [f64; 3]) -> Plane {
    (DVec3::from_array(p), DVec3::from_array(n).normalize())
}

/// Four planes through one tilted axis and four across it: 8 wedges × 5 slabs = 40 regions,
/// none thin.
fn pencil_and_slabs() -> Vec<Plane> {
    let axis = DVec3::new(0.1, 1.0, 0.05).normalize();
    let centre = DVec3::new(0.03, 0.0, -0.02);
    let across = axis.cross(DVec3::X).normalize();
    let other = axis.cross(across);
    let mut planes = Vec::new();
    for k in 0..4 {
        let angle = (10.0 + 45.0 * k as f64).to_radians();
        planes.push((centre, across * angle.cos() + other * angle.sin()));
    }
    for offset in [-0.6, -0.2, 0.2, 0.6] {
        planes.push((centre + axis * (offset + 0.01), axis));
    }
    planes
}

#[test]
fn several_knives_give_the_regions_of_their_arrangement() {
    let three = vec![
        plane([0.1, 0.0, 0.0], [1.0, 0.3, 0.0]),
        plane([0.0, 0.2, 0.0], [0.2, 1.0, 0.1]),
        plane([0.0, 0.0, -0.3], [0.3, -0.2, 1.0]),
    ];
    let five = vec![
        plane([0.339, 0.315, 0.135], [0.271, 0.130, -0.954]),
        plane([0.218, -0.229, 0.363], [0.127, -0.849, 0.513]),
        plane([-0.374, 0.265, 0.332], [-0.719, -0.624, -0.306]),
        plane([0.143, 0.056, 0.362], [0.738, 0.673, -0.044]),
        plane([-0.385, 0.179, 0.155], [0.719, 0.669, 0.186]),
    ];
    let eight = pencil_and_slabs();
    let sphere = 4.0 / 3.0 * std::f64::consts::PI;
    for (planes, closed_form) in [(three, Some(8)), (five, None), (eight, Some(40))] {
        let regions = arrangement(&planes, 160);
        if let Some(count) = closed_form {
            assert_eq!(regions.len(), count);
        }
        // Every region is far above the sliver volume at the coarser resolution tested (8 cells
        // of 2.2/32): these resolutions resolve the arrangement.
        let sliver = 8.0 * (2.2f64 / 32.0).powi(3);
        assert!(regions[0] > 3.0 * sliver, "{regions:?}");
        let mut shortfall = Vec::new();
        for res in [32, 48] {
            let (count, total) = pieces_at(&planes, res);
            assert_eq!(
                count,
                regions.len(),
                "{} knives at {res} cells",
                planes.len()
            );
            shortfall.push(sphere - total);
        }
        // The pieces fill the ball up to a first-order error at their edges, which shrinks
        // with the cell.
        assert!(
            shortfall[0] > 0.0 && shortfall[1] < shortfall[0],
            "{shortfall:?}"
        );
        assert!(shortfall[1] < 0.06 * sphere, "{shortfall:?}");
    }
}

#[test]
fn slivers_never_add_pieces() {
    // Two knives crossing at 1.15° through the centre: two thin wedges (about 0.013 of volume
    // each) that a 24-cell grid cannot resolve along their edge. Whatever survives of them, a
    // cut never returns more pieces than the four regions, every piece it returns is above
    // the minimum volume, and what it drops is small.
    let planes = [
        plane([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
        plane([0.0, 0.0, 0.0], [1.0, 0.02, 0.0]),
    ];
    let knives: Vec<Field> = planes.iter().map(|&p| knife(p)).collect();
    for res in [24, 48] {
        let cell = 2.2 / res as f64;
        let d = Domain::with_cells(
            DVec3::splat(-1.1),
            DVec3::splat(2.2),
            DVec3::ZERO,
            cell,
            cell,
        )
        .unwrap();
        let least = 8.0 * cell * cell * cell;
        let result = cut(&unit_ball(), &knives, &d, least).unwrap();
        assert!(
            (2..=4).contains(&result.pieces.len()),
            "{}",
            result.pieces.len()
        );
        assert!(result.pieces.iter().all(|p| p.volume() >= least));
        assert!(result.dropped_volume < 0.03, "{}", result.dropped_volume);
    }
    let cell = 2.2 / 24.0;
    let d = Domain::with_cells(
        DVec3::splat(-1.1),
        DVec3::splat(2.2),
        DVec3::ZERO,
        cell,
        cell,
    )
    .unwrap();
    let too_many: Vec<Field> = (0..64).map(|_| knives[0].clone()).collect();
    assert!(cut(&unit_ball(), &too_many, &d, 0.0).is_err());
    assert!(cut(&unit_ball(), &knives, &d, -1.0).is_err());
}
