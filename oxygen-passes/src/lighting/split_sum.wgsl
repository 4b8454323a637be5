// The split-sum environment BRDF lookup table (see split_sum.rs): texel
// (i, j) of an N x N target holds the scale A and bias B applied to F0 for
// n·v = i / (N - 1) and perceptual roughness j / (N - 1), integrating the
// same specular lobe the direct lights use (GGX, height-correlated Smith
// visibility, Schlick Fresnel) by GGX importance sampling. Twin of
// `oxygen_core::split_sum_brdf`.

#include "lighting/constants"

const PI: f32 = 3.14159265358979;
const SAMPLES: u32 = 1024u;

@vertex
fn vs(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    return vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
}

fn hammersley(i: u32, n: u32) -> vec2<f32> {
    return vec2<f32>(f32(i) / f32(n), f32(reverseBits(i)) / 4294967296.0);
}

@fragment
fn fs(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let last = f32(SPLIT_SUM_LUT_SIZE - 1u);
    let n_dot_v = max(floor(position.x) / last, 1e-3);
    let roughness = floor(position.y) / last;
    let a = clamp(roughness * roughness, 0.002, 1.0);
    let a2 = a * a;
    // n = +z, v in the xz plane.
    let v = vec3<f32>(sqrt(1.0 - n_dot_v * n_dot_v), 0.0, n_dot_v);
    var scale = 0.0;
    var bias = 0.0;
    for (var i = 0u; i < SAMPLES; i++) {
        let u = hammersley(i, SAMPLES);
        let phi = 2.0 * PI * u.x;
        let cos_theta = sqrt((1.0 - u.y) / (1.0 + (a2 - 1.0) * u.y));
        let sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
        let h = vec3<f32>(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
        let v_dot_h = dot(v, h);
        let l = h * (2.0 * v_dot_h) - v;
        let n_dot_l = l.z;
        if n_dot_l > 0.0 && v_dot_h > 0.0 {
            let visibility = 0.5 / (n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2)
                + n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2));
            // D · V · n·l / pdf(l), with pdf(l) = D (n·h) / (4 v·h).
            let weight = visibility * n_dot_l * 4.0 * v_dot_h / cos_theta;
            let m = 1.0 - v_dot_h;
            let fresnel = m * m * m * m * m;
            scale += (1.0 - fresnel) * weight;
            bias += fresnel * weight;
        }
    }
    return vec4<f32>(scale / f32(SAMPLES), bias / f32(SAMPLES), 0.0, 1.0);
}
