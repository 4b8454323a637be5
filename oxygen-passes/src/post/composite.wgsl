// Composition: another view's final image (a rectangle of its texture:
// the whole of it, or a batch camera's tile) drawn into a rectangle of this
// view (the viewport), filtered linearly. Both images are sRGB: sampling
// decodes to linear and the target encodes again.

#include "post/CompositeParams"

@group(0) @binding(0) var image: texture_2d<f32>;
@group(0) @binding(1) var linear: sampler;
@group(0) @binding(2) var<uniform> params: CompositeParams;

struct Varying {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
}

@vertex
fn vs(@builtin(vertex_index) i: u32) -> Varying {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return Varying(vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0), uv);
}

@fragment
fn fs(in: Varying) -> @location(0) vec4<f32> {
    return textureSample(image, linear, params.uv_offset + in.uv * params.uv_scale);
}
