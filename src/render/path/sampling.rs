//! Random numbers and the directions drawn from them.
//!
//! Every number a path uses is a counter hash of `(seed, pixel, sample, bounce, dimension)`:
//! a path's numbers do not depend on which thread traces it or on what was traced before, so
//! an image is bit-identical for any thread count. The dimension is a running counter within
//! a bounce (a free flight may take any number of tentative collisions), and each bounce
//! starts its own counter, so a change to how many numbers one bounce takes leaves the
//! numbers of the other bounces alone. Phase functions are sampled exactly (their pdf is the
//! phase itself), so a scattered path keeps its weight.

use crate::render::phase::Phase;
use glam::DVec3;
use std::f64::consts::PI;

/// SplitMix64's finaliser: a bijection that scatters nearby counters across all 64 bits.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The stream of the numbers drawn before the first flight; bounces are at most
/// `MAX_BOUNCES`, far below.
const CAMERA_STREAM: u32 = u32::MAX;

/// The random numbers of one path.
#[derive(Clone, Debug)]
pub struct PathRandom {
    /// The hash of `(seed, pixel, sample)`.
    path: u64,
    /// The hash of the path and the current bounce.
    bounce: u64,
    dimension: u64,
}

impl PathRandom {
    pub fn new(seed: u64, pixel: u64, sample: u64) -> PathRandom {
        let mut h = mix(seed ^ 0x6a09_e667_f3bc_c908);
        h = mix(h ^ pixel);
        h = mix(h ^ sample.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        let mut random = PathRandom {
            path: h,
            bounce: 0,
            dimension: 0,
        };
        // The camera's own numbers (pixel jitter) come from a stream no bounce uses.
        random.start_bounce(CAMERA_STREAM);
        random
    }

    /// Restarts the counter for the numbers of scattering order `bounce`.
    pub fn start_bounce(&mut self, bounce: u32) {
        self.bounce = mix(self.path ^ (u64::from(bounce) + 1).wrapping_mul(0xbf58_476d_1ce4_e5b9));
        self.dimension = 0;
    }

    /// The next number in [0, 1): the top 53 bits as a fraction, never 1.
    pub fn uniform(&mut self) -> f64 {
        self.dimension += 1;
        let h = mix(self.bounce ^ self.dimension.wrapping_mul(0x94d0_49bb_1331_11eb));
        (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// An exponential variate of mean 1 (an optical depth to the next tentative collision).
    pub fn optical_depth(&mut self) -> f64 {
        // 1 − u is in (0, 1], so the logarithm is finite.
        -(1.0 - self.uniform()).ln()
    }
}

/// A unit vector at angle `acos(cos_theta)` from `axis`, turned by `phi` around it.
pub fn around(axis: DVec3, cos_theta: f64, phi: f64) -> DVec3 {
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let (u, v) = axis.any_orthonormal_pair();
    (axis * cos_theta + (u * phi.cos() + v * phi.sin()) * sin_theta).normalize()
}

/// The cosine of a Henyey–Greenstein scattering angle with eccentricity `g`, by inverting its
/// cumulative distribution (pbrt-v4 §11.3.1); near `g = 0` the uniform cosine.
fn henyey_greenstein_cosine(g: f64, u: f64) -> f64 {
    if g.abs() < 1e-3 {
        return 1.0 - 2.0 * u;
    }
    let ratio = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    ((1.0 + g * g - ratio * ratio) / (2.0 * g)).clamp(-1.0, 1.0)
}

/// A new direction for a path travelling along `direction` that scatters with `phase`.
///
/// The phase's `cos_theta` is between the direction light travels and the direction towards
/// the camera; a path traced from the camera runs against the light, so both are reversed and
/// the cosine is the one between the path's old and new directions: forward scattering
/// (`g > 0`) keeps a path going the way it went.
pub fn scatter(phase: &Phase, direction: DVec3, random: &mut PathRandom) -> DVec3 {
    let g = match *phase {
        Phase::Isotropic => 0.0,
        Phase::HenyeyGreenstein { g } => g,
        Phase::TwoLobe { g1, g2, weight } => {
            if random.uniform() < weight {
                g1
            } else {
                g2
            }
        }
    };
    let cos_theta = henyey_greenstein_cosine(g, random.uniform());
    around(direction, cos_theta, 2.0 * PI * random.uniform())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampled_cosines_follow_the_phase() {
        // The mean cosine of Henyey–Greenstein is g, and of the two-lobe mix the weighted
        // mean of its lobes' g (the definition of the eccentricity, independent of sampling).
        let mut random = PathRandom::new(3, 4, 5);
        for (phase, expected) in [
            (Phase::Isotropic, 0.0),
            (Phase::HenyeyGreenstein { g: 0.7 }, 0.7),
            (Phase::HenyeyGreenstein { g: -0.4 }, -0.4),
            (
                Phase::TwoLobe {
                    g1: 0.8,
                    g2: -0.3,
                    weight: 0.6,
                },
                0.6 * 0.8 - 0.4 * 0.3,
            ),
        ] {
            let n = 200_000;
            let axis = DVec3::new(1.0, 2.0, -0.5).normalize();
            let (mut sum, mut sum2) = (0.0, 0.0);
            for _ in 0..n {
                let d = scatter(&phase, axis, &mut random);
                assert!((d.length() - 1.0).abs() < 1e-12);
                let c = d.dot(axis);
                sum += c;
                sum2 += c * c;
            }
            let mean = sum / n as f64;
            let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
            assert!(
                (mean - expected).abs() < 5.0 * sigma,
                "{phase:?}: {mean} vs {expected} (σ {sigma})"
            );
        }
    }

    #[test]
    fn numbers_depend_on_their_counters_only() {
        let mut a = PathRandom::new(1, 2, 3);
        a.start_bounce(4);
        let first = a.uniform();
        let mut b = PathRandom::new(1, 2, 3);
        b.uniform();
        b.start_bounce(4);
        assert_eq!(first.to_bits(), b.uniform().to_bits());
        let mut c = PathRandom::new(1, 2, 4);
        c.start_bounce(4);
        assert_ne!(first.to_bits(), c.uniform().to_bits());
        // Uniform: the mean of many draws is ½ within a few standard errors.
        let n = 100_000;
        let mean = (0..n).map(|_| a.uniform()).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 5.0 * (1.0 / 12.0 / n as f64).sqrt());
    }
}
