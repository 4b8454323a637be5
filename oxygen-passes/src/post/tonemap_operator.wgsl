// The tone-map operator, shared by the tone-map pass and by the forward lit
// pass when it tone-maps in place (`TONE_MAP_OUTPUT`): one definition, so
// both paths give the same image. Exposure, then the Khronos PBR Neutral
// operator (colours below about 0.76 pass almost unchanged; brighter ones
// compress towards white); the result is in [0, 1], ready for the sRGB
// target.

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

// Linear radiance `hdr` scaled by `exposure` and tone-mapped. Shading writes
// finite radiance (tests/shading_finite.rs checks the HDR target); should a
// NaN get here anyway it shows black, and an infinity white (the operator
// itself would compute infinity × 0).
fn tone_map(hdr: vec3<f32>, exposure: f32) -> vec3<f32> {
    let not_nan = select(vec3<f32>(0.0), hdr, hdr == hdr);
    let safe = min(not_nan, vec3<f32>(65504.0)); // the largest finite f16
    return clamp(pbr_neutral(max(safe * exposure, vec3<f32>(0.0))), vec3<f32>(0.0), vec3<f32>(1.0));
}
