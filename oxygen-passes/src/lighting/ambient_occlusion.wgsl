// Ground-truth ambient occlusion (GTAO) from a view's depth, in three or
// four compute steps over buffers of one float a pixel (lighting/
// ambient_occlusion.rs records them between the depth pre-pass and
// shading):
//
// 1. `linearize` (`linearize_multisampled` for a multisampled depth, its
//    first sample): the device depth becomes metres in front of the eye
//    (0 where nothing was drawn).
// 2. `gtao`: per pixel, `slices` directions across the screen; along each,
//    `steps` samples on both sides find the horizon the depth buffer makes
//    within `radius` metres, and the cosine-weighted visible part of the
//    hemisphere between the two horizons is integrated in closed form
//    (Jimenez et al., "Practical Realtime Strategies for Accurate Indirect
//    Occlusion", 2016). The normal comes from the depth itself. Slice
//    directions and step offsets turn from pixel to pixel (and from frame
//    to frame with the temporal step), which the next steps average away.
// 3. `denoise`: a 5 × 5 mean weighted by depth similarity.
// 4. `temporal` (optional): the denoised value blended with last frame's
//    result at the same surface point, reprojected; a point last frame
//    did not see (its depth there differs) starts again.
//
// The result is the fraction of the ambient light that reaches the pixel
// (1: none occluded); the forward shader multiplies the indirect light
// (ambient, environment, probes) by it.

#include "lighting/AoParams"
#include "shaders/noise.wgsl"

@group(0) @binding(0) var<uniform> params: AoParams;
// The depth through plain unfilterable float bindings: GL's shading
// language turns a depth texture binding into a shadow sampler, which
// cannot load.
@group(0) @binding(1) var depth_texture: texture_2d<f32>;
@group(0) @binding(2) var<storage, read_write> depth_out: array<f32>;
@group(0) @binding(3) var<storage, read_write> raw_out: array<f32>;
@group(0) @binding(4) var<storage, read> view_depth: array<f32>;
@group(0) @binding(5) var<storage, read> ao_in: array<f32>;
@group(0) @binding(6) var<storage, read_write> ao_out: array<f32>;
@group(0) @binding(7) var<storage, read> previous_depth: array<f32>;
@group(0) @binding(8) var<storage, read> history: array<f32>;
@group(0) @binding(9) var depth_texture_multisampled: texture_multisampled_2d<f32>;

const PI: f32 = 3.141592653589793;
const HALF_PI: f32 = 1.5707963267948966;

fn size() -> vec2<i32> {
    return vec2<i32>(params.size.xy);
}

fn inside(p: vec2<i32>) -> bool {
    return all(p >= vec2<i32>(0)) && all(p < size());
}

fn index_of(p: vec2<i32>) -> u32 {
    return u32(p.y) * params.size.x + u32(p.x);
}

// Metres in front of the eye of device depth `d` at pixel `p` (0 for the
// far plane, where nothing was drawn: reverse-Z clears depth to 0).
fn linear_depth(p: vec2<i32>, d: f32) -> f32 {
    if d <= 0.0 {
        return 0.0;
    }
    let ndc = pixel_ndc(vec2<f32>(p) + 0.5);
    let v = params.inverse_projection * vec4<f32>(ndc, d, 1.0);
    let z = -v.z / v.w;
    return select(0.0, z, z > 0.0 && z < 3.0e38);
}

fn pixel_ndc(pixel: vec2<f32>) -> vec2<f32> {
    let uv = pixel / vec2<f32>(params.size.xy);
    return vec2<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
}

@compute @workgroup_size(8, 8)
fn linearize(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = vec2<i32>(id.xy);
    if !inside(p) {
        return;
    }
    depth_out[index_of(p)] = linear_depth(p, textureLoad(depth_texture, p, 0).x);
}

@compute @workgroup_size(8, 8)
fn linearize_multisampled(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = vec2<i32>(id.xy);
    if !inside(p) {
        return;
    }
    depth_out[index_of(p)] = linear_depth(p, textureLoad(depth_texture_multisampled, p, 0).x);
}

// The view-space point at pixel centre `pixel` whose depth is `z` metres:
// x = (ndc.x · a + b) · z for a perspective view, without the `z` for an
// orthographic one (params.unproject holds a and b for x and y).
fn view_point(pixel: vec2<f32>, z: f32) -> vec3<f32> {
    let ndc = pixel_ndc(pixel);
    let scale = select(1.0, z, params.size.w != 0u);
    let xy = (ndc * params.unproject.xy + params.unproject.zw) * scale;
    return vec3<f32>(xy, -z);
}

fn depth_at(p: vec2<i32>) -> f32 {
    return view_depth[index_of(clamp(p, vec2<i32>(0), size() - 1))];
}

// The noise of pixel `p`; `frame` shifts it for the temporal step.
fn noise(p: vec2<i32>, frame: u32) -> f32 {
    return interleaved_gradient_noise(vec2<f32>(p) + 5.588238 * f32(frame % 64u));
}

// The surface normal at `p` from the depth: of the two neighbours along
// each axis, the one nearer in depth (so an edge does not bend it),
// facing the eye.
fn depth_normal(p: vec2<i32>, centre: vec3<f32>, z: f32) -> vec3<f32> {
    let pixel = vec2<f32>(p) + 0.5;
    let zr = depth_at(p + vec2<i32>(1, 0));
    let zl = depth_at(p - vec2<i32>(1, 0));
    let zd = depth_at(p + vec2<i32>(0, 1));
    let zu = depth_at(p - vec2<i32>(0, 1));
    var dx = view_point(pixel + vec2<f32>(1.0, 0.0), zr) - centre;
    if zr <= 0.0 || (zl > 0.0 && abs(zl - z) < abs(zr - z)) {
        dx = centre - view_point(pixel - vec2<f32>(1.0, 0.0), zl);
    }
    var dy = view_point(pixel + vec2<f32>(0.0, 1.0), zd) - centre;
    if zd <= 0.0 || (zu > 0.0 && abs(zu - z) < abs(zd - z)) {
        dy = centre - view_point(pixel - vec2<f32>(0.0, 1.0), zu);
    }
    let n = cross(dy, dx);
    let len = length(n);
    if !(len > 0.0) {
        return normalize(-centre);
    }
    let unit = n / len;
    return select(unit, -unit, dot(unit, -centre) < 0.0);
}

// The cosine of the highest horizon seen from `centre` along the screen
// direction `direction` (a unit vector in pixels): samples from a pixel
// away out to the radius, `step_length` pixels apart, shifted by `jitter`
// of a step.
fn horizon_cos(p: vec2<i32>, centre: vec3<f32>, to_eye: vec3<f32>, direction: vec2<f32>, step_length: f32, jitter: f32) -> f32 {
    let radius = params.shape.x;
    let steps = params.size.z >> 16u;
    var best = -1.0;
    for (var j = 0u; j < steps; j++) {
        let at = vec2<f32>(p) + 0.5 + direction * (1.0 + (f32(j) + jitter) * step_length);
        let q = vec2<i32>(floor(at));
        if !inside(q) {
            break;
        }
        let z = view_depth[index_of(q)];
        if z <= 0.0 {
            continue;
        }
        let d = view_point(vec2<f32>(q) + 0.5, z) - centre;
        let distance = length(d);
        if !(distance > 0.0) {
            continue;
        }
        var c = dot(d, to_eye) / distance;
        // Samples beyond the radius fade to the lowest horizon: what is far
        // away does not occlude (and thin objects in front of a far wall
        // do not darken it).
        let fade = clamp((distance - params.shape.y * radius) / ((1.0 - params.shape.y) * radius), 0.0, 1.0);
        c = mix(c, -1.0, fade);
        best = max(best, c);
    }
    return best;
}

@compute @workgroup_size(8, 8)
fn gtao(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = vec2<i32>(id.xy);
    if !inside(p) {
        return;
    }
    let z = view_depth[index_of(p)];
    if z <= 0.0 {
        raw_out[index_of(p)] = 1.0;
        return;
    }
    let centre = view_point(vec2<f32>(p) + 0.5, z);
    let to_eye = select(vec3<f32>(0.0, 0.0, 1.0), normalize(-centre), params.size.w != 0u);
    let normal = depth_normal(p, centre, z);
    // The radius on screen: pixels per metre at this depth.
    let radius_px = params.shape.x * params.shape.z / select(1.0, z, params.size.w != 0u);
    let slices = params.size.z & 0xffffu;
    let steps = params.size.z >> 16u;
    if radius_px < 1.0 || slices == 0u || steps == 0u {
        raw_out[index_of(p)] = 1.0;
        return;
    }
    let rotation = noise(p, params.frame.x);
    let jitter = noise(p + vec2<i32>(37, 17), params.frame.x);
    let step_length = radius_px / f32(steps);
    var visibility = 0.0;
    for (var s = 0u; s < slices; s++) {
        let phi = (f32(s) + rotation) * PI / f32(slices);
        let omega = vec2<f32>(cos(phi), sin(phi));
        // The slice's direction in view space (y up) and on screen (y down).
        let direction = vec3<f32>(omega, 0.0);
        let screen = vec2<f32>(omega.x, -omega.y);
        let ortho = direction - dot(direction, to_eye) * to_eye;
        let axis = normalize(cross(direction, to_eye));
        let projected = normal - axis * dot(normal, axis);
        let projected_length = length(projected);
        if !(projected_length > 1.0e-6) {
            visibility += 1.0;
            continue;
        }
        let cos_n = clamp(dot(projected, to_eye) / projected_length, -1.0, 1.0);
        let n = select(-1.0, 1.0, dot(ortho, projected) >= 0.0) * acos(cos_n);
        let forward = horizon_cos(p, centre, to_eye, screen, step_length, jitter);
        let backward = horizon_cos(p, centre, to_eye, -screen, step_length, jitter);
        let h1 = n + min(acos(clamp(forward, -1.0, 1.0)) - n, HALF_PI);
        let h0 = n + max(-acos(clamp(backward, -1.0, 1.0)) - n, -HALF_PI);
        let sin_n = sin(n);
        let arc0 = -cos(2.0 * h0 - n) + cos_n + 2.0 * h0 * sin_n;
        let arc1 = -cos(2.0 * h1 - n) + cos_n + 2.0 * h1 * sin_n;
        visibility += projected_length * 0.25 * (arc0 + arc1);
    }
    raw_out[index_of(p)] = clamp(visibility / f32(slices), 0.0, 1.0);
}

// A 5 × 5 mean of the raw occlusion, each neighbour weighted by how close
// its depth is to the pixel's (a surface behind an edge does not blur in).
@compute @workgroup_size(8, 8)
fn denoise(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = vec2<i32>(id.xy);
    if !inside(p) {
        return;
    }
    let z = view_depth[index_of(p)];
    if z <= 0.0 {
        ao_out[index_of(p)] = 1.0;
        return;
    }
    var sum = 0.0;
    var weights = 0.0;
    for (var dy = -2; dy <= 2; dy++) {
        for (var dx = -2; dx <= 2; dx++) {
            let q = p + vec2<i32>(dx, dy);
            if !inside(q) {
                continue;
            }
            let zq = view_depth[index_of(q)];
            let w = max(0.0, 1.0 - abs(zq - z) / (params.shape.w * z));
            sum += w * ao_in[index_of(q)];
            weights += w;
        }
    }
    ao_out[index_of(p)] = select(1.0, sum / weights, weights > 0.0);
}

// This frame's denoised value blended into last frame's result at the same
// surface point (reprojected through last frame's camera), or taken as it
// is where last frame did not see that point.
@compute @workgroup_size(8, 8)
fn temporal(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = vec2<i32>(id.xy);
    if !inside(p) {
        return;
    }
    let current = ao_in[index_of(p)];
    let z = view_depth[index_of(p)];
    if z <= 0.0 || params.frame.y == 0u {
        ao_out[index_of(p)] = current;
        return;
    }
    let previous_view = params.reproject * vec4<f32>(view_point(vec2<f32>(p) + 0.5, z), 1.0);
    let clip = params.previous_projection * previous_view;
    var result = current;
    if clip.w > 0.0 {
        let ndc = clip.xy / clip.w;
        let pixel = vec2<f32>((ndc.x + 1.0) * 0.5, (1.0 - ndc.y) * 0.5) * vec2<f32>(params.size.xy);
        let q = vec2<i32>(floor(pixel));
        if inside(q) {
            let expected = -previous_view.z;
            let seen = previous_depth[index_of(q)];
            if seen > 0.0 && abs(seen - expected) <= params.frame_weights.y * expected {
                result = mix(history[index_of(q)], current, params.frame_weights.x);
            }
        }
    }
    ao_out[index_of(p)] = result;
}
