// Tone map: exposure, then Khronos PBR Neutral (colours below about 0.76
// pass almost unchanged; brighter ones compress towards white), written to
// the sRGB target. A full-screen triangle; no bindless state.

struct TonemapParams {
    exposure: f32,
    pad0: f32,
    pad1: f32,
    pad2: f32,
}

@group(0) @binding(0) var hdr_texture: texture_2d<f32>;
@group(0) @binding(1) var<uniform> params: TonemapParams;

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

fn pbr_neutral(input: vec3<f32>) -> vec3<f32> {
    let start_compression = 0.8 - 0.04;
    let desaturation = 0.15;
    var color = input;
    let x = min(color.r, min(color.g, color.b));
    let offset = select(0.04, x - 6.25 * x * x, x < 0.08);
    color -= offset;
    let peak = max(color.r, max(color.g, color.b));
    if peak < start_compression {
        return color;
    }
    let d = 1.0 - start_compression;
    let new_peak = 1.0 - d * d / (peak + d - start_compression);
    color *= new_peak / peak;
    let g = 1.0 - 1.0 / (desaturation * (peak - new_peak) + 1.0);
    return mix(color, vec3<f32>(new_peak), g);
}

@fragment
fn fs_tonemap(in: FullscreenVarying) -> @location(0) vec4<f32> {
    let hdr = textureLoad(hdr_texture, vec2<i32>(in.position.xy), 0).rgb;
    // Shading writes finite radiance (tests/shading_finite.rs checks the
    // HDR target); should a NaN get there anyway it shows black, and an
    // infinity white (the operator itself would compute infinity × 0).
    let not_nan = select(vec3<f32>(0.0), hdr, hdr == hdr);
    let safe = min(not_nan, vec3<f32>(65504.0)); // the largest finite f16
    return vec4<f32>(clamp(pbr_neutral(max(safe * params.exposure, vec3<f32>(0.0))), vec3<f32>(0.0), vec3<f32>(1.0)), 1.0);
}
