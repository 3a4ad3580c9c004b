//! IEEE 754 binary16 ("half") conversions for grids that OpenVDB saved at half precision.
//!
//! felt keeps values in `f32`; only the file stores 16 bits. Widening is exact. Narrowing
//! rounds to nearest with ties to even, as OpenVDB's half type does, so a grid that felt writes
//! at half precision holds the same bits OpenVDB would have written. Written here rather than
//! taken from a crate because two small, exhaustively tested functions are all felt needs.

/// The `f32` equal to the half float with bit pattern `bits` (exact).
pub(crate) fn f16_to_f32(bits: u16) -> f32 {
    let negative = bits & 0x8000 != 0;
    let exponent = u32::from((bits >> 10) & 0x1f);
    let mantissa = u32::from(bits & 0x3ff);
    let sign = if negative { 0x8000_0000u32 } else { 0 };
    match exponent {
        // Zero and subnormals: mantissa × 2^-24, exact in f32.
        0 => {
            let magnitude = mantissa as f32 * (1.0 / 16_777_216.0);
            if negative { -magnitude } else { magnitude }
        }
        // Infinities and NaNs keep their payload in the top mantissa bits.
        31 => f32::from_bits(sign | 0x7f80_0000 | (mantissa << 13)),
        // Normal numbers: rebias the exponent from 15 to 127.
        _ => f32::from_bits(sign | ((exponent + 112) << 23) | (mantissa << 13)),
    }
}

/// The half float nearest to `value` (ties to even); too large → infinity, NaN stays NaN.
pub(crate) fn f32_to_f16(value: f32) -> u16 {
    let bits = value.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let exponent = ((bits >> 23) & 0xff) as i32;
    let mantissa = bits & 0x7f_ffff;
    if exponent == 0xff {
        let payload = if mantissa != 0 {
            0x200 | (mantissa >> 13) as u16
        } else {
            0
        };
        return sign | 0x7c00 | payload;
    }
    let half_exponent = exponent - 127 + 15;
    if half_exponent >= 31 {
        return sign | 0x7c00;
    }
    if half_exponent <= 0 {
        // The result is subnormal (or zero): units of 2^-24.
        if half_exponent < -10 {
            return sign;
        }
        let full = mantissa | 0x80_0000;
        let shift = (14 - half_exponent) as u32;
        let kept = full >> shift;
        let rest = full & ((1 << shift) - 1);
        let halfway = 1 << (shift - 1);
        let rounded = if rest > halfway || (rest == halfway && kept & 1 == 1) {
            kept + 1
        } else {
            kept
        };
        // A carry out of the subnormal range lands exactly on the smallest normal number.
        return sign | rounded as u16;
    }
    let kept = ((half_exponent as u32) << 10) | (mantissa >> 13);
    let rest = mantissa & 0x1fff;
    // A carry into the exponent is the correct rounding, up to and including infinity.
    let rounded = if rest > 0x1000 || (rest == 0x1000 && kept & 1 == 1) {
        kept + 1
    } else {
        kept
    };
    sign | rounded as u16
}

/// `value` rounded to the nearest half float, as an `f32`.
pub(crate) fn round_to_half(value: f32) -> f32 {
    f16_to_f32(f32_to_f16(value))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_bit_patterns() {
        // Values from the binary16 definition: 1 = 2^0, 65504 = (2 - 2^-10)·2^15, 2^-24 is
        // the smallest subnormal, 2^-14 the smallest normal.
        let cases: [(f32, u16); 9] = [
            (1.0, 0x3c00),
            (-2.0, 0xc000),
            (0.5, 0x3800),
            (65504.0, 0x7bff),
            (2f32.powi(-24), 0x0001),
            (2f32.powi(-14), 0x0400),
            (0.0, 0x0000),
            (-0.0, 0x8000),
            (f32::INFINITY, 0x7c00),
        ];
        for (value, bits) in cases {
            assert_eq!(f32_to_f16(value), bits, "{value}");
            assert_eq!(f16_to_f32(bits).to_bits(), value.to_bits(), "{bits:#x}");
        }
    }

    #[test]
    fn rounding_is_to_nearest_even() {
        // 0.1 lies between 0x2e66 (0.0999755859375) and 0x2e67 (0.10003662109375), nearer
        // the first; OpenVDB's own file stores 0.0999755859375 for a 0.1 background.
        assert_eq!(f32_to_f16(0.1), 0x2e66);
        assert_eq!(f64::from(f16_to_f32(0x2e66)), 0.099_975_585_937_5);
        // 1 + 2^-11 is halfway between 1 and 1 + 2^-10: ties go to the even mantissa (1).
        assert_eq!(f32_to_f16(1.0 + 2f32.powi(-11)), 0x3c00);
        // 1 + 3·2^-11 is halfway between 1 + 2^-10 (odd) and 1 + 2^-9 (even).
        assert_eq!(f32_to_f16(1.0 + 3.0 * 2f32.powi(-11)), 0x3c02);
        // 65520 is halfway between 65504 and 65536 (not representable): rounds to infinity.
        assert_eq!(f32_to_f16(65520.0), 0x7c00);
        assert_eq!(f32_to_f16(65519.99), 0x7bff);
        // 2^-25 is halfway between 0 and the smallest subnormal: ties to even, zero.
        assert_eq!(f32_to_f16(2f32.powi(-25)), 0x0000);
        assert_eq!(f32_to_f16(2f32.powi(-25) * 1.0001), 0x0001);
        // 1.5 · 2^-24 ties between subnormals 1 and 2: to 2 (even).
        assert_eq!(f32_to_f16(1.5 * 2f32.powi(-24)), 0x0002);
    }

    #[test]
    fn every_half_round_trips() {
        for bits in 0..=u16::MAX {
            let value = f16_to_f32(bits);
            if value.is_nan() {
                assert!(f16_to_f32(f32_to_f16(value)).is_nan());
            } else {
                assert_eq!(f32_to_f16(value), bits, "{bits:#x} -> {value}");
            }
        }
    }

    #[test]
    fn narrowing_picks_the_nearest_half() {
        // Against a brute-force nearest search over neighbouring halves.
        let mut state = 0x2545_f491_u32;
        for _ in 0..20_000 {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            let value = f32::from_bits(state & 0xc7ff_ffff); // magnitudes up to ~2^17
            if !value.is_finite() || value.abs() >= 65504.0 {
                continue;
            }
            let chosen = f16_to_f32(f32_to_f16(value)) as f64;
            let error = (chosen - value as f64).abs();
            let bits = f32_to_f16(value);
            for neighbour in [bits.wrapping_sub(1), bits.wrapping_add(1)] {
                let other = f16_to_f32(neighbour) as f64;
                if other.is_finite() && (other.signum() == chosen.signum() || other == 0.0) {
                    assert!(error <= (other - value as f64).abs(), "{value}");
                }
            }
        }
    }
}
