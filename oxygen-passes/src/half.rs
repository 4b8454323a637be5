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
        // Subnormal half: shift the implicit one in.
        let m = (mantissa | 0x80_0000) >> (1 - exponent);
        let rounded = (m + 0x1000) >> 13;
        return sign | rounded as u16;
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
            let back = oxygen_core::gpu::f16_to_f32(super::f32_to_f16(v));
            let expected = v.clamp(-65504.0, 65504.0);
            assert!((back - expected).abs() <= expected.abs() * 1e-3 + 1e-7, "{v} -> {back}");
        }
        assert_eq!(super::f32_to_f16(f32::NAN), 0);
    }
}
