// Tone map pass: the HDR target through `tone_map` (tonemap_operator.wgsl)
// into the sRGB target. A full-screen triangle; no
// bindless state.

#include "post/tonemap_operator.wgsl"
#include "post/TonemapParams"

@group(0) @binding(0) var hdr_texture: texture_2d<f32>;
@group(0) @binding(1) var<uniform> params: TonemapParams;

#include "shaders/fullscreen.wgsl"

@fragment
fn fs_tonemap(in: FullscreenVarying) -> @location(0) vec4<f32> {
    let hdr = textureLoad(hdr_texture, vec2<i32>(in.position.xy), 0).rgb;
    return vec4<f32>(tone_map(hdr, params.exposure), 1.0);
}
