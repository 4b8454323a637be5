// `sample_texture` on the binding-array path: the slot indexes
// `texture_array` itself, and the location record's sampler field picks an
// entry of the sampler table. The group-2 declarations are generated in
// path.rs (from MAX_TEXTURES and SAMPLERS), the constants in location.rs and
// wgsl_constants.rs; oxygen-passes' shader registry resolves the includes.

#include "bindless/constants"
#include "bindless/domains"
#include "bindless/textures/binding_array/bindings"

// `v` moved into [0, 1] the way `wrap` wants, for a texture whose v axis
// wraps unlike its u axis (the table sampler wraps both like u; on [0, 1]
// every mode leaves a coordinate as it is). Clamping stops half a texel of
// the coarsest mip level the fetch reads inside the edge, so its bilinear
// taps stay on the edge row at every level; a repeat or mirror seam filters
// across the sampler's edge rule instead of the wrap's (half a texel wide,
// documented in docs/bindless.md).
fn wrap_v_here(v: f32, wrap: u32, size: vec2<f32>, duv_dx: vec2<f32>, duv_dy: vec2<f32>) -> f32 {
    switch wrap {
        case TEXTURE_WRAP_CLAMP: {
            let texels = max(length(duv_dx * size), length(duv_dy * size));
            let h = 0.5 * exp2(ceil(log2(max(texels, 1.0)))) / size.y;
            return clamp(v, min(h, 0.5), max(1.0 - h, 0.5));
        }
        case TEXTURE_WRAP_MIRROR: { return 1.0 - abs(fract(v * 0.5) * 2.0 - 1.0); }
        default: { return fract(v); }
    }
}

// Opaque white for a slot past the array (INVALID_SLOT included). The
// caller passes the UV's screen derivatives, taken in uniform control flow,
// which pick the mip level.
fn sample_texture(slot: u32, uv: vec2<f32>, duv_dx: vec2<f32>, duv_dy: vec2<f32>) -> vec4<f32> {
    if slot >= MAX_TEXTURES { return vec4<f32>(1.0); }
    let location = texture_location_domain[slot];
    let table = location >> TEXTURE_LOCATION_SAMPLER_SHIFT;
    let wrap_v = (location >> TEXTURE_LOCATION_WRAP_V_SHIFT) & TEXTURE_LOCATION_WRAP_V_MASK;
    var at = uv;
    if wrap_v != table / 2u {
        at.y = wrap_v_here(uv.y, wrap_v, vec2<f32>(textureDimensions(texture_array[slot])), duv_dx, duv_dy);
    }
    // One case per table entry: a sampler cannot be chosen by index here.
    switch table {
        case 0u: { return textureSampleGrad(texture_array[slot], texture_sampler_0, at, duv_dx, duv_dy); }
        case 1u: { return textureSampleGrad(texture_array[slot], texture_sampler_1, at, duv_dx, duv_dy); }
        case 2u: { return textureSampleGrad(texture_array[slot], texture_sampler_2, at, duv_dx, duv_dy); }
        case 3u: { return textureSampleGrad(texture_array[slot], texture_sampler_3, at, duv_dx, duv_dy); }
        case 4u: { return textureSampleGrad(texture_array[slot], texture_sampler_4, at, duv_dx, duv_dy); }
        case 5u: { return textureSampleGrad(texture_array[slot], texture_sampler_5, at, duv_dx, duv_dy); }
        default: { return vec4<f32>(1.0); }
    }
}
