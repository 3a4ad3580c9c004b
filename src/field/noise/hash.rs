//! Lattice hashing: turns an integer lattice point and a seed into well-mixed bits.
//!
//! The one key decision: hash arithmetically (multiplies, xors and shifts on 32-bit integers)
//! instead of looking corners up in a permutation table. Table lookups become scalar gathers
//! that stop the compiler from keeping eight points in one vector register; the arithmetic form
//! stays in vector lanes and, with AVX2, costs a few instructions per corner. Lattice
//! coordinates are taken modulo 2³², so every noise is periodic with period 2³² lattice cells,
//! far beyond any coordinate a scene uses.

use super::lattice::Real;

/// Odd multipliers that spread each axis over all 32 bits before the axes are combined.
pub(crate) const PRIME_X: u32 = 0x8da6_b343;
pub(crate) const PRIME_Y: u32 = 0xd816_3841;
pub(crate) const PRIME_Z: u32 = 0xcb1a_b31f;

/// A bijective avalanche of 32 bits (two multiply/xor-shift rounds): every output bit depends
/// on every input bit, so neighbouring lattice points get unrelated gradients.
#[inline(always)]
pub(crate) fn mix(mut h: u32) -> u32 {
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^= h >> 16;
    h
}

/// Spreads a user seed so that seeds 0, 1, 2, ... give unrelated fields.
#[inline]
pub(crate) fn seed_key(seed: u32) -> u32 {
    mix(mix(seed ^ 0x9e37_79b9).wrapping_add(0x632b_e5ab))
}

/// Per-axis premultiplied lattice coordinates; a corner's hash is `mix(x ^ y ^ z ^ key)`.
#[inline(always)]
pub(crate) fn axis_terms(cell: [u32; 3]) -> [u32; 3] {
    [
        cell[0].wrapping_mul(PRIME_X),
        cell[1].wrapping_mul(PRIME_Y),
        cell[2].wrapping_mul(PRIME_Z),
    ]
}

/// The hash of the corner whose premultiplied axis terms are given.
#[inline(always)]
pub(crate) fn corner(x: u32, y: u32, z: u32, key: u32) -> u32 {
    mix(x ^ y ^ z ^ key)
}

/// One of the twelve cube-edge gradients `(±1, ±1, 0)`, `(±1, 0, ±1)`, `(0, ±1, ±1)`, each
/// equally likely: the top ten bits choose the axis that is zero (as `⌊3v/1024⌋`, a multiply
/// instead of a table or a modulo), the low three bits the signs.
#[inline(always)]
pub(crate) fn edge_gradient<R: Real>(h: u32) -> [R; 3] {
    let zero_axis = ((h >> 22) * 3) >> 10;
    let sign = |bit: u32| 1 - (((h >> bit) & 1) << 1) as i32;
    let component =
        |axis: u32, bit: u32| R::from_i32(if zero_axis == axis { 0 } else { sign(bit) });
    [component(0, 0), component(1, 1), component(2, 2)]
}

/// The ramp `g·d` of the edge gradient `g = edge_gradient(h)`, bit for bit as the three
/// products and two sums would give it, without turning `g` into numbers: a ±1 component
/// becomes a sign flip of `d`'s component and the zero component the product `0·d` (a zero
/// carrying `d`'s sign, which a plain `0` would not, and which decides the sign of a ramp
/// whose other terms are zeros too). Only a NaN `d` may come out with another sign bit.
#[inline(always)]
pub(crate) fn edge_ramp<R: Real>(h: u32, d: [R; 3]) -> R {
    let zero_axis = ((h >> 22) * 3) >> 10;
    let term = |axis: u32, bit: u32| {
        let v = d[axis as usize];
        if zero_axis == axis {
            v * R::ZERO
        } else {
            v.negate_if((h >> bit) & 1 == 1)
        }
    };
    term(0, 0) + term(1, 1) + term(2, 2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mix_is_a_bijection_on_a_sample() {
        let mut seen: Vec<u32> = (0..1u32 << 16).map(mix).collect();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), 1 << 16);
    }

    #[test]
    fn edge_gradients_are_uniform_over_the_twelve() {
        let mut counts = std::collections::HashMap::new();
        let n = 120_000u32;
        for i in 0..n {
            let g: [f64; 3] = edge_gradient(corner(i.wrapping_mul(PRIME_X), 0, 0, 7));
            assert_eq!(g.iter().filter(|c| **c == 0.0).count(), 1);
            assert_eq!(g.iter().map(|c| c * c).sum::<f64>(), 2.0);
            *counts.entry(g.map(|c| c as i32)).or_insert(0u32) += 1;
        }
        assert_eq!(counts.len(), 12);
        // Each gradient expects n/12 = 10000 hits, standard deviation about 96.
        for (g, count) in counts {
            assert!((count as f64 - 10_000.0).abs() < 500.0, "{g:?}: {count}");
        }
    }

    /// The sign-flip ramp is the product ramp to the bit, zeros' signs included, for all twelve
    /// gradients and offsets of both signs, zeros, subnormals and infinities.
    #[test]
    fn edge_ramp_is_the_dot_product_bit_for_bit() {
        let specials = [
            0.0f32,
            -0.0,
            0.25,
            -0.25,
            1.0,
            -1.0,
            1e-40,
            -1e-40,
            3.0e38,
            -3.0e38,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        let dot = |g: [f32; 3], d: [f32; 3]| g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
        let mut hashes = 0;
        for i in 0..4096u32 {
            let h = mix(i);
            hashes += 1;
            let g: [f32; 3] = edge_gradient(h);
            let g64: [f64; 3] = edge_gradient(h);
            for a in specials {
                for b in specials {
                    for c in specials {
                        let d = [a, b, c];
                        let (want, got) = (dot(g, d), edge_ramp(h, d));
                        // A NaN ramp (0·∞, ∞ − ∞) must stay NaN; its sign is not specified.
                        if want.is_nan() {
                            assert!(got.is_nan(), "{h:#x} {d:?}");
                            continue;
                        }
                        assert_eq!(want.to_bits(), got.to_bits(), "{h:#x} {d:?}");
                        let d64 = d.map(f64::from);
                        let want = g64[0] * d64[0] + g64[1] * d64[1] + g64[2] * d64[2];
                        let got = edge_ramp(h, d64);
                        assert!(want.is_nan() == got.is_nan(), "{h:#x} {d64:?}");
                        if !want.is_nan() {
                            assert_eq!(want.to_bits(), got.to_bits(), "{h:#x} {d64:?}");
                        }
                    }
                }
            }
        }
        assert_eq!(hashes, 4096);
    }

    #[test]
    fn seeds_are_spread() {
        let keys: Vec<u32> = (0..4).map(seed_key).collect();
        for a in 0..4 {
            for b in a + 1..4 {
                assert!((keys[a] ^ keys[b]).count_ones() > 6);
            }
        }
    }
}
