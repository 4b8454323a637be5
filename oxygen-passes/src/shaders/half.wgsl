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

// The half float nearest `v` (ties to even, as IEEE rounds), for `v`
// between 0 and 65504; anything else (negative, NaN, larger) is first
// brought into that range, NaN to 0, so the result always fits 16 bits.
// Rounds by adding just under half of the dropped bits' unit, plus one
// when the kept part is odd, before truncating (a carry into the
// exponent is the right rounding up).
fn f32_to_half(value: f32) -> u32 {
    let v = select(clamp(value, 0.0, 65504.0), 0.0, value != value);
    let b = bitcast<u32>(v);
    let bits = b + 0xfffu + ((b >> 13u) & 1u);
    let exponent = i32((bits >> 23u) & 0xffu) - 112;
    if exponent <= 0 {
        // Below the smallest normal half (2^-14): a multiple of 2^-24.
        return u32(round(v * 16777216.0));
    }
    return ((u32(exponent) << 10u) | ((bits >> 13u) & 0x3ffu)) & 0xffffu;
}
