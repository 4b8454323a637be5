// Half floats by hand, for buffers that hold them: pack2x16float and
// unpack2x16float need a capability some adapters lack. Both take
// non-negative finite values only (what the lighting stores).

// A non-negative finite half float's value.
fn half_to_f32(bits: u32) -> f32 {
    let exponent = (bits >> 10u) & 0x1fu;
    let mantissa = bits & 0x3ffu;
    if exponent == 0u {
        return f32(mantissa) * 5.9604645e-8;
    }
    return bitcast<f32>(((exponent + 112u) << 23u) | (mantissa << 13u));
}

// The half float nearest `v`, for `v` between 0 and 65504 (the caller
// clamps): rounded to nearest by adding half of the dropped bits' unit
// before truncating (a carry into the exponent is the right rounding up).
fn f32_to_half(v: f32) -> u32 {
    let bits = bitcast<u32>(v) + 0x1000u;
    let exponent = i32((bits >> 23u) & 0xffu) - 112;
    if exponent <= 0 {
        // Below the smallest normal half (2^-14): a multiple of 2^-24.
        return u32(round(v * 16777216.0));
    }
    return (u32(exponent) << 10u) | ((bits >> 13u) & 0x3ffu);
}
