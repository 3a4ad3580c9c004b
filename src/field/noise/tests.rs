//! Value tests of the noise kernels: derivatives against finite differences, f32 against f64
//! near and far from the origin, statistics far from the origin, determinism, continuity.

use super::*;
use crate::sample::BLOCK;

const KINDS: [NoiseKind; 3] = [NoiseKind::Perlin, NoiseKind::Simplex, NoiseKind::Worley];

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

/// Everything at f64 for a list of points: value, gradient, Hessian per point.
pub(super) fn full_f64(
    kind: NoiseKind,
    seed: u32,
    points: &[[f64; 3]],
) -> Vec<(f64, [f64; 3], [f64; 6])> {
    let mut result = Vec::with_capacity(points.len());
    for chunk in points.chunks(BLOCK) {
        let n = chunk.len();
        let x: Vec<f64> = chunk.iter().map(|p| p[0]).collect();
        let y: Vec<f64> = chunk.iter().map(|p| p[1]).collect();
        let z: Vec<f64> = chunk.iter().map(|p| p[2]).collect();
        let mut value = vec![0.0; n];
        let mut g = vec![vec![0.0; n]; 3];
        let mut h = vec![vec![0.0; n]; 6];
        {
            let [g0, g1, g2] = &mut g[..] else {
                unreachable!()
            };
            let [h0, h1, h2, h3, h4, h5] = &mut h[..] else {
                unreachable!()
            };
            eval_f64(
                kind,
                seed,
                &x,
                &y,
                &z,
                NoiseOutput {
                    value: &mut value,
                    gradient: Some([g0, g1, g2]),
                    hessian: Some([h0, h1, h2, h3, h4, h5]),
                },
            );
        }
        for i in 0..n {
            result.push((
                value[i],
                [g[0][i], g[1][i], g[2][i]],
                [h[0][i], h[1][i], h[2][i], h[3][i], h[4][i], h[5][i]],
            ));
        }
    }
    result
}

pub(super) fn values_f64(kind: NoiseKind, seed: u32, points: &[[f64; 3]]) -> Vec<f64> {
    full_f64(kind, seed, points)
        .into_iter()
        .map(|s| s.0)
        .collect()
}

/// Value and gradient in f32 for points given as one base plus offsets.
pub(super) fn full_f32(
    kind: NoiseKind,
    seed: u32,
    base: [f64; 3],
    offsets: &[[f32; 3]],
) -> Vec<(f32, [f32; 3], [f32; 6])> {
    let mut result = Vec::with_capacity(offsets.len());
    for chunk in offsets.chunks(BLOCK) {
        let n = chunk.len();
        let x: Vec<f32> = chunk.iter().map(|p| p[0]).collect();
        let y: Vec<f32> = chunk.iter().map(|p| p[1]).collect();
        let z: Vec<f32> = chunk.iter().map(|p| p[2]).collect();
        let mut value = vec![0.0; n];
        let mut g = vec![vec![0.0; n]; 3];
        let mut h = vec![vec![0.0; n]; 6];
        {
            let [g0, g1, g2] = &mut g[..] else {
                unreachable!()
            };
            let [h0, h1, h2, h3, h4, h5] = &mut h[..] else {
                unreachable!()
            };
            eval_f32(
                kind,
                seed,
                base,
                &x,
                &y,
                &z,
                NoiseOutput {
                    value: &mut value,
                    gradient: Some([g0, g1, g2]),
                    hessian: Some([h0, h1, h2, h3, h4, h5]),
                },
            );
        }
        for i in 0..n {
            result.push((
                value[i],
                [g[0][i], g[1][i], g[2][i]],
                [h[0][i], h[1][i], h[2][i], h[3][i], h[4][i], h[5][i]],
            ));
        }
    }
    result
}

fn random_points(stream: &mut Stream, n: usize, centre: f64, half: f64) -> Vec<[f64; 3]> {
    (0..n)
        .map(|_| [0, 1, 2].map(|_| centre + stream.range(-half, half)))
        .collect()
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
            for (p, (_, gradient, hessian)) in points.iter().zip(&exact) {
                // Worley has kinks on Voronoi faces and at the cap; skip points whose
                // difference stencil could straddle one (the value near 1 or the nearest two
                // features almost tied are both detected by the gradient jumping).
                let mut shifted = Vec::new();
                for axis in 0..3 {
                    for sign in [1.0, -1.0] {
                        let mut q = *p;
                        q[axis] += sign * step;
                        shifted.push(q);
                    }
                }
                let around = full_f64(kind, seed, &shifted);
                let jump = around
                    .iter()
                    .any(|s| (0..3).any(|a| (s.1[a] - gradient[a]).abs() > 1e-2));
                if kind == NoiseKind::Worley && jump {
                    continue;
                }
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
        }
    }
}
