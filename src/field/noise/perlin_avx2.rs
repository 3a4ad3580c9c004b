//! Perlin noise values, eight points per AVX2 register, written with intrinsics: the loop a
//! cache fill or a render spends most of its time in.
//!
//! The generic kernel (`perlin.rs`) compiled with AVX2 enabled computes the same function, but
//! the compiler turns its per-corner choices into blend instructions (two or three
//! micro-ops each) and spills registers around them. Here every choice is a mask: a ±1 gradient
//! component is an xor of the offset's sign bit, the zero component an and-not. The one key
//! decision: this path must give the generic kernel's bits, so it repeats its arithmetic
//! operation for operation (no fused multiply-adds, the same order of sums) and differs only in
//! how it selects.
//!
//! The and-not makes a zero component `+0` where the generic kernel has `0·d`, `−0` when the
//! offset `d` is negative. That changes at most the sign of a zero ramp, and the value cannot
//! see it: the lower corner's ramp is never `−0` (its offsets are fractional positions, never
//! `−0`, and one of its terms is `+0`), so neither is any blend `a + (b − a)·t` built on it,
//! and a blend whose `a` is not `−0` gives the same bits for `b = +0` and `b = −0` (with
//! `t ≥ 0`). Derivatives do combine ramps otherwise, so they stay with the generic kernel.
//!
//! The agreement holds for finite points within 2³¹ lattice cells of the block's base (every
//! block of a grid or a ray); beyond that, and for NaN or infinite offsets, both paths give
//! some value without failing, but not necessarily the same one. Tests in `tests.rs` compare
//! the two bit for bit.

use super::hash::{PRIME_X, PRIME_Y, PRIME_Z};
use super::lattice::BlockBase;
use super::perlin;
use std::arch::x86_64::*;

/// The sign bit of an `f32`, in every lane.
const SIGN: i32 = i32::MIN;

/// Noise values at `base + (x[i], y[i], z[i])` for the common length of the slices, eight
/// points at a time; a tail shorter than eight goes through the generic kernel.
#[target_feature(enable = "avx2,fma")]
pub(super) fn values(
    key: u32,
    base: &BlockBase,
    x: &[f32],
    y: &[f32],
    z: &[f32],
    value: &mut [f32],
) {
    let n = value.len().min(x.len()).min(y.len()).min(z.len());
    let whole = n - n % 8;
    let cell = base.cell();
    let frac = base.frac();
    let lattice = Lattice {
        key: _mm256_set1_epi32(key as i32),
        cell: cell.map(|c| _mm256_set1_epi32(c as i32)),
        frac: frac.map(|f| _mm256_set1_ps(f)),
    };
    let mut i = 0;
    while i < whole {
        // SAFETY: i + 8 <= n, which no slice is shorter than.
        let offsets = unsafe {
            [
                _mm256_loadu_ps(x.as_ptr().add(i)),
                _mm256_loadu_ps(y.as_ptr().add(i)),
                _mm256_loadu_ps(z.as_ptr().add(i)),
            ]
        };
        let v = lattice.sample(offsets);
        // SAFETY: as for the loads.
        unsafe { _mm256_storeu_ps(value.as_mut_ptr().add(i), v) };
        i += 8;
    }
    for i in whole..n {
        let p = base.locate([x[i], y[i], z[i]]);
        value[i] = perlin::sample::<f32, false, false>(p, key).value;
    }
}

/// A block's base cell and position, and the seed's key, in every lane.
struct Lattice {
    key: __m256i,
    cell: [__m256i; 3],
    frac: [__m256; 3],
}

impl Lattice {
    /// Perlin noise at eight points given as offsets from the block's base.
    #[target_feature(enable = "avx2,fma")]
    fn sample(&self, offsets: [__m256; 3]) -> __m256 {
        // Where each point sits: as `BlockBase::locate`, whose floor equals the rounded-down
        // value for every offset that fits the lattice's i32 cells.
        let mut terms = [_mm256_setzero_si256(); 3];
        let mut lower = [_mm256_setzero_ps(); 3];
        let primes = [PRIME_X, PRIME_Y, PRIME_Z];
        for axis in 0..3 {
            let t = _mm256_add_ps(self.frac[axis], offsets[axis]);
            let floor = _mm256_floor_ps(t);
            let cell = _mm256_add_epi32(self.cell[axis], _mm256_cvttps_epi32(floor));
            terms[axis] = _mm256_mullo_epi32(cell, _mm256_set1_epi32(primes[axis] as i32));
            lower[axis] = _mm256_sub_ps(t, floor);
        }
        let one = _mm256_set1_ps(1.0);
        let upper = lower.map(|d| _mm256_sub_ps(d, one));
        let x = [terms[0], _mm256_add_epi32(terms[0], splat(PRIME_X as i32))];
        let y = [terms[1], _mm256_add_epi32(terms[1], splat(PRIME_Y as i32))];
        let z = [terms[2], _mm256_add_epi32(terms[2], splat(PRIME_Z as i32))];
        let zk = [
            _mm256_xor_si256(z[0], self.key),
            _mm256_xor_si256(z[1], self.key),
        ];

        // Corner `i + 2j + 4k`, written out eight times: left as a loop, the corners stayed a
        // loop, with the ramps kept in memory and the offsets chosen by branches.
        let d = [lower, upper];
        let corner = |i: usize, j: usize, k: usize| {
            let h = mix(_mm256_xor_si256(x[i], _mm256_xor_si256(y[j], zk[k])));
            edge_ramp(h, [d[i][0], d[j][1], d[k][2]])
        };
        let ramp = [
            corner(0, 0, 0),
            corner(1, 0, 0),
            corner(0, 1, 0),
            corner(1, 1, 0),
            corner(0, 0, 1),
            corner(1, 0, 1),
            corner(0, 1, 1),
            corner(1, 1, 1),
        ];

        let u = fade(lower[0]);
        let v = fade(lower[1]);
        let w = fade(lower[2]);
        let x00 = lerp(ramp[0], ramp[1], u);
        let x10 = lerp(ramp[2], ramp[3], u);
        let x01 = lerp(ramp[4], ramp[5], u);
        let x11 = lerp(ramp[6], ramp[7], u);
        lerp(lerp(x00, x10, v), lerp(x01, x11, v), w)
    }
}

#[target_feature(enable = "avx2,fma")]
fn splat(v: i32) -> __m256i {
    _mm256_set1_epi32(v)
}

/// `hash::mix` on eight lanes.
#[target_feature(enable = "avx2,fma")]
fn mix(mut h: __m256i) -> __m256i {
    h = _mm256_xor_si256(h, _mm256_srli_epi32::<16>(h));
    h = _mm256_mullo_epi32(h, splat(0x7feb_352d));
    h = _mm256_xor_si256(h, _mm256_srli_epi32::<15>(h));
    h = _mm256_mullo_epi32(h, splat(0x846c_a68b_u32 as i32));
    _mm256_xor_si256(h, _mm256_srli_epi32::<16>(h))
}

/// `hash::edge_ramp` on eight lanes, up to the sign of a zero ramp (see the module notes): the
/// zero axis `⌊3·(h >> 22) / 1024⌋` (the product fits 16 bits, so one multiply-add of 16-bit
/// halves computes it) drops its term, bits 0–2 flip the signs of the others.
#[target_feature(enable = "avx2,fma")]
fn edge_ramp(h: __m256i, d: [__m256; 3]) -> __m256 {
    let zero_axis =
        _mm256_srli_epi32::<10>(_mm256_madd_epi16(_mm256_srli_epi32::<22>(h), splat(3)));
    let sign = splat(SIGN);
    let flips = [
        _mm256_slli_epi32::<31>(h),
        _mm256_and_si256(_mm256_slli_epi32::<30>(h), sign),
        _mm256_and_si256(_mm256_slli_epi32::<29>(h), sign),
    ];
    let mut terms = [_mm256_setzero_ps(); 3];
    for axis in 0..3 {
        let dropped = _mm256_castsi256_ps(_mm256_cmpeq_epi32(zero_axis, splat(axis as i32)));
        let flipped = _mm256_xor_ps(d[axis], _mm256_castsi256_ps(flips[axis]));
        terms[axis] = _mm256_andnot_ps(dropped, flipped);
    }
    _mm256_add_ps(_mm256_add_ps(terms[0], terms[1]), terms[2])
}

/// `perlin::fade`'s value, operation for operation.
#[target_feature(enable = "avx2,fma")]
fn fade(t: __m256) -> __m256 {
    let t2 = _mm256_mul_ps(t, t);
    let inner = _mm256_sub_ps(_mm256_mul_ps(t, _mm256_set1_ps(6.0)), _mm256_set1_ps(15.0));
    let inner = _mm256_add_ps(_mm256_mul_ps(t, inner), _mm256_set1_ps(10.0));
    _mm256_mul_ps(_mm256_mul_ps(t2, t), inner)
}

/// `a + (b − a)·t`, rounded after each step as the generic kernel does.
#[target_feature(enable = "avx2,fma")]
fn lerp(a: __m256, b: __m256, t: __m256) -> __m256 {
    _mm256_add_ps(a, _mm256_mul_ps(_mm256_sub_ps(b, a), t))
}
