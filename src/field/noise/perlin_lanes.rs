//! Perlin noise values written with intrinsics, eight points per register with AVX2 and
//! sixteen with AVX-512: the loop a cache fill or a render spends most of its time in.
//!
//! The generic kernel (`perlin.rs`) compiled with AVX2 enabled computes the same function, but
//! the compiler turns its per-corner choices into blend instructions (two or three
//! micro-ops each) and spills registers around them. Here every choice is a mask: a ±1 gradient
//! component is an xor of the offset's sign bit, the zero component is cleared. The one key
//! decision: this path must give the generic kernel's bits, so it repeats its arithmetic
//! operation for operation (no fused multiply-adds, the same order of sums) and differs only in
//! how it selects. The kernel is written once (`perlin_values!`) over a small set of lane
//! operations, which `lane_ops!` defines for both register widths from one table; the widths
//! differ only in how a term is cleared (an and-not with a compare's lanes, or a zeroing mask).
//!
//! Clearing makes a zero component `+0` where the generic kernel has `0·d`, `−0` when the
//! offset `d` is negative. That changes at most the sign of a zero ramp, and the value cannot
//! see it: the lower corner's ramp is never `−0` (its offsets are fractional positions, never
//! `−0`, and one of its terms is `+0`), so neither is any blend `a + (b − a)·t` built on it,
//! and a blend whose `a` is not `−0` gives the same bits for `b = +0` and `b = −0` (with
//! `t ≥ 0`). Derivatives do combine ramps otherwise, so they stay with the generic kernel.
//!
//! The agreement holds for finite points within 2³¹ lattice cells of the block's base (every
//! block of a grid or a ray); beyond that, and for NaN or infinite offsets, both paths give
//! some value without failing, but not necessarily the same one. Tests in `tests.rs` compare
//! the builds bit for bit.

use super::hash::{PRIME_X, PRIME_Y, PRIME_Z};
use super::lattice::BlockBase;
use super::perlin;

/// The lane operations of both register widths from one table whose rows name the AVX2
/// intrinsic, then the AVX-512 one.
macro_rules! lane_ops {
    ($( $name:ident ( $($arg:ident : $ty:ident),* ) -> $out:ident = $avx2:path, $avx512:path; )*) => {
        lane_module! {
            avx2, "avx2,fma", __m256, __m256i, 8, _mm256_loadu_ps, _mm256_storeu_ps,
            |axis, which, f| _mm256_andnot_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(axis, which)), f);
            $( $name ( $($arg : $ty),* ) -> $out = $avx2; )*
        }
        lane_module! {
            avx512, "avx512f,avx512bw,avx512dq,avx2,fma", __m512, __m512i, 16, _mm512_loadu_ps,
            _mm512_storeu_ps,
            |axis, which, f| _mm512_maskz_mov_ps(!_mm512_cmpeq_epi32_mask(axis, which), f);
            $( $name ( $($arg : $ty),* ) -> $out = $avx512; )*
        }
    };
}

/// One width's lane operations, each a one-instruction wrapper compiled with the width's
/// features, plus loads, stores and `clear_where`, which the widths write differently.
macro_rules! lane_module {
    (
        $module:ident, $features:literal, $f:ty, $i:ty, $lanes:literal, $load:path, $store:path,
        |$axis:ident, $which:ident, $v:ident| $clear:expr;
        $( $name:ident ( $($arg:ident : $ty:ident),* ) -> $out:ident = $intrinsic:path; )*
    ) => {
        pub(super) mod $module {
            use std::arch::x86_64::*;
            pub type F = $f;
            pub type I = $i;
            pub const LANES: usize = $lanes;
            $(
                #[inline]
                #[target_feature(enable = $features)]
                pub fn $name($($arg: $ty),*) -> $out { $intrinsic($($arg),*) }
            )*
            /// `f` with the lanes where `axis == which` set to `+0`.
            #[inline]
            #[target_feature(enable = $features)]
            pub fn clear_where($axis: I, $which: I, $v: F) -> F {
                $clear
            }
            /// # Safety
            /// `p` must be valid for reading `LANES` values.
            #[inline]
            #[target_feature(enable = $features)]
            pub unsafe fn load(p: *const f32) -> F {
                // SAFETY: the caller's promise.
                unsafe { $load(p) }
            }
            /// # Safety
            /// `p` must be valid for writing `LANES` values.
            #[inline]
            #[target_feature(enable = $features)]
            pub unsafe fn store(p: *mut f32, v: F) {
                // SAFETY: the caller's promise.
                unsafe { $store(p, v) }
            }
        }
    };
}

lane_ops! {
    splat_f(v: f32) -> F = _mm256_set1_ps, _mm512_set1_ps;
    splat_i(v: i32) -> I = _mm256_set1_epi32, _mm512_set1_epi32;
    add(a: F, b: F) -> F = _mm256_add_ps, _mm512_add_ps;
    sub(a: F, b: F) -> F = _mm256_sub_ps, _mm512_sub_ps;
    mul(a: F, b: F) -> F = _mm256_mul_ps, _mm512_mul_ps;
    floor(a: F) -> F = _mm256_floor_ps, _mm512_roundscale_ps::<0x01>;
    truncate(a: F) -> I = _mm256_cvttps_epi32, _mm512_cvttps_epi32;
    add_i(a: I, b: I) -> I = _mm256_add_epi32, _mm512_add_epi32;
    mul_i(a: I, b: I) -> I = _mm256_mullo_epi32, _mm512_mullo_epi32;
    xor_i(a: I, b: I) -> I = _mm256_xor_si256, _mm512_xor_si512;
    and_i(a: I, b: I) -> I = _mm256_and_si256, _mm512_and_si512;
    madd_16(a: I, b: I) -> I = _mm256_madd_epi16, _mm512_madd_epi16;
    shr_10(a: I) -> I = _mm256_srli_epi32::<10>, _mm512_srli_epi32::<10>;
    shr_15(a: I) -> I = _mm256_srli_epi32::<15>, _mm512_srli_epi32::<15>;
    shr_16(a: I) -> I = _mm256_srli_epi32::<16>, _mm512_srli_epi32::<16>;
    shr_22(a: I) -> I = _mm256_srli_epi32::<22>, _mm512_srli_epi32::<22>;
    shl_29(a: I) -> I = _mm256_slli_epi32::<29>, _mm512_slli_epi32::<29>;
    shl_30(a: I) -> I = _mm256_slli_epi32::<30>, _mm512_slli_epi32::<30>;
    shl_31(a: I) -> I = _mm256_slli_epi32::<31>, _mm512_slli_epi32::<31>;
    as_f(a: I) -> F = _mm256_castsi256_ps, _mm512_castsi512_ps;
    as_i(a: F) -> I = _mm256_castps_si256, _mm512_castps_si512;
}

/// The values loop over one width's lane operations, in the module it is expanded in.
macro_rules! perlin_values {
    ($features:literal) => {
        /// Noise values at `base + (x[i], y[i], z[i])` for the first `LANES·⌊n / LANES⌋` points
        /// of the common length `n` of the slices; returns how many it wrote.
        #[target_feature(enable = $features)]
        pub fn values(
            key: u32,
            base: &BlockBase,
            x: &[f32],
            y: &[f32],
            z: &[f32],
            value: &mut [f32],
        ) -> usize {
            let n = value.len().min(x.len()).min(y.len()).min(z.len());
            let whole = n - n % LANES;
            let cell = base.cell();
            let frac = base.frac();
            let lattice = Lattice {
                key: splat_i(key as i32),
                cell: cell.map(|c| splat_i(c as i32)),
                frac: frac.map(|f| splat_f(f)),
            };
            let mut i = 0;
            while i < whole {
                // SAFETY: i + LANES <= n, which no slice is shorter than.
                let offsets = unsafe {
                    [
                        load(x.as_ptr().add(i)),
                        load(y.as_ptr().add(i)),
                        load(z.as_ptr().add(i)),
                    ]
                };
                let v = lattice.sample(offsets);
                // SAFETY: as for the loads.
                unsafe { store(value.as_mut_ptr().add(i), v) };
                i += LANES;
            }
            whole
        }

        /// A block's base cell and position, and the seed's key, in every lane.
        struct Lattice {
            key: I,
            cell: [I; 3],
            frac: [F; 3],
        }

        impl Lattice {
            /// Perlin noise at one register of points given as offsets from the block's base.
            #[target_feature(enable = $features)]
            fn sample(&self, offsets: [F; 3]) -> F {
                // Where each point sits: as `BlockBase::locate`, whose floor equals the
                // rounded-down value for every offset that fits the lattice's i32 cells.
                let mut terms = [splat_i(0); 3];
                let mut lower = [splat_f(0.0); 3];
                let primes = [PRIME_X, PRIME_Y, PRIME_Z];
                for axis in 0..3 {
                    let t = add(self.frac[axis], offsets[axis]);
                    let rounded = floor(t);
                    let cell = add_i(self.cell[axis], truncate(rounded));
                    terms[axis] = mul_i(cell, splat_i(primes[axis] as i32));
                    lower[axis] = sub(t, rounded);
                }
                let one = splat_f(1.0);
                let upper = lower.map(|d| sub(d, one));
                let x = [terms[0], add_i(terms[0], splat_i(PRIME_X as i32))];
                let y = [terms[1], add_i(terms[1], splat_i(PRIME_Y as i32))];
                let z = [terms[2], add_i(terms[2], splat_i(PRIME_Z as i32))];
                let zk = [xor_i(z[0], self.key), xor_i(z[1], self.key)];

                // Corner `i + 2j + 4k`, written out eight times: left as a loop, the corners
                // stayed a loop, with the ramps kept in memory and the offsets chosen by
                // branches.
                let d = [lower, upper];
                let corner = |i: usize, j: usize, k: usize| {
                    let h = mix(xor_i(x[i], xor_i(y[j], zk[k])));
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

        /// `hash::mix` on every lane.
        #[target_feature(enable = $features)]
        fn mix(mut h: I) -> I {
            h = xor_i(h, shr_16(h));
            h = mul_i(h, splat_i(0x7feb_352d));
            h = xor_i(h, shr_15(h));
            h = mul_i(h, splat_i(0x846c_a68b_u32 as i32));
            xor_i(h, shr_16(h))
        }

        /// `hash::edge_ramp` on every lane, up to the sign of a zero ramp (see the module
        /// notes): the zero axis `⌊3·(h >> 22) / 1024⌋` (the product fits 16 bits, so one
        /// multiply-add of 16-bit halves computes it) drops its term, bits 0–2 flip the signs
        /// of the others.
        #[target_feature(enable = $features)]
        fn edge_ramp(h: I, d: [F; 3]) -> F {
            let zero_axis = shr_10(madd_16(shr_22(h), splat_i(3)));
            let sign = splat_i(i32::MIN);
            let flips = [shl_31(h), and_i(shl_30(h), sign), and_i(shl_29(h), sign)];
            let mut terms = [splat_f(0.0); 3];
            for axis in 0..3 {
                let flipped = as_f(xor_i(as_i(d[axis]), flips[axis]));
                terms[axis] = clear_where(zero_axis, splat_i(axis as i32), flipped);
            }
            add(add(terms[0], terms[1]), terms[2])
        }

        /// `perlin::fade`'s value, operation for operation.
        #[target_feature(enable = $features)]
        fn fade(t: F) -> F {
            let t2 = mul(t, t);
            let inner = sub(mul(t, splat_f(6.0)), splat_f(15.0));
            let inner = add(mul(t, inner), splat_f(10.0));
            mul(mul(t2, t), inner)
        }

        /// `a + (b − a)·t`, rounded after each step as the generic kernel does.
        #[target_feature(enable = $features)]
        fn lerp(a: F, b: F, t: F) -> F {
            add(a, mul(sub(b, a), t))
        }
    };
}

/// The eight-lane loop.
mod avx2_values {
    use super::avx2::*;
    use super::{BlockBase, PRIME_X, PRIME_Y, PRIME_Z};
    perlin_values!("avx2,fma");
}

/// The sixteen-lane loop.
mod avx512_values {
    use super::avx512::*;
    use super::{BlockBase, PRIME_X, PRIME_Y, PRIME_Z};
    perlin_values!("avx512f,avx512bw,avx512dq,avx2,fma");
}

/// Whether this CPU runs the sixteen-lane loop (detected once, then cached by `std`).
pub(super) fn has_avx512() -> bool {
    std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512bw")
        && std::arch::is_x86_feature_detected!("avx512dq")
}

/// Noise values at `base + (x[i], y[i], z[i])` for the common length of the slices: sixteen
/// points at a time where `wide` (the caller has checked `has_avx512`), then eight, then the
/// generic kernel for a tail shorter than eight.
///
/// # Safety
/// The CPU must have AVX2 and FMA, and the AVX-512 features of `has_avx512` when `wide`.
pub(super) unsafe fn values(
    wide: bool,
    key: u32,
    base: &BlockBase,
    x: &[f32],
    y: &[f32],
    z: &[f32],
    value: &mut [f32],
) {
    let mut done = 0;
    if wide {
        // SAFETY: the caller's promise.
        done = unsafe { avx512_values::values(key, base, x, y, z, value) };
    }
    // SAFETY: the caller's promise.
    done += unsafe {
        avx2_values::values(
            key,
            base,
            &x[done..],
            &y[done..],
            &z[done..],
            &mut value[done..],
        )
    };
    let n = value.len().min(x.len()).min(y.len()).min(z.len());
    for i in done..n {
        let p = base.locate([x[i], y[i], z[i]]);
        value[i] = perlin::sample::<f32, false, false>(p, key).value;
    }
}
