// A harness for `hiz_visible` (hiz_test.wgsl) that the root crate's GPU
// test (tests/hiz_pyramid.rs) runs against a CPU reference: one invocation
// per box, writing 1 where the box may be visible against the pyramid and
// 0 where it is hidden. No pipeline of the renderer uses it; it is in the
// shader registry so that the validation test checks it with the others.

#include "visibility/hiz_test.wgsl"

struct Params { view_projection: mat4x4<f32>, size: vec2<u32>, levels: u32, count: u32 }
struct Box { lo: vec4<f32>, hi: vec4<f32> }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> boxes: array<Box>;
@group(0) @binding(2) var<storage, read_write> out: array<u32>;
@group(0) @binding(3) var<storage, read> hiz_pyramid: array<f32>;

@compute @workgroup_size(64)
fn visible_boxes(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.count { return; }
    let b = boxes[id.x];
    out[id.x] = select(0u, 1u, hiz_visible(params.levels, params.size, params.view_projection, b.lo.xyz, b.hi.xyz));
}
