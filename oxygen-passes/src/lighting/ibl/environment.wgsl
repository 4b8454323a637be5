// Reading the renderer's environment and the split-sum table, shared by the
// shading pass and the path-traced reference. The including shader
// declares `environment_faces` (the prefiltered cube, texture_2d_array),
// `environment_sampler` (trilinear), `split_sum` (the table's uniform
// array).

#include "lighting/constants"
#include "lighting/ibl/cube_faces.wgsl"
#include "shaders/half.wgsl"

// Coefficient `i` of the environment's irradiance harmonics: the 3 x 3
// corner of the layer after the faces, stored divided by 16
// (lighting/ibl/cube_filter.rs HARMONICS_SCALE). Signed coordinates: GLSL's texelFetch
// takes ints.
fn harmonic(i: u32) -> vec3<f32> {
    return textureLoad(environment_faces, vec2<i32>(i32(i % 3u), i32(i / 3u)), i32(PROBE_FACES), 0).rgb * 16.0;
}

// Irradiance from the environment on a surface facing `n` (its nine
// spherical-harmonic coefficients, cosine-convolved), summed as they are
// loaded.
fn environment_irradiance(n: vec3<f32>) -> vec3<f32> {
    var e = harmonic(0u) * 0.282095;
    e += harmonic(1u) * (0.488603 * n.y);
    e += harmonic(2u) * (0.488603 * n.z);
    e += harmonic(3u) * (0.488603 * n.x);
    e += harmonic(4u) * (1.092548 * n.x * n.y);
    e += harmonic(5u) * (1.092548 * n.y * n.z);
    e += harmonic(6u) * (0.315392 * (3.0 * n.z * n.z - 1.0));
    e += harmonic(7u) * (1.092548 * n.x * n.z);
    e += harmonic(8u) * (0.546274 * (n.x * n.x - n.y * n.y));
    return max(e, vec3<f32>(0.0));
}

// The prefiltered environment along `direction` for a surface of
// `roughness`: level l holds the GGX lobe of roughness l / (levels - 1);
// level 0 is the radiance itself.
fn sample_environment(direction: vec3<f32>, roughness: f32) -> vec3<f32> {
    let at = cube_face_uv(direction);
    let lod = clamp(roughness, 0.0, 1.0) * f32(textureNumLevels(environment_faces) - 1u);
    return textureSampleLevel(environment_faces, environment_sampler, at.xy, u32(at.z), lod).rgb;
}

// Texel (x, y) of the split-sum table: (A, B), red in the low half of the
// texel's first word (two RGBA16F texels per vec4<u32>).
fn split_sum_texel(x: u32, y: u32) -> vec2<f32> {
    let t = y * SPLIT_SUM_LUT_SIZE + x;
    let words = split_sum[t / 2u];
    let rg = select(words.x, words.z, (t & 1u) == 1u);
    return vec2<f32>(half_to_f32(rg & 0xffffu), half_to_f32(rg >> 16u));
}

// The split-sum scale and bias for F0 (lighting/split_sum.rs), interpolated
// bilinearly: texel i of the table is n·v (or roughness) i / (N - 1).
fn split_sum_brdf(f0: vec3<f32>, roughness: f32, n_dot_v: f32) -> vec3<f32> {
    let last = f32(SPLIT_SUM_LUT_SIZE - 1u);
    let p = clamp(vec2<f32>(n_dot_v, roughness), vec2<f32>(0.0), vec2<f32>(1.0)) * last;
    let i = min(vec2<u32>(floor(p)), vec2<u32>(SPLIT_SUM_LUT_SIZE - 2u));
    let f = p - vec2<f32>(i);
    let top = mix(split_sum_texel(i.x, i.y), split_sum_texel(i.x + 1u, i.y), f.x);
    let bottom = mix(split_sum_texel(i.x, i.y + 1u), split_sum_texel(i.x + 1u, i.y + 1u), f.x);
    let ab = mix(top, bottom, f.y);
    return f0 * ab.x + ab.y;
}
