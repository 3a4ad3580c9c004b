//! Splat tests on cases worked by hand: brick boundaries, the far faces, dense bricks and
//! splatting onto an earlier state. Cells are of size 1 from the origin, so cell `i` spans
//! `[i, i + 1)` with its centre at `i + 0.5`.

use super::Particles;
use super::splat::{Deposit, Indexer, Kernel, splat};
use crate::grid::cache::Cache;
use crate::space::domain::Domain;
use glam::DVec3;

/// `x × y × z` cells of size 1 from the origin.
fn boxed(x: f64, y: f64, z: f64) -> Domain {
    Domain::with_cells(DVec3::ZERO, DVec3::new(x, y, z), DVec3::ZERO, 1.0, 1.0).unwrap()
}

fn at(cache: &Cache, i: usize, j: usize, k: usize) -> f32 {
    cache.value_at_cell(i, j, k).unwrap()[0]
}

#[test]
fn a_point_between_two_bricks_is_shared_by_both() {
    // x = 8 is halfway between centres 7.5 (brick 0) and 8.5 (brick 1); y and z sit on the
    // first centres.
    let domain = boxed(16.0, 8.0, 8.0);
    let set = Particles::new(vec![[8.0, 0.5, 0.5]]);
    let (cache, report) =
        splat(&set, Deposit::One, Kernel::Trilinear, &domain, &[0.0], None).unwrap();
    assert_eq!(report.splatted, 1);
    assert_eq!(at(&cache, 7, 0, 0), 0.5);
    assert_eq!(at(&cache, 8, 0, 0), 0.5);
    assert_eq!(cache.bricks_total(), 2);
    assert_eq!(cache.bricks_filled(), 2);
}

#[test]
fn a_point_on_the_corner_of_eight_bricks_gives_each_an_eighth() {
    let domain = boxed(16.0, 16.0, 16.0);
    let set = Particles::new(vec![[8.0, 8.0, 8.0]]);
    let (cache, _) = splat(&set, Deposit::One, Kernel::Trilinear, &domain, &[0.0], None).unwrap();
    for k in [7, 8] {
        for j in [7, 8] {
            for i in [7, 8] {
                assert_eq!(at(&cache, i, j, k), 0.125, "cell {i} {j} {k}");
            }
        }
    }
    assert_eq!(cache.stored_bricks().count(), 8);
    // Cells one further out get nothing.
    assert_eq!(at(&cache, 6, 8, 8), 0.0);
    assert_eq!(at(&cache, 9, 8, 8), 0.0);
}

#[test]
fn the_far_faces_are_outside_and_just_inside_goes_to_the_border_cell() {
    let domain = boxed(4.0, 4.0, 4.0);
    let below_four = f32::from_bits(4.0f32.to_bits() - 1);
    let set = Particles::new(vec![
        [4.0, 1.5, 1.5],
        [1.5, 1.5, 4.0],
        [below_four, 1.5, 1.5],
        [0.0, 0.0, 0.0],
    ]);
    let (cache, report) =
        splat(&set, Deposit::One, Kernel::Trilinear, &domain, &[0.0], None).unwrap();
    assert_eq!((report.splatted, report.outside), (2, 2));
    // Past the last centre (3.5) all the weight along x stays in cell 3; y and z are centred.
    assert_eq!(at(&cache, 3, 1, 1), 1.0);
    // Before the first centres the whole value goes to the corner cell.
    assert_eq!(at(&cache, 0, 0, 0), 1.0);
    let (nearest, _) = splat(&set, Deposit::One, Kernel::Nearest, &domain, &[0.0], None).unwrap();
    assert_eq!(at(&nearest, 3, 1, 1), 1.0);
    assert_eq!(at(&nearest, 0, 0, 0), 1.0);
}

#[test]
fn a_partial_brick_at_the_far_faces_holds_what_lands_there() {
    // 10 cells along x: the second brick has two cells, 8 and 9.
    let domain = boxed(10.0, 3.0, 3.0);
    let set = Particles::new(vec![[9.25, 2.5, 2.5], [8.75, 2.5, 2.5]]);
    let (cache, _) = splat(&set, Deposit::One, Kernel::Trilinear, &domain, &[0.0], None).unwrap();
    // 9.25 lies 0.75 of the way from centre 8.5 to 9.5, and 8.75 lies 0.25 of the way.
    assert_eq!(at(&cache, 8, 2, 2), 0.25 + 0.75);
    assert_eq!(at(&cache, 9, 2, 2), 0.75 + 0.25);
    assert_eq!(at(&cache, 7, 2, 2), 0.0);
}

#[test]
fn a_dense_brick_sums_exactly_for_any_thread_count() {
    // More points than one batch bins, all in one brick: 1.75 is 0.25 past centre 1.5, and
    // z = 1.0 is halfway between centres 0.5 and 1.5. The sums stay below 2^24, so f32 holds
    // them exactly.
    let n = (1 << 22) + 100_000;
    let domain = boxed(4.0, 4.0, 4.0);
    let set = Particles::new(vec![[1.75, 0.5, 1.0]; n]);
    for threads in [1, 2, 3] {
        let (cache, _) = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| splat(&set, Deposit::One, Kernel::Trilinear, &domain, &[0.0], None))
            .unwrap();
        let n = n as f32;
        assert_eq!(at(&cache, 1, 0, 0), n * 0.375);
        assert_eq!(at(&cache, 2, 0, 0), n * 0.125);
        assert_eq!(at(&cache, 1, 0, 1), n * 0.375);
        assert_eq!(at(&cache, 2, 0, 1), n * 0.125);
    }
}

#[test]
fn splatting_onto_an_earlier_state_adds_where_it_lands_and_keeps_the_rest() {
    // Two bricks along x, background 0.5; the first splat lands in each brick, the second
    // only in the first.
    let domain = boxed(16.0, 8.0, 8.0);
    let first = Particles::new(vec![[2.5, 2.5, 2.5], [12.5, 3.5, 4.5]]);
    let masses = [2.0f32, 3.0];
    let (earlier, _) = splat(
        &first,
        Deposit::Float(&masses),
        Kernel::Nearest,
        &domain,
        &[0.5],
        None,
    )
    .unwrap();
    assert_eq!(at(&earlier, 2, 2, 2), 2.5);
    assert_eq!(at(&earlier, 12, 3, 4), 3.5);
    assert_eq!(at(&earlier, 0, 0, 0), 0.5);
    // 3.0 is halfway between centres 2.5 and 3.5 along x.
    let second = Particles::new(vec![[3.0, 2.5, 2.5]]);
    let (later, report) = splat(
        &second,
        Deposit::Float(&[4.0]),
        Kernel::Trilinear,
        &domain,
        &[0.5],
        Some(&earlier),
    )
    .unwrap();
    assert_eq!(report.splatted, 1);
    assert_eq!(at(&later, 2, 2, 2), 2.5 + 2.0);
    assert_eq!(at(&later, 3, 2, 2), 0.5 + 2.0);
    assert_eq!(at(&later, 12, 3, 4), 3.5);
    assert_eq!(at(&later, 5, 5, 5), 0.5);
    // The earlier state is unchanged.
    assert_eq!(at(&earlier, 2, 2, 2), 2.5);
    // A vector splat onto an earlier vector state adds component by component.
    let colors = [[1.0f32, 2.0, 3.0]];
    let (base, _) = splat(
        &second,
        Deposit::Vector(&colors),
        Kernel::Nearest,
        &domain,
        &[0.0, 0.0, 1.0],
        None,
    )
    .unwrap();
    let (twice, _) = splat(
        &second,
        Deposit::Vector(&colors),
        Kernel::Nearest,
        &domain,
        &[0.0, 0.0, 1.0],
        Some(&base),
    )
    .unwrap();
    // x = 3.0 lies in cell 3.
    assert_eq!(twice.value_at_cell(3, 2, 2).unwrap(), &[2.0, 4.0, 7.0]);
    assert_eq!(twice.value_at_cell(2, 2, 2).unwrap(), &[0.0, 0.0, 1.0]);
}

#[test]
fn splatting_onto_a_state_of_another_shape_is_a_failure() {
    let set = Particles::new(vec![[1.0, 1.0, 1.0]]);
    let (small, _) = splat(
        &set,
        Deposit::One,
        Kernel::Nearest,
        &boxed(4.0, 4.0, 4.0),
        &[0.0],
        None,
    )
    .unwrap();
    let other = boxed(8.0, 4.0, 4.0);
    assert!(
        splat(
            &set,
            Deposit::One,
            Kernel::Nearest,
            &other,
            &[0.0],
            Some(&small)
        )
        .is_err()
    );
}

#[test]
fn an_unrotated_domain_lands_particles_as_the_full_matrix_does() {
    // The per-axis shortcut drops the matrix's zero terms; landings must not change, at cell
    // faces, outside, at signed zeros and at non-finite coordinates alike.
    let domain = Domain::with_cells(
        DVec3::new(-1.3, 0.25, -4.0),
        DVec3::new(5.2, 3.0, 2.5),
        DVec3::ZERO,
        0.1,
        0.1,
    )
    .unwrap();
    let special = [
        -1.3,
        -1.2,
        0.0,
        -0.0,
        0.25,
        3.25,
        3.9,
        -4.0,
        -1.5,
        f32::MAX,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        1e-30,
    ];
    let mut rng = crate::base::test_random::SplitMix(5);
    let mut points = Vec::new();
    for &x in &special {
        for &y in &special {
            for &z in &special {
                points.push([x, y, z]);
            }
        }
    }
    // About a third of the random points land inside the domain.
    let (lo, hi) = ([-2.0, -0.5, -4.5], [4.5, 4.0, -1.0]);
    points.extend((0..20_000).map(|_| [0, 1, 2].map(|a| rng.range(lo[a], hi[a]) as f32)));
    for kernel in [Kernel::Nearest, Kernel::Trilinear] {
        let fast = Indexer::new(&domain, kernel).unwrap();
        let full = Indexer::new(&domain, kernel).unwrap().through_the_matrix();
        let mut landed = 0;
        for &p in &points {
            assert_eq!(fast.land(p), full.land(p), "{p:?}");
            landed += fast.land(p).is_some() as usize;
        }
        assert!(landed > 5000 && landed < points.len() - 5000, "{landed}");
    }
}
