// The history screen-space reflections read (lighting/reflections.rs): the
// view's HDR image kept after shading as three half floats a pixel in two
// words (red and green in the first, blue in the low half of the second), then each level of the chain a 2 × 2 mean of the one before
// (rounded up: an odd edge's last pixel averages itself), for the rough
// surfaces that read it blurred. One dispatch a level, in order.

#include "lighting/HistoryStep"
#include "shaders/half.wgsl"

@group(0) @binding(0) var<uniform> level: HistoryStep;
@group(0) @binding(1) var<storage, read_write> history: array<vec2<u32>>;
// The HDR image through a plain unfilterable binding (it is only loaded).
@group(0) @binding(2) var hdr: texture_2d<f32>;

// The largest value a half float holds, less its rounding: a brighter
// texel would be stored as infinity.
const HALF_MAX: f32 = 65000.0;

fn pack(c: vec3<f32>) -> vec2<u32> {
    // max/min drop a NaN on every backend we run: what is kept is finite.
    let v = min(max(c, vec3<f32>(0.0)), vec3<f32>(HALF_MAX));
    return vec2<u32>(f32_to_half(v.r) | (f32_to_half(v.g) << 16u), f32_to_half(v.b));
}

fn unpack(w: vec2<u32>) -> vec3<f32> {
    return vec3<f32>(half_to_f32(w.x & 0xffffu), half_to_f32(w.x >> 16u), half_to_f32(w.y & 0xffffu));
}

@compute @workgroup_size(8, 8)
fn copy_hdr(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = level.dst.xy;
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let c = textureLoad(hdr, vec2<i32>(id.xy), 0).rgb;
    history[level.dst.z + id.y * size.x + id.x] = pack(c);
}

@compute @workgroup_size(8, 8)
fn halve(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = level.dst.xy;
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let src = level.src;
    var sum = vec3<f32>(0.0);
    for (var dy = 0u; dy < 2u; dy++) {
        for (var dx = 0u; dx < 2u; dx++) {
            let p = min(id.xy * 2u + vec2<u32>(dx, dy), src.xy - 1u);
            sum += unpack(history[src.z + p.y * src.x + p.x]);
        }
    }
    history[level.dst.z + id.y * size.x + id.x] = pack(sum * 0.25);
}
