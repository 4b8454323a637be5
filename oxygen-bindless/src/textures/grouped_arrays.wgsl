// `sample_texture` on the grouped-arrays path: the location record names
// an array (size class × colour space), a layer in it, a wrap mode and a
// filter. Every array has one repeat-linear sampler (GL pairs a texture
// with one sampler), so the other wrap modes are applied to the coordinate
// here, and nearest filtering loads the texel under it. The group-2
// declarations are generated in path.rs, the constants in location.rs and
// wgsl_constants.rs; oxygen-passes' shader registry resolves the includes.

#include "bindless/constants"
#include "bindless/domains"
#include "bindless/textures/grouped_arrays/bindings"

// One coordinate moved the way `wrap` wants (into [0, 1] for clamp and
// mirror; repeat is the sampler's own). Clamping stops half a texel of the
// coarsest mip level the fetch reads (`texels`: the footprint in level-0
// texels) inside, so that the repeat sampler's bilinear taps do not wrap
// around at any level.
fn wrap_axis(x: f32, wrap: u32, side: f32, texels: f32) -> f32 {
    switch wrap {
        case TEXTURE_WRAP_CLAMP: {
            let h = 0.5 * exp2(ceil(log2(max(texels, 1.0)))) / side;
            return clamp(x, min(h, 0.5), max(1.0 - h, 0.5));
        }
        case TEXTURE_WRAP_MIRROR: { return 1.0 - abs(fract(x * 0.5) * 2.0 - 1.0); }
        default: { return x; }
    }
}

// `uv` wrapped per axis: u by `wrap_u`, v by `wrap_v`.
fn wrap_uv(uv: vec2<f32>, wrap_u: u32, wrap_v: u32, side: f32, duv_dx: vec2<f32>, duv_dy: vec2<f32>) -> vec2<f32> {
    let texels = max(length(duv_dx), length(duv_dy)) * side;
    return vec2<f32>(wrap_axis(uv.x, wrap_u, side, texels), wrap_axis(uv.y, wrap_v, side, texels));
}

// One coordinate of the level-0 texel under it, wrapped.
fn nearest_axis(x: f32, wrap: u32) -> f32 {
    if wrap == TEXTURE_WRAP_CLAMP { return clamp(x, 0.0, 1.0); }
    if wrap == TEXTURE_WRAP_MIRROR { return 1.0 - abs(fract(x * 0.5) * 2.0 - 1.0); }
    return fract(x);
}

// The level-0 texel under `uv` in a `side` × `side` layer, wrapped per axis.
fn nearest_texel(uv: vec2<f32>, wrap_u: u32, wrap_v: u32, side: f32) -> vec2<i32> {
    let w = vec2<f32>(nearest_axis(uv.x, wrap_u), nearest_axis(uv.y, wrap_v));
    return clamp(vec2<i32>(floor(w * side)), vec2<i32>(0), vec2<i32>(i32(side) - 1));
}

// Opaque white for INVALID_SLOT. The caller passes the UV's screen
// derivatives, taken in uniform control flow, which pick the mip level.
fn sample_texture(slot: u32, uv: vec2<f32>, duv_dx: vec2<f32>, duv_dy: vec2<f32>) -> vec4<f32> {
    if slot == INVALID_SLOT { return vec4<f32>(1.0); }
    let location = texture_location_domain[slot];
    let layer = location & TEXTURE_LOCATION_LAYER_MASK;
    let wrap = location >> TEXTURE_LOCATION_SAMPLER_SHIFT;
    let wrap_v = (location >> TEXTURE_LOCATION_WRAP_V_SHIFT) & TEXTURE_LOCATION_WRAP_V_MASK;
    let nearest = (location & TEXTURE_LOCATION_NEAREST_BIT) != 0u;
    // One case per array: textures of different arrays cannot be chosen by index.
    switch (location >> TEXTURE_LOCATION_GROUP_SHIFT) & TEXTURE_LOCATION_GROUP_MASK {
        case 0u: {
            let side = f32(textureDimensions(texture_group_0).x);
            if nearest { return textureLoad(texture_group_0, nearest_texel(uv, wrap, wrap_v, side), layer, 0); }
            return textureSampleGrad(texture_group_0, texture_sampler_0, wrap_uv(uv, wrap, wrap_v, side, duv_dx, duv_dy), layer, duv_dx, duv_dy);
        }
        case 1u: {
            let side = f32(textureDimensions(texture_group_1).x);
            if nearest { return textureLoad(texture_group_1, nearest_texel(uv, wrap, wrap_v, side), layer, 0); }
            return textureSampleGrad(texture_group_1, texture_sampler_0, wrap_uv(uv, wrap, wrap_v, side, duv_dx, duv_dy), layer, duv_dx, duv_dy);
        }
        case 2u: {
            let side = f32(textureDimensions(texture_group_2).x);
            if nearest { return textureLoad(texture_group_2, nearest_texel(uv, wrap, wrap_v, side), layer, 0); }
            return textureSampleGrad(texture_group_2, texture_sampler_0, wrap_uv(uv, wrap, wrap_v, side, duv_dx, duv_dy), layer, duv_dx, duv_dy);
        }
        case 3u: {
            let side = f32(textureDimensions(texture_group_3).x);
            if nearest { return textureLoad(texture_group_3, nearest_texel(uv, wrap, wrap_v, side), layer, 0); }
            return textureSampleGrad(texture_group_3, texture_sampler_0, wrap_uv(uv, wrap, wrap_v, side, duv_dx, duv_dy), layer, duv_dx, duv_dy);
        }
        case 4u: {
            let side = f32(textureDimensions(texture_group_4).x);
            if nearest { return textureLoad(texture_group_4, nearest_texel(uv, wrap, wrap_v, side), layer, 0); }
            return textureSampleGrad(texture_group_4, texture_sampler_0, wrap_uv(uv, wrap, wrap_v, side, duv_dx, duv_dy), layer, duv_dx, duv_dy);
        }
        case 5u: {
            let side = f32(textureDimensions(texture_group_5).x);
            if nearest { return textureLoad(texture_group_5, nearest_texel(uv, wrap, wrap_v, side), layer, 0); }
            return textureSampleGrad(texture_group_5, texture_sampler_0, wrap_uv(uv, wrap, wrap_v, side, duv_dx, duv_dy), layer, duv_dx, duv_dy);
        }
        default: { return vec4<f32>(1.0); }
    }
}
