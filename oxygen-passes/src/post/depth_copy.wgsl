// Depth as colour: the bits of each texel of a depth texture written, one
// for one, into an R32Uint target, for adapters that cannot copy depth
// into a buffer (GL; where R32Float is not renderable either). The depth is loaded through a plain unfilterable
// texture_2d<f32> binding: GL's shading language would turn a
// texture_depth_2d into a shadow sampler, which cannot load.

@group(0) @binding(0) var depth: texture_2d<f32>;

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
}

@fragment
fn fs(@builtin(position) position: vec4<f32>) -> @location(0) u32 {
    return bitcast<u32>(textureLoad(depth, vec2<u32>(position.xy), 0).x);
}
