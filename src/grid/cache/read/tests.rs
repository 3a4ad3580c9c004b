use crate::grid::cache::test_support::*;
use crate::grid::cache::{BRICK, Cache};
use crate::space::domain::Domain;
use crate::space::{Aabb, FnField, GridSource, Interp};
use glam::DVec3;
use std::sync::Arc;

#[test]
fn linear_field_is_reproduced_in_a_rotated_domain() {
    let d = domain(
        DVec3::new(0.3, -0.7, 0.2),
        DVec3::new(1.3, 0.9, 1.1),
        DVec3::new(0.4, -0.3, 0.8),
        0.1,
    );
    let slope = DVec3::new(2.0, -3.0, 0.5);
    let line = move |p: DVec3| 1.0 + slope.dot(p);
    let cache = scalar_cache(d.clone(), line);
    // Include the domain's corners, where both rules extrapolate over the half-cell border.
    let mut points = points_inside(&d, 400);
    points.extend(
        d.corners()
            .iter()
            .map(|&c| c + (d.bounds().center() - c) * 1e-9),
    );
    for interp in [Interp::Linear, Interp::Cubic] {
        let values = sample(&cache, interp, &points);
        let gradients = gradient(&cache, interp, &points);
        let n = points.len();
        for (i, p) in points.iter().enumerate() {
            // f32 storage of values of size ~5: about 5e-7 per sample.
            assert!((values[i] - line(*p)).abs() < 2e-6, "{interp:?} at {p}");
            let g = DVec3::new(gradients[i], gradients[n + i], gradients[2 * n + i]);
            // Sample rounding divided by the cell size.
            assert!(
                (g - slope).length() < 1e-4,
                "{interp:?} gradient {g} at {p}"
            );
        }
    }
}

#[test]
fn linear_vector_field_is_reproduced_componentwise() {
    let d = domain(
        DVec3::splat(-1.0),
        DVec3::new(2.0, 1.5, 1.0),
        DVec3::new(0.0, 0.0, 0.6),
        0.25,
    );
    let field = FnField::new(3, |p: DVec3, out: &mut [f64]| {
        out[0] = p.x - 2.0 * p.z;
        out[1] = 0.5 + p.y;
        out[2] = 3.0 * p.x + p.y + p.z;
    });
    let cache = Cache::from_field(d.clone(), 3, Arc::new(field), vec![0.0; 3], "v".into()).unwrap();
    let points = points_inside(&d, 200);
    let n = points.len();
    for interp in [Interp::Linear, Interp::Cubic] {
        let values = sample(&cache, interp, &points);
        let gradients = gradient(&cache, interp, &points);
        let jacobian = [[1.0, 0.0, -2.0], [0.0, 1.0, 0.0], [3.0, 1.0, 1.0]];
        for (i, p) in points.iter().enumerate() {
            let expected = [p.x - 2.0 * p.z, 0.5 + p.y, 3.0 * p.x + p.y + p.z];
            for c in 0..3 {
                assert!((values[c * n + i] - expected[c]).abs() < 2e-6);
                for j in 0..3 {
                    let g = gradients[(c * 3 + j) * n + i];
                    assert!(
                        (g - jacobian[c][j]).abs() < 1e-4,
                        "{interp:?} d{c}/dx{j} = {g}"
                    );
                }
            }
        }
    }
}

/// Largest error over fixed interior points of caches at cell sizes h, h/2, h/4, and the
/// orders measured between successive halvings.
fn measured_orders(interp: Interp) -> [f64; 2] {
    let wave =
        |p: DVec3| (3.0 * p.x + 0.4).sin() * (2.0 * p.y + 1.1).sin() * (2.5 * p.z - 0.3).cos();
    let points = points_in(DVec3::splat(0.3), DVec3::splat(0.7), 150);
    let errors: Vec<f64> = [16.0, 32.0, 64.0]
        .iter()
        .map(|cells| {
            let d = domain(DVec3::ZERO, DVec3::ONE, DVec3::ZERO, 1.0 / cells);
            let cache = scalar_cache(d, wave);
            let values = sample(&cache, interp, &points);
            points
                .iter()
                .zip(values)
                .map(|(p, v)| (v - wave(*p)).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    [
        (errors[0] / errors[1]).log2(),
        (errors[1] / errors[2]).log2(),
    ]
}

#[test]
fn cubic_reads_converge_at_third_order() {
    for order in measured_orders(Interp::Cubic) {
        assert!((2.6..=3.4).contains(&order), "cubic order {order}");
    }
}

#[test]
fn linear_reads_converge_at_second_order() {
    for order in measured_orders(Interp::Linear) {
        assert!((1.8..=2.2).contains(&order), "linear order {order}");
    }
}

#[test]
fn one_query_fills_only_its_stencil_bricks() {
    // 32 cells of size 1 per axis: 4 bricks per axis; index u = world - 0.5.
    for (interp, reach) in [(Interp::Linear, (0, 1)), (Interp::Cubic, (1, 2))] {
        for u in [
            DVec3::new(7.3, 7.6, 8.2),
            DVec3::splat(3.5),
            DVec3::new(0.1, 30.7, 15.9),
        ] {
            let cache = scalar_cache(
                domain(DVec3::ZERO, DVec3::splat(32.0), DVec3::ZERO, 1.0),
                |p| p.x,
            );
            sample(&cache, interp, &[u + DVec3::splat(0.5)]);
            // Cells floor(u) - reach.0 ..= floor(u) + reach.1, clipped to the grid.
            let bricks = |a: usize| {
                let low = (u[a].floor() as i64 - reach.0).max(0) as usize / BRICK;
                let high = (u[a].floor() as i64 + reach.1).min(31) as usize / BRICK;
                low..=high
            };
            let mut expected = 0;
            for bz in 0..4 {
                for by in 0..4 {
                    for bx in 0..4 {
                        let wanted = bricks(0).contains(&bx)
                            && bricks(1).contains(&by)
                            && bricks(2).contains(&bz);
                        expected += wanted as usize;
                        assert_eq!(cache.brick_resolved([bx, by, bz]), wanted, "{interp:?} {u}");
                    }
                }
            }
            assert_eq!(cache.bricks_filled(), expected);
            if interp == Interp::Linear {
                assert!(cache.bricks_filled() <= 8);
            }
        }
    }
    let cache = scalar_cache(
        domain(DVec3::ZERO, DVec3::splat(32.0), DVec3::ZERO, 1.0),
        |p| p.x,
    );
    sample(&cache, Interp::Linear, &[DVec3::new(7.8, 8.1, 8.7)]);
    assert_eq!(cache.bricks_filled(), 4);
}

#[test]
fn outside_the_domain_reads_the_background() {
    let d = domain(DVec3::ZERO, DVec3::ONE, DVec3::new(0.0, 0.5, 0.0), 0.125);
    let field = FnField::new(3, |p: DVec3, out: &mut [f64]| {
        out[0] = p.x;
        out[1] = p.y;
        out[2] = p.z;
    });
    let background = vec![0.25, -1.5, 7.0];
    let cache = Cache::from_field(
        d.clone(),
        3,
        Arc::new(field),
        background.clone(),
        "b".into(),
    )
    .unwrap();
    let outside = [
        DVec3::splat(-0.01),
        DVec3::new(0.5, 1.2, 0.5),
        DVec3::new(40.0, 0.0, 0.0),
    ];
    assert!(outside.iter().all(|&p| !d.contains(p)));
    for interp in [Interp::Linear, Interp::Cubic] {
        let values = sample(&cache, interp, &outside);
        let gradients = gradient(&cache, interp, &outside);
        for i in 0..outside.len() {
            for c in 0..3 {
                assert_eq!(values[c * 3 + i], background[c]);
            }
        }
        assert!(gradients.iter().all(|&g| g == 0.0));
    }
    assert_eq!(cache.bricks_filled(), 0);
    assert_eq!(GridSource::background(&cache), background);
    assert_eq!(cache.bounds(), d.bounds());
    assert_eq!(cache.cell_size(), DVec3::splat(0.125));
}

#[test]
fn range_contains_every_interpolated_value() {
    // Rough data: alternating signs make cubic overshoot and border extrapolation visible.
    let d = domain(
        DVec3::ZERO,
        DVec3::new(2.0, 2.0, 1.0),
        DVec3::new(0.0, 0.3, 0.0),
        0.125,
    );
    let rough = |p: DVec3| ((p.x * 40.0).sin() * (p.y * 33.0).cos() + p.z).round();
    let cache = scalar_cache(d.clone(), rough);
    let regions = [
        Aabb::new(DVec3::new(0.3, 0.4, 0.2), DVec3::new(0.6, 0.5, 0.4)),
        Aabb::new(DVec3::new(-0.1, -0.1, -0.1), DVec3::new(0.2, 0.3, 0.3)),
        Aabb::new(DVec3::new(1.0, 0.5, -0.6), DVec3::new(2.5, 2.5, 1.5)),
    ];
    for region in regions {
        let range = cache.range(&region)[0];
        for interp in [Interp::Linear, Interp::Cubic] {
            let points = points_in(region.min, region.max, 3000);
            for v in sample(&cache, interp, &points) {
                assert!(range.0 <= v && v <= range.1, "{v} outside {range:?}");
            }
        }
    }
    // A region beyond the domain reads only the background.
    let far = Aabb::new(DVec3::splat(10.0), DVec3::splat(11.0));
    assert_eq!(cache.range(&far), vec![(0.0, 0.0)]);
}

#[test]
fn range_of_empty_space_is_exactly_empty() {
    let d = domain(
        DVec3::splat(-1.0),
        DVec3::splat(2.0),
        DVec3::ZERO,
        1.0 / 32.0,
    );
    let ball = Ball {
        centre: DVec3::ZERO,
        radius: 0.3,
    };
    let field = FnField::new(1, move |p: DVec3, out: &mut [f64]| out[0] = ball.density(p));
    let cache = Cache::from_field(d, 1, Arc::new(field), vec![0.0], "e".into()).unwrap();
    let corner = Aabb::new(DVec3::splat(0.5), DVec3::splat(0.9));
    assert_eq!(cache.range(&corner), vec![(0.0, 0.0)]);
    let centre = cache.range(&Aabb::new(DVec3::splat(-0.1), DVec3::splat(0.1)))[0];
    assert!(centre.0 < 0.7 && centre.1 >= 1.0 - 0.5 / 32.0 * 3f64.sqrt() / 0.3);
    // Leaving the domain with a non-zero background brings the background in.
    let d = domain(DVec3::ZERO, DVec3::ONE, DVec3::ZERO, 0.25);
    let field = FnField::new(1, |_p: DVec3, out: &mut [f64]| out[0] = 2.0);
    let cache = Cache::from_field(d, 1, Arc::new(field), vec![-3.0], "e".into()).unwrap();
    // A constant other than zero is kept to within the rounding of the weighted sum: the
    // weights of a read need not sum to exactly one, so neither does its value.
    let inside = Aabb::new(DVec3::splat(0.1), DVec3::splat(0.9));
    let (lo, hi) = cache.range(&inside)[0];
    assert!(lo < 2.0 && hi > 2.0 && hi - lo < 1e-11, "{lo} {hi}");
    for v in sample(
        &cache,
        Interp::Linear,
        &points_in(inside.min, inside.max, 2000),
    ) {
        assert!(lo <= v && v <= hi, "{v} outside [{lo}, {hi}]");
    }
    for region in [
        Aabb::new(DVec3::splat(0.5), DVec3::splat(1.5)),
        Aabb::everything(),
    ] {
        let (lo, hi) = cache.range(&region)[0];
        assert!(lo == -3.0 && hi > 2.0 && hi < 2.0 + 1e-11, "{lo} {hi}");
    }
}

#[test]
fn small_regions_read_the_cells_they_reach() {
    // One brick holding a ball's surface: a small region beside it in the same brick reads
    // only its own empty cells, while the brick as a whole is not empty.
    let d = domain(DVec3::ZERO, DVec3::ONE, DVec3::ZERO, 1.0 / 32.0);
    let ball = Ball {
        centre: DVec3::splat(0.125),
        radius: 0.06,
    };
    let field = FnField::new(1, move |p: DVec3, out: &mut [f64]| out[0] = ball.density(p));
    let cache = Cache::from_field(d, 1, Arc::new(field), vec![0.0], "s".into()).unwrap();
    // Cells 0–7 along each axis form the first brick; the ball covers cells near 4.
    let brick = Aabb::new(DVec3::ZERO, DVec3::splat(0.25));
    assert!(cache.range(&brick)[0].1 > 0.5);
    // Cells 0–1 are more than a radius from the centre along the diagonal corner.
    let corner = Aabb::new(DVec3::splat(0.0), DVec3::splat(0.03));
    assert_eq!(cache.range_read(&corner, Interp::Linear), vec![(0.0, 0.0)]);
    // A cubic read reaches one cell further, still empty here; a region reaching the ball is not.
    assert_eq!(cache.range_read(&corner, Interp::Cubic), vec![(0.0, 0.0)]);
    let near = Aabb::new(DVec3::splat(0.1), DVec3::splat(0.11));
    assert!(cache.range_read(&near, Interp::Linear)[0].1 > 0.5);
    // Every linear read in the corner region is zero, as the range says.
    for v in sample(
        &cache,
        Interp::Linear,
        &points_in(corner.min, corner.max, 500),
    ) {
        assert_eq!(v, 0.0);
    }
}

#[test]
fn linear_matrix_field_is_reproduced_with_its_jacobian_layout() {
    let d = domain(
        DVec3::new(0.5, 0.0, -1.0),
        DVec3::splat(1.0),
        DVec3::new(0.3, 0.3, 0.0),
        0.125,
    );
    // Component c is c + b_c . p with b_c = (c, 1 - c, 0.5 c).
    let slope = |c: usize| DVec3::new(c as f64, 1.0 - c as f64, 0.5 * c as f64);
    let field = FnField::new(9, move |p: DVec3, out: &mut [f64]| {
        for (c, v) in out.iter_mut().enumerate() {
            *v = c as f64 + slope(c).dot(p);
        }
    });
    let cache = Cache::from_field(d.clone(), 9, Arc::new(field), vec![0.0; 9], "m".into()).unwrap();
    let points = points_inside(&d, 100);
    let n = points.len();
    for interp in [Interp::Linear, Interp::Cubic] {
        let values = sample(&cache, interp, &points);
        let gradients = gradient(&cache, interp, &points);
        for (i, p) in points.iter().enumerate() {
            for c in 0..9 {
                let expected = c as f64 + slope(c).dot(*p);
                assert!((values[c * n + i] - expected).abs() < 1e-5);
                for j in 0..3 {
                    let g = gradients[(c * 3 + j) * n + i];
                    assert!(
                        (g - slope(c)[j]).abs() < 1e-3,
                        "{interp:?} d{c}/dx{j} = {g}"
                    );
                }
            }
        }
    }
}

#[test]
fn a_domain_inside_the_cache_on_its_cells_copies_them() {
    // Cells of 1/16 over [-1, 1]³; a fitted domain over [-0.5, 0.75] × [0, 1] × [-1, 0.25] has
    // the same cells, offset by (8, 16, 0).
    let d = domain(
        DVec3::splat(-1.0),
        DVec3::splat(2.0),
        DVec3::ZERO,
        1.0 / 16.0,
    );
    let wave = |p: DVec3| (p.x * 3.0).sin() + p.y * p.z;
    let cache = scalar_cache(d, wave);
    let inner = Domain::fitted(
        DVec3::new(-0.5, 0.0, -1.0),
        DVec3::new(1.25, 1.0, 1.25),
        DVec3::ZERO,
        1.0 / 16.0,
    )
    .unwrap();
    let (lo, hi) = ([3, 0, 5], [12, 16, 20]);
    let count = (0..3).map(|a| hi[a] - lo[a]).product::<usize>();
    let mut copied = vec![0f32; count];
    assert!(GridSource::cells(&cache, &inner, lo, hi, &mut copied));
    // The values a read gives at the inner domain's cell centres, which lie on the cache's.
    let mut centres = Vec::new();
    for k in lo[2]..hi[2] {
        for j in lo[1]..hi[1] {
            for i in lo[0]..hi[0] {
                centres.push(inner.cell_center(i, j, k));
            }
        }
    }
    let read = sample(&cache, Interp::Linear, &centres);
    for ((c, r), p) in copied.iter().zip(&read).zip(&centres) {
        assert_eq!(f64::from(*c), *r, "at {p}");
    }
    // Cells that are not the cache's own (shifted by half a cell, or another size) are
    // refused, and so is a domain reaching past the cache.
    let shifted = Domain::fitted(
        DVec3::new(-0.5 + 1.0 / 32.0, 0.0, -1.0),
        DVec3::new(1.25, 1.0, 1.25),
        DVec3::ZERO,
        1.0 / 16.0,
    )
    .unwrap();
    assert!(!GridSource::cells(&cache, &shifted, lo, hi, &mut copied));
    let finer = Domain::fitted(DVec3::splat(-0.5), DVec3::ONE, DVec3::ZERO, 1.0 / 32.0).unwrap();
    assert!(!GridSource::cells(
        &cache,
        &finer,
        [0; 3],
        [2; 3],
        &mut copied[..8]
    ));
    let beyond = Domain::fitted(DVec3::splat(0.5), DVec3::ONE, DVec3::ZERO, 1.0 / 16.0).unwrap();
    assert!(!GridSource::cells(
        &cache,
        &beyond,
        [0; 3],
        [16; 3],
        &mut vec![0f32; 4096]
    ));
    // A domain on the same lattice far outside the cache is refused, not indexed.
    let far = Domain::fitted(DVec3::splat(1.0e6), DVec3::ONE, DVec3::ZERO, 1.0 / 16.0).unwrap();
    assert!(!GridSource::cells(
        &cache,
        &far,
        [0; 3],
        [1; 3],
        &mut copied[..1]
    ));
}

#[test]
fn larger_regions_see_zero_cells_through_a_bricks_bit_rows() {
    // A small ball in the corner of the first brick (cells 0–2); a region reading cells 4–10
    // along each axis (7³ cells, too many to read one by one) covers the zero part of that brick
    // and the empty bricks beyond, so its range is exactly zero.
    let d = domain(DVec3::ZERO, DVec3::ONE, DVec3::ZERO, 1.0 / 32.0);
    let ball = Ball {
        centre: DVec3::splat(1.5 / 32.0),
        radius: 1.2 / 32.0,
    };
    let field = FnField::new(1, move |p: DVec3, out: &mut [f64]| out[0] = ball.density(p));
    let cache = Cache::from_field(d, 1, Arc::new(field), vec![0.0], "z".into()).unwrap();
    let brick = Aabb::new(DVec3::ZERO, DVec3::splat(0.25));
    assert!(cache.range(&brick)[0].1 > 0.5);
    // Cell centres 4.5/32 … 9.5/32 give linear reads of cells 4–10.
    let region = Aabb::new(DVec3::splat(4.5 / 32.0), DVec3::splat(9.75 / 32.0));
    assert_eq!(cache.range_read(&region, Interp::Linear), vec![(0.0, 0.0)]);
    for v in sample(
        &cache,
        Interp::Linear,
        &points_in(region.min, region.max, 500),
    ) {
        assert_eq!(v, 0.0);
    }
    // A region that also reads cell (1, 1, 1), the ball's centre, is not zero.
    let nearer = Aabb::new(DVec3::splat(1.5 / 32.0), DVec3::splat(9.75 / 32.0));
    assert!(cache.range_read(&nearer, Interp::Linear)[0].1 > 0.5);
}
