// `sample_texture` on the grouped-arrays path: the location record names
// an array (size class × colour space), a layer in it, a wrap mode and a
// filter. Every array has one repeat-linear sampler (GL pairs a texture
// with one sampler), so the other wrap modes are applied to the coordinate
// here, and nearest filtering loads the texel under it. The group-2
// declarations before this file are generated in path.rs; the constants in
// location.rs and wgsl_constants.rs.

// `uv` moved into [0, 1) the way `wrap` wants. Clamping stops half a texel
// inside, so that the repeat sampler's bilinear taps do not wrap around.
fn wrap_uv(uv: vec2<f32>, wrap: u32, side: f32) -> vec2<f32> {
    switch wrap {
        case TEXTURE_WRAP_CLAMP: { let h = 0.5 / side; return clamp(uv, vec2<f32>(h), vec2<f32>(1.0 - h)); }
        case TEXTURE_WRAP_MIRROR: { return 1.0 - abs(fract(uv * 0.5) * 2.0 - 1.0); }
        default: { return uv; }
    }
}

// The level-0 texel under `uv` in a `side` × `side` layer, wrapped.
fn nearest_texel(uv: vec2<f32>, wrap: u32, side: f32) -> vec2<i32> {
    var w = fract(uv);
    if wrap == TEXTURE_WRAP_CLAMP { w = clamp(uv, vec2<f32>(0.0), vec2<f32>(1.0)); }
    if wrap == TEXTURE_WRAP_MIRROR { w = 1.0 - abs(fract(uv * 0.5) * 2.0 - 1.0); }
    return clamp(vec2<i32>(floor(w * side)), vec2<i32>(0), vec2<i32>(i32(side) - 1));
}

// Opaque white for INVALID_SLOT. The caller passes the UV's screen
// derivatives, taken in uniform control flow, which pick the mip level.
fn sample_texture(slot: u32, uv: vec2<f32>, duv_dx: vec2<f32>, duv_dy: vec2<f32>) -> vec4<f32> {
    if slot == INVALID_SLOT { return vec4<f32>(1.0); }
    let location = texture_location_domain[slot];
    let layer = location & TEXTURE_LOCATION_LAYER_MASK;
    let wrap = location >> TEXTURE_LOCATION_SAMPLER_SHIFT;
    let nearest = (location & TEXTURE_LOCATION_NEAREST_BIT) != 0u;
    // One case per array: textures of different arrays cannot be chosen by index.
    switch (location >> TEXTURE_LOCATION_GROUP_SHIFT) & TEXTURE_LOCATION_GROUP_MASK {
        case 0u: {
            let side = f32(textureDimensions(texture_group_0).x);
            if nearest { return textureLoad(texture_group_0, nearest_texel(uv, wrap, side), layer, 0); }
            return textureSampleGrad(texture_group_0, texture_sampler_0, wrap_uv(uv, wrap, side), layer, duv_dx, duv_dy);
        }
        case 1u: {
            let side = f32(textureDimensions(texture_group_1).x);
            if nearest { return textureLoad(texture_group_1, nearest_texel(uv, wrap, side), layer, 0); }
            return textureSampleGrad(texture_group_1, texture_sampler_0, wrap_uv(uv, wrap, side), layer, duv_dx, duv_dy);
        }
        case 2u: {
            let side = f32(textureDimensions(texture_group_2).x);
            if nearest { return textureLoad(texture_group_2, nearest_texel(uv, wrap, side), layer, 0); }
            return textureSampleGrad(texture_group_2, texture_sampler_0, wrap_uv(uv, wrap, side), layer, duv_dx, duv_dy);
        }
        case 3u: {
            let side = f32(textureDimensions(texture_group_3).x);
            if nearest { return textureLoad(texture_group_3, nearest_texel(uv, wrap, side), layer, 0); }
            return textureSampleGrad(texture_group_3, texture_sampler_0, wrap_uv(uv, wrap, side), layer, duv_dx, duv_dy);
        }
        case 4u: {
            let side = f32(textureDimensions(texture_group_4).x);
            if nearest { return textureLoad(texture_group_4, nearest_texel(uv, wrap, side), layer, 0); }
            return textureSampleGrad(texture_group_4, texture_sampler_0, wrap_uv(uv, wrap, side), layer, duv_dx, duv_dy);
        }
        case 5u: {
            let side = f32(textureDimensions(texture_group_5).x);
            if nearest { return textureLoad(texture_group_5, nearest_texel(uv, wrap, side), layer, 0); }
            return textureSampleGrad(texture_group_5, texture_sampler_0, wrap_uv(uv, wrap, side), layer, duv_dx, duv_dy);
        }
        default: { return vec4<f32>(1.0); }
    }
}
