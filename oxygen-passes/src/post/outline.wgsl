// A selection outline by jump flooding (post/overlay.rs): which pixels
// show a chosen node is read from the view's instance labels; `seed`
// marks each such pixel as its own nearest chosen pixel, then `flood`
// passes at halving strides each give every pixel the nearest chosen
// pixel any of its nine neighbours at that stride knows (Rong and Tan's
// jump flooding: exact but for rare ties); `vs_fullscreen`/`fs` draw the pixels
// outside the chosen nodes within `width` of one, fading over the last
// pixel, over the view's final image.

#include "post/OutlineParams"
#include "shaders/color.wgsl"
#include "shaders/fullscreen.wgsl"

@group(0) @binding(0) var<uniform> params: OutlineParams;
// The instance labels: a node's stable id + 1 per pixel, 0 for none.
@group(0) @binding(1) var instances: texture_2d<u32>;
// Bit `id` of word `id / 32` is set for a chosen node.
@group(0) @binding(2) var<storage, read> chosen: array<u32>;
@group(0) @binding(3) var<storage, read> seeds_in: array<u32>;
@group(0) @binding(4) var<storage, read_write> seeds_out: array<u32>;

const NONE: u32 = 0xffffffffu;

fn is_chosen(pixel: vec2<u32>) -> bool {
    let label = textureLoad(instances, vec2<i32>(pixel + params.origin.zw), 0).r;
    if label == 0u {
        return false;
    }
    let id = label - 1u;
    let word = id / 32u;
    return word < arrayLength(&chosen) && ((chosen[word] >> (id % 32u)) & 1u) == 1u;
}

fn pack(p: vec2<u32>) -> u32 {
    return p.x | (p.y << 16u);
}

fn unpack(s: u32) -> vec2<f32> {
    return vec2<f32>(f32(s & 0xffffu), f32(s >> 16u));
}

@compute @workgroup_size(8, 8)
fn seed(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = params.size.xy;
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    seeds_out[id.y * size.x + id.x] = select(NONE, pack(id.xy), is_chosen(id.xy));
}

@compute @workgroup_size(8, 8)
fn flood(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = params.size.xy;
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let stride = i32(params.size.z);
    let here = vec2<f32>(id.xy);
    var best = NONE;
    var best_distance = 3.4e38;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let q = vec2<i32>(id.xy) + vec2<i32>(dx, dy) * stride;
            if any(q < vec2<i32>(0)) || any(q >= vec2<i32>(size)) {
                continue;
            }
            let s = seeds_in[u32(q.y) * size.x + u32(q.x)];
            if s == NONE {
                continue;
            }
            let d = distance(here, unpack(s));
            if d < best_distance {
                best_distance = d;
                best = s;
            }
        }
    }
    seeds_out[id.y * size.x + id.x] = best;
}



@fragment
fn fs(v: FullscreenVarying) -> @location(0) vec4<f32> {
    // The fragment's pixel in the view (its viewport may be a tile's).
    let pixel = vec2<u32>(max(v.position.xy - vec2<f32>(params.origin.xy), vec2<f32>(0.0)));
    let size = params.size.xy;
    if pixel.x >= size.x || pixel.y >= size.y || is_chosen(pixel) {
        discard;
    }
    let s = seeds_in[pixel.y * size.x + pixel.x];
    if s == NONE {
        discard;
    }
    // Distance to the chosen pixel's edge, not its centre.
    let d = distance(vec2<f32>(pixel), unpack(s)) - 0.5;
    let coverage = clamp(params.shape.x + 0.5 - d, 0.0, 1.0);
    let alpha = params.color.a * coverage;
    return vec4<f32>(srgb_to_linear(params.color.rgb) * alpha, alpha);
}
