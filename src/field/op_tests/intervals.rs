//! Interval soundness, op by op: over thousands of seeded boxes per op — straddling poles,
//! zeros of divisors, integers and crests, at huge magnitudes and reaching to infinity — every
//! point value lies inside the interval the engine computes for its box; and a brick the fill
//! skips as empty is zero wherever it is sampled.

use super::*;

/// An interval to evaluate a rule on: random, straddling a special point, huge, a point, or
/// reaching infinity.
fn draw_interval(rng: &mut Rng, specials: &[f64]) -> (f64, f64) {
    let (lo, hi) = match rng.below(7) {
        0 => {
            let c = rng.range(-10.0, 10.0);
            let w = 10f64.powf(rng.range(-6.0, 1.0));
            (c - w * rng.unit(), c + w * rng.unit())
        }
        1 | 2 => {
            let s = specials[rng.below(specials.len())];
            let w = 10f64.powf(rng.range(-12.0, 0.5));
            match rng.below(4) {
                0 => (s, s),
                1 => (s - w, s),
                2 => (s, s + w),
                _ => (s - w * rng.unit(), s + w * rng.unit()),
            }
        }
        3 => {
            let c = rng.sign() * 10f64.powf(rng.range(5.0, 300.0));
            let w = c.abs() * 10f64.powf(rng.range(-17.0, 0.0));
            (c - w * rng.unit(), c + w * rng.unit())
        }
        4 => {
            let v = rng.sign() * 10f64.powf(rng.range(-8.0, 20.0));
            (v, v)
        }
        5 => {
            let a = rng.range(-3.0, 3.0);
            let b = rng.range(-3.0, 3.0);
            (a.min(b), a.max(b))
        }
        _ => match rng.below(4) {
            0 => (-INF, INF),
            1 => (rng.range(-2.0, 2.0), INF),
            2 => (-INF, rng.range(-2.0, 2.0)),
            _ => (1e308, INF),
        },
    };
    (lo.min(hi), lo.max(hi))
}

/// Points of `[lo, hi]` to check: the ends, their neighbours inside, the special points inside,
/// and random points between.
fn samples_of(rng: &mut Rng, (lo, hi): (f64, f64), specials: &[f64], random: usize) -> Vec<f64> {
    let mut s = vec![lo, hi, lo.next_up().min(hi), hi.next_down().max(lo)];
    s.extend(specials.iter().copied().filter(|&v| lo <= v && v <= hi));
    for _ in 0..random {
        let t = rng.unit();
        // Written so that no intermediate overflows at huge magnitudes.
        let v = lo * (1.0 - t) + hi * t;
        if v.is_finite() && lo <= v && v <= hi {
            s.push(v);
        }
    }
    s.retain(|v| v.is_finite() || *v == lo || *v == hi);
    s
}

/// Special points of the one-argument rules: poles, crests and zeros of sin, cos and tan,
/// integers (floor, ceil, fract, sign), the ends of asin and acos's domain.
fn unary_specials() -> Vec<f64> {
    let mut s = vec![0.0, -0.0, 1.0, -1.0, 2.0, -2.0, 0.5, 1e-300, -1e-300];
    for k in -6..=6 {
        s.push(k as f64 * FRAC_PI_2);
    }
    s
}

/// Checks `value` at `at` against the interval, with a readable message.
fn assert_contains(what: &str, iv: Interval, value: f64, at: &dyn std::fmt::Debug) {
    if value.is_nan() {
        return;
    }
    assert!(
        iv.lo <= value && value <= iv.hi,
        "{what} at {at:?} = {value:e}, outside its interval [{:e}, {:e}]",
        iv.lo,
        iv.hi
    );
}

fn region(x: (f64, f64), y: (f64, f64), z: (f64, f64)) -> Aabb {
    Aabb::new(DVec3::new(x.0, y.0, z.0), DVec3::new(x.1, y.1, z.1))
}

/// Boxes per op in the interval tests: enough to hit every category many times, few enough to
/// keep the suite to seconds.
const BOXES: usize = 3000;

#[test]
fn math_fn_ranges_contain_every_sampled_value() {
    let specials = unary_specials();
    let x = node::position(0);
    for m in every_math_fn() {
        let root = node::unary(m, x.clone());
        let intervals = IntervalTape::new(std::slice::from_ref(&root));
        let mut rng = Rng(0x5eed ^ m as u64);
        let mut boxes = Vec::new();
        let mut points = Vec::new();
        for _ in 0..BOXES {
            let ix = draw_interval(&mut rng, &specials);
            let iv = intervals.ranges(&region(ix, (0.0, 0.0), (0.0, 0.0)))[0];
            for v in samples_of(&mut rng, ix, &specials, 6) {
                boxes.push((ix, iv));
                points.push([v, 0.0, 0.0]);
            }
        }
        let values = tape(std::slice::from_ref(&root), &points, Precision::Double);
        for ((ix, iv), (p, v)) in boxes.iter().zip(points.iter().zip(&values[0])) {
            assert_contains(
                &format!("{m:?} over [{:e}, {:e}]", ix.0, ix.1),
                *iv,
                *v,
                &p[0],
            );
        }
    }
}

#[test]
fn binary_op_ranges_contain_every_sampled_value() {
    let specials = unary_specials();
    let (x, y) = (node::position(0), node::position(1));
    for op in every_bin_op() {
        let root = node::binary(op, x.clone(), y.clone());
        let intervals = IntervalTape::new(std::slice::from_ref(&root));
        let mut rng = Rng(0xb1 ^ (op as u64) << 8);
        let mut boxes = Vec::new();
        let mut points = Vec::new();
        for _ in 0..BOXES {
            let (ix, iy) = (
                draw_interval(&mut rng, &specials),
                draw_interval(&mut rng, &specials),
            );
            let iv = intervals.ranges(&region(ix, iy, (0.0, 0.0)))[0];
            let xs = samples_of(&mut rng, ix, &specials, 3);
            let ys = samples_of(&mut rng, iy, &specials, 3);
            for &a in &xs {
                for &b in &ys {
                    boxes.push((ix, iy, iv));
                    points.push([a, b, 0.0]);
                }
            }
        }
        let values = tape(std::slice::from_ref(&root), &points, Precision::Double);
        for ((ix, iy, iv), (p, v)) in boxes.iter().zip(points.iter().zip(&values[0])) {
            let what = format!(
                "{op:?} over [{:e}, {:e}] x [{:e}, {:e}]",
                ix.0, ix.1, iy.0, iy.1
            );
            assert_contains(&what, *iv, *v, &(p[0], p[1]));
        }
    }
}

#[test]
fn select_ranges_contain_every_sampled_value() {
    let specials = [0.0, -0.0, 1.0, -1.0];
    let root = node::select(node::position(0), node::position(1), node::position(2));
    let intervals = IntervalTape::new(std::slice::from_ref(&root));
    let mut rng = Rng(0x5e1);
    for _ in 0..BOXES {
        let b = [(); 3].map(|_| draw_interval(&mut rng, &specials));
        let iv = intervals.ranges(&region(b[0], b[1], b[2]))[0];
        let s = b.map(|i| samples_of(&mut rng, i, &specials, 2));
        let mut points: Vec<[f64; 3]> = Vec::new();
        for &c in &s[0] {
            for &a in &s[1] {
                points.extend(s[2].iter().map(|&e| [c, a, e]));
            }
        }
        let values = tape(std::slice::from_ref(&root), &points, Precision::Double);
        for (p, v) in points.iter().zip(&values[0]) {
            assert_contains("select", iv, *v, p);
        }
    }
}

/// A random box of positions: small to a few cells, near the origin or 1e5 units away.
fn draw_box(rng: &mut Rng, reach: f64) -> Aabb {
    let far = if rng.below(4) == 0 { 1e5 } else { 0.0 };
    let c = DVec3::new(
        rng.range(-reach, reach),
        rng.range(-reach, reach),
        rng.range(-reach, reach),
    ) + far;
    let half = DVec3::new(rng.unit(), rng.unit(), rng.unit()) * 10f64.powf(rng.range(-3.0, 0.5));
    Aabb::new(c - half, c + half)
}

fn points_in_box(rng: &mut Rng, b: &Aabb, count: usize) -> Vec<[f64; 3]> {
    let mut points: Vec<[f64; 3]> = (0..8)
        .map(|n| {
            let pick = |bit: usize, a: usize| if n & bit != 0 { b.max[a] } else { b.min[a] };
            [pick(1, 0), pick(2, 1), pick(4, 2)]
        })
        .collect();
    while points.len() < count {
        let t = DVec3::new(rng.unit(), rng.unit(), rng.unit());
        points.push((b.min + (b.max - b.min) * t).to_array());
    }
    points
}

#[test]
fn noise_ranges_contain_both_precisions() {
    let mut rng = Rng(0x401);
    for kind in [NoiseKind::Perlin, NoiseKind::Simplex, NoiseKind::Worley] {
        let roots: Vec<NodeRef> = (0..10)
            .map(|i| {
                node::kernel_output(
                    Arc::new(Noise { kind, seed: 9 }),
                    (0..3).map(node::position).collect(),
                    i,
                )
            })
            .collect();
        let intervals = IntervalTape::new(&roots);
        for _ in 0..150 {
            let b = draw_box(&mut rng, 40.0);
            let ranges = intervals.ranges(&b);
            let points = points_in_box(&mut rng, &b, BLOCK);
            for precision in [Precision::Single, Precision::Double] {
                let values = tape(&roots, &points, precision);
                for (out, iv) in ranges.iter().enumerate() {
                    for (p, v) in points.iter().zip(&values[out]) {
                        let what = format!("{kind:?} output {out} ({precision:?})");
                        assert_contains(&what, *iv, *v, p);
                    }
                }
            }
        }
    }
}

/// A small grid with rough values (cubic reads overshoot them) and a non-zero background.
fn rough_grid(background: f64) -> Arc<Cache> {
    let domain = Domain::with_cells(
        DVec3::new(-0.5, -0.25, 0.0),
        DVec3::new(1.5, 1.0, 1.0),
        DVec3::ZERO,
        0.125,
        0.125,
    )
    .unwrap();
    let field = crate::space::FnField::new(1, |p: DVec3, out: &mut [f64]| {
        out[0] = ((p.x * 23.0).sin() * (p.y * 17.0).cos() + p.z * 2.0).round();
    });
    let cache = Cache::from_field(domain, 1, Arc::new(field), vec![background], "t".into());
    Arc::new(cache.unwrap())
}

#[test]
fn grid_read_ranges_contain_every_value() {
    let mut rng = Rng(0x6e1d);
    for background in [0.0, -3.0] {
        let grid = rough_grid(background);
        for interp in [Interp::Linear, Interp::Cubic] {
            let field = Field::from_grid(
                grid.clone() as Arc<dyn GridSource>,
                interp,
                GridDerivative::Interpolant,
            )
            .unwrap();
            let intervals = IntervalTape::new(field.components());
            for _ in 0..200 {
                let mut b = draw_box(&mut rng, 1.5);
                if b.min.x > 1e4 {
                    b = Aabb::new(b.min - 1e5, b.max - 1e5);
                }
                let iv = intervals.ranges(&b)[0];
                let points = points_in_box(&mut rng, &b, 64);
                let values = tape(field.components(), &points, Precision::Double);
                for (p, v) in points.iter().zip(&values[0]) {
                    assert_contains(&format!("{interp:?} read"), iv, *v, p);
                }
            }
        }
    }
}

/// A random expression of the position that is finite everywhere, `depth` levels deep.
fn finite_expression(rng: &mut Rng, depth: usize) -> NodeRef {
    if depth == 0 {
        return match rng.below(4) {
            3 => node::constant(rng.range(-2.0, 2.0)),
            axis => node::position(axis),
        };
    }
    let mut sub = || finite_expression(rng, depth - 1);
    let (a, b, c) = (sub(), sub(), sub());
    match rng.below(12) {
        0 => node::add(a, b),
        1 => node::sub(a, b),
        2 => node::mul(a, b),
        3 => node::binary(BinOp::Min, a, b),
        4 => node::binary(BinOp::Max, a, b),
        5 => node::unary(MathFn::Sin, a),
        6 => node::unary(MathFn::Fract, a),
        7 => node::unary(MathFn::Sqrt, node::unary(MathFn::Abs, a)),
        8 => node::unary(MathFn::Step, a),
        9 => node::binary(BinOp::Atan2, a, b),
        10 => node::select(a, b, node::constant(0.25)),
        _ => {
            let at = [a, b, c].map(Field::scalar);
            let at = Field::vector_from(&at[0], &at[1], &at[2]).unwrap();
            let warped = Field::noise(NoiseKind::Perlin, 5).compose(&at).unwrap();
            warped.components()[0].clone()
        }
    }
}

/// The point of skipping: a brick whose range is exactly the background is never evaluated.
/// Here every brick the fill skipped is sampled densely — its cell centres, which the fill
/// would have stored, and random points between them — in both precisions, and every value
/// must be the background.
#[test]
fn bricks_skipped_as_empty_are_empty() {
    let mut rng = Rng(0xb71c);
    let domain = Domain::with_cells(
        DVec3::splat(-1.0),
        DVec3::splat(2.0),
        DVec3::new(0.0, 0.2, 0.0),
        1.0 / 16.0,
        1.0 / 16.0,
    )
    .unwrap();
    let [nx, ny, nz] = domain.resolution.unwrap();
    let mut skipped_total = 0;
    for case in 0..24 {
        // Compact support: a ball, a slab or a mask of noise, times a random expression.
        let p = Field::identity();
        let centre = DVec3::new(
            rng.range(-0.5, 0.5),
            rng.range(-0.5, 0.5),
            rng.range(-0.5, 0.5),
        );
        let offset = p.sub(&Field::constant_vector(centre)).unwrap();
        let radius = Field::constant_scalar(rng.range(0.2, 0.6));
        let inside = match case % 3 {
            0 => radius.sub(&offset.length().unwrap()).unwrap(),
            1 => radius
                .sub(&offset.component(1).unwrap().math(MathFn::Abs).unwrap())
                .unwrap(),
            _ => Field::noise(NoiseKind::Simplex, case as u32)
                .sub(&Field::constant_scalar(0.4))
                .unwrap(),
        };
        let shape = if case % 2 == 0 {
            Field::max(&inside, &Field::constant_scalar(0.0)).unwrap()
        } else {
            inside.mask().unwrap()
        };
        let density = shape
            .mul(&Field::scalar(finite_expression(&mut rng, 3)))
            .unwrap();
        let compiled = Arc::new(CompiledField::new(&density));
        let cache = Cache::from_field(
            domain.clone(),
            1,
            compiled.clone() as Arc<dyn FieldSampler>,
            vec![0.0],
            "skip".into(),
        )
        .unwrap();
        cache.fill_all();
        let bricks = [nx, ny, nz].map(|n| n.div_ceil(BRICK));
        let mut skipped = 0;
        for bz in 0..bricks[2] {
            for by in 0..bricks[1] {
                for bx in 0..bricks[0] {
                    let lo = [bx, by, bz].map(|b| b * BRICK);
                    let hi = [(bx + 1) * BRICK, (by + 1) * BRICK, (bz + 1) * BRICK];
                    let hi = [hi[0].min(nx), hi[1].min(ny), hi[2].min(nz)];
                    let mut centres = Vec::new();
                    for k in lo[2]..hi[2] {
                        for j in lo[1]..hi[1] {
                            for i in lo[0]..hi[0] {
                                centres.push(domain.cell_center(i, j, k));
                            }
                        }
                    }
                    let mut bounds = Aabb::new(centres[0], centres[0]);
                    for c in &centres {
                        bounds = bounds.union(&Aabb::new(*c, *c));
                    }
                    // The fill's own decision, asked again the same way.
                    if compiled.range(&bounds) != vec![(0.0, 0.0)] {
                        continue;
                    }
                    skipped += 1;
                    let mut points: Vec<[f64; 3]> = centres.iter().map(|c| c.to_array()).collect();
                    points.extend(points_in_box(&mut rng, &bounds, 512));
                    for precision in [Precision::Single, Precision::Double] {
                        let values = tape(density.components(), &points, precision);
                        for (p, v) in points.iter().zip(&values[0]) {
                            assert!(
                                *v == 0.0,
                                "case {case}: brick {bx},{by},{bz} was skipped but is {v:e} at {p:?}"
                            );
                        }
                    }
                }
            }
        }
        assert_eq!(
            skipped,
            cache.bricks_skipped(),
            "case {case}: skip decisions differ"
        );
        skipped_total += skipped;
    }
    // The property is only worth something if bricks were skipped.
    assert!(skipped_total > 100, "only {skipped_total} bricks skipped");
}
