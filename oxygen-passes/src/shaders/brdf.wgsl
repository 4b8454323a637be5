// The reflectance model and light falloff shared by the raster shading
// pass (mesh/shading.wgsl) and the path-traced reference (reference/trace.wgsl),
// so that both model the same surfaces and lights with the same numbers.

#include "sceneprep/gpu_records.wgsl"
#include "sceneprep/constants"

const PI: f32 = 3.14159265;

// True when `x` has a direction: its largest component exceeds 1e-30, far
// above the smallest normal f32 (1.2e-38), so no GPU flushes it to zero as
// a denormal and `normalize_or` can scale `x` by its reciprocal.
fn has_direction(x: vec3<f32>) -> bool {
    return max(abs(x.x), max(abs(x.y), abs(x.z))) > 1e-30;
}

// `x` at unit length, or `fallback` when `x` has no direction. Finite for
// every finite `x`: `x` is first divided by its largest component (at least
// 1e-30, see `has_direction`), which leaves a vector whose squared length
// lies in [1, 3], so `inverseSqrt` can neither overflow nor meet zero, and
// squaring cannot overflow even for lengths near f32's maximum.
fn normalize_or(x: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let largest = max(abs(x.x), max(abs(x.y), abs(x.z)));
    if !(largest > 1e-30) {
        return fallback;
    }
    let scaled = x / largest;
    return scaled * inverseSqrt(dot(scaled, scaled));
}

// Schlick's Fresnel weight (1 - cos)^5, by multiplication. `cos_theta` is
// clamped to [0, 1]: a dot product of two unit vectors can exceed 1 by a
// rounding error (v·h where the view and light directions coincide, the
// sun's "hot spot" on the ground), and `pow` of the negative base 1 - cos is
// NaN (lavapipe evaluates pow as exp2(5 log2 x)). That NaN was issue 17's
// black pixel.
fn schlick_weight(cos_theta: f32) -> f32 {
    let m = 1.0 - clamp(cos_theta, 0.0, 1.0);
    let m2 = m * m;
    return m2 * m2 * m;
}

// Radiance reflected towards `v` from light arriving along `l`, per unit
// incoming irradiance at normal incidence. `n`, `v`, `l` are unit vectors;
// the result is finite for any finite input (each guard below says why).
fn brdf_cosine(n: vec3<f32>, v: vec3<f32>, l: vec3<f32>, albedo: vec3<f32>, metallic: f32, roughness: f32) -> vec3<f32> {
    // Written so that a NaN dot product also takes the early return.
    let n_dot_l_raw = dot(n, l);
    if !(n_dot_l_raw > 0.0) {
        return vec3<f32>(0.0);
    }
    let n_dot_l = min(n_dot_l_raw, 1.0);
    // The half vector has no direction when the view looks straight along
    // the light (v = -l, only possible with n·v < 0): h = 0 then gives the
    // specular lobe's grazing minimum (n·h = 0) rather than a NaN.
    let h = normalize_or(v + l, vec3<f32>(0.0));
    // Cosines clamped to [0, 1]: rounding can push a unit dot product past 1.
    // n·v at least 1e-4 keeps the visibility denominator positive below; a
    // surface seen edge-on (or from behind its shading normal) stays lit
    // as if seen at 89.99°.
    let n_dot_v = clamp(dot(n, v), 1e-4, 1.0);
    let n_dot_h = clamp(dot(n, h), 0.0, 1.0);
    let v_dot_h = clamp(dot(v, h), 0.0, 1.0);
    // GGX alpha at least 0.002 (roughness 0.045): roughness 0 would make
    // alpha² and the distribution's denominator both 0 where n·h = 1 (0/0).
    // With n·h in [0, 1] the denominator 1 - n·h² (1 - alpha²) is at least
    // alpha² = 4e-6, over 30 times f32's spacing near 1 (1.2e-7), so its
    // rounding cannot take it to zero; the peak 1 / (pi alpha²) is 8e4.
    let a = clamp(roughness * roughness, 0.002, 1.0);
    let a2 = a * a;
    let denom = 1.0 - n_dot_h * n_dot_h * (1.0 - a2);
    let distribution = a2 / (PI * denom * denom);
    // Height-correlated Smith visibility. Both square roots take at least
    // alpha² > 0 (1 - alpha² >= 0), so the denominator is at least
    // n·v alpha >= 1e-4 × 0.002, and n·l × visibility <= 0.5 / alpha.
    let visibility = 0.5 / (n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2) + n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2));
    let f0 = mix(vec3<f32>(0.04), albedo, metallic);
    let fresnel = f0 + (vec3<f32>(1.0) - f0) * schlick_weight(v_dot_h);
    let diffuse = (vec3<f32>(1.0) - fresnel) * (1.0 - metallic) * albedo / PI;
    return (diffuse + distribution * visibility * fresnel) * n_dot_l;
}

// How much of a spot light reaches a point at `cos_angle` from its axis: 1
// inside the inner cone, 0 outside the outer one, a smooth step between.
// WGSL's smoothstep is undefined when its edges are equal, which happens
// for a very narrow spot (the CPU keeps the cone angles 1e-4 rad apart, but
// their cosines both round to 1.0): a width under 1e-6 (about 16 f32 steps
// of a cosine near 1) becomes a hard edge, and the division by at least
// 1e-6 of a difference of at most 2 is finite.
fn spot_cone(cos_outer: f32, cos_inner: f32, cos_angle: f32) -> f32 {
    let width = cos_inner - cos_outer;
    if !(width > 1e-6) {
        return select(0.0, 1.0, cos_angle >= cos_outer);
    }
    let t = clamp((cos_angle - cos_outer) / width, 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}


// Where a positional light is seen from `position` and how much of its
// intensity arrives there, shadows aside: inverse-square falloff (the
// squared distance kept above 1e-4 so a light inside a surface stays
// finite), glTF's smooth range window, and a spot light's cone.
struct LightReach {
    l: vec3<f32>,
    attenuation: f32,
    distance: f32,
}

fn positional_light_at(light: PositionalLightRecord, position: vec3<f32>) -> LightReach {
    let to_light = light.position - position;
    let distance_sq = max(dot(to_light, to_light), 1e-4);
    let l = to_light * inverseSqrt(distance_sq);
    var attenuation = 1.0 / distance_sq;
    if light.range > 0.0 {
        let ratio = sqrt(distance_sq) / light.range;
        attenuation *= clamp(1.0 - ratio * ratio * ratio * ratio, 0.0, 1.0);
    }
    if light.kind == LIGHT_SPOT {
        attenuation *= spot_cone(light.cos_outer, light.cos_inner, dot(-l, light.direction));
    }
    return LightReach(l, attenuation, sqrt(distance_sq));
}
