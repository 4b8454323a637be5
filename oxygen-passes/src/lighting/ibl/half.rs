//! Half floats, the format of HDR targets and environments, converted on
//! the CPU (uploads and readbacks).

/// `value` as a half float (round to nearest even; overflow to the largest
/// finite half, which the HDR target can hold; NaN to 0).
pub(crate) fn f32_to_f16(value: f32) -> u16 {
    if !value.is_finite() {
        return if value.is_nan() {
            0
        } else if value > 0.0 {
            0x7bff
        } else {
            0xfbff
        };
    }
    let bits = value.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let exponent = ((bits >> 23) & 0xff) as i32 - 127 + 15;
    let mantissa = bits & 0x7f_ffff;
    if exponent >= 31 {
        return sign | 0x7bff;
    }
    if exponent <= 0 {
        if exponent < -10 {
            return sign;
        }
        // Subnormal half: the 24-bit significand (implicit one shifted in)
        // shifted down to the half's 10 bits, rounded to nearest even on
        // every bit shifted out (a carry into the smallest normal, 0x0400,
        // is that normal's encoding).
        let significand = mantissa | 0x80_0000;
        let shift = (14 - exponent) as u32;
        let kept = significand >> shift;
        let rest = significand & ((1 << shift) - 1);
        let halfway = 1 << (shift - 1);
        let up = rest > halfway || (rest == halfway && kept & 1 == 1);
        return sign | (kept + u32::from(up)) as u16;
    }
    let rounded = ((exponent as u32) << 10 | (mantissa >> 13))
        + u32::from((mantissa & 0x1fff) > 0x1000 || ((mantissa & 0x1fff) == 0x1000 && (mantissa >> 13) & 1 == 1));
    if rounded >= 0x7c00 { sign | 0x7bff } else { sign | rounded as u16 }
}

#[cfg(test)]
mod tests {
    #[test]
    fn half_floats_round_trip_within_their_precision() {
        for v in [0.0f32, 1.0, -2.5, 0.1, 2.7, 1e-5, 6.1e-5, 65504.0, 1e6, -1e6] {
            let back = oxygen_gpu::f16_to_f32(super::f32_to_f16(v));
            let expected = v.clamp(-65504.0, 65504.0);
            assert!((back - expected).abs() <= expected.abs() * 1e-3 + 1e-7, "{v} -> {back}");
        }
        assert_eq!(super::f32_to_f16(f32::NAN), 0);
    }

    /// Every finite half comes back as itself; every midpoint between two
    /// neighbouring halves (normal and subnormal, both signs) rounds to the
    /// even one, and the floats just beside it to the nearer one; beyond
    /// the largest half, infinities saturate; below the smallest subnormal's
    /// half, values flush to a signed zero.
    #[test]
    fn every_half_round_trips_and_midpoints_round_to_even() {
        use oxygen_gpu::f16_to_f32;
        let to_half = super::f32_to_f16;
        for sign in [0u16, 0x8000] {
            for magnitude in 0..0x7c00u16 {
                let h = sign | magnitude;
                assert_eq!(to_half(f16_to_f32(h)), h, "{h:#06x} does not round-trip");
                if magnitude + 1 == 0x7c00 {
                    continue;
                }
                let next = h + 1;
                let (a, b) = (f16_to_f32(h) as f64, f16_to_f32(next) as f64);
                // Halves have at most 11 significant bits: the midpoint is exact in f32.
                let mid = ((a + b) / 2.0) as f32;
                let even = if magnitude & 1 == 0 { h } else { next };
                assert_eq!(to_half(mid), even, "midpoint of {h:#06x} and {next:#06x} ({mid:e})");
                let away = f32::from_bits(mid.to_bits() + 1); // one ulp further from zero
                let toward = f32::from_bits(mid.to_bits() - 1);
                assert_eq!(to_half(away), next, "just past the midpoint of {h:#06x} and {next:#06x}");
                assert_eq!(to_half(toward), h, "just short of the midpoint of {h:#06x} and {next:#06x}");
            }
            let signed = |v: f32| if sign == 0 { v } else { -v };
            // Halfway between the largest half and 2^16 rounds up past it: saturated.
            assert_eq!(to_half(signed(65520.0)), sign | 0x7bff);
            assert_eq!(to_half(signed(65519.0)), sign | 0x7bff);
            assert_eq!(to_half(signed(1e9)), sign | 0x7bff);
            assert_eq!(to_half(signed(f32::INFINITY)), sign | 0x7bff);
            // Half the smallest subnormal (2^-25) is a tie: to the even zero.
            assert_eq!(to_half(signed(2f32.powi(-25))), sign);
            assert_eq!(to_half(signed(2f32.powi(-26))), sign);
            assert_eq!(to_half(signed(f32::from_bits(2f32.powi(-25).to_bits() + 1))), sign | 1);
        }
    }
}
