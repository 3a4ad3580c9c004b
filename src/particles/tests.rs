//! Value tests for particles, splats, point fields, walks and flames. Every expected value
//! comes from a closed form or an independent computation written out here.

use super::io::{self, FileKind};
use super::pointfield::{Blend, PointField};
use super::random::Stream;
use super::splat::{Deposit, Kernel, splat};
use super::wisp::Walk;
use super::{Particles, Values, chaos, flame, guide, wisp};
use crate::field::{CompiledField, FieldValue, probe};
use crate::grid::cache::Cache;
use crate::space::domain::Domain;
use crate::space::{FieldSampler, GridSource, Interp};
use glam::DVec3;
use std::f64::consts::PI;

fn vector_at(name: &str, p: DVec3) -> DVec3 {
    let f = flame::variation(name, flame::default_params(name)).unwrap();
    match probe(&f, p).unwrap() {
        FieldValue::Vector(v) => v,
        other => panic!("{name} is not a vectorfield: {other:?}"),
    }
}

#[test]
fn spherical_of_two_on_the_x_axis_is_one_half() {
    let v = vector_at("spherical", DVec3::new(2.0, 0.0, 0.0));
    // 2 / (4 + EPS): flam3's guard moves it by 1.25e-11.
    assert!((v.x - 0.5).abs() < 1e-10, "{v}");
    assert_eq!((v.y, v.z), (0.0, 0.0));
}

/// flam3's 2D variations as its code computes them: θ = atan2(x, y), sin θ = x/r,
/// cos θ = y/r, EPS where flam3 adds it.
fn flam3(name: &str, x: f64, y: f64) -> (f64, f64) {
    const EPS: f64 = 1e-10;
    let r2 = x * x + y * y;
    let r = r2.sqrt();
    let a = x.atan2(y);
    let (sina, cosa) = (x / r, y / r);
    match name {
        "spherical" => (x / (r2 + EPS), y / (r2 + EPS)),
        "swirl" => (x * r2.sin() - y * r2.cos(), x * r2.cos() + y * r2.sin()),
        "horseshoe" => {
            let k = 1.0 / (r + EPS);
            ((x - y) * (x + y) * k, 2.0 * x * y * k)
        }
        "polar" => (a / PI, r - 1.0),
        "handkerchief" => (r * (a + r).sin(), r * (a - r).cos()),
        "heart" => (r * (r * a).sin(), -r * (r * a).cos()),
        "disc" => ((PI * r).sin() * a / PI, (PI * r).cos() * a / PI),
        "spiral" => {
            let re = r + EPS;
            ((cosa + re.sin()) / re, (sina - re.cos()) / re)
        }
        "hyperbolic" => (sina / (r + EPS), cosa * (r + EPS)),
        "diamond" => (sina * r.cos(), cosa * r.sin()),
        other => panic!("no flam3 reference for {other}"),
    }
}

#[test]
fn two_dimensional_restrictions_match_flam3() {
    // Appendix A's V2 to V11: spherical, swirl, horseshoe, polar, handkerchief, heart, disc,
    // spiral, hyperbolic, diamond.
    let names = &flame::NAMES[2..12];
    let points = [
        (0.3, 0.7),
        (-0.9, 0.2),
        (1.7, -1.1),
        (-0.05, -0.6),
        (2.5, 0.01),
        (-1.3, -2.2),
    ];
    for &name in names {
        for &(x, y) in &points {
            let v = vector_at(name, DVec3::new(x, y, 0.0));
            let (fx, fy) = flam3(name, x, y);
            let scale = 1.0f64.max(fx.abs()).max(fy.abs());
            assert!(
                (v.x - fx).abs() <= 1e-12 * scale && (v.y - fy).abs() <= 1e-12 * scale,
                "{name} at ({x}, {y}): felt ({}, {}), flam3 ({fx}, {fy})",
                v.x,
                v.y
            );
        }
    }
}

fn hard_points() -> Vec<DVec3> {
    let mut points = vec![DVec3::ZERO, DVec3::splat(-0.0)];
    for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
        for s in [1.0, -1.0, 1e-300, -1e-300, 1e6, -1e6, 0.5] {
            points.push(axis * s);
        }
    }
    points.extend([
        DVec3::splat(1e6),
        DVec3::splat(-1e6),
        DVec3::new(1e6, -1e6, 1e6),
    ]);
    points
}

#[test]
fn every_variation_is_finite_at_the_origin_on_the_axes_and_far_away() {
    for name in flame::NAMES {
        let f = flame::variation(name, flame::default_params(name)).unwrap();
        let compiled = CompiledField::prepared(&f).unwrap();
        let mut eval = compiled.evaluator();
        for p in hard_points() {
            let v = vector_at(name, p);
            assert!(v.is_finite(), "{name} at {p} is {v} in f64");
            let mut out = [0f32; 3];
            eval.eval_f32(&[p.x], &[p.y], &[p.z], &mut out);
            assert!(
                out.iter().all(|c| c.is_finite()),
                "{name} at {p} is {out:?} in f32"
            );
        }
    }
}

#[test]
fn bent_and_julia_follow_their_cases() {
    // Bent's four quadrants, from the Appendix A table.
    let cases = [
        (DVec3::new(1.0, 2.0, 3.0), DVec3::new(1.0, 2.0, 3.0)),
        (DVec3::new(-1.0, 2.0, 3.0), DVec3::new(-2.0, 2.0, 6.0)),
        (DVec3::new(1.0, -2.0, 3.0), DVec3::new(1.0, -1.0, 1.5)),
        (DVec3::new(-1.0, -2.0, 3.0), DVec3::new(-2.0, -1.0, 3.0)),
    ];
    for (p, want) in cases {
        assert_eq!(vector_at("bent", p), want);
    }
    // Julia is ±√r (cos θ/2, sin θ/2, sin θ₂/2).
    let p = DVec3::new(0.4, -0.3, 0.2);
    let v = vector_at("julia", p);
    let (t, t2) = (p.x.atan2(p.y), p.x.atan2(p.z));
    let principal =
        DVec3::new((t / 2.0).cos(), (t / 2.0).sin(), (t2 / 2.0).sin()) * p.length().sqrt();
    assert!(
        (v - principal).length() < 1e-12 || (v + principal).length() < 1e-12,
        "{v}"
    );
}

#[test]
fn affine_coefficients_are_rows_with_translation_last() {
    let c = [
        1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0,
    ];
    let (m, t) = flame::affine_from_coefficients(&c).unwrap();
    let p = DVec3::new(1.0, -1.0, 2.0);
    let q = m * p + t;
    assert_eq!(
        q,
        DVec3::new(
            1.0 - 2.0 + 6.0 + 4.0,
            5.0 - 6.0 + 14.0 + 8.0,
            9.0 - 10.0 + 22.0 + 12.0
        )
    );
    let f = flame::flame("linear", &[], Some((m, t)), Some((m, t))).unwrap();
    let FieldValue::Vector(v) = probe(&f, p).unwrap() else {
        panic!()
    };
    assert_eq!(v, m * q + t);
}

#[test]
fn correlated_walk_epsilon_zero_is_random_and_one_stays_put() {
    let mut a = Stream::new(5, 1);
    let mut b = Stream::new(5, 1);
    let random = Walk::Correlated { epsilon: 0.0 };
    let mut x = [0.3, 0.2, 0.1];
    for _ in 0..10 {
        x = random.step(x, &mut a);
        assert_eq!(x, b.cube());
    }
    let stuck = Walk::Correlated { epsilon: 1.0 };
    let start = [0.3, -0.2, 0.1];
    let mut x = start;
    for _ in 0..10 {
        x = stuck.step(x, &mut a);
    }
    assert_eq!(x, start);
    // ε = 0.7: 70 % of the previous point.
    let mut c = Stream::new(9, 0);
    let mut d = Stream::new(9, 0);
    let y = Walk::Correlated { epsilon: 0.7 }.step(start, &mut c);
    let v = d.cube();
    for k in 0..3 {
        assert!((y[k] - (0.7 * start[k] + 0.3 * v[k])).abs() < 1e-15);
    }
}

#[test]
fn levy_walk_at_zero_magnitude_is_finite() {
    let mut s = Stream::new(1, 2);
    for q in [0.5, 1.0, 3.0] {
        let walk = Walk::Levy { epsilon: 1.0, q };
        let x = walk.step([0.0; 3], &mut s);
        assert!(x.iter().all(|c| c.is_finite()), "{x:?}");
        assert_eq!(x, [0.0; 3]);
        let mut y = [0.2, 0.1, -0.3];
        let walk = Walk::Levy { epsilon: 0.5, q };
        for _ in 0..1000 {
            y = walk.step(y, &mut s);
            assert!(y.iter().all(|c| c.is_finite()), "{y:?}");
        }
    }
    // One step by hand: blend, then divide by mag^q.
    let (mut a, mut b) = (Stream::new(3, 3), Stream::new(3, 3));
    let x = [0.5, -0.25, 0.125];
    let got = Walk::Levy {
        epsilon: 0.4,
        q: 0.75,
    }
    .step(x, &mut a);
    let v = b.cube();
    let y: Vec<f64> = (0..3).map(|k| 0.4 * x[k] + 0.6 * v[k]).collect();
    let mag: f64 = y.iter().map(|c| c * c).sum();
    for k in 0..3 {
        assert!((got[k] - y[k] / mag.powf(0.75)).abs() < 1e-12);
    }
}

fn random_particles(n: usize, seed: u64, lo: f64, hi: f64) -> Particles {
    let mut s = Stream::new(seed, 0);
    let positions = (0..n)
        .map(|_| [0; 3].map(|_| (lo + (hi - lo) * s.uniform()) as f32))
        .collect();
    let mut set = Particles::new(positions);
    let mass = (0..n).map(|_| (0.1 + s.uniform()) as f32).collect();
    set.set("mass", Values::Float(mass)).unwrap();
    let color = (0..n).map(|_| [0; 3].map(|_| s.uniform() as f32)).collect();
    set.set("Cd", Values::Vector(color)).unwrap();
    set
}

fn unit_domain(cells: f64) -> Domain {
    Domain::with_cells(
        DVec3::splat(-1.0),
        DVec3::splat(2.0),
        DVec3::ZERO,
        2.0 / cells,
        2.0 / cells,
    )
    .unwrap()
}

fn cache_sum(cache: &Cache) -> [f64; 3] {
    let mut total = [0.0; 3];
    for (_, v) in cache.cells() {
        for (c, x) in v.iter().enumerate() {
            total[c] += *x as f64;
        }
    }
    total
}

fn cache_bits(cache: &Cache) -> Vec<([usize; 3], Vec<u32>)> {
    cache
        .cells()
        .map(|(c, v)| (c, v.iter().map(|x| x.to_bits()).collect()))
        .collect()
}

#[test]
fn splatting_preserves_the_total_for_both_kernels() {
    let set = random_particles(20_000, 7, -1.0, 1.0);
    let domain = unit_domain(20.0);
    for kernel in [Kernel::Trilinear, Kernel::Nearest] {
        let masses = set.floats("mass").unwrap();
        let (cache, report) =
            splat(&set, Deposit::Float(masses), kernel, &domain, &[0.0], None).unwrap();
        let want: f64 = masses.iter().map(|&m| m as f64).sum();
        assert_eq!(report.outside, 0);
        let got = cache_sum(&cache)[0];
        assert!(
            ((got - want) / want).abs() < 1e-6,
            "{kernel:?}: {got} vs {want}"
        );
        let colors = set.vectors("Cd").unwrap();
        let (cache, _) = splat(
            &set,
            Deposit::Vector(colors),
            kernel,
            &domain,
            &[0.0; 3],
            None,
        )
        .unwrap();
        let got = cache_sum(&cache);
        for c in 0..3 {
            let want: f64 = colors.iter().map(|v| v[c] as f64).sum();
            assert!(((got[c] - want) / want).abs() < 1e-6);
        }
    }
}

#[test]
fn a_trilinear_splat_spreads_by_the_trilinear_weights() {
    // Cells of size 1 over [0, 4)³: centres at 0.5, 1.5, ... A point at (1.75, 0.5, 1.0)
    // sits 0.25 past centre 1 in x, on centre 0 in y, halfway between centres 0 and 1 in z.
    let domain = Domain::with_cells(DVec3::ZERO, DVec3::splat(4.0), DVec3::ZERO, 1.0, 1.0).unwrap();
    let set = Particles::new(vec![[1.75, 0.5, 1.0]]);
    let (cache, _) = splat(&set, Deposit::One, Kernel::Trilinear, &domain, &[0.0], None).unwrap();
    let at = |i, j, k| cache.value_at_cell(i, j, k).unwrap()[0];
    assert_eq!(at(1, 0, 0), 0.75 * 0.5);
    assert_eq!(at(2, 0, 0), 0.25 * 0.5);
    assert_eq!(at(1, 0, 1), 0.75 * 0.5);
    assert_eq!(at(2, 0, 1), 0.25 * 0.5);
    assert_eq!(at(1, 1, 0), 0.0);
    // Near the border the outside weight goes to the border cell.
    let set = Particles::new(vec![[0.1, 0.5, 0.5]]);
    let (cache, _) = splat(&set, Deposit::One, Kernel::Trilinear, &domain, &[0.0], None).unwrap();
    assert_eq!(cache.value_at_cell(0, 0, 0).unwrap()[0], 1.0);
    // Splatting again accumulates onto the cache.
    let (again, report) = splat(
        &set,
        Deposit::One,
        Kernel::Nearest,
        &domain,
        &[0.0],
        Some(&cache),
    )
    .unwrap();
    assert_eq!(again.value_at_cell(0, 0, 0).unwrap()[0], 2.0);
    assert_eq!(report.splatted, 1);
}

#[test]
fn particles_outside_the_domain_are_counted_not_splatted() {
    let domain = unit_domain(8.0);
    let set = Particles::new(vec![[0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [0.0, -1.5, 0.0]]);
    let (cache, report) =
        splat(&set, Deposit::One, Kernel::Trilinear, &domain, &[0.0], None).unwrap();
    assert_eq!((report.splatted, report.outside), (1, 2));
    assert!((cache_sum(&cache)[0] - 1.0).abs() < 1e-6);
}

/// Runs `f` in a pool of `threads` threads.
pub(super) fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

#[test]
fn splatting_is_bit_identical_for_any_thread_count() {
    let set = random_particles(70_000, 11, -1.2, 1.2);
    let domain = unit_domain(24.0);
    let run = || {
        let (cache, _) = splat(
            &set,
            Deposit::Float(set.floats("mass").unwrap()),
            Kernel::Trilinear,
            &domain,
            &[0.0],
            None,
        )
        .unwrap();
        cache_bits(&cache)
    };
    let one = in_pool(1, run);
    assert_eq!(one, in_pool(2, run));
    assert_eq!(one, in_pool(3, run));
    // And independent of the particles' order.
    let mut reversed = set.clone();
    reversed.positions.reverse();
    let Values::Float(m) = &mut reversed.attributes[0].values else {
        panic!()
    };
    m.reverse();
    let (cache, _) = splat(
        &reversed,
        Deposit::Float(reversed.floats("mass").unwrap()),
        Kernel::Trilinear,
        &domain,
        &[0.0],
        None,
    )
    .unwrap();
    assert_eq!(one, cache_bits(&cache));
}

#[test]
fn files_read_back_bit_for_bit() {
    let mut set = random_particles(50, 3, -3.0, 3.0);
    set.set("N", Values::Vector(vec![[0.0, 1.0, 0.0]; 50]))
        .unwrap();
    for kind in [FileKind::PlyBinary, FileKind::PlyAscii, FileKind::Csv] {
        let bytes = io::write(&set, kind).unwrap();
        let name = if kind == FileKind::Csv {
            "a.csv"
        } else {
            "a.ply"
        };
        let back = io::read(&bytes, name).unwrap();
        assert_eq!(back, set, "{kind:?}");
    }
}

#[test]
fn lying_or_broken_files_are_failures() {
    let huge = b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0";
    assert!(io::read(huge, "a.ply").is_err());
    let ascii = b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n4 5\n";
    assert!(io::read(ascii, "a.ply").is_err());
    assert!(io::read(b"x,y\n1,2\n", "a.csv").is_err());
    assert!(io::read(b"x,y,z\n1,2,oops\n", "a.csv").is_err());
    // A big-endian file with a double and a uchar column.
    let mut big = b"ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty double x\nproperty float y\nproperty float z\nproperty uchar id\nend_header\n".to_vec();
    big.extend(1.5f64.to_be_bytes());
    big.extend(2.5f32.to_be_bytes());
    big.extend((-3.0f32).to_be_bytes());
    big.push(200);
    let set = io::read(&big, "b.ply").unwrap();
    assert_eq!(set.positions, vec![[1.5, 2.5, -3.0]]);
    assert_eq!(set.floats("id").unwrap(), &[200.0]);
}

#[test]
fn a_point_field_is_the_sum_or_blend_of_smooth_spheres() {
    let mut set = Particles::new(vec![[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]]);
    set.set("billow", Values::Float(vec![2.0, 4.0])).unwrap();
    let sum = PointField::new(&set, "billow", 2.0, Blend::Sum).unwrap();
    let mut out = [0.0];
    let at = |f: &PointField, x: f64, out: &mut [f64; 1]| {
        f.sample(Interp::Linear, &[x], &[0.0], &[0.0], out);
        out[0]
    };
    // At a lone point's centre: its value. At half the radius: (1 - 1/4)^3 of it.
    assert_eq!(at(&sum, 0.0, &mut out), 2.0);
    assert!((at(&sum, -1.0, &mut out) - 2.0 * 0.75f64.powi(3)).abs() < 1e-15);
    // Between the two: both spheres, s = 1.5/2 for each.
    let k = (1.0 - 0.75f64 * 0.75).powi(3);
    assert!((at(&sum, 1.5, &mut out) - 6.0 * k).abs() < 1e-15);
    let average = PointField::new(&set, "billow", 2.0, Blend::Average).unwrap();
    assert!((at(&average, 1.5, &mut out) - 3.0).abs() < 1e-15);
    assert_eq!(at(&average, 10.0, &mut out), 0.0);
    // The gradient is the kernel's: d/dx 2(1 - x²/4)³ = -3x(1 - x²/4)².
    let mut g = [0.0; 3];
    sum.sample_gradient(Interp::Linear, &[-1.0], &[0.0], &[0.0], &mut g);
    assert!((g[0] - 3.0 * 0.75f64.powi(2)).abs() < 1e-14, "{g:?}");
}

fn guides_at(points: &[[f32; 3]]) -> Vec<guide::Guide> {
    guide::guides(&Particles::new(points.to_vec())).unwrap()
}

#[test]
fn the_same_seed_gives_the_same_wisp_for_any_thread_count() {
    let radial = CompiledField::prepared(
        &crate::field::Field::noise(crate::field::noise::NoiseKind::Perlin, 3)
            .add(&crate::field::Field::constant_scalar(1.0))
            .unwrap(),
    )
    .unwrap();
    let guides = guides_at(&[[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]]);
    let settings = wisp::Settings {
        walk: Walk::Levy {
            epsilon: 0.6,
            q: 0.3,
        },
        radial: Some(&radial),
        alpha: 2.0,
        displace: None,
        color: None,
    };
    let run = || wisp::generate(&guides, 9000, 42, &settings).unwrap();
    let one = in_pool(1, run);
    assert_eq!(one.len(), 18_000);
    assert_eq!(one, in_pool(2, run));
    assert_ne!(one, wisp::generate(&guides, 9000, 43, &settings).unwrap());
    // Without radial noise every dot lies on the unit sphere around its guide (or at its centre).
    let plain = wisp::Settings {
        radial: None,
        ..settings
    };
    let dots = wisp::generate(&guides[..1], 2000, 1, &plain).unwrap();
    for p in &dots.positions {
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        assert!((r - 1.0).abs() < 1e-6 || r == 0.0, "{r}");
    }
}

#[test]
fn the_chaos_game_of_halving_maps_fills_the_sierpinski_tetrahedron() {
    // f_i(p) = (p + v_i)/2 for the corners v_i of a tetrahedron: the attractor lies inside it,
    // so every stamped dot satisfies the four face inequalities (after 20 skipped steps the
    // start's distance has shrunk by 2^-20).
    let corners = [
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(1.0, -1.0, -1.0),
        DVec3::new(-1.0, 1.0, -1.0),
        DVec3::new(-1.0, -1.0, 1.0),
    ];
    let fields: Vec<CompiledField> = corners
        .iter()
        .map(|&v| {
            let f = crate::field::Field::identity()
                .add(&crate::field::Field::constant_vector(v))
                .unwrap();
            CompiledField::prepared(&f.mul(&crate::field::Field::constant_scalar(0.5)).unwrap())
                .unwrap()
        })
        .collect();
    let settings = chaos::Settings {
        maps: fields
            .iter()
            .enumerate()
            .map(|(i, f)| chaos::Map {
                field: f as &dyn FieldSampler,
                weight: 1.0,
                color: DVec3::splat(i as f64),
            })
            .collect(),
        displace: None,
        amount: 0.0,
        color: None,
        iterations: 300,
        skip: 20,
    };
    let guides = guides_at(&[[0.0; 3]]);
    let run = || chaos::generate(&guides, 5000, 9, &settings).unwrap();
    let (dots, report) = in_pool(1, run);
    assert_eq!(report.restarts, 0);
    assert_eq!((dots.clone(), report), in_pool(2, run));
    for p in &dots.positions {
        let (x, y, z) = (p[0] as f64, p[1] as f64, p[2] as f64);
        let slack = 1e-5;
        assert!(
            x + y + z >= -1.0 - slack && x - y - z >= -1.0 - slack,
            "{p:?}"
        );
        assert!(
            -x + y - z >= -1.0 - slack && -x - y + z >= -1.0 - slack,
            "{p:?}"
        );
    }
    // The running colour average stays within the map colours.
    let Values::Vector(c) = dots.attribute("Cd").unwrap() else {
        panic!()
    };
    assert!(
        c.iter()
            .all(|v| v.iter().all(|&x| (0.0..=3.0).contains(&x)))
    );
}

#[test]
fn tone_maps_scale_by_one_factor() {
    use crate::render::tonemap::ToneMap;
    let m = ToneMap::MaxPlusOne;
    assert_eq!(m.factor([3.0, 1.0, 0.0]), 0.25);
    let log = ToneMap::LogDensity {
        brightness: 2.0,
        gamma: 1.0,
    };
    // The brightest channel becomes log10(1 + k m) / k.
    let f = log.factor([4.0, 1.0, 0.5]) as f64;
    assert!((4.0 * f - (9.0f64).log10() / 2.0).abs() < 1e-6);
    assert_eq!(m.factor([0.0; 3]), 0.0);
}

#[test]
fn an_identity_guide_places_finite_points_at_themselves_plus_zero() {
    let identity = guides_at(&[[0.0; 3]])[0];
    assert!(identity.is_identity());
    let values = [0.0, -0.0, 1.5, -2.25, 1e-300, -1e-310, 1e10, -1e10, 3.0e-5];
    for &x in &values {
        for &y in &values {
            for &z in &values {
                let p = glam::DVec3::new(x, y, z);
                let (placed, shortcut) = (identity.place(p), p + 0.0);
                assert_eq!(
                    placed.to_array().map(f64::to_bits),
                    shortcut.to_array().map(f64::to_bits),
                    "{p:?}"
                );
            }
        }
    }
    // Any change of frame, scale or position is not the identity.
    let mut moved = identity;
    moved.position.x = 1e-9;
    let mut scaled = identity;
    scaled.scale = 2.0;
    let mut turned = identity;
    turned.right = glam::DVec3::new(0.0, 0.0, 1.0);
    assert!(!moved.is_identity() && !scaled.is_identity() && !turned.is_identity());
}
