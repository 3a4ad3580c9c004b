//! Where a point sits on the integer lattice, in f32 lanes or in f64, and the number type the
//! noise kernels are written over.
//!
//! The one key decision: precision far from the origin comes from splitting positions, not
//! from wide lanes. A block of points is given as one `f64` base point plus small `f32`
//! offsets; the base's lattice cell is taken once per block in `f64`/`i64`, and each lane only
//! adds its offset to the base's fractional part. So a point 10⁹ units away is located as
//! exactly as one near the origin, while the per-point work stays in `f32`. The `f64` path
//! floors each coordinate directly; both paths then run the same kernel code (generic over
//! [`Real`]), so they compute the same function and differ only by rounding.

use std::ops::{Add, Mul, Neg, Sub};

/// The lane number type of the kernels: `f32` for speed, `f64` as the accuracy reference.
pub(crate) trait Real:
    Copy
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Neg<Output = Self>
{
    const ZERO: Self;
    const ONE: Self;
    /// A constant written in `f64` (folded at compile time).
    fn lit(v: f64) -> Self;
    fn from_i32(v: i32) -> Self;
    fn sqrt(self) -> Self;
    /// `1 / self`.
    fn recip(self) -> Self;
    /// `-self` if `negate`, else `self`: the product with `-1` or `1` for every value but NaN,
    /// done on the sign bit so the compiler keeps it an integer xor in vector lanes.
    fn negate_if(self, negate: bool) -> Self;
}

impl Real for f32 {
    const ZERO: f32 = 0.0;
    const ONE: f32 = 1.0;
    #[inline(always)]
    fn lit(v: f64) -> f32 {
        v as f32
    }
    #[inline(always)]
    fn from_i32(v: i32) -> f32 {
        v as f32
    }
    #[inline(always)]
    fn sqrt(self) -> f32 {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn recip(self) -> f32 {
        1.0 / self
    }
    #[inline(always)]
    fn negate_if(self, negate: bool) -> f32 {
        f32::from_bits(self.to_bits() ^ ((negate as u32) << 31))
    }
}

impl Real for f64 {
    const ZERO: f64 = 0.0;
    const ONE: f64 = 1.0;
    #[inline(always)]
    fn lit(v: f64) -> f64 {
        v
    }
    #[inline(always)]
    fn from_i32(v: i32) -> f64 {
        v as f64
    }
    #[inline(always)]
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn recip(self) -> f64 {
        1.0 / self
    }
    #[inline(always)]
    fn negate_if(self, negate: bool) -> f64 {
        f64::from_bits(self.to_bits() ^ ((negate as u64) << 63))
    }
}

/// `if c { a } else { b }` for lane values; compiles to a blend, not a branch.
#[inline(always)]
pub(crate) fn select<R: Real>(c: bool, a: R, b: R) -> R {
    if c { a } else { b }
}

/// What a kernel returns for one point. Hessian order: xx, yy, zz, xy, xz, yz.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sample<R> {
    pub value: R,
    pub gradient: [R; 3],
    pub hessian: [R; 6],
}

impl<R: Real> Sample<R> {
    #[inline(always)]
    pub fn zero() -> Sample<R> {
        Sample {
            value: R::ZERO,
            gradient: [R::ZERO; 3],
            hessian: [R::ZERO; 6],
        }
    }
}

/// A point on the lattice: its cell (modulo 2³²) and its position inside the cell, in [0, 1).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Located<R> {
    pub cell: [u32; 3],
    pub frac: [R; 3],
}

/// A block's base point on the lattice, located once in `f64`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BlockBase {
    cell: [u32; 3],
    frac: [f32; 3],
}

impl BlockBase {
    pub fn new(base: [f64; 3]) -> BlockBase {
        let mut cell = [0u32; 3];
        let mut frac = [0f32; 3];
        for axis in 0..3 {
            let floor = base[axis].floor();
            // i64 holds any cell a scene can reach; the hash only sees it modulo 2³².
            cell[axis] = floor as i64 as u32;
            frac[axis] = (base[axis] - floor) as f32;
        }
        BlockBase { cell, frac }
    }

    /// The base's lattice cell (modulo 2³²).
    #[inline(always)]
    pub fn cell(&self) -> [u32; 3] {
        self.cell
    }

    /// The base's position inside its cell, rounded to `f32`.
    #[inline(always)]
    pub fn frac(&self) -> [f32; 3] {
        self.frac
    }

    /// The lattice position of `base + offset`. Only the small offset is carried in `f32`.
    #[inline(always)]
    pub fn locate(&self, offset: [f32; 3]) -> Located<f32> {
        let mut cell = [0u32; 3];
        let mut frac = [0f32; 3];
        for axis in 0..3 {
            let t = self.frac[axis] + offset[axis];
            let floor = floor_i32(t);
            cell[axis] = self.cell[axis].wrapping_add(floor as u32);
            frac[axis] = t - floor as f32;
        }
        Located { cell, frac }
    }
}

/// `floor` of a lane value that fits an i32 (block offsets always do; anything else, NaN and
/// infinities included, gives some cell but never fails: the convert saturates and the
/// correction wraps). Written with a truncating convert so it vectorises on every x86 level.
///
/// The convert is Rust's saturating `as i32` spelled out: x86 has no saturating vector
/// convert, so a plain `as` is split into one scalar convert and two branches-free fix-ups
/// per lane, which cost as much as a third of a Perlin sample. Here only in-range lanes are
/// converted (a single packed convert) and the out-of-range ones are chosen by compares, with
/// the same result as `as` for every input.
#[inline(always)]
fn floor_i32(t: f32) -> i32 {
    const LIMIT: f32 = 2_147_483_648.0; // 2³¹
    // NaN fails both compares, like every out-of-range value.
    let inside = (-LIMIT..LIMIT).contains(&t);
    // SAFETY: the converted value is finite and in [-2³¹, 2³¹), so it truncates to an i32.
    let converted = unsafe { (if inside { t } else { 0.0 }).to_int_unchecked::<i32>() };
    let saturated = if t > 0.0 {
        i32::MAX
    } else if t < 0.0 {
        i32::MIN
    } else {
        0
    };
    let truncated = if inside { converted } else { saturated };
    truncated.wrapping_sub(((truncated as f32) > t) as i32)
}

/// The lattice position of an `f64` point.
#[inline(always)]
pub(crate) fn locate_f64(p: [f64; 3]) -> Located<f64> {
    let mut cell = [0u32; 3];
    let mut frac = [0f64; 3];
    for axis in 0..3 {
        let floor = p[axis].floor();
        cell[axis] = floor as i64 as u32;
        frac[axis] = p[axis] - floor;
    }
    Located { cell, frac }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn far_cells_wrap_the_same_way_in_both_paths() {
        for &(base, offset) in &[
            (1.0e9 + 0.25, 0.5f32),
            (-1.0e9 - 0.75, 0.5),
            (-1.0e9 - 0.75, -1.5),
            (123_456.5, -0.75),
            (-0.25, 0.5),
        ] {
            let block = BlockBase::new([base, 0.0, 0.0]).locate([offset, 0.0, 0.0]);
            let direct = locate_f64([base + offset as f64, 0.0, 0.0]);
            assert_eq!(block.cell[0], direct.cell[0], "{base} + {offset}");
            assert!((block.frac[0] as f64 - direct.frac[0]).abs() < 1e-6);
            // The cell of x is floor(x) modulo 2³².
            let expected = (base + offset as f64).floor() as i64;
            assert_eq!(direct.cell[0], expected.rem_euclid(1 << 32) as u32);
        }
    }

    #[test]
    fn floor_of_lanes() {
        for &(t, f) in &[(-0.5f32, -1), (0.0, 0), (2.75, 2), (-3.0, -3), (-2.999, -3)] {
            assert_eq!(floor_i32(t), f);
        }
    }

    /// The convert spelled out for vector lanes gives what `as i32` (which saturates and maps
    /// NaN to 0) followed by the same correction gives, for every kind of input, in range or
    /// not; and the lanes of a vectorised loop agree with the scalar calls.
    #[test]
    fn floor_agrees_with_the_saturating_convert() {
        let saturating = |t: f32| {
            let truncated = t as i32;
            truncated.wrapping_sub(((truncated as f32) > t) as i32)
        };
        let mut inputs = vec![
            0.0f32,
            -0.0,
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            f32::MIN,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-40,
            -1e-40,
            2_147_483_648.0,
            -2_147_483_648.0,
            2_147_483_520.0,
            -2_147_483_520.0,
            -2_147_483_904.0,
            4.0e9,
            -4.0e9,
            16_777_217.0,
            -16_777_215.5,
            0.999_999_94,
            -0.999_999_94,
            -1.0e-10,
        ];
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..20_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            // Random bit patterns cover every exponent, both signs and NaN payloads.
            inputs.push(f32::from_bits((state >> 32) as u32));
            inputs.push(((state & 0xffff) as f32 - 32768.0) / 64.0);
        }
        let scalar: Vec<i32> = inputs.iter().map(|&t| saturating(t)).collect();
        let mut lanes = vec![0i32; inputs.len()];
        for (l, &t) in lanes.iter_mut().zip(&inputs) {
            *l = floor_i32(t);
        }
        for ((t, s), l) in inputs.iter().zip(&scalar).zip(&lanes) {
            assert_eq!(s, l, "floor of {t:e} ({:#010x})", t.to_bits());
            assert_eq!(*s, std::hint::black_box(floor_i32)(*t), "{t:e}");
        }
    }
}
