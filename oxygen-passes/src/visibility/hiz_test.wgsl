// Whether a world-space box may be visible against a depth pyramid built
// by hiz.wgsl (reverse Z: 1 near, 0 far). The including shader declares
// `hiz_pyramid: array<f32>`, the pyramid's buffer. Conservative: false
// only when every pixel the box could cover holds a depth nearer than the
// box's nearest point. A box reaching behind the eye, or off screen, is
// visible (frustum culling decides about the latter).
//
// Straight-line code: every invocation runs the same instructions, and the
// loops' trip counts are the same for all.

// Where level k starts in the buffer, for a level 0 of `size`.
fn hiz_level_offset(size: vec2<u32>, levels: u32, k: u32) -> u32 {
    var offset = 0u;
    for (var j = 0u; j < levels; j++) {
        let texels = max(size.x >> j, 1u) * max(size.y >> j, 1u);
        offset += select(0u, texels, j < k);
    }
    return offset;
}

fn hiz_visible(levels: u32, size: vec2<u32>, view_projection: mat4x4<f32>, box_min: vec3<f32>,
               box_max: vec3<f32>) -> bool {
    var ndc_min = vec2<f32>(3.0e38);
    var ndc_max = vec2<f32>(-3.0e38);
    var nearest = 0.0;
    var min_w = 3.0e38;
    for (var i = 0u; i < 8u; i++) {
        let corner = select(box_min, box_max, vec3<bool>((i & 1u) != 0u, (i & 2u) != 0u, (i & 4u) != 0u));
        let clip = view_projection * vec4<f32>(corner, 1.0);
        min_w = min(min_w, clip.w);
        let ndc = clip.xyz / max(clip.w, 1e-5);
        ndc_min = min(ndc_min, ndc.xy);
        ndc_max = max(ndc_max, ndc.xy);
        nearest = max(nearest, ndc.z);
    }
    // Reaching behind the eye, nearer than the near plane, a projection that
    // lost its numbers, or no pyramid.
    let trivially = min_w <= 1e-5 || !(nearest < 1.0) || !(nearest >= 0.0) || levels == 0u
        || ndc_max.x < -1.0 || ndc_min.x > 1.0 || ndc_max.y < -1.0 || ndc_min.y > 1.0;
    // The pixels the box may cover, one pixel wider on every side against
    // rounding; y grows downwards in pixels.
    let dims = vec2<f32>(size);
    let lo = clamp(vec2<f32>(ndc_min.x * 0.5 + 0.5, 0.5 - ndc_max.y * 0.5) * dims - 1.0, vec2<f32>(0.0), dims - 1.0);
    let hi = clamp(vec2<f32>(ndc_max.x * 0.5 + 0.5, 0.5 - ndc_min.y * 0.5) * dims + 1.0, vec2<f32>(0.0), dims - 1.0);
    let p0 = vec2<u32>(lo);
    let p1 = vec2<u32>(hi);
    // A level at which the rectangle spans at most 3×3 texels: with the
    // extent below 2^(k+1), (p1 >> k) − (p0 >> k) ≤ 2 on both axes. (2×2
    // texels one level coarser would often reach past the box into the sky.)
    let extent = max(p1.x - p0.x, p1.y - p0.y);
    let k = min(select(firstLeadingBit(extent), 0u, extent <= 1u), max(levels, 1u) - 1u);
    let level_size = max(size >> vec2<u32>(k), vec2<u32>(1u));
    let last = level_size - vec2<u32>(1u);
    let a = min(p0 >> vec2<u32>(k), last);
    let b = min(p1 >> vec2<u32>(k), last);
    let base = hiz_level_offset(size, levels, k);
    var farthest = 1.0;
    for (var dy = 0u; dy < 3u; dy++) {
        for (var dx = 0u; dx < 3u; dx++) {
            let texel = min(a + vec2<u32>(dx, dy), b);
            farthest = min(farthest, hiz_pyramid[base + texel.y * level_size.x + texel.x]);
        }
    }
    return trivially || nearest >= farthest;
}
