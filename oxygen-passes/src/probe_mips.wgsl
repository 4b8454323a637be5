@group(0) @binding(0) var source: texture_2d_array<f32>;
@group(0) @binding(1) var source_sampler: sampler;
struct Varying {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) @interpolate(flat) layer: u32,
}
// Vertices 3k .. 3k + 2 draw the full-screen triangle for layer k.
@vertex
fn vs(@builtin(vertex_index) index: u32) -> Varying {
    let corner = index % 3u;
    let uv = vec2<f32>(f32((corner << 1u) & 2u), f32(corner & 2u));
    return Varying(vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0), uv, index / 3u);
}
@fragment
fn fs(v: Varying) -> @location(0) vec4<f32> {
    // Level n is exactly half of level n - 1, so this bilinear tap lands on
    // the corner of four source texels and averages them.
    return textureSampleLevel(source, source_sampler, v.uv, v.layer, 0.0);
}
