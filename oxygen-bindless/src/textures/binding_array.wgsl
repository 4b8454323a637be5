// `sample_texture` on the binding-array path: the slot indexes
// `texture_array` itself, and the location record's sampler field picks an
// entry of the sampler table. The group-2 declarations before this file are
// generated in path.rs (from MAX_TEXTURES and SAMPLERS), the constants in
// location.rs and wgsl_constants.rs.

// Opaque white for a slot past the array (INVALID_SLOT included). The
// caller passes the UV's screen derivatives, taken in uniform control flow,
// which pick the mip level.
fn sample_texture(slot: u32, uv: vec2<f32>, duv_dx: vec2<f32>, duv_dy: vec2<f32>) -> vec4<f32> {
    if slot >= MAX_TEXTURES { return vec4<f32>(1.0); }
    let location = texture_location_domain[slot];
    // One case per table entry: a sampler cannot be chosen by index here.
    switch location >> TEXTURE_LOCATION_SAMPLER_SHIFT {
        case 0u: { return textureSampleGrad(texture_array[slot], texture_sampler_0, uv, duv_dx, duv_dy); }
        case 1u: { return textureSampleGrad(texture_array[slot], texture_sampler_1, uv, duv_dx, duv_dy); }
        case 2u: { return textureSampleGrad(texture_array[slot], texture_sampler_2, uv, duv_dx, duv_dy); }
        case 3u: { return textureSampleGrad(texture_array[slot], texture_sampler_3, uv, duv_dx, duv_dy); }
        case 4u: { return textureSampleGrad(texture_array[slot], texture_sampler_4, uv, duv_dx, duv_dy); }
        case 5u: { return textureSampleGrad(texture_array[slot], texture_sampler_5, uv, duv_dx, duv_dy); }
        default: { return vec4<f32>(1.0); }
    }
}
