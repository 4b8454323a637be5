// One triangle over the whole target (three vertices, no buffers): the
// vertex stage of every full-screen draw (the tone map and its effects,
// the selection outline). Its depth is 0, which no depth test it is drawn
// with compares.

struct FullscreenVarying {
    @builtin(position) position: vec4<f32>,
}

@vertex
fn vs_fullscreen(@builtin(vertex_index) index: u32) -> FullscreenVarying {
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    var out: FullscreenVarying;
    out.position = vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
    return out;
}
