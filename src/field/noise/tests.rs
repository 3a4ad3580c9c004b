//! Value tests of the noise kernels against independent routes: derivatives against finite
//! differences, `f32` blocks against the `f64` reference near and far from the origin, each
//! kernel against a brute-force evaluation of its definition, and the independence of the
//! output from how points are cut into blocks.

use super::hash::{axis_terms, corner, edge_gradient, seed_key};
use super::*;
use crate::space::BLOCK;

pub(super) const KINDS: [NoiseKind; 3] = [NoiseKind::Perlin, NoiseKind::Simplex, NoiseKind::Worley];

/// A seeded stream of uniform numbers in [0, 1) (splitmix64), for test points.
pub(super) struct Stream(u64);

impl Stream {
    pub fn new(seed: u64) -> Stream {
        Stream(seed)
    }
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// Value, gradient and Hessian of one point.
pub(super) type Full<T> = (T, [T; 3], [T; 6]);

/// Everything at f64 for a list of points.
pub(super) fn full_f64(kind: NoiseKind, seed: u32, points: &[[f64; 3]]) -> Vec<Full<f64>> {
    let mut result = Vec::with_capacity(points.len());
    for chunk in points.chunks(BLOCK) {
        let n = chunk.len();
        let axis = |a: usize| chunk.iter().map(|p| p[a]).collect::<Vec<f64>>();
        let mut value = vec![0.0; n];
        let mut g: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; n]);
        let mut h: [Vec<f64>; 6] = std::array::from_fn(|_| vec![0.0; n]);
        let [g0, g1, g2] = &mut g;
        let [h0, h1, h2, h3, h4, h5] = &mut h;
        let out = NoiseOutput {
            value: &mut value,
            gradient: Some([g0, g1, g2]),
            hessian: Some([h0, h1, h2, h3, h4, h5]),
        };
        eval_f64(kind, seed, &axis(0), &axis(1), &axis(2), out);
        for i in 0..n {
            result.push((
                value[i],
                std::array::from_fn(|a| g[a][i]),
                std::array::from_fn(|a| h[a][i]),
            ));
        }
    }
    result
}

/// Everything at f32 for points given as one base plus offsets, in calls of `block` points.
pub(super) fn full_f32(
    kind: NoiseKind,
    seed: u32,
    base: [f64; 3],
    offsets: &[[f32; 3]],
    block: usize,
) -> Vec<Full<f32>> {
    let mut result = Vec::with_capacity(offsets.len());
    for chunk in offsets.chunks(block) {
        let n = chunk.len();
        let axis = |a: usize| chunk.iter().map(|p| p[a]).collect::<Vec<f32>>();
        let mut value = vec![0.0; n];
        let mut g: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0; n]);
        let mut h: [Vec<f32>; 6] = std::array::from_fn(|_| vec![0.0; n]);
        let [g0, g1, g2] = &mut g;
        let [h0, h1, h2, h3, h4, h5] = &mut h;
        let out = NoiseOutput {
            value: &mut value,
            gradient: Some([g0, g1, g2]),
            hessian: Some([h0, h1, h2, h3, h4, h5]),
        };
        eval_f32(kind, seed, base, &axis(0), &axis(1), &axis(2), out);
        for i in 0..n {
            result.push((
                value[i],
                std::array::from_fn(|a| g[a][i]),
                std::array::from_fn(|a| h[a][i]),
            ));
        }
    }
    result
}

/// Values only, at f32, in one call per `BLOCK` points, by the build this machine runs.
fn values_f32(kind: NoiseKind, seed: u32, base: [f64; 3], offsets: &[[f32; 3]]) -> Vec<f32> {
    values_built(Build::detect(), kind, seed, base, offsets, BLOCK)
}

pub(super) fn random_points(
    stream: &mut Stream,
    n: usize,
    centre: f64,
    half: f64,
) -> Vec<[f64; 3]> {
    (0..n)
        .map(|_| [0, 1, 2].map(|_| centre + stream.range(-half, half)))
        .collect()
}

fn length(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

const HESSIAN_PAIRS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];

#[test]
fn derivatives_match_central_differences() {
    let step = 1e-5;
    let mut stream = Stream::new(11);
    for kind in KINDS {
        for seed in [0u32, 1, 977] {
            let points = random_points(&mut stream, 200, 0.0, 20.0);
            let exact = full_f64(kind, seed, &points);
            let mut checked = 0;
            for (p, (_, gradient, hessian)) in points.iter().zip(&exact) {
                let mut shifted = Vec::new();
                for axis in 0..3 {
                    for sign in [1.0, -1.0] {
                        let mut q = *p;
                        q[axis] += sign * step;
                        shifted.push(q);
                    }
                }
                let around = full_f64(kind, seed, &shifted);
                // Worley has kinks on Voronoi faces and at the cap; skip points whose
                // difference stencil straddles one (the gradient jumps there).
                let jump = around
                    .iter()
                    .any(|s| (0..3).any(|a| (s.1[a] - gradient[a]).abs() > 1e-2));
                if kind == NoiseKind::Worley && jump {
                    continue;
                }
                checked += 1;
                for axis in 0..3 {
                    let plus = &around[2 * axis];
                    let minus = &around[2 * axis + 1];
                    let dv = (plus.0 - minus.0) / (2.0 * step);
                    assert!(
                        (dv - gradient[axis]).abs() < 1e-6 * (1.0 + gradient[axis].abs()),
                        "{kind:?} seed {seed} at {p:?}: d/d{axis} {dv} vs {}",
                        gradient[axis]
                    );
                    for (slot, (i, j)) in HESSIAN_PAIRS.iter().enumerate() {
                        if *j != axis {
                            continue;
                        }
                        let dg = (plus.1[*i] - minus.1[*i]) / (2.0 * step);
                        assert!(
                            (dg - hessian[slot]).abs() < 1e-5 * (1.0 + hessian[slot].abs()),
                            "{kind:?} seed {seed} at {p:?}: H{i}{j} {dg} vs {}",
                            hessian[slot]
                        );
                    }
                }
            }
            assert!(checked > 150, "{kind:?}: only {checked} points checked");
        }
    }
}

/// The hard case of precision: blocks based 1e5 and 1e8 units from the origin, with offsets
/// spanning several lattice cells, agree with the f64 reference to f32 rounding. Plain f32
/// positions would be quantised to 1/128 of a cell at 1e5 and would miss by up to 0.03.
#[test]
fn f32_blocks_match_f64_near_and_far() {
    let mut stream = Stream::new(5);
    let bases = [
        [0.31, -0.72, 0.2],
        [1.0e5 + 0.37, -1.0e5 + 0.11, 1.0e5],
        [-1.0e8 - 0.5, 1.0e8 + 0.25, 3.0e7],
    ];
    for kind in KINDS {
        for base in bases {
            let offsets: Vec<[f32; 3]> = (0..512)
                .map(|_| [0, 1, 2].map(|_| stream.range(-6.0, 6.0) as f32))
                .collect();
            let absolute: Vec<[f64; 3]> = offsets
                .iter()
                .map(|o| [0, 1, 2].map(|a| base[a] + o[a] as f64))
                .collect();
            let reference = full_f64(kind, 42, &absolute);
            let block = full_f32(kind, 42, base, &offsets, BLOCK);
            for ((r, b), p) in reference.iter().zip(&block).zip(&absolute) {
                assert!(
                    (r.0 - b.0 as f64).abs() < 1e-5,
                    "{kind:?} at {p:?}: f32 {} vs f64 {}",
                    b.0,
                    r.0
                );
                // Worley's gradient jumps across Voronoi faces; its value is what matters.
                if kind == NoiseKind::Worley {
                    continue;
                }
                for a in 0..3 {
                    let tolerance = 1e-4 * (1.0 + r.1[a].abs());
                    assert!(
                        (r.1[a] - b.1[a] as f64).abs() < tolerance,
                        "{kind:?} at {p:?}"
                    );
                }
                for s in 0..6 {
                    let tolerance = 1e-3 * (1.0 + r.2[s].abs());
                    assert!(
                        (r.2[s] - b.2[s] as f64).abs() < tolerance,
                        "{kind:?} at {p:?}"
                    );
                }
            }
        }
    }
}

/// Output depends only on each point's base and offset: cutting the same points into calls
/// of other lengths, or asking for fewer outputs, changes no bit.
#[test]
fn output_does_not_depend_on_blocking() {
    let mut stream = Stream::new(9);
    let base = [1.0e5 + 0.5, 17.25, -3.0];
    let offsets: Vec<[f32; 3]> = (0..700)
        .map(|_| [0, 1, 2].map(|_| stream.range(-9.0, 9.0) as f32))
        .collect();
    for kind in KINDS {
        let whole = full_f32(kind, 3, base, &offsets, BLOCK);
        for block in [1, 7, 100, 255] {
            let cut = full_f32(kind, 3, base, &offsets, block);
            for (a, b) in whole.iter().zip(&cut) {
                assert_eq!(a.0.to_bits(), b.0.to_bits(), "{kind:?} block {block}");
                assert_eq!(a.1.map(f32::to_bits), b.1.map(f32::to_bits));
                assert_eq!(a.2.map(f32::to_bits), b.2.map(f32::to_bits));
            }
        }
        let values = values_f32(kind, 3, base, &offsets);
        for (a, v) in whole.iter().zip(&values) {
            assert_eq!(
                a.0.to_bits(),
                v.to_bits(),
                "{kind:?}: value-only call differs"
            );
        }
    }
}

/// At a lattice point Perlin noise is 0 and its gradient is that corner's edge gradient.
#[test]
fn perlin_vanishes_on_the_lattice_with_the_corner_gradient() {
    let mut stream = Stream::new(21);
    for seed in [0u32, 8, 123_456] {
        let key = seed_key(seed);
        let cells: Vec<[i64; 3]> = (0..300)
            .map(|_| [0, 1, 2].map(|_| stream.range(-2e5, 2e5).floor() as i64))
            .collect();
        let points: Vec<[f64; 3]> = cells.iter().map(|c| c.map(|v| v as f64)).collect();
        for (cell, sample) in cells.iter().zip(full_f64(NoiseKind::Perlin, seed, &points)) {
            let [x, y, z] = axis_terms(cell.map(|v| v as u32));
            let g: [f64; 3] = edge_gradient(corner(x, y, z, key));
            assert_eq!(sample.0, 0.0, "at {cell:?}");
            assert_eq!(sample.1, g, "at {cell:?}");
        }
    }
}

/// Simplex noise as its definition says: the scaled sum, over every lattice point of the
/// skewed lattice, of `(½ − |d|²)₊⁴·g·d`. The kernel walks only the four corners of the
/// point's tetrahedron; this sums all 64 lattice points around the skewed cell.
#[test]
fn simplex_is_the_sum_over_every_lattice_point_in_reach() {
    let mut stream = Stream::new(33);
    let points = random_points(&mut stream, 2000, 0.0, 1e3);
    let key = seed_key(77);
    let sampled = full_f64(NoiseKind::Simplex, 77, &points);
    for (p, s) in points.iter().zip(sampled) {
        let t = simplex::skew(*p);
        let cell = t.map(f64::floor);
        let mut sum = 0.0;
        for n in 0..64 {
            let step = [n % 4 - 1, (n / 4) % 4 - 1, n / 16 - 1].map(f64::from);
            let lattice = [0, 1, 2].map(|a| cell[a] + step[a]);
            // p − unskew(lattice) = unskew(t − lattice), small numbers only.
            let x = [0, 1, 2].map(|a| t[a] - lattice[a]);
            let back = (x[0] + x[1] + x[2]) * simplex::UNSKEW;
            let d = x.map(|v| v - back);
            let q = 0.5 - (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            if q <= 0.0 {
                continue;
            }
            let [hx, hy, hz] = axis_terms(lattice.map(|v| v as i64 as u32));
            let g: [f64; 3] = edge_gradient(corner(hx, hy, hz, key));
            sum += q.powi(4) * (g[0] * d[0] + g[1] * d[1] + g[2] * d[2]);
        }
        let expected = simplex::SCALE * sum;
        assert!(
            (s.0 - expected).abs() < 1e-12,
            "at {p:?}: {} vs {expected}",
            s.0
        );
    }
}

/// Worley noise as its definition says: the distance to the nearest feature point, capped at
/// 1, searched here over the 125 cells around the point instead of the kernel's 27.
#[test]
fn worley_is_the_capped_distance_to_the_nearest_feature() {
    let mut stream = Stream::new(44);
    let points = random_points(&mut stream, 1000, 0.0, 1e4);
    let key = seed_key(5);
    let sampled = full_f64(NoiseKind::Worley, 5, &points);
    let mut capped = 0;
    for (p, s) in points.iter().zip(sampled) {
        let cell = p.map(f64::floor);
        let mut nearest = f64::INFINITY;
        for n in 0..125 {
            let step = [n % 5 - 2, (n / 5) % 5 - 2, n / 25 - 2].map(f64::from);
            let lattice = [0, 1, 2].map(|a| cell[a] + step[a]);
            let [hx, hy, hz] = axis_terms(lattice.map(|v| v as i64 as u32));
            let h = corner(hx, hy, hz, key);
            let jitter = |shift: u32| (((h >> shift) & 1023) as f64 + 0.5) / 1024.0;
            let feature = [
                lattice[0] + jitter(0),
                lattice[1] + jitter(10),
                lattice[2] + jitter(20),
            ];
            let d = [0, 1, 2].map(|a| p[a] - feature[a]);
            nearest = nearest.min(length(d));
        }
        if nearest >= 1.0 {
            capped += 1;
        }
        let expected = nearest.min(1.0);
        assert!(
            (s.0 - expected).abs() < 1e-12,
            "at {p:?}: {} vs {expected}",
            s.0
        );
    }
    // One feature per unit cell leaves few points farther than 1 from all of them.
    assert!(capped < 20, "{capped} capped points");
}

/// `value_range` and `lipschitz` hold at many random points, in f64 and in f32 far from the
/// origin, and are not vacuous: the sampled extremes come within a stated distance of them.
#[test]
fn value_range_and_lipschitz_hold_at_random_points() {
    let mut stream = Stream::new(61);
    for kind in KINDS {
        let (lo, hi) = value_range(kind);
        let lipschitz = lipschitz(kind);
        let points = random_points(&mut stream, 40_000, 0.0, 500.0);
        let mut extreme: f64 = 0.0;
        let mut steepest: f64 = 0.0;
        for seed in [0u32, 1] {
            for (p, s) in points.iter().zip(full_f64(kind, seed, &points)) {
                assert!(s.0 >= lo && s.0 <= hi, "{kind:?} at {p:?}: {}", s.0);
                let slope = length(s.1);
                // Rounding may lengthen Worley's unit gradient by an ulp.
                assert!(
                    slope <= lipschitz * (1.0 + 1e-12),
                    "{kind:?} at {p:?}: slope {slope}"
                );
                extreme = extreme.max(s.0.abs());
                steepest = steepest.max(slope);
            }
        }
        let offsets: Vec<[f32; 3]> = (0..40_000)
            .map(|_| [0, 1, 2].map(|_| stream.range(-8.0, 8.0) as f32))
            .collect();
        for s in full_f32(kind, 2, [-1e5, 1e5, 0.5], &offsets, BLOCK) {
            let slope = length(s.1.map(f64::from));
            assert!(
                s.0 as f64 >= lo - 1e-6 && s.0 as f64 <= hi + 1e-6,
                "{kind:?}: {}",
                s.0
            );
            assert!(slope <= lipschitz + 1e-5, "{kind:?}: slope {slope}");
        }
        // Sampled extremes (80 000 points): Perlin reaches about 0.8 and slope 3.2, simplex
        // 0.85 and 5.5, Worley 1 and 1 (slope 1 almost everywhere).
        let (least_value, least_slope) = match kind {
            NoiseKind::Perlin => (0.7, 2.8),
            NoiseKind::Simplex => (0.75, 4.8),
            NoiseKind::Worley => (0.99, 0.999),
        };
        assert!(extreme > least_value, "{kind:?}: largest |value| {extreme}");
        assert!(steepest > least_slope, "{kind:?}: largest slope {steepest}");
    }
}

#[test]
fn seeds_give_unrelated_fields() {
    let mut stream = Stream::new(71);
    let points = random_points(&mut stream, 20_000, 0.0, 300.0);
    for kind in KINDS {
        let a = full_f64(kind, 0, &points);
        let b = full_f64(kind, 1, &points);
        let n = points.len() as f64;
        let mean = |s: &[Full<f64>]| s.iter().map(|v| v.0).sum::<f64>() / n;
        let (ma, mb) = (mean(&a), mean(&b));
        let mut cov = 0.0;
        let mut va = 0.0;
        let mut vb = 0.0;
        for (x, y) in a.iter().zip(&b) {
            cov += (x.0 - ma) * (y.0 - mb);
            va += (x.0 - ma).powi(2);
            vb += (y.0 - mb).powi(2);
        }
        // Independent fields: the sample correlation has standard deviation 1/√20000 ≈ 0.007.
        let correlation = cov / (va * vb).sqrt();
        assert!(
            correlation.abs() < 0.03,
            "{kind:?}: correlation {correlation}"
        );
    }
}

#[test]
fn non_finite_positions_do_not_panic() {
    for kind in KINDS {
        let bad = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e300];
        let mut value = [0.0; 4];
        eval_f64(kind, 0, &bad, &bad, &bad, NoiseOutput::value(&mut value));
        let mut value = [0f32; 4];
        let offsets = [f32::NAN, f32::INFINITY, 3e38, -3e38];
        eval_f32(
            kind,
            0,
            [f64::NAN, 0.0, 1e300],
            &offsets,
            &offsets,
            &offsets,
            NoiseOutput::value(&mut value),
        );
        // A finite value far away stays in range; what NaN gives is unspecified but harmless.
        let mut far = [0.0; 1];
        eval_f64(
            kind,
            0,
            &[1e300],
            &[0.5],
            &[0.5],
            NoiseOutput::value(&mut far),
        );
        let (lo, hi) = value_range(kind);
        assert!(far[0] >= lo && far[0] <= hi, "{kind:?}: {}", far[0]);
    }
}

/// Offsets that stress locating: random ones of both signs and sizes up to the 2³¹ cells the
/// builds agree within, exact lattice planes and their neighbours one `f32` step away, tiny
/// negatives (whose fractional position rounds to 1), and signed zeros.
fn hard_offsets(stream: &mut Stream, n: usize) -> Vec<[f32; 3]> {
    let special = |stream: &mut Stream| -> f32 {
        let k = stream.range(-300.0, 300.0).floor() as f32;
        match (stream.next() * 9.0) as u32 {
            0 => k,
            1 => k.next_up(),
            2 => k.next_down(),
            3 => -1e-9,
            4 => -0.0,
            5 => stream.range(-1e6, 1e6) as f32,
            6 => stream.range(-1.0, 1.0) as f32,
            7 => stream.range(-2.1e9, 2.1e9) as f32,
            _ => stream.range(-8.0, 8.0) as f32,
        }
    };
    (0..n).map(|_| [0, 1, 2].map(|_| special(stream))).collect()
}

/// Values of one build over `offsets`, in calls of `chunk` points.
fn values_built(
    build: Build,
    kind: NoiseKind,
    seed: u32,
    base: [f64; 3],
    offsets: &[[f32; 3]],
    chunk: usize,
) -> Vec<f32> {
    let mut result = Vec::with_capacity(offsets.len());
    for chunk in offsets.chunks(chunk) {
        let axis = |a: usize| chunk.iter().map(|p| p[a]).collect::<Vec<f32>>();
        let mut value = vec![0.0; chunk.len()];
        let out = NoiseOutput::value(&mut value);
        eval_f32_built(build, kind, seed, base, &axis(0), &axis(1), &axis(2), out);
        result.extend(value);
    }
    result
}

/// Every build of the `f32` block loops gives the same bits: the baseline build, the generic
/// loops with AVX2, and the Perlin intrinsics loop, at bases near and far from the origin
/// (integral ones too, so offsets land exactly on lattice planes), for every family.
#[test]
fn builds_agree_bit_for_bit() {
    let mut stream = Stream::new(77);
    let bases = [
        [0.0, 0.0, 0.0],
        [-3.0, 2.0, 5.0],
        [0.31, -0.72, 0.2],
        [1.0e5 + 0.37, -1.0e5 + 0.11, 1.0e5],
        [-1.0e8 - 0.5, 1.0e8 + 0.25, 3.0e7],
    ];
    let builds = [
        Build::Plain,
        Build::Avx2,
        Build::Avx2Intrinsics,
        Build::Avx512Intrinsics,
    ];
    let mut compared = 0;
    for kind in KINDS {
        for base in bases {
            for seed in [0u32, 5] {
                let offsets = hard_offsets(&mut stream, 2000);
                // Calls of `BLOCK - 3` points, so the sixteen- and eight-lane loops and the scalar
                // tail all run.
                let reference = values_built(Build::Plain, kind, seed, base, &offsets, BLOCK - 3);
                for build in builds {
                    let values = values_built(build, kind, seed, base, &offsets, BLOCK - 3);
                    for ((r, v), o) in reference.iter().zip(&values).zip(&offsets) {
                        assert_eq!(
                            r.to_bits(),
                            v.to_bits(),
                            "{kind:?} {build:?} base {base:?} offset {o:?}: {r} vs {v}"
                        );
                        compared += 1;
                    }
                }
            }
        }
    }
    assert_eq!(compared, 3 * 5 * 2 * 4 * 2000);
}
