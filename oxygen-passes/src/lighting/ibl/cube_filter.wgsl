// Building prefiltered cubes (environments and reflection probes) on the
// GPU, one full-screen triangle per face and level (see cube_filter.rs).

#include "lighting/ibl/cube_faces.wgsl"
#include "lighting/ibl/CubeFilterParams"

@group(0) @binding(0) var source: texture_2d_array<f32>;
@group(0) @binding(1) var source_sampler: sampler;
@group(0) @binding(2) var<uniform> params: CubeFilterParams;


const PI: f32 = 3.14159265358979;

struct Varying {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) @interpolate(flat) layer: u32,
}

// Vertices 3k .. 3k + 2 draw the full-screen triangle for layer k.
@vertex
fn vs(@builtin(vertex_index) index: u32) -> Varying {
    let corner = index % 3u;
    let uv = vec2<f32>(f32((corner << 1u) & 2u), f32(corner & 2u));
    return Varying(vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0), uv, index / 3u);
}

// Copies or halves a level: with a source twice the target's size this
// bilinear tap lands on the corner of four texels and averages them; with
// an equal size it lands on one texel's centre and copies it.
@fragment
fn fs_downsample(v: Varying) -> @location(0) vec4<f32> {
    return textureSampleLevel(source, source_sampler, v.uv, v.layer, 0.0);
}

// The procedural sky (twin of `oxygen_core::Sky::radiance`).
@fragment
fn fs_sky(v: Varying) -> @location(0) vec4<f32> {
    let d = normalize(cube_face_point(v.layer, v.uv));
    let up = d.y;
    var base: vec3<f32>;
    if up >= 0.0 {
        base = mix(params.horizon.rgb, params.zenith.rgb, sqrt(up));
    } else {
        base = mix(params.ground.rgb, params.horizon.rgb, clamp(1.0 + up * 12.0, 0.0, 1.0));
    }
    let towards_sun = max(dot(d, -params.sun_direction.xyz), 0.0);
    let glow = select(0.0, 1.0, up > -0.05) * pow(towards_sun, 32.0);
    return vec4<f32>(base + params.glow.rgb * glow, 1.0);
}

// An equirectangular image (layer 0 of `source`, with a box-filtered mip
// chain) resampled onto the face: longitude along x (-Z at the centre,
// turning towards +X), latitude along y (+Y at the top). The level is the
// one whose texels are as tall as this face texel, so a small bright spot
// (the sun) keeps its energy instead of falling between samples.
@fragment
fn fs_equirect(v: Varying) -> @location(0) vec4<f32> {
    let p = cube_face_point(v.layer, v.uv);
    let d = normalize(p);
    let longitude = atan2(d.x, -d.z);
    let latitude = acos(clamp(d.y, -1.0, 1.0));
    let uv = vec2<f32>(longitude / (2.0 * PI) + 0.5, latitude / PI);
    // Angular size of this face texel: (2 / size) / |p|² across at its
    // centre; an image row spans π / height.
    let texel_angle = 2.0 / f32(params.target_size) / dot(p, p);
    let image_height = f32(textureDimensions(source, 0).y);
    let lod = max(log2(texel_angle * image_height / PI), 0.0);
    return vec4<f32>(textureSampleLevel(source, source_sampler, uv, 0u, lod).rgb, 1.0);
}

fn hammersley(i: u32, n: u32) -> vec2<f32> {
    return vec2<f32>(f32(i) / f32(n), f32(reverseBits(i)) / 4294967296.0);
}

// The radiance a mirror of `params.roughness` sees along the face texel's
// direction n (the split-sum's prefiltered radiance, view = normal):
// GGX-distributed half vectors around n, each reflected light direction
// read from the box-filtered source at the level whose texels cover the
// solid angle the sample stands for (filtered importance sampling), so a
// few dozen samples give a smooth result. Samples cross face seams freely.
@fragment
fn fs_ggx(v: Varying) -> @location(0) vec4<f32> {
    let n = normalize(cube_face_point(v.layer, v.uv));
    let alpha = max(params.roughness * params.roughness, 1e-4);
    let a2 = alpha * alpha;
    // The CPU prefilter's frame (oxygen_core::environment): X × n near ±Y,
    // which stays perpendicular to n there as a fixed X does not.
    var t: vec3<f32>;
    if abs(n.y) < 0.999 {
        t = normalize(cross(vec3<f32>(0.0, 1.0, 0.0), n));
    } else {
        t = normalize(cross(vec3<f32>(1.0, 0.0, 0.0), n));
    }
    let b = cross(n, t);
    let source_size = f32(textureDimensions(source, 0).x);
    let source_levels = f32(textureNumLevels(source));
    let texel_solid_angle = 4.0 * PI / (6.0 * source_size * source_size);
    let samples = max(params.samples, 1u);
    var sum = vec3<f32>(0.0);
    var weight = 0.0;
    for (var i = 0u; i < samples; i++) {
        let u = hammersley(i, samples);
        let phi = 2.0 * PI * u.x;
        let cos_theta = sqrt((1.0 - u.y) / (1.0 + (a2 - 1.0) * u.y));
        let sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
        let h = t * (sin_theta * cos(phi)) + b * (sin_theta * sin(phi)) + n * cos_theta;
        let l = h * (2.0 * dot(n, h)) - n;
        let n_dot_l = dot(n, l);
        if n_dot_l > 0.0 {
            // pdf(l) = D(h) (n·h) / (4 (v·h)) = D(h) / 4 with v = n.
            let q = cos_theta * cos_theta * (a2 - 1.0) + 1.0;
            let pdf = a2 / (PI * q * q) / 4.0;
            let sample_solid_angle = 1.0 / (f32(samples) * pdf);
            // No bias towards blurrier levels (often +1 in the literature):
            // measured against the CPU reference, +1 doubled the error.
            let lod = clamp(0.5 * log2(sample_solid_angle / texel_solid_angle), 0.0, source_levels - 1.0);
            let at = cube_face_uv(l);
            sum += textureSampleLevel(source, source_sampler, at.xy, u32(at.z), lod).rgb * n_dot_l;
            weight += n_dot_l;
        }
    }
    return vec4<f32>(sum / max(weight, 1e-6), 1.0);
}

// The nine spherical-harmonic coefficients of the cosine-convolved radiance
// (irradiance), one per fragment of a 3 x 3 viewport (coefficient
// x + 3 y): every texel of a
// box-filtered level weighted by its solid angle (a box filter keeps each
// face's energy, so the sun counts fully), times the band's factor
// (π, 2π/3, π/4). Twin of `oxygen_core::Environment::prefilter`.
@fragment
fn fs_harmonics(v: Varying) -> @location(0) vec4<f32> {
    let index = u32(v.position.x) + 3u * u32(v.position.y);
    // Signed level and coordinates: GLSL's textureSize and texelFetch take
    // ints (naga passes a u32 through and GL refuses the shader).
    let level = i32(params.harmonics_level);
    let side = i32(textureDimensions(source, level).x);
    var sum = vec3<f32>(0.0);
    for (var face = 0; face < 6; face++) {
        for (var y = 0; y < side; y++) {
            for (var x = 0; x < side; x++) {
                let uv = (vec2<f32>(f32(x), f32(y)) + 0.5) / f32(side);
                let p = cube_face_point(u32(face), uv);
                let d2 = dot(p, p);
                let solid_angle = (2.0 / f32(side)) * (2.0 / f32(side)) / (d2 * sqrt(d2));
                let n = p / sqrt(d2);
                let radiance = textureLoad(source, vec2<i32>(x, y), face, level).rgb;
                sum += radiance * (sh_basis(index, n) * solid_angle);
            }
        }
    }
    var band = PI / 4.0;
    if index == 0u {
        band = PI;
    } else if index < 4u {
        band = 2.0 * PI / 3.0;
    }
    // Stored divided by HARMONICS_SCALE (16): the half float would overflow
    // for a bright environment.
    return vec4<f32>(sum * (band / 16.0), 1.0);
}

// Real spherical harmonic `i` of bands 0-2 (`oxygen_core::sh9`).
fn sh_basis(i: u32, n: vec3<f32>) -> f32 {
    switch i {
        case 0u: { return 0.282095; }
        case 1u: { return 0.488603 * n.y; }
        case 2u: { return 0.488603 * n.z; }
        case 3u: { return 0.488603 * n.x; }
        case 4u: { return 1.092548 * n.x * n.y; }
        case 5u: { return 1.092548 * n.y * n.z; }
        case 6u: { return 0.315392 * (3.0 * n.z * n.z - 1.0); }
        case 7u: { return 1.092548 * n.x * n.z; }
        default: { return 0.546274 * (n.x * n.x - n.y * n.y); }
    }
}
