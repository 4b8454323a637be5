// The overlay over a view's final image (post/overlay.rs): triangles the
// CPU tessellated (oxygen-overlay), already in clip space, each vertex
// saying how its fragment's coverage is found:
//
// 0 solid: the colour as it is.
// 1 line: `local.x` is the distance across the line in pixels,
//   `params.x` half its width: full inside, falling off over a pixel.
// 2 disc, ring or arc: `local` is the offset from the centre in pixels,
//   `params` the outer and inner radius, the start and the sweep (radians,
//   clockwise on screen from +x): covered between the radii, within the
//   sweep.
// 3 atlas: a texel of the glyph-and-image atlas at `local`, times the
//   colour (glyphs are white with their coverage in alpha).
//
// Colours arrive sRGB-encoded with straight alpha; the target is sRGB, so
// blending happens in linear light: the fragment returns linear colour,
// premultiplied by its opacity and coverage.

struct VertexIn {
    @location(0) clip: vec4<f32>,
    @location(1) local: vec2<f32>,
    @location(2) params: vec4<f32>,
    @location(3) color: vec4<f32>,
    @location(4) kind: u32,
}

struct VertexOut {
    @builtin(position) position: vec4<f32>,
    @location(0) local: vec2<f32>,
    @location(1) @interpolate(flat) params: vec4<f32>,
    @location(2) color: vec4<f32>,
    @location(3) @interpolate(flat) kind: u32,
}

#include "shaders/color.wgsl"

@group(0) @binding(0) var atlas: texture_2d<f32>;
@group(0) @binding(1) var atlas_sampler: sampler;

const TAU: f32 = 6.28318530718;

@vertex
fn vs(v: VertexIn) -> VertexOut {
    return VertexOut(v.clip, v.local, v.params, v.color, v.kind);
}


@fragment
fn fs(v: VertexOut) -> @location(0) vec4<f32> {
    var color = vec4<f32>(srgb_to_linear(v.color.rgb), v.color.a);
    var coverage = 1.0;
    switch v.kind {
        case 1u: {
            coverage = clamp(v.params.x + 0.5 - abs(v.local.x), 0.0, 1.0);
        }
        case 2u: {
            let r = length(v.local);
            coverage = clamp(v.params.x + 0.5 - r, 0.0, 1.0) * clamp(r - v.params.y + 0.5, 0.0, 1.0);
            if v.params.w < TAU - 1e-4 {
                let angle = atan2(v.local.y, v.local.x);
                let from_start = angle - v.params.z - floor((angle - v.params.z) / TAU) * TAU;
                if from_start > v.params.w {
                    coverage = 0.0;
                }
            }
        }
        case 3u: {
            // Level 0: glyphs are drawn texel for pixel, images scaled
            // little (explicit level: no derivatives in a branch).
            color *= textureSampleLevel(atlas, atlas_sampler, v.local, 0.0);
        }
        default: {}
    }
    let alpha = color.a * coverage;
    return vec4<f32>(color.rgb * alpha, alpha);
}
