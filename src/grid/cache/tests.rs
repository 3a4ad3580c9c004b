use super::test_support::*;
use super::*;
use crate::space::domain::memory_limit;
use crate::space::{FnField, GridSource, Interp};
use rayon::prelude::*;
use std::sync::Weak;

#[test]
fn concurrent_lazy_queries_equal_an_eager_fill() {
    let d = busy_domain();
    let eager = scalar_cache(d.clone(), busy_field);
    eager.fill_all();
    // Points over part of the box, so that the lazy caches leave some bricks unfilled.
    let bounds = d.bounds();
    let points = points_in(bounds.min, bounds.min + bounds.size() * 0.6, 4000);
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
    let sparse = sparse
        .with_label("cache tests: loaded.vdb")
        .with_profile("cacheload");
    let row = || {
        profile::report()
            .into_iter()
            .find(|e| e.label == "cache tests: loaded.vdb")
            .unwrap()
    };
    assert_eq!(row().kind, "cacheload");
    assert_eq!(row().bricks_filled, 2);
    assert_eq!(row().bricks_skipped as usize, sparse.bricks_total() - 2);
    assert_eq!(row().bytes_live, sparse.bytes());
    let stored: Vec<[usize; 3]> = sparse.cells().map(|(cell, _)| cell).collect();
    assert_eq!(stored.len(), 2 * BRICK_CELLS);
    drop(sparse);
    assert_eq!(row().bytes_live, 0);
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
    let mismatch = Cache::from_field(d.clone(), 3, field(), vec![0.0; 3], "x".into()).unwrap_err();
    assert_eq!(
        mismatch.message,
        "cannot write a scalarfield into a vectorcache"
    );
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
    assert!(error.message.contains("memory budget"));
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

#[test]
fn fills_evaluate_exactly_at_cell_centres() {
    // The field answers 1 only where its position is bit for bit a cell centre.
    let d = busy_domain();
    let probe = d.clone();
    let cache = scalar_cache(d, move |p| {
        let index = probe.world_to_index(p).round();
        let centre = probe.cell_center(index.x as usize, index.y as usize, index.z as usize);
        if centre == p { 1.0 } else { 0.0 }
    });
    cache.fill_all();
    assert!(all_cells(&cache).iter().all(|&bits| bits == 1f32.to_bits()));
}

/// Whole blocks and boxes written at once equal the same cells written one at a time, whether
/// they line up with bricks or straddle them, for scalar and vector caches.
#[test]
fn block_writes_equal_cell_by_cell_writes() {
    // 20 × 16 × 12 cells: the last bricks along x and z are partial.
    let d = domain(DVec3::ZERO, DVec3::new(20.0, 16.0, 12.0), DVec3::ZERO, 1.0);
    for width in [1usize, 3] {
        let background = vec![0.5; width];
        let leaf: Vec<f32> = (0..BRICK_CELLS * width)
            .map(|n| n as f32 * 0.25 - 7.0)
            .collect();
        let tile = vec![2.0f32; width];
        let mut by_block = SparseBuilder::new(d.clone(), width, background.clone()).unwrap();
        let mut by_cell = SparseBuilder::new(d.clone(), width, background.clone()).unwrap();
        // One aligned leaf, one straddling four bricks; a box covering one whole brick and parts
        // of its neighbours, clipped at the partial far brick.
        for first in [[8, 0, 0], [3, 5, 2]] {
            by_block.set_leaf(first, &leaf).unwrap();
            for (n, value) in leaf.chunks_exact(width).enumerate() {
                let cell = [
                    first[0] + (n >> 6),
                    first[1] + ((n >> 3) & 7),
                    first[2] + (n & 7),
                ];
                by_cell.set(cell, value).unwrap();
            }
        }
        let (lo, hi) = ([6, 8, 0], [20, 16, 9]);
        by_block.fill_box(lo, hi, &tile).unwrap();
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                for x in lo[0]..hi[0] {
                    by_cell.set([x, y, z], &tile).unwrap();
                }
            }
        }
        let mut refused = SparseBuilder::new(d.clone(), width, background.clone()).unwrap();
        assert!(
            refused.set_leaf([16, 0, 0], &leaf).is_err(),
            "past the far face"
        );
        assert!(refused.set_leaf([0, 0, 0], &leaf[1..]).is_err());
        assert!(refused.fill_box([0, 0, 0], [21, 1, 1], &tile).is_err());
        let (a, b) = (by_block.build(), by_cell.build());
        assert_eq!(a.bricks_filled(), b.bricks_filled());
        for z in 0..12 {
            for y in 0..16 {
                for x in 0..20 {
                    assert_eq!(
                        a.value_at_cell(x, y, z),
                        b.value_at_cell(x, y, z),
                        "{x} {y} {z}"
                    );
                }
            }
        }
    }
}

#[test]
fn trilinear_reads_equal_the_general_stencil_bit_for_bit() {
    // A rotated domain whose ball leaves most bricks empty (skipped), scalar and vector, read
    // at points spread over and beyond the box, at cell centres (which take the general path
    // inside the fast one) and on brick faces (stencils reaching two to eight bricks).
    let d = domain(
        DVec3::new(-1.0, -0.9, -1.1),
        DVec3::new(2.0, 1.75, 2.0),
        DVec3::new(0.2, -0.1, 0.3),
        1.0 / 24.0,
    );
    let ball = move |p: DVec3| (0.5 - (p - DVec3::new(0.1, -0.2, 0.05)).length()).max(0.0);
    let scalar = scalar_cache(d.clone(), ball);
    let vector_field = FnField::new(3, move |p, out: &mut [f64]| {
        let b = ball(p);
        out.copy_from_slice(&[b, b * p.x + 0.25, -b * p.y]);
    });
    let vector = Cache::from_field(
        d.clone(),
        3,
        Arc::new(vector_field),
        vec![0.0, 0.25, 0.0],
        "v".into(),
    )
    .unwrap();
    let mut points = points_in(d.bounds().min - 0.1, d.bounds().max + 0.1, 6000);
    let to_world = |u: DVec3| d.origin + d.rotation * ((u + 0.5) * d.cell);
    for k in 0..400 {
        let u = DVec3::new(
            (k % 20) as f64,
            ((k / 20) % 20) as f64,
            (k % 7) as f64 * 3.0,
        );
        points.push(to_world(u));
        // On the face between bricks along each axis.
        points.push(to_world(DVec3::new(7.5, u.y + 0.3, u.z + 0.6)));
        points.push(to_world(DVec3::new(u.x + 0.2, 15.5, 7.5)));
    }
    for cache in [&scalar, &vector] {
        cache.fill_all();
        // Bricks that came out uniform hold no values: the fast path's other branch.
        let dense = cache.bricks_total() * BRICK_CELLS * cache.width() * 4;
        assert!(cache.bytes() < dense as u64);
        let fast = sample(cache, Interp::Linear, &points);
        let xs: Vec<f64> = points.iter().map(|p| p.x).collect();
        let ys: Vec<f64> = points.iter().map(|p| p.y).collect();
        let zs: Vec<f64> = points.iter().map(|p| p.z).collect();
        let mut general = vec![0.0; fast.len()];
        crate::grid::points::values_of(
            cache,
            cache.width(),
            Interp::Linear,
            &xs,
            &ys,
            &zs,
            &mut general,
        );
        let differ = fast
            .iter()
            .zip(&general)
            .filter(|(a, b)| a.to_bits() != b.to_bits())
            .count();
        assert_eq!(differ, 0, "width {}", cache.width());
        // The points reach into the ball.
        let most = fast.iter().fold(0.0f64, |m, &v| m.max(v));
        assert!(most > 0.3, "{most}");
    }
}
