// The window composition shader: a full-screen triangle (drawn into each
// view's rectangle through the viewport) showing a view's display image
// (`fs_color`, sampled), or a depth-only view's reverse-Z depth as grey,
// near white (`fs_depth`, loaded texel by texel through a plain
// unfilterable `texture_2d<f32>` binding: GL's shading language would turn
// a `texture_depth_2d` into a shadow sampler, which it cannot load from).
// The renderer's compositor (src/renderer/present.rs in the root crate)
// binds the image alone for `fs_depth`, the image and a linear sampler for
// `fs_color`.

@group(0) @binding(0) var image: texture_2d<f32>;
@group(0) @binding(1) var linear: sampler;

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
fn fs_color(in: Varying) -> @location(0) vec4<f32> {
    return textureSample(image, linear, in.uv);
}

@fragment
fn fs_depth(in: Varying) -> @location(0) vec4<f32> {
    let size = vec2<f32>(textureDimensions(image));
    let texel = vec2<u32>(clamp(in.uv * size, vec2<f32>(0.0), size - 1.0));
    let d = textureLoad(image, texel, 0).x;
    return vec4<f32>(d, d, d, 1.0);
}
