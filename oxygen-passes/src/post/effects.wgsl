// The tone-map step's effects (post/effects.rs): a bloom chain and
// automatic exposure, then the tone map with both.
//
// Bloom: the HDR image is halved level by level into a mip chain
// (`fs_bloom_down`, a 13-tap filter; the first level weights each tap by
// 1 / (1 + luma) so that a single very bright pixel does not flare), then
// each level is blurred back up into the one above with a 3 × 3 tent and
// added to it (`fs_bloom_up`, additive blending). The tone map mixes the
// top level into the image.
//
// Automatic exposure: a histogram of the image's log2 luminance over 256
// bins (`luminance_histogram`; bin 0 holds the black pixels), then one
// workgroup (`adapt_exposure`) takes the mean log2 luminance of the pixels
// between two percentiles, the exposure that brings it to the key, and
// moves the view's exposure toward it at the adaptation speed.

#include "post/tonemap_operator.wgsl"
#include "post/BloomParams"
#include "post/ExposureParams"
#include "post/EffectsParams"

#include "shaders/fullscreen.wgsl"

// ---- Bloom

@group(0) @binding(0) var bloom_source: texture_2d<f32>;
@group(0) @binding(1) var bloom_sampler: sampler;
@group(0) @binding(2) var<uniform> bloom: BloomParams;

fn luma(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}

fn tap(uv: vec2<f32>, offset: vec2<f32>) -> vec3<f32> {
    // Finite and non-negative: a NaN or negative texel spreads nothing.
    let c = textureSampleLevel(bloom_source, bloom_sampler, uv + offset * bloom.source_texel, 0.0).rgb;
    return clamp(select(vec3<f32>(0.0), c, c == c), vec3<f32>(0.0), vec3<f32>(65000.0));
}

// Weighted by 1 / (1 + luma) on the first level only.
fn karis(c: vec3<f32>) -> f32 {
    return select(1.0, 1.0 / (1.0 + luma(c)), bloom.first_level != 0u);
}

fn group_of_four(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, d: vec3<f32>) -> vec4<f32> {
    let wa = karis(a);
    let wb = karis(b);
    let wc = karis(c);
    let wd = karis(d);
    return vec4<f32>(a * wa + b * wb + c * wc + d * wd, wa + wb + wc + wd);
}

@fragment
fn fs_bloom_down(in: FullscreenVarying) -> @location(0) vec4<f32> {
    let uv = in.position.xy * bloom.target_texel;
    let a = tap(uv, vec2<f32>(-2.0, -2.0));
    let b = tap(uv, vec2<f32>(0.0, -2.0));
    let c = tap(uv, vec2<f32>(2.0, -2.0));
    let d = tap(uv, vec2<f32>(-2.0, 0.0));
    let e = tap(uv, vec2<f32>(0.0, 0.0));
    let f = tap(uv, vec2<f32>(2.0, 0.0));
    let g = tap(uv, vec2<f32>(-2.0, 2.0));
    let h = tap(uv, vec2<f32>(0.0, 2.0));
    let i = tap(uv, vec2<f32>(2.0, 2.0));
    let j = tap(uv, vec2<f32>(-1.0, -1.0));
    let k = tap(uv, vec2<f32>(1.0, -1.0));
    let l = tap(uv, vec2<f32>(-1.0, 1.0));
    let m = tap(uv, vec2<f32>(1.0, 1.0));
    // Five overlapping boxes: the centre one weighs half, the corners an
    // eighth each.
    let centre = group_of_four(j, k, l, m);
    let corners = array<vec4<f32>, 4>(
        group_of_four(a, b, d, e),
        group_of_four(b, c, e, f),
        group_of_four(d, e, g, h),
        group_of_four(e, f, h, i),
    );
    var sum = 0.5 * centre;
    for (var q = 0; q < 4; q++) {
        sum += 0.125 * corners[q];
    }
    return vec4<f32>(sum.rgb / max(sum.a, 1.0e-6), 1.0);
}

@fragment
fn fs_bloom_up(in: FullscreenVarying) -> @location(0) vec4<f32> {
    let uv = in.position.xy * bloom.target_texel;
    let r = bloom.radius;
    var sum = 4.0 * tap(uv, vec2<f32>(0.0));
    sum += 2.0 * (tap(uv, vec2<f32>(-r, 0.0)) + tap(uv, vec2<f32>(r, 0.0)) + tap(uv, vec2<f32>(0.0, -r)) + tap(uv, vec2<f32>(0.0, r)));
    sum += tap(uv, vec2<f32>(-r, -r)) + tap(uv, vec2<f32>(r, -r)) + tap(uv, vec2<f32>(-r, r)) + tap(uv, vec2<f32>(r, r));
    return vec4<f32>(sum / 16.0, 1.0);
}

// ---- Automatic exposure

@group(0) @binding(3) var exposure_source: texture_2d<f32>;
@group(0) @binding(4) var<uniform> exposure_params: ExposureParams;
@group(0) @binding(5) var<storage, read_write> histogram: array<atomic<u32>, 256>;
// [exposure, its log2, the mean log2 luminance measured, 1 once set]
@group(0) @binding(6) var<storage, read_write> exposure_state: array<f32, 4>;

var<workgroup> bins: array<atomic<u32>, 256>;
var<workgroup> counts: array<u32, 256>;

fn bin_of(c: vec3<f32>) -> u32 {
    let l = luma(c);
    if !(l > 1.0e-6) {
        return 0u;
    }
    let t = clamp((log2(l) - exposure_params.log2_min) * exposure_params.inverse_log2_range, 0.0, 1.0);
    return 1u + u32(t * 254.0);
}

@compute @workgroup_size(16, 16)
fn luminance_histogram(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    atomicStore(&bins[lane], 0u);
    workgroupBarrier();
    let size = textureDimensions(exposure_source);
    if all(id.xy < size) {
        let c = textureLoad(exposure_source, vec2<i32>(id.xy), 0).rgb;
        atomicAdd(&bins[bin_of(c)], 1u);
    }
    workgroupBarrier();
    atomicAdd(&histogram[lane], atomicLoad(&bins[lane]));
}

@compute @workgroup_size(256)
fn adapt_exposure(@builtin(local_invocation_index) lane: u32) {
    counts[lane] = atomicLoad(&histogram[lane]);
    // Cleared for the next frame's histogram.
    atomicStore(&histogram[lane], 0u);
    workgroupBarrier();
    if lane != 0u {
        return;
    }
    var lit = 0u;
    for (var b = 1u; b < 256u; b++) {
        lit += counts[b];
    }
    let previous_set = exposure_state[3] > 0.5;
    if lit == 0u {
        // A black image: nothing to measure, the exposure stays.
        if !previous_set {
            exposure_state[0] = 1.0;
            exposure_state[1] = 0.0;
        }
        return;
    }
    // The mean bin of the pixels between the two percentiles.
    let low = exposure_params.low_fraction * f32(lit);
    let high = exposure_params.high_fraction * f32(lit);
    var below = 0.0;
    var weighted = 0.0;
    var taken = 0.0;
    for (var b = 1u; b < 256u; b++) {
        let n = f32(counts[b]);
        let start = max(below, low);
        let stop = min(below + n, high);
        if stop > start {
            weighted += (stop - start) * f32(b);
            taken += stop - start;
        }
        below += n;
    }
    let mean_bin = select(f32(bin_of(vec3<f32>(0.0))), weighted / taken, taken > 0.0);
    let mean_log2 = exposure_params.log2_min + (mean_bin - 1.0 + 0.5) / 254.0 / exposure_params.inverse_log2_range;
    // The exposure that brings the mean to the key, with the compensation.
    let target_log2 = clamp(
        log2(exposure_params.key) - mean_log2 + exposure_params.compensation,
        exposure_params.min_exposure_log2,
        exposure_params.max_exposure_log2,
    );
    var log2_exposure = target_log2;
    if previous_set && exposure_params.dt > 0.0 {
        let current = exposure_state[1];
        // Up (the scene darkened) at one speed, down (it brightened) at another.
        let speed = select(exposure_params.speed_brighter, exposure_params.speed_darker, target_log2 > current);
        log2_exposure = current + (target_log2 - current) * (1.0 - exp(-exposure_params.dt * speed));
    } else if previous_set {
        log2_exposure = exposure_state[1];
    }
    exposure_state[0] = exp2(log2_exposure);
    exposure_state[1] = log2_exposure;
    exposure_state[2] = mean_log2;
    exposure_state[3] = 1.0;
}

// ---- The tone map with the effects

@group(0) @binding(7) var hdr_texture: texture_2d<f32>;
@group(0) @binding(8) var<uniform> effects: EffectsParams;
@group(0) @binding(9) var bloom_texture: texture_2d<f32>;
@group(0) @binding(10) var<storage, read> view_exposure: array<f32, 4>;

@fragment
fn fs_tonemap_effects(in: FullscreenVarying) -> @location(0) vec4<f32> {
    var hdr = textureLoad(hdr_texture, vec2<i32>(in.position.xy), 0).rgb;
    if effects.bloom_intensity > 0.0 {
        let uv = in.position.xy * effects.output_texel;
        // The top level holds the sum of every level's blur: its mean, mixed in.
        let blurred = textureSampleLevel(bloom_texture, bloom_sampler, uv, 0.0).rgb / f32(effects.bloom_levels);
        hdr = mix(hdr, blurred, effects.bloom_intensity);
    }
    var exposure = effects.exposure;
    if effects.auto_exposure != 0u {
        exposure *= view_exposure[0];
    }
    return vec4<f32>(tone_map(hdr, exposure), 1.0);
}
