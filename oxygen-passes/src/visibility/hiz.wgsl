// The depth pyramid, stored level after level in one f32 storage buffer
// (row-major, level k of size max(W >> k, 1) × max(H >> k, 1)): level 0
// copies the view's depth, each further level keeps the minimum (in reverse
// Z, the farthest) of the texels below it — the 2×2 texels (2x..2x+1,
// 2y..2y+1), and for the last texel of a row or column also the odd one
// left over. Texel x of level k thus covers the depth pixels
// [x·2^k, (x+1)·2^k), the last one up to the edge.
//
// A buffer rather than a mipmapped texture: llvmpipe (lavapipe) reads the
// wrong level when neighbouring invocations of one dispatch load different
// mip levels of a texture, which is exactly what occlusion tests do.

#include "visibility/LevelParams"

@group(0) @binding(0) var depth: texture_depth_2d;
@group(0) @binding(1) var<storage, read_write> pyramid: array<f32>;
@group(0) @binding(2) var<uniform> level: LevelParams;

@compute @workgroup_size(8, 8)
fn copy_depth(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= level.dst_width || id.y >= level.dst_height {
        return;
    }
    pyramid[level.dst_offset + id.y * level.dst_width + id.x] = textureLoad(depth, id.xy, 0);
}

@compute @workgroup_size(8, 8)
fn reduce(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<u32>(level.dst_width, level.dst_height);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let last = vec2<u32>(level.src_width, level.src_height) - vec2<u32>(1u);
    let first = min(id.xy * 2u, last);
    // The last texel of an odd-sized level below takes its third row/column.
    let end = select(min(id.xy * 2u + vec2<u32>(1u), last), last, id.xy == size - vec2<u32>(1u));
    var farthest = 1.0;
    for (var y = first.y; y <= end.y; y++) {
        for (var x = first.x; x <= end.x; x++) {
            farthest = min(farthest, pyramid[level.src_offset + y * level.src_width + x]);
        }
    }
    pyramid[level.dst_offset + id.y * size.x + id.x] = farthest;
}
