use super::*;
use crate::grid::domain::memory_limit;
use crate::sample::{FnField, GridSource, Interp};
use std::sync::Weak;

fn domain(origin: DVec3, lengths: DVec3, orientation: DVec3, cell: f64) -> Domain {
    Domain::with_cells(origin, lengths, orientation, cell, cell).unwrap()
}

fn scalar_cache(domain: Domain, f: impl Fn(DVec3) -> f64 + Send + Sync + 'static) -> Cache {
    let field = FnField::new(1, move |p, out: &mut [f64]| out[0] = f(p));
    Cache::from_field(domain, 1, Arc::new(field), vec![0.0], "test".into()).unwrap()
}

/// Deterministic points spread over a box (a 3D additive recurrence).
fn points_in(lo: DVec3, hi: DVec3, count: usize) -> Vec<DVec3> {
    let step = DVec3::new(0.754_877_666, 0.569_840_291, 0.430_159_709);
    (0..count)
        .map(|n| {
            let t = (step * (n as f64 + 0.5)).fract();
            lo + (hi - lo) * t
        })
        .collect()
}

fn sample(cache: &Cache, interp: Interp, points: &[DVec3]) -> Vec<f64> {
    let xs: Vec<f64> = points.iter().map(|p| p.x).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.y).collect();
    let zs: Vec<f64> = points.iter().map(|p| p.z).collect();
    let mut out = vec![0.0; points.len() * cache.width()];
    cache.sample(interp, &xs, &ys, &zs, &mut out);
    out
}

fn gradient(cache: &Cache, interp: Interp, points: &[DVec3]) -> Vec<f64> {
    let xs: Vec<f64> = points.iter().map(|p| p.x).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.y).collect();
    let zs: Vec<f64> = points.iter().map(|p| p.z).collect();
    let mut out = vec![0.0; points.len() * cache.width() * 3];
    cache.sample_gradient(interp, &xs, &ys, &zs, &mut out);
    out
}

/// Points inside an oriented domain, from its local frame.
fn points_inside(d: &Domain, count: usize) -> Vec<DVec3> {
    points_in(DVec3::ZERO, d.lengths, count)
        .into_iter()
        .map(|local| d.local_to_world(local))
        .collect()
}

fn all_cells(cache: &Cache) -> Vec<u32> {
    let [nx, ny, nz] = cache.resolution();
    let mut bits = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let value = cache.value_at_cell(i, j, k).unwrap();
                bits.extend(value.iter().map(|v| v.to_bits()));
            }
        }
    }
    bits
}

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

fn busy_field(p: DVec3) -> f64 {
    (p.x * 7.1).sin() * (p.y * 5.3 + p.z).cos() + (p - DVec3::new(0.2, 0.1, -0.3)).length()
}

fn busy_domain() -> Domain {
    Domain::with_cells(
        DVec3::new(-1.0, -0.8, -0.6),
        DVec3::new(2.0, 1.8, 1.4),
        DVec3::new(0.1, 0.2, -0.3),
        0.05,
        0.05,
    )
    .unwrap()
}

#[test]
fn concurrent_lazy_queries_equal_an_eager_fill() {
    let d = busy_domain();
    let eager = scalar_cache(d.clone(), busy_field);
    eager.fill_all();
    let points = points_in(d.bounds().min, d.bounds().max, 4000);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(4)
        .build()
        .unwrap();
    for interp in [Interp::Linear, Interp::Cubic] {
        let lazy = scalar_cache(d.clone(), busy_field);
        let values: Vec<f64> = pool.install(|| {
            points
                .par_chunks(7)
                .flat_map_iter(|chunk| sample(&lazy, interp, chunk))
                .collect()
        });
        let expected = sample(&eager, interp, &points);
        let same = values
            .iter()
            .zip(&expected)
            .all(|(a, b)| a.to_bits() == b.to_bits());
        assert!(same, "{interp:?}");
        assert!(lazy.bricks_filled() < lazy.bricks_total());
        lazy.fill_all();
        assert_eq!(all_cells(&lazy), all_cells(&eager));
    }
}

#[test]
fn fill_all_is_the_same_for_one_and_two_threads() {
    let fill = |threads: usize| {
        let cache = scalar_cache(busy_domain(), busy_field);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| cache.fill_all());
        assert_eq!(cache.bricks_filled(), cache.bricks_total());
        all_cells(&cache)
    };
    assert_eq!(fill(1), fill(2));
}

#[test]
fn cells_hold_the_field_at_cell_centres() {
    let d = busy_domain();
    let cache = scalar_cache(d.clone(), busy_field);
    let [nx, ny, nz] = cache.resolution();
    assert_eq!([nx, ny, nz], [40, 36, 28]);
    for (i, j, k) in [(0, 0, 0), (39, 35, 27), (17, 8, 26)] {
        let stored = cache.value_at_cell(i, j, k).unwrap()[0];
        assert_eq!(stored, busy_field(d.cell_center(i, j, k)) as f32);
    }
    assert!(cache.value_at_cell(40, 0, 0).is_none());
    let mut count = 0;
    for (cell, value) in cache.cells() {
        assert_eq!(
            value[0],
            busy_field(d.cell_center(cell[0], cell[1], cell[2])) as f32
        );
        count += 1;
    }
    assert_eq!(count, nx * ny * nz);
    // Brick views agree with cell access.
    let brick = cache.stored_bricks().last().unwrap();
    assert_eq!(brick.origin, [32, 32, 24]);
    assert_eq!(brick.size, [8, 4, 4]);
    assert_eq!(
        brick.value([7, 3, 3]),
        cache.value_at_cell(39, 35, 27).unwrap()
    );
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

/// A ball of density with an exact interval form, as the field engine would provide.
struct Ball {
    centre: DVec3,
    radius: f64,
}

impl Ball {
    fn density(&self, p: DVec3) -> f64 {
        (1.0 - (p - self.centre).length() / self.radius).max(0.0)
    }
}

struct BallEval<'a>(&'a Ball);

impl BlockEval for BallEval<'_> {
    fn eval_f32(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f32]) {
        for i in 0..xs.len() {
            out[i] = self.0.density(DVec3::new(xs[i], ys[i], zs[i])) as f32;
        }
    }

    fn eval_f64(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        for i in 0..xs.len() {
            out[i] = self.0.density(DVec3::new(xs[i], ys[i], zs[i]));
        }
    }
}

impl FieldSampler for Ball {
    fn width(&self) -> usize {
        1
    }

    fn evaluator(&self) -> Box<dyn BlockEval + '_> {
        Box::new(BallEval(self))
    }

    fn bounds(&self) -> Option<Aabb> {
        Some(Aabb::new(
            self.centre - self.radius,
            self.centre + self.radius,
        ))
    }

    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        let nearest = self.centre.clamp(region.min, region.max);
        let farthest = DVec3::select(
            (self.centre - region.min).cmpgt(region.max - self.centre),
            region.min,
            region.max,
        );
        let near = (nearest - self.centre).length();
        let far = (farthest - self.centre).length();
        vec![(
            (1.0 - far / self.radius).max(0.0),
            (1.0 - near / self.radius).max(0.0),
        )]
    }
}

#[test]
fn empty_bricks_are_skipped_without_changing_values() {
    let d = domain(
        DVec3::splat(-1.0),
        DVec3::splat(2.0),
        DVec3::new(0.2, 0.0, 0.1),
        1.0 / 32.0,
    );
    let ball = Ball {
        centre: DVec3::new(0.1, -0.2, 0.05),
        radius: 0.45,
    };
    let plain = scalar_cache(d.clone(), move |p| ball.density(p));
    let ball = Ball {
        centre: DVec3::new(0.1, -0.2, 0.05),
        radius: 0.45,
    };
    let skipping =
        Cache::from_field(d.clone(), 1, Arc::new(ball), vec![0.0], "ball".into()).unwrap();
    skipping.fill_all();
    plain.fill_all();
    assert!(skipping.bricks_skipped() > skipping.bricks_total() / 2);
    assert_eq!(
        skipping.bricks_skipped() + skipping.bricks_filled(),
        skipping.bricks_total()
    );
    assert_eq!(plain.bricks_skipped(), 0);
    assert_eq!(all_cells(&skipping), all_cells(&plain));
    // Evaluated bricks that came out all zero cost no memory either.
    assert_eq!(skipping.bytes(), plain.bytes());
    let points = points_inside(&d, 3000);
    for interp in [Interp::Linear, Interp::Cubic] {
        let a = sample(&skipping, interp, &points);
        let b = sample(&plain, interp, &points);
        assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
    }
}

#[test]
fn nonfinite_values_are_reported_with_the_first_position() {
    // Cell centres at x = -1, 0, 1 (exactly), y and z at 0.5 and 1.5.
    let d = domain(
        DVec3::new(-1.5, 0.0, 0.0),
        DVec3::new(3.0, 2.0, 2.0),
        DVec3::ZERO,
        1.0,
    );
    let cache = scalar_cache(d.clone(), |p| 1.0 / p.x);
    assert_eq!(cache.nonfinite_report(), None);
    cache.fill_all();
    let (count, first) = cache.nonfinite_report().unwrap();
    assert_eq!(count, 4);
    assert_eq!(first, DVec3::new(0.0, 0.5, 0.5));
    assert_eq!(cache.value_at_cell(1, 1, 1).unwrap()[0], f32::INFINITY);
    // A NaN makes the brick's range unbounded rather than silently narrow.
    let nan = scalar_cache(d.clone(), |p| p.x / p.x);
    let range = nan.range(&d.bounds());
    assert_eq!(range, vec![(f64::NEG_INFINITY, f64::INFINITY)]);
    assert_eq!(nan.nonfinite_report().unwrap().0, 4);
    let finite = scalar_cache(d, |p| p.y);
    finite.fill_all();
    assert_eq!(finite.nonfinite_report(), None);
}

#[test]
fn the_source_is_released_once_every_brick_is_resolved() {
    let field: Arc<dyn FieldSampler> =
        Arc::new(FnField::new(1, |p: DVec3, out: &mut [f64]| out[0] = p.x));
    let weak: Weak<dyn FieldSampler> = Arc::downgrade(&field);
    let d = domain(DVec3::ZERO, DVec3::splat(2.0), DVec3::ZERO, 0.125);
    let cache = Cache::from_field(d, 1, field, vec![0.0], "r".into()).unwrap();
    sample(&cache, Interp::Linear, &[DVec3::splat(0.3)]);
    assert!(weak.upgrade().is_some());
    assert!(!cache.source_released());
    cache.fill_all();
    assert!(weak.upgrade().is_none());
    assert!(cache.source_released());
    // Reads still work from the stored bricks.
    assert_eq!(
        sample(&cache, Interp::Linear, &[DVec3::new(1.0, 0.5, 0.5)]),
        vec![1.0]
    );

    // Lazy queries that happen to touch every brick release it too.
    let field: Arc<dyn FieldSampler> =
        Arc::new(FnField::new(1, |p: DVec3, out: &mut [f64]| out[0] = p.y));
    let weak = Arc::downgrade(&field);
    let d = domain(DVec3::ZERO, DVec3::new(1.0, 1.0, 0.5), DVec3::ZERO, 0.125);
    let cache = Cache::from_field(d, 1, field, vec![0.0], "r".into()).unwrap();
    assert_eq!(cache.bricks_total(), 1);
    sample(&cache, Interp::Cubic, &[DVec3::splat(0.2)]);
    assert!(weak.upgrade().is_none());
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
    assert_eq!(
        cache.range(&Aabb::new(DVec3::splat(0.1), DVec3::splat(0.9))),
        vec![(2.0, 2.0)]
    );
    assert_eq!(
        cache.range(&Aabb::new(DVec3::splat(0.5), DVec3::splat(1.5))),
        vec![(-3.0, 2.0)]
    );
    assert_eq!(cache.range(&Aabb::everything()), vec![(-3.0, 2.0)]);
}

#[test]
fn dense_and_sparse_data_read_back() {
    let d = domain(DVec3::ZERO, DVec3::new(1.0, 0.75, 0.5), DVec3::ZERO, 0.0625);
    let [nx, ny, nz] = d.resolution.unwrap();
    let value = |i: usize, j: usize, k: usize| (i as f32) * 0.5 - (j * k) as f32;
    let mut data = vec![0.0f32; nx * ny * nz];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                data[i + nx * (j + ny * k)] = value(i, j, k);
            }
        }
    }
    let dense = Cache::from_dense(d.clone(), 1, vec![data], vec![0.0]).unwrap();
    assert_eq!(dense.bricks_filled(), dense.bricks_total());
    assert!(dense.source_released());
    for (i, j, k) in [(0, 0, 0), (15, 11, 7), (9, 3, 5)] {
        assert_eq!(dense.value_at_cell(i, j, k).unwrap()[0], value(i, j, k));
    }
    // Cell (9, 3, 5) read through the interpolant at its centre.
    let centre = d.cell_center(9, 3, 5);
    for interp in [Interp::Linear, Interp::Cubic] {
        let read = sample(&dense, interp, &[centre])[0];
        assert!((read - f64::from(value(9, 3, 5))).abs() < 1e-9);
    }

    let mut builder = SparseBuilder::new(d.clone(), 3, vec![1.0, 2.0, 3.0]).unwrap();
    builder.set([12, 2, 1], &[4.0, 5.0, 6.0]).unwrap();
    builder.set([0, 0, 0], &[-1.0, -2.0, -3.0]).unwrap();
    assert!(builder.set([16, 0, 0], &[0.0; 3]).is_err());
    assert!(builder.set([0, 0, 0], &[0.0; 2]).is_err());
    let sparse = builder.with_label_for_test();
    assert_eq!(sparse.bricks_filled(), 2);
    assert_eq!(sparse.bricks_skipped(), sparse.bricks_total() - 2);
    assert_eq!(sparse.value_at_cell(12, 2, 1).unwrap(), &[4.0, 5.0, 6.0]);
    assert_eq!(sparse.value_at_cell(0, 0, 0).unwrap(), &[-1.0, -2.0, -3.0]);
    assert_eq!(sparse.value_at_cell(15, 11, 7).unwrap(), &[1.0, 2.0, 3.0]);
    assert_eq!(sparse.label(), "loaded");
    let stored: Vec<[usize; 3]> = sparse.cells().map(|(cell, _)| cell).collect();
    assert_eq!(stored.len(), 2 * BRICK_CELLS);
}

impl SparseBuilder {
    fn with_label_for_test(self) -> Cache {
        self.build().with_label("loaded")
    }
}

#[test]
fn bad_layouts_are_failures() {
    let flat = Domain::new(DVec3::ZERO, DVec3::ONE, DVec3::ZERO).unwrap();
    let field = || -> Arc<dyn FieldSampler> {
        Arc::new(FnField::new(1, |_p: DVec3, out: &mut [f64]| out[0] = 1.0))
    };
    let error = Cache::from_field(flat, 1, field(), vec![0.0], "x".into()).unwrap_err();
    assert!(error.message.contains("domain with cells"));
    assert!(error.help.is_some());
    let d = domain(DVec3::ZERO, DVec3::ONE, DVec3::ZERO, 0.25);
    assert!(Cache::from_field(d.clone(), 2, field(), vec![0.0; 2], "x".into()).is_err());
    assert!(Cache::from_field(d.clone(), 3, field(), vec![0.0; 3], "x".into()).is_err());
    assert!(Cache::from_field(d.clone(), 1, field(), vec![0.0; 3], "x".into()).is_err());
    assert!(Cache::from_field(d.clone(), 1, field(), vec![f64::NAN], "x".into()).is_err());
    let short = Cache::from_dense(d.clone(), 1, vec![vec![0.0; 63]], vec![0.0]).unwrap_err();
    assert!(
        short
            .message
            .contains("expected 1 component(s) of 64 values, got [63]")
    );
    assert!(Cache::from_dense(d, 3, vec![vec![0.0; 64]], vec![0.0; 3]).is_err());
    // A domain whose scalar grid fits but whose matrix grid (9 components) does not.
    let side = ((memory_limit() / 4) as f64).cbrt().floor();
    let big = domain(DVec3::ZERO, DVec3::splat(side), DVec3::ZERO, 1.0);
    let matrix = FnField::new(9, |_p: DVec3, out: &mut [f64]| out.fill(0.0));
    let error = Cache::from_field(big, 9, Arc::new(matrix), vec![0.0; 9], "x".into()).unwrap_err();
    assert!(error.message.contains("memory limit"));
}

#[test]
fn states_have_distinct_identities_and_report_to_the_profile() {
    let d = domain(DVec3::ZERO, DVec3::splat(2.0), DVec3::ZERO, 0.125);
    let label = "cache tests: line 7";
    let make = || {
        let field = FnField::new(1, |p: DVec3, out: &mut [f64]| out[0] = p.x);
        Cache::from_field(d.clone(), 1, Arc::new(field), vec![0.0], label.into()).unwrap()
    };
    let first = make();
    let second = make();
    assert_ne!(first.identity(), second.identity());
    assert_eq!(first.label(), label);
    first.fill_all();
    sample(&second, Interp::Linear, &[DVec3::splat(0.1)]);
    assert_eq!(
        first.bytes(),
        first.table_bytes() + 8 * (BRICK_CELLS as u64 * 4)
    );
    assert!(first.fill_seconds() > 0.0);
    let row = profile::report()
        .into_iter()
        .find(|e| e.label == label)
        .unwrap();
    assert_eq!(row.kind, "cachewrite");
    assert_eq!(row.instances, 2);
    assert_eq!(row.bricks_total, 16);
    assert_eq!(row.bricks_filled, 9);
    assert_eq!(row.bytes_live, first.bytes() + second.bytes());
    drop(first);
    drop(second);
    let row = profile::report()
        .into_iter()
        .find(|e| e.label == label)
        .unwrap();
    assert_eq!(row.bytes_live, 0);
}
