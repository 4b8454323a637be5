// Metallic-roughness shading: Cook-Torrance specular (GGX distribution,
// height-correlated Smith visibility, Schlick Fresnel) plus Lambert diffuse,
// with base-colour, metallic-roughness, normal and emissive textures,
// from every directional and positional light of the frame (read through
// their slots), and a small constant ambient term. Writes linear radiance to
// the HDR target, which the tone-map step makes displayable, or, with
// TONE_MAP_OUTPUT, the tone-mapped colour straight to the sRGB target.
//
// Finite in, finite out: every division, normalisation and square root of
// the shading path is guarded (each guard says why its epsilon is safe), so
// grazing and degenerate inputs — a zero-length normal from the vertex data,
// the view along the light, roughness 0 — shade to a finite colour.
// `tests/shading_finite.rs` runs these functions over such inputs.

#include "mesh/mesh_vertex.wgsl"
#include "mesh/label_values.wgsl"
#include "post/tonemap_operator.wgsl"
#include "shaders/brdf.wgsl"
#include "shaders/noise.wgsl"
#include "lighting/ibl/environment.wgsl"

// Pipeline-overridable constants (pipelines/features.rs `ShaderFeatures`, set when
// a pipeline is created): each leaves out code the view does not need this
// frame. The defaults keep everything, so the shader as written is right for
// any scene; a pass turns a feature off only when its input is absent (no
// cascades, no positional light, no atlas, no probe, no textured material),
// where the code would compute exactly what leaving it out does.
override HAS_SUN_SHADOWS: bool = true;
override HAS_LOCAL_LIGHTS: bool = true;
override HAS_LOCAL_SHADOWS: bool = true;
// Soften the sun's shadow by its disc when the view asks for PCSS
// (`shadows.shadow_filter.x` taps per side; 0: PCF).
override HAS_SOFT_SHADOWS: bool = true;
// Visit the lights of the pixel's cluster only (when the view has clusters
// this frame: `shadows.cluster_grid.w` words per cluster, else every light).
override HAS_CLUSTERED_LIGHTS: bool = true;
override HAS_PROBES: bool = true;
// A linked probe has a parallax box (see `probe_lookup`).
override HAS_PROBE_PARALLAX: bool = true;
override HAS_TEXTURES: bool = true;
// Dim the indirect light by the view's screen-space ambient occlusion
// (lighting/ambient_occlusion.rs; `shadows.screen_width` > 0).
override HAS_AMBIENT_OCCLUSION: bool = true;
// March toward each shadow-casting light through the view's depth
// (lighting/contact_shadows.rs; `shadows.screen_width` > 0).
override HAS_CONTACT_SHADOWS: bool = true;
// Reflect the view's last frame where a march through its depth finds the
// reflected surface (lighting/reflections.rs; `shadows.reflection_history.w`
// is 1 when the history holds a frame).
override HAS_SCREEN_REFLECTIONS: bool = true;
// Tone-map at the end of shading and write the display colour (the view's
// sRGB target) instead of radiance: for views whose HDR image nothing reads.
override TONE_MAP_OUTPUT: bool = false;
override EXPOSURE: f32 = 1.0;

const AMBIENT: f32 = 0.03;
// The brightest channel shading writes: under the largest finite value of
// the HDR target's `Rgba16Float` texels (65504), with room for the rounding
// of `fit_hdr`'s scaling and of blending.
const HDR_MAX: f32 = 65000.0;

// Scales `color` down, keeping its hue, so that no channel exceeds what the
// HDR target can hold: a channel above 65504 would be stored as +infinity
// (a near-mirror lit at grazing incidence reaches millions). Colours in
// range are unchanged. A sum of lights that overflowed f32 itself (absurd
// intensities) is first brought back to 3e38, so the scaling never computes
// infinity × 0. A NaN channel stays NaN (comparisons with it are false, and
// NaN × x is NaN): the tests must see it.
fn fit_hdr(color: vec3<f32>) -> vec3<f32> {
    let finite = select(color, vec3<f32>(3e38), color > vec3<f32>(3e38));
    let peak = max(finite.r, max(finite.g, finite.b));
    if peak > HDR_MAX {
        return finite * (HDR_MAX / peak);
    }
    return color;
}

// Group 1: what this view reads from other views (see lighting/inputs.rs and lighting/params.rs):
// cascade shadow maps (bindings 0 to MAX_CASCADES - 1, one per cascade),
// the local-light shadow atlas and the reflection probes. The sizes and
// bindings are constants generated from lighting/params.rs.
#include "lighting/LightingInputs"
@group(1) @binding(0) var shadow_map_0: texture_depth_2d;
@group(1) @binding(1) var shadow_map_1: texture_depth_2d;
@group(1) @binding(2) var shadow_map_2: texture_depth_2d;
@group(1) @binding(3) var shadow_map_3: texture_depth_2d;
@group(1) @binding(COMPARISON_SAMPLER_BINDING) var shadow_sampler: sampler_comparison;
@group(1) @binding(UNIFORM_BINDING) var<uniform> shadows: LightingInputs;
@group(1) @binding(PROBE_SAMPLER_BINDING) var probe_sampler: sampler;
@group(1) @binding(FIRST_PROBE_BINDING) var probe_faces_0: texture_2d_array<f32>;
@group(1) @binding(FIRST_PROBE_BINDING + 1u) var probe_faces_1: texture_2d_array<f32>;
@group(1) @binding(FIRST_PROBE_BINDING + 2u) var probe_faces_2: texture_2d_array<f32>;
@group(1) @binding(FIRST_PROBE_BINDING + 3u) var probe_faces_3: texture_2d_array<f32>;
@group(1) @binding(ENVIRONMENT_BINDING) var environment_faces: texture_2d_array<f32>;
@group(1) @binding(ENVIRONMENT_SAMPLER_BINDING) var environment_sampler: sampler;
// The split-sum table's half floats, two texels (RGBA16F) per vec4<u32>
// (environment.wgsl reads it, the environment and the cube layout).
@group(1) @binding(SPLIT_SUM_BINDING) var<uniform> split_sum: array<vec4<u32>, SPLIT_SUM_LUT_SIZE * SPLIT_SUM_LUT_SIZE / 2u>;
// The view's light clusters (lighting/clusters.wgsl): per cluster,
// `shadows.cluster_grid.w` words, bit b of word w set when positional light
// 32 w + b may reach it.
@group(1) @binding(CLUSTER_LIGHTS_BINDING) var<storage, read> cluster_bits: array<u32>;
// The view's ambient occlusion: the share of the indirect light reaching
// each pixel, row by row, `shadows.screen_width` a row.
@group(1) @binding(AMBIENT_OCCLUSION_BINDING) var<storage, read> screen_occlusion: array<f32>;

// The view's depth in metres, row by row, `shadows.screen_width` a row
// (0 where nothing was drawn): what contact shadows march through.
@group(1) @binding(VIEW_DEPTH_BINDING) var<storage, read> view_depth: array<f32>;

// The share of the light arriving at `position` from the unit direction
// `to_light` that no surface of the view's depth blocks within
// `max_length` metres (the contact shadows' length when shorter): 0 when
// the ray passes behind a surface by less than its thickness, else 1.
// `frag` is the fragment's position (it turns the samples' offset from
// pixel to pixel).
fn contact_visibility(position: vec3<f32>, normal: vec3<f32>, to_light: vec3<f32>, max_length: f32, frag: vec4<f32>) -> f32 {
    let width = shadows.screen_width;
    if !HAS_CONTACT_SHADOWS || width == 0u {
        return 1.0;
    }
    let count = arrayLength(&view_depth);
    let height = count / width;
    let length = min(shadows.contact_shadows.x, max_length);
    let thickness = shadows.contact_shadows.y;
    let steps = u32(shadows.contact_shadows.z);
    if !(length > 0.0) || steps == 0u || height == 0u {
        return 1.0;
    }
    // Off the surface by a fraction of its depth, and as much slack in the
    // comparison: the depth holds one value a pixel, which a grazing
    // surface would otherwise shadow itself through.
    let depth = max(-(scene.camera.view * vec4<f32>(position, 1.0)).z, 0.0);
    let slack = CONTACT_DEPTH_SLACK * depth;
    let start = position + normal * slack;
    let jitter = interleaved_gradient_noise(frag.xy);
    for (var i = 0u; i < steps; i++) {
        let p = start + to_light * (length * (f32(i) + jitter) / f32(steps));
        let clip = scene.camera.view_projection * vec4<f32>(p, 1.0);
        if clip.w <= 0.0 {
            break;
        }
        let ndc = clip.xy / clip.w;
        if any(abs(ndc) >= vec2<f32>(1.0)) {
            break;
        }
        let pixel = vec2<u32>(vec2<f32>((ndc.x + 1.0) * 0.5, (1.0 - ndc.y) * 0.5) * vec2<f32>(f32(width), f32(height)));
        let surface = view_depth[min(pixel.y * width + min(pixel.x, width - 1u), count - 1u)];
        let ray = -(scene.camera.view * vec4<f32>(p, 1.0)).z;
        let behind = ray - surface;
        if surface > 0.0 && behind > CONTACT_DEPTH_SLACK * ray && behind < thickness {
            return 0.0;
        }
    }
    return 1.0;
}

// Share of a point's depth by which contact shadows start off its surface
// and by which a sample must pass behind the depth to count.
const CONTACT_DEPTH_SLACK: f32 = 0.002;

// The view's last frame as screen-space reflections read it
// (lighting/reflection_history.wgsl): three half floats a pixel in two
// words, level after
// level, each half the last (rounded up).
@group(1) @binding(REFLECTION_HISTORY_BINDING) var<storage, read> reflection_history: array<vec2<u32>>;

// Width, height and first pixel of the history's level `level`.
fn history_level(level: u32) -> vec3<u32> {
    var size = shadows.reflection_history.xy;
    var offset = 0u;
    for (var l = 0u; l < level; l++) {
        offset += size.x * size.y;
        size = (size + 1u) / 2u;
    }
    return vec3<u32>(size, offset);
}

fn history_texel(level: vec3<u32>, p: vec2<i32>) -> vec3<f32> {
    let q = vec2<u32>(clamp(p, vec2<i32>(0), vec2<i32>(level.xy) - 1));
    let i = min(level.z + q.y * level.x + q.x, arrayLength(&reflection_history) - 1u);
    let w = reflection_history[i];
    return vec3<f32>(half_to_f32(w.x & 0xffffu), half_to_f32(w.x >> 16u), half_to_f32(w.y & 0xffffu));
}

// The history at `uv` (0 to 1 across the last frame's image), bilinear in
// a level and linear between two.
fn sample_history(uv: vec2<f32>, lod: f32) -> vec3<f32> {
    let top = f32(shadows.reflection_history.z - 1u);
    let l = clamp(lod, 0.0, top);
    let below = u32(floor(l));
    let above = min(below + 1u, u32(top));
    return mix(history_bilinear(history_level(below), uv), history_bilinear(history_level(above), uv), l - floor(l));
}

fn history_bilinear(level: vec3<u32>, uv: vec2<f32>) -> vec3<f32> {
    let p = uv * vec2<f32>(level.xy) - 0.5;
    let i = vec2<i32>(floor(p));
    let f = p - floor(p);
    let top = mix(history_texel(level, i), history_texel(level, i + vec2<i32>(1, 0)), f.x);
    let bottom = mix(history_texel(level, i + vec2<i32>(0, 1)), history_texel(level, i + vec2<i32>(1, 1)), f.x);
    return mix(top, bottom, f.y);
}

// The view's depth in metres at pixel `p` (0: nothing drawn there).
fn depth_at(p: vec2<f32>, width: u32, count: u32) -> f32 {
    let q = vec2<u32>(max(p, vec2<f32>(0.0)));
    return view_depth[min(q.y * width + min(q.x, width - 1u), count - 1u)];
}

// What the view's last frame showed along the reflection of the view
// direction `v` about `n` at `position`, and in `a` how much of it to take
// (the rest: the probe or environment). A screen-space march: the ray from
// the point to `max_distance` metres (stopped before the near plane when it
// heads for the camera) is projected and cut to the screen, then sampled
// `steps` times along its path in pixels (jittered from pixel to pixel),
// its depth interpolated in perspective; the first sample behind the
// view's depth by less than the thickness (and the depth a step covers) is
// refined by halving, and the point found is reprojected into the last
// frame and read there, from a level as blurred as the surface's lobe is
// wide over the distance travelled. Weight 0 without history, on a surface
// rougher than `max_roughness`, or for a ray that hits nothing on screen;
// faded near the last frame's edges, toward the camera, toward the
// roughness limit and toward the ray's end.
fn screen_reflection(position: vec3<f32>, n: vec3<f32>, v: vec3<f32>, roughness: f32, frag: vec4<f32>) -> vec4<f32> {
    let width = shadows.screen_width;
    let history = shadows.reflection_history;
    if !HAS_SCREEN_REFLECTIONS || width == 0u || history.w == 0u {
        return vec4<f32>(0.0);
    }
    let settings = shadows.screen_reflections;
    if !(settings.x > 0.0) {
        return vec4<f32>(0.0);
    }
    let rough_fade = 1.0 - smoothstep(0.7 * settings.x, settings.x, roughness);
    let count = arrayLength(&view_depth);
    let height = count / width;
    if !(rough_fade > 0.0) || height == 0u {
        return vec4<f32>(0.0);
    }
    let r = reflect(-v, n);
    let view_start = (scene.camera.view * vec4<f32>(position, 1.0)).xyz;
    let view_dir = (scene.camera.view * vec4<f32>(r, 0.0)).xyz;
    // Off the surface by a fraction of its depth, as contact shadows.
    let slack = CONTACT_DEPTH_SLACK * max(-view_start.z, 0.0);
    let a = position + n * slack;
    let view_a = (scene.camera.view * vec4<f32>(a, 1.0)).xyz;
    var ray_length = settings.z;
    if view_dir.z > 1e-6 {
        // View z grows toward the camera: stop 1 % short of the near plane.
        ray_length = min(ray_length, 0.99 * (-shadows.screen_view.x - view_a.z) / view_dir.z);
    }
    if !(ray_length > 0.0) {
        return vec4<f32>(0.0);
    }
    let b = a + r * ray_length;
    let ca = scene.camera.view_projection * vec4<f32>(a, 1.0);
    let cb = scene.camera.view_projection * vec4<f32>(b, 1.0);
    if ca.w <= 0.0 || cb.w <= 0.0 {
        return vec4<f32>(0.0);
    }
    let screen = vec2<f32>(f32(width), f32(height));
    let ka = 1.0 / ca.w;
    let kb = 1.0 / cb.w;
    let sa = vec2<f32>(ca.x * ka + 1.0, 1.0 - ca.y * ka) * 0.5 * screen;
    let sb = vec2<f32>(cb.x * kb + 1.0, 1.0 - cb.y * kb) * 0.5 * screen;
    // Depth in metres along the ray, interpolated in perspective: depth · k
    // and k = 1 / w are linear across the screen.
    let da = -view_a.z;
    let db = -(scene.camera.view * vec4<f32>(b, 1.0)).z;
    // Where the path leaves the screen.
    let delta = sb - sa;
    var t_end = 1.0;
    for (var axis = 0u; axis < 2u; axis++) {
        if delta[axis] > 1e-6 {
            t_end = min(t_end, (screen[axis] - 0.5 - sa[axis]) / delta[axis]);
        } else if delta[axis] < -1e-6 {
            t_end = min(t_end, (0.5 - sa[axis]) / delta[axis]);
        }
    }
    let pixels = length(delta) * max(t_end, 0.0);
    if !(t_end > 0.0) || pixels < 1.0 {
        return vec4<f32>(0.0);
    }
    // The first pixels are skipped: the depth holds one value a pixel,
    // which the surface the ray leaves would otherwise hit itself through.
    let t_start = SKIPPED_PIXELS / length(delta);
    if t_start >= t_end {
        return vec4<f32>(0.0);
    }
    let steps = clamp(u32(pixels - SKIPPED_PIXELS), 1u, u32(settings.w));
    let dt = (t_end - t_start) / f32(steps);
    let jitter = interleaved_gradient_noise(frag.xy);
    var previous_t = t_start;
    var hit_t = -1.0;
    for (var i = 0u; i < steps; i++) {
        let t = t_start + (f32(i) + jitter) * dt;
        let k = mix(ka, kb, t);
        let ray = mix(da * ka, db * kb, t) / k;
        let surface = depth_at(mix(sa, sb, t), width, count);
        // The depth one step covers, so a steep ray does not slip between
        // two samples of a thin surface.
        let covered = abs(ray - mix(da * ka, db * kb, previous_t) / mix(ka, kb, previous_t));
        let behind = ray - surface;
        if surface > 0.0 && behind > CONTACT_DEPTH_SLACK * ray && behind < settings.y + covered {
            hit_t = t;
            break;
        }
        previous_t = t;
    }
    if hit_t < 0.0 {
        return vec4<f32>(0.0);
    }
    // Halve between the last sample in front and the first behind.
    var front = previous_t;
    var back = hit_t;
    for (var i = 0u; i < 4u; i++) {
        let t = 0.5 * (front + back);
        let ray = mix(da * ka, db * kb, t) / mix(ka, kb, t);
        let surface = depth_at(mix(sa, sb, t), width, count);
        if surface > 0.0 && ray > surface {
            back = t;
        } else {
            front = t;
        }
    }
    let t = back;
    let k = mix(ka, kb, t);
    // The hit point in the world, interpolated in perspective as the depth.
    let hit = (a * ka * (1.0 - t) + b * kb * t) / k;
    let last = shadows.reflection_reprojection * vec4<f32>(hit, 1.0);
    if last.w <= 0.0 {
        return vec4<f32>(0.0);
    }
    let uv = vec2<f32>(last.x / last.w + 1.0, 1.0 - last.y / last.w) * 0.5;
    let edge = min(min(uv.x, 1.0 - uv.x), min(uv.y, 1.0 - uv.y));
    let edge_fade = clamp(edge / EDGE_FADE, 0.0, 1.0);
    // Rays toward the camera see the backs of what the depth holds the
    // fronts of: faded out by the time they turn 30° toward it.
    let toward_fade = 1.0 - clamp(normalize(view_dir).z * 2.0, 0.0, 1.0);
    let travelled = length(hit - a);
    let end_fade = 1.0 - smoothstep(0.8 * settings.z, settings.z, travelled);
    let weight = rough_fade * edge_fade * toward_fade * end_fade;
    if !(weight > 0.0) {
        return vec4<f32>(0.0);
    }
    // The lobe's width (GGX alpha, about the tangent of its half-angle)
    // across the pixels travelled: the level of that blur.
    let alpha = roughness * roughness;
    let spread = CONE_SPREAD * alpha * length(mix(sa, sb, t) - sa);
    let lod = log2(max(spread, 1.0));
    return vec4<f32>(sample_history(uv, lod), weight);
}

// Share of the screen's width and height over which a reflection fades
// out toward the last frame's edges.
const EDGE_FADE: f32 = 0.05;
// The blur a reflection is read with: this many times the lobe's GGX
// alpha times the pixels travelled (4 fitted the glossy floor of
// tests/screen_space_reflections.rs best: 2 and 8 were further from the
// reference).
const CONE_SPREAD: f32 = 4.0;
// Pixels of a reflected ray's path before its march starts.
const SKIPPED_PIXELS: f32 = 2.0;

// The screen-space ambient occlusion at fragment position `frag` (1 when
// the view has none).
fn screen_ambient_occlusion(frag: vec4<f32>) -> f32 {
    let width = shadows.screen_width;
    // The width may be set for the depth alone (contact shadows,
    // reflections): the occlusion is there only when said so.
    if !HAS_AMBIENT_OCCLUSION || width == 0u || shadows.screen_view.y == 0.0 {
        return 1.0;
    }
    let p = vec2<u32>(max(frag.xy, vec2<f32>(0.0)));
    let i = min(p.y * width + min(p.x, width - 1u), arrayLength(&screen_occlusion) - 1u);
    return clamp(screen_occlusion[i], 0.0, 1.0);
}

// The first word of the cluster holding `position` (relative to the render
// origin): its screen tile from the point's NDC (y up, as the cluster pass
// cuts them), its depth slice from the distance in front of the eye.
fn cluster_words(position: vec3<f32>) -> u32 {
    let grid = shadows.cluster_grid;
    let clip = scene.camera.view_projection * vec4<f32>(position, 1.0);
    let ndc = clip.xy / max(abs(clip.w), 1e-30) * sign(clip.w);
    let tile = vec2<u32>(clamp((ndc * 0.5 + 0.5) * vec2<f32>(grid.xy), vec2<f32>(0.0), vec2<f32>(grid.xy - 1u)));
    let depth = -(scene.camera.view * vec4<f32>(position, 1.0)).z;
    let first = shadows.cluster_depth.x;
    var slice = 0u;
    if depth >= first && grid.z > 1u {
        slice = min(u32(1.0 + floor(log(depth / first) * shadows.cluster_depth.y)), grid.z - 1u);
    }
    return ((slice * grid.y + tile.y) * grid.x + tile.x) * grid.w;
}

// The probe nearest to `position` (the surface reflects what that probe saw).
fn nearest_probe(position: vec3<f32>) -> u32 {
    // A probe whose parallax box holds the point serves it ahead of any
    // whose box does not (or that has none); among equals, the nearest.
    var best = 0u;
    var best_distance = 3.4e38;
    var best_inside = false;
    for (var i = 0u; i < shadows.probe_count; i++) {
        let offset = shadows.probe_positions[i].xyz - position;
        let d = dot(offset, offset);
        let inside = in_parallax_box(i, position);
        if (inside && !best_inside) || (inside == best_inside && d < best_distance) {
            best_distance = d;
            best = i;
            best_inside = inside;
        }
    }
    return best;
}

fn in_parallax_box(probe: u32, position: vec3<f32>) -> bool {
    if !HAS_PROBE_PARALLAX {
        return false;
    }
    let box_min = shadows.probe_box_min[probe];
    return box_min.w != 0.0 && all(position >= box_min.xyz) && all(position <= shadows.probe_box_max[probe].xyz);
}

// The direction to read probe `probe`'s cube in for a reflection leaving
// `position` along `direction`. A probe without a parallax box takes its
// surroundings as infinitely far: `direction` itself. With one they lie on
// the box's faces: the ray leaves the box at the nearest of the three
// planes it is heading for, and the probe saw that point from its own
// position (box projection). A point outside the box, or a direction along
// which no plane lies ahead, keeps `direction`; components of `direction`
// near zero never divide (`select` takes the far value instead).
fn probe_lookup(probe: u32, position: vec3<f32>, direction: vec3<f32>) -> vec3<f32> {
    if !in_parallax_box(probe, position) {
        return direction;
    }
    let ahead = select(shadows.probe_box_min[probe].xyz, shadows.probe_box_max[probe].xyz, direction > vec3<f32>(0.0));
    let moving = abs(direction) > vec3<f32>(1e-20);
    let safe = select(vec3<f32>(1.0), direction, moving);
    let t = select(vec3<f32>(3.4e38), (ahead - position) / safe, moving);
    let leave = min(t.x, min(t.y, t.z));
    if !(leave > 0.0 && leave < 3.4e38) {
        return direction;
    }
    return normalize_or(position + direction * leave - shadows.probe_positions[probe].xyz, direction);
}

// `roughness` picks the mip level: a rough surface reflects a blurrier
// level (levels are GGX-prefiltered like the environment's, see
// lighting/ibl/cube_filter.rs).
fn sample_probe_face(probe: u32, uv: vec2<f32>, face: u32, roughness: f32) -> vec3<f32> {
    switch probe {
        case 0u: { return textureSampleLevel(probe_faces_0, probe_sampler, uv, face, probe_lod(textureNumLevels(probe_faces_0), roughness)).rgb; }
        case 1u: { return textureSampleLevel(probe_faces_1, probe_sampler, uv, face, probe_lod(textureNumLevels(probe_faces_1), roughness)).rgb; }
        case 2u: { return textureSampleLevel(probe_faces_2, probe_sampler, uv, face, probe_lod(textureNumLevels(probe_faces_2), roughness)).rgb; }
        default: { return textureSampleLevel(probe_faces_3, probe_sampler, uv, face, probe_lod(textureNumLevels(probe_faces_3), roughness)).rgb; }
    }
}
// Level for `roughness`: level l holds roughness l / (levels - 3), the
// roughest with 4 x 4 faces; the last two (tiny) levels are not filtered.
fn probe_lod(levels: u32, roughness: f32) -> f32 {
    let usable = max(f32(levels) - 3.0, 0.0);
    return clamp(roughness, 0.0, 1.0) * usable;
}
@group(1) @binding(SHADOW_ATLAS_BINDING) var shadow_atlas: texture_depth_2d_array;

// Fraction of a shadow-casting local light's light reaching `world_position`
// through atlas tile `slot` (a spot's map, or one cube face of a point
// light's) (3 × 3 PCF; the normal offset grows with the distance from the light).
fn tile_visibility(slot: u32, light_position: vec3<f32>, world_position: vec3<f32>, geometric_normal: vec3<f32>, light_radius: f32) -> f32 {
    if slot >= shadows.tile_count {
        return 1.0;
    }
    let distance = length(light_position - world_position);
    let offset = geometric_normal * distance * shadows.tile_texel_angle[slot / 4u][slot % 4u] * shadows.normal_offset;
    let clip = shadows.tile_view_projection[slot] * vec4<f32>(world_position + offset, 1.0);
    if clip.w <= 0.0 {
        return 1.0;
    }
    let ndc = clip.xyz / clip.w;
    if any(abs(ndc.xy) > vec2<f32>(1.0)) || ndc.z < 0.0 || ndc.z > 1.0 {
        return 1.0;
    }
    let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
    if HAS_SOFT_SHADOWS && shadows.shadow_filter.x > 0.0 && light_radius > 0.0 {
        let to_light = (light_position - world_position) / max(distance, 1e-6);
        let facing = clamp(dot(geometric_normal, to_light), 0.05, 1.0);
        let tangent = sqrt(1.0 - facing * facing) / facing;
        // clip.w: the point's distance along the light's axis.
        return soft_tile_visibility(slot, uv, clip.w, light_radius, tangent);
    }
    // The map is layer `slot` of the atlas; 3 x 3 taps one texel apart,
    // each a bilinear comparison (reverse-Z: lit when at least as close to
    // the light as the stored depth).
    let texel = 1.0 / vec2<f32>(textureDimensions(shadow_atlas));
    var lit = 0.0;
    for (var y = -1; y <= 1; y++) {
        for (var x = -1; x <= 1; x++) {
            let tap = uv + vec2<f32>(f32(x), f32(y)) * texel;
            lit += textureSampleCompareLevel(shadow_atlas, shadow_sampler, tap, slot, ndc.z);
        }
    }
    return lit / 9.0;
}

// The device depth tile `slot`'s map holds for a point `z` metres along its
// light's axis: a + b / z (its perspective projection's depth row).
fn tile_device_depth(slot: u32, z: f32) -> f32 {
    let terms = shadows.tile_depth[slot / 2u];
    let ab = select(terms.xy, terms.zw, (slot & 1u) == 1u);
    return ab.x + ab.y / max(z, 1e-6);
}

// Texels of tile `slot` within `radius` texels of `uv` (a grid of
// `taps`² gathers of four) nearer the light than `height` metres above
// the receiver at distance `z`, the receiver's plane allowed to rise
// `slope` metres a texel of offset (so that a surface tilted from the
// light does not count itself a blocker).
fn tile_blocked_above(slot: u32, uv: vec2<f32>, z: f32, taps: u32, radius: f32, height: f32, slope: f32) -> f32 {
    let texel = 1.0 / vec2<f32>(textureDimensions(shadow_atlas));
    var blocked = 0.0;
    for (var y = 0u; y < taps; y++) {
        for (var x = 0u; x < taps; x++) {
            let at = grid_tap(x, y, taps) * radius;
            let reference = tile_device_depth(slot, z - height - length(at) * slope);
            let lit = textureGatherCompare(shadow_atlas, shadow_sampler, uv + at * texel, slot, reference);
            blocked += 4.0 - (lit.x + lit.y + lit.z + lit.w);
        }
    }
    return blocked;
}

// Percentage-closer soft shadows from a spot light of radius
// `light_radius` metres through its tile `slot`, for a receiver `z` metres
// along the light's axis whose surface is tilted `tangent` (tan of the
// angle between its normal and the light) from facing it. As the sun's
// (`soft_shadow`), with comparisons only: the blockers' mean height above
// the receiver from a geometric ladder of heights, then a grid of
// comparisons across the penumbra a sphere of that radius casts from that
// height (radius × height / blocker distance, at the receiver).
fn soft_tile_visibility(slot: u32, uv: vec2<f32>, z: f32, light_radius: f32, tangent: f32) -> f32 {
    let search_taps = u32(shadows.shadow_filter.x);
    let widest = shadows.shadow_filter.y;
    let filter_taps = u32(shadows.shadow_filter.z);
    let texel_metres = max(z * shadows.tile_texel_angle[slot / 4u][slot % 4u], 1e-6);
    let slope = min(tangent, 4.0) * texel_metres;
    // From a texel's depth up to the height whose penumbra is the widest.
    let lowest = texel_metres;
    let highest = widest * texel_metres * z / (light_radius + widest * texel_metres);
    var ladder = blocker_ladder(lowest, highest);
    for (var k = 0u; k <= BLOCKER_LEVELS && !ladder.done; k++) {
        ladder = ladder_step(ladder, k, tile_blocked_above(slot, uv, z, search_taps, widest, ladder.height, slope));
    }
    if ladder.blockers == 0.0 {
        return 1.0;
    }
    let mean_height = lowest + ladder.integral / ladder.blockers;
    let blocker_distance = max(z - mean_height, 1e-3);
    // As the sun's: no narrower than a texel and a half.
    let radius = clamp(light_radius * mean_height / blocker_distance / texel_metres, 1.5, widest);
    let texel = 1.0 / vec2<f32>(textureDimensions(shadow_atlas));
    var lit = 0.0;
    for (var y = 0u; y < filter_taps; y++) {
        for (var x = 0u; x < filter_taps; x++) {
            let at = grid_tap(x, y, filter_taps) * radius;
            let reference = tile_device_depth(slot, z - length(at) * slope);
            lit += textureSampleCompareLevel(shadow_atlas, shadow_sampler, uv + at * texel, slot, reference);
        }
    }
    return lit / f32(filter_taps * filter_taps);
}

// Radiance the probe saw along `direction`.
fn sample_probe(probe: u32, direction: vec3<f32>, roughness: f32) -> vec3<f32> {
    let at = cube_face_uv(direction);
    return sample_probe_face(probe, at.xy, u32(at.z), roughness);
}

fn compare_cascade(cascade: u32, uv: vec2<f32>, depth: f32) -> f32 {
    switch cascade {
        case 0u: { return textureSampleCompareLevel(shadow_map_0, shadow_sampler, uv, depth); }
        case 1u: { return textureSampleCompareLevel(shadow_map_1, shadow_sampler, uv, depth); }
        case 2u: { return textureSampleCompareLevel(shadow_map_2, shadow_sampler, uv, depth); }
        default: { return textureSampleCompareLevel(shadow_map_3, shadow_sampler, uv, depth); }
    }
}

// The four texels of cascade `cascade` around `uv`, each compared with
// `depth` (1: lit, the texel's depth at most `depth`'s nearness).
fn gather_cascade(cascade: u32, uv: vec2<f32>, depth: f32) -> vec4<f32> {
    switch cascade {
        case 0u: { return textureGatherCompare(shadow_map_0, shadow_sampler, uv, depth); }
        case 1u: { return textureGatherCompare(shadow_map_1, shadow_sampler, uv, depth); }
        case 2u: { return textureGatherCompare(shadow_map_2, shadow_sampler, uv, depth); }
        default: { return textureGatherCompare(shadow_map_3, shadow_sampler, uv, depth); }
    }
}

// What soft shadows know of the cascade around a point: where it is in
// the map, its depth, and how depth changes along its surface's plane.
struct ShadowPoint {
    cascade: u32,
    uv: vec2<f32>,
    depth: f32,
    // Depth change per NDC x and y along the surface's plane.
    slope: vec2<f32>,
}

// The depth the surface's plane has `offset` (UV) away from the point.
fn plane_depth(p: ShadowPoint, offset: vec2<f32>) -> f32 {
    return p.depth + dot(p.slope, vec2<f32>(2.0 * offset.x, -2.0 * offset.y));
}

// Heights of the blocker search's ladder past the first (a geometric
// ladder from a texel's depth to the height whose penumbra is the widest):
// the blockers' mean height is measured to within the ladder's ratio.
const BLOCKER_LEVELS: u32 = 6u;

// A blocker search climbing the ladder (the sun's and the spots' soft
// shadows): blockers counted above each height in turn, integrated over
// the heights, which gives the sum of their heights.
struct BlockerLadder {
    ratio: f32,
    // The height the next count is taken at.
    height: f32,
    // The count above the lowest height (0: no blocker).
    blockers: f32,
    integral: f32,
    previous: f32,
    // A count of 0 was taken: no blocker stands higher.
    done: bool,
}

// The ladder from `lowest` to `highest` in BLOCKER_LEVELS steps.
fn blocker_ladder(lowest: f32, highest: f32) -> BlockerLadder {
    let ratio = pow(max(highest / lowest, 1.0), 1.0 / f32(BLOCKER_LEVELS));
    return BlockerLadder(ratio, lowest, 0.0, 0.0, 0.0, false);
}

// `ladder` with `count`, the blockers above its height at step `k` (from 0).
fn ladder_step(ladder: BlockerLadder, k: u32, count: f32) -> BlockerLadder {
    var next = ladder;
    if k == 0u {
        next.blockers = count;
    } else {
        next.integral += (ladder.height - ladder.height / ladder.ratio) * 0.5 * (count + ladder.previous);
    }
    next.done = count == 0.0;
    next.previous = count;
    next.height = ladder.height * ladder.ratio;
    return next;
}

// Tap (x, y) of a `taps` × `taps` grid spread evenly over [-1, 1]².
fn grid_tap(x: u32, y: u32, taps: u32) -> vec2<f32> {
    return (vec2<f32>(f32(x), f32(y)) + 0.5) * (2.0 / f32(taps)) - 1.0;
}

// Texels within `radius` texels of the point (a grid of `taps`² gathers of
// four) standing more than `height` (depth units) above its plane.
fn blocked_above(p: ShadowPoint, taps: u32, radius: f32, height: f32) -> f32 {
    var blocked = 0.0;
    for (var y = 0u; y < taps; y++) {
        for (var x = 0u; x < taps; x++) {
            let at = grid_tap(x, y, taps);
            let offset = at * radius * shadows.uv_texel[p.cascade];
            let lit = gather_cascade(p.cascade, p.uv + offset, plane_depth(p, offset) + height);
            blocked += 4.0 - (lit.x + lit.y + lit.z + lit.w);
        }
    }
    return blocked;
}

// Percentage-closer soft shadows in cascade `i` for a sun of angular radius
// `angle`. The blockers are the texels across the widest penumbra that
// stand above the surface's plane (`normal`: each texel is compared with
// the depth the plane has there, not the centre's, so a surface tilted
// towards the sun does not shadow itself). Their mean height is measured
// with comparisons only (GL's shaders cannot read a depth texture's values
// in a shader that also compares it): how many stand above each of a
// geometric ladder of heights, whose integral over the ladder is the sum
// of their heights. That height times tan(angle) is the penumbra's radius,
// over which a grid of comparisons is averaged. No blocker: fully lit.
// Regular grids: the filter is the same from pixel to pixel (no noise).
fn soft_shadow(i: u32, uv: vec2<f32>, depth: f32, angle: f32, normal: vec3<f32>) -> f32 {
    let search_taps = u32(shadows.shadow_filter.x);
    let widest = shadows.shadow_filter.y;
    let filter_taps = u32(shadows.shadow_filter.z);
    // The cascade's orthographic projection: its rows are the light's axes
    // scaled to NDC per metre (the z row's length converts depth to metres).
    let m = shadows.light_view_projection[i];
    let r0 = vec3<f32>(m[0][0], m[1][0], m[2][0]);
    let r1 = vec3<f32>(m[0][1], m[1][1], m[2][1]);
    let r2 = vec3<f32>(m[0][2], m[1][2], m[2][2]);
    let depth_per_metre = max(length(r2), 1e-20);
    let texel_metres = max(shadows.texel_world_size[i], 1e-20);
    // Depth change per NDC x and y along the surface's plane (the rows are
    // orthogonal: a step in the plane is a sum of them), kept below four
    // texels' depth a texel (a plane along the light's rays has none).
    let facing = dot(normal, r2);
    var slope = vec2<f32>(0.0);
    if abs(facing) > 1e-6 {
        slope = -dot(r2, r2) / facing * vec2<f32>(dot(normal, r0) / max(dot(r0, r0), 1e-30), dot(normal, r1) / max(dot(r1, r1), 1e-30));
    }
    let steepest = 4.0 * depth_per_metre * texel_metres / max(2.0 * shadows.uv_texel[i], 1e-20);
    let p = ShadowPoint(i, uv, depth, clamp(slope, vec2<f32>(-steepest), vec2<f32>(steepest)));

    // A blocker stands a texel's depth above the plane; past the height
    // whose penumbra is the widest, heights no longer matter.
    let lowest = depth_per_metre * texel_metres;
    let tangent = tan(angle);
    let highest = widest * texel_metres / max(tangent, 1e-6) * depth_per_metre;
    var ladder = blocker_ladder(lowest, highest);
    for (var k = 0u; k <= BLOCKER_LEVELS && !ladder.done; k++) {
        ladder = ladder_step(ladder, k, blocked_above(p, search_taps, widest, ladder.height));
    }
    if ladder.blockers == 0.0 {
        return 1.0;
    }
    let mean_height = (lowest + ladder.integral / ladder.blockers) / depth_per_metre;
    // No narrower than a texel and a half: the map's bilinear comparisons
    // cannot draw a sharper edge than that without stair steps (a sun of
    // 0.5° in tests/soft_shadows.rs: 1.5 is where PCSS stops being worse
    // than PCF of radius 1).
    let radius = clamp(mean_height * tangent / texel_metres, 1.5, widest);
    var lit = 0.0;
    for (var y = 0u; y < filter_taps; y++) {
        for (var x = 0u; x < filter_taps; x++) {
            let at = grid_tap(x, y, filter_taps);
            let offset = at * radius * shadows.uv_texel[i];
            lit += compare_cascade(i, uv + offset, plane_depth(p, offset));
        }
    }
    return lit / f32(filter_taps * filter_taps);
}

// Fraction of the light reaching `world_position`: the first cascade whose
// box holds the point, a normal offset against acne, then (2r + 1)² PCF
// taps, or soft shadows for a sun of angular radius `angle` when the view
// asks for them.
fn shadow_visibility(world_position: vec3<f32>, geometric_normal: vec3<f32>, angle: f32) -> f32 {
    for (var i = 0u; i < shadows.count; i++) {
        let offset = geometric_normal * shadows.texel_world_size[i] * shadows.normal_offset;
        let clip = shadows.light_view_projection[i] * vec4<f32>(world_position + offset, 1.0);
        let ndc = clip.xyz / clip.w;
        if all(abs(ndc.xy) < vec2<f32>(0.98)) && ndc.z >= 0.0 && ndc.z <= 1.0 {
            let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
            if HAS_SOFT_SHADOWS && shadows.shadow_filter.x > 0.0 {
                return soft_shadow(i, uv, ndc.z, angle, geometric_normal);
            }
            let r = i32(shadows.pcf_radius);
            var lit = 0.0;
            for (var y = -r; y <= r; y++) {
                for (var x = -r; x <= r; x++) {
                    let tap = uv + vec2<f32>(f32(x), f32(y)) * shadows.uv_texel[i];
                    lit += compare_cascade(i, tap, ndc.z);
                }
            }
            let taps = f32((2 * r + 1) * (2 * r + 1));
            return lit / taps;
        }
    }
    return 1.0;
}

// Unit normal of the triangle being shaded, from the screen derivatives of
// the position, turned towards the viewer (`to_viewer`: camera minus
// surface point); the view direction, then +Y, when the derivatives have no
// direction (a quad whose positions do not change on screen).
fn facet_normal(d: Derivatives, to_viewer: vec3<f32>) -> vec3<f32> {
    let facet = cross(d.dp_dx, d.dp_dy);
    let towards = select(facet, -facet, dot(facet, to_viewer) < 0.0);
    return normalize_or(towards, normalize_or(to_viewer, vec3<f32>(0.0, 1.0, 0.0)));
}

// The unit shading normal from the interpolated vertex normal. Double-sided
// surfaces are lit on the side we see (`flip`: a double-sided back face);
// single-sided ones only show their front (culling), so their normal stands
// as it is. A vertex normal without direction (zero in the vertex data, or
// opposite normals interpolated across a triangle) would normalise to NaN:
// the triangle's own normal, which faces the viewer, stands in for it.
fn shading_normal(world_normal: vec3<f32>, flip: bool, d: Derivatives, to_viewer: vec3<f32>) -> vec3<f32> {
    let oriented = select(world_normal, -world_normal, flip);
    if has_direction(oriented) {
        return normalize_or(oriented, oriented);
    }
    return facet_normal(d, to_viewer);
}

// Towards the viewer from `world_position`, not normalised. A perspective
// camera's rays meet at the eye; an orthographic camera's (its projection's
// w row is (0, 0, 0, 1)) all run along the view's axis, so every point sees
// the viewer along the view's +Z in world space: from the eye instead, a
// plane seen at 75° in an orthographic view reflected 15 % less than the
// BRDF says at its centre, by up to a tenth of a turn of the view vector.
fn to_viewer(world_position: vec3<f32>) -> vec3<f32> {
    let p = scene.camera.projection;
    if p[3][3] == 1.0 && p[2][3] == 0.0 {
        let view = scene.camera.view;
        return vec3<f32>(view[0][2], view[1][2], view[2][2]);
    }
    return scene.camera.camera_position.xyz - world_position;
}

fn surface_normal(mesh: MeshVarying, front_facing: bool, material: MaterialRecord, d: Derivatives) -> vec3<f32> {
    let double_sided = (material.flags & MATERIAL_DOUBLE_SIDED) != 0u;
    let to_viewer = to_viewer(mesh.world_position);
    return shading_normal(mesh.world_normal, double_sided && !front_facing, d, to_viewer);
}

// Unit direction from the surface to the camera; the normal `n` when the
// camera sits on the surface point itself (no direction to it).
fn view_direction(to_viewer: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return normalize_or(to_viewer, n);
}

// Screen-space derivatives, taken at the top of each fragment entry point
// (uniform control flow) for normal mapping without stored tangents.
struct Derivatives {
    dp_dx: vec3<f32>,
    dp_dy: vec3<f32>,
    uv: UvDerivatives,
}

fn derivatives_of(mesh: MeshVarying) -> Derivatives {
    return Derivatives(dpdx(mesh.world_position), dpdy(mesh.world_position), uv_derivatives_of(mesh));
}

// Tangent frame from position and UV derivatives (a cotangent frame), so a
// tangent-space normal map needs no per-vertex tangents. glTF's v axis points
// down the image, hence the bitangent's sign. `at` carries the normal map's
// own UV derivatives (its set, through its transform).
fn perturb_normal(n: vec3<f32>, d: Derivatives, at: TexCoord, tangent_normal: vec3<f32>) -> vec3<f32> {
    let dp2_perp = cross(d.dp_dy, n);
    let dp1_perp = cross(n, d.dp_dx);
    // Window y grows downwards here (dpdy too), which turns the cotangent
    // frame of a y-up derivation around: both vectors change sign. glTF's
    // v grows down the image, which turns the bitangent once more.
    let t = -(dp2_perp * at.dx.x + dp1_perp * at.dy.x);
    let b = dp2_perp * at.dx.y + dp1_perp * at.dy.y;
    let largest = max(dot(t, t), dot(b, b));
    if !(largest > 1e-20) {
        return n; // no UV variation here: keep the geometric normal
    }
    let scale = inverseSqrt(largest);
    // A tangent-space normal pointing into the surface can cancel out (no
    // direction): keep the geometric normal then.
    return normalize_or(mat3x3<f32>(t * scale, b * scale, n) * tangent_normal, n);
}

// The unit tangent-space normal a normal-map texel encodes, its XY scaled by
// `normal_scale`. A mid-grey texel (or scale 0 with z = 0) encodes no
// direction; it reads as the unperturbed normal (0, 0, 1).
fn tangent_space_normal(texel: vec3<f32>, normal_scale: f32) -> vec3<f32> {
    let decoded = texel * 2.0 - 1.0;
    return normalize_or(vec3<f32>(decoded.xy * normal_scale, decoded.z), vec3<f32>(0.0, 0.0, 1.0));
}

// A material texture, or opaque white when the scene has no textured
// material (what `sample_texture` returns for an absent texture anyway).
fn material_texture(slot: u32, at: TexCoord) -> vec4<f32> {
    if !HAS_TEXTURES {
        return vec4<f32>(1.0);
    }
    return sample_at(slot, at);
}

// What positional light `i` of the frame adds at `position` (its shadow
// included) to a surface of normal `n` seen along `v`.
fn positional_light(
    i: u32,
    position: vec3<f32>,
    geometric_normal: vec3<f32>,
    n: vec3<f32>,
    v: vec3<f32>,
    albedo: vec3<f32>,
    metallic: f32,
    roughness: f32,
    frag: vec4<f32>,
) -> vec3<f32> {
    let light = positional_light_domain[scene.renderer.positional_lights_slot + i];
    let reach = positional_light_at(light, position);
    let l = reach.l;
    var attenuation = reach.attenuation;
    if light.kind == LIGHT_SPOT {
        if HAS_LOCAL_SHADOWS && light.shadow_slot != INVALID_SLOT {
            attenuation *= tile_visibility(light.shadow_slot, light.position, position, geometric_normal, light.radius);
        }
    } else if HAS_LOCAL_SHADOWS && light.shadow_slot != INVALID_SLOT {
        // A point light's six faces follow its first tile, in
        // PROBE_FACE_AXES order: the face is the major axis of -l.
        let tile = light.shadow_slot + cube_face(-l);
        // Point lights' shadows stay PCF: a soft search would cross the
        // cube's faces.
        attenuation *= tile_visibility(tile, light.position, position, geometric_normal, 0.0);
    }
    if HAS_CONTACT_SHADOWS && light.shadow_slot != INVALID_SLOT && attenuation > 0.0 {
        attenuation *= contact_visibility(position, geometric_normal, l, distance(light.position, position), frag);
    }
    return brdf_cosine(n, v, l, albedo, metallic, roughness) * light.color * light.intensity * attenuation;
}

// The split-sum weight of the reflected light (strong on metals, a few
// percent on dielectrics except at grazing angles).
fn specular_weight(albedo: vec3<f32>, metallic: f32, roughness: f32, n: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    let f0 = mix(vec3<f32>(0.04), albedo, metallic);
    return split_sum_brdf(f0, roughness, max(dot(n, v), 0.0));
}

// The reflected light: where the screen shows what is reflected
// (screen-space reflections), that replaces `fallback`, the probe's or
// environment's guess (ambient occlusion no longer dims it: the screen saw
// the occluders). Without the feature, `fallback` as it is, and no other
// code: the pipelines without it shade exactly as before it existed.
fn screen_or(fallback: vec3<f32>, mesh: MeshVarying, n: vec3<f32>, v: vec3<f32>, roughness: f32) -> vec3<f32> {
    if !HAS_SCREEN_REFLECTIONS {
        return fallback;
    }
    let screen = screen_reflection(mesh.world_position, n, v, roughness, mesh.clip_position);
    return mix(fallback, screen.rgb, screen.a);
}

// What a fragment writes: radiance for the HDR target, or, with
// TONE_MAP_OUTPUT, the tone-mapped colour for the sRGB target (the same
// operator as the tone-map pass).
fn output_color(radiance: vec3<f32>) -> vec4<f32> {
    if TONE_MAP_OUTPUT {
        return vec4<f32>(tone_map(radiance, EXPOSURE), 1.0);
    }
    return vec4<f32>(radiance, 1.0);
}

fn shade(mesh: MeshVarying, front_facing: bool, material: MaterialRecord, d: Derivatives) -> vec4<f32> {
    let base = material.base_color * mesh.color
        * material_texture(material.base_color_texture, tex_coord(mesh, material, material.uv_transforms[0], d.uv));
    // Unlit (KHR_materials_unlit): the base colour is the radiance.
    if (material.flags & MATERIAL_UNLIT) != 0u {
        return base;
    }
    var n = surface_normal(mesh, front_facing, material, d);
    let geometric_normal = n;
    if HAS_TEXTURES && material.normal_texture != INVALID_SLOT {
        let at = tex_coord(mesh, material, material.uv_transforms[2], d.uv);
        let texel = sample_at(material.normal_texture, at).xyz;
        n = perturb_normal(n, d, at, tangent_space_normal(texel, material.normal_scale));
    }
    let v = view_direction(to_viewer(mesh.world_position), n);
    let albedo = base.rgb;
    // glTF packs roughness in G and metallic in B.
    let metal_rough = material_texture(material.metallic_roughness_texture, tex_coord(mesh, material, material.uv_transforms[1], d.uv));
    let metallic = clamp(material.metallic * metal_rough.b, 0.0, 1.0);
    let roughness = clamp(material.roughness * metal_rough.g, 0.045, 1.0);
    // Ambient occlusion dims indirect light only: the ambient term and the
    // probe reflection, not the lights.
    let occlusion_texel = material_texture(material.occlusion_texture, tex_coord(mesh, material, material.uv_transforms[4], d.uv));
    let occlusion = mix(1.0, occlusion_texel.r, material.occlusion_strength) * screen_ambient_occlusion(mesh.clip_position);
    // Ambient light: the environment's irradiance (diffuse) and its
    // prefiltered reflection (specular, below) when the renderer has one;
    // else a constant.
    let has_environment = shadows.environment_levels > 0u;
    var color: vec3<f32>;
    if has_environment {
        color = albedo * (1.0 - metallic) * environment_irradiance(n) * (occlusion / PI);
    } else {
        color = (albedo * (1.0 - metallic) * AMBIENT + mix(vec3<f32>(0.04), albedo, metallic) * AMBIENT) * occlusion;
    }

    let dir_count = scene.renderer.directional_light_count;
    var shadowed_light_done = false;
    for (var i = 0u; i < dir_count; i++) {
        let light = directional_light_domain[scene.renderer.directional_lights_slot + i];
        var visibility = 1.0;
        // The cascades belong to the first shadow-casting directional light.
        if HAS_SUN_SHADOWS && (light.flags & LIGHT_CASTS_SHADOWS) != 0u && !shadowed_light_done {
            shadowed_light_done = true;
            visibility = shadow_visibility(mesh.world_position, geometric_normal, light.angular_radius);
        }
        if HAS_CONTACT_SHADOWS && (light.flags & LIGHT_CASTS_SHADOWS) != 0u && visibility > 0.0 {
            visibility *= contact_visibility(mesh.world_position, geometric_normal, -light.direction, 3.0e38, mesh.clip_position);
        }
        color += brdf_cosine(n, v, -light.direction, albedo, metallic, roughness) * light.color * light.intensity * visibility;
    }

    let pos_count = select(0u, scene.renderer.positional_light_count, HAS_LOCAL_LIGHTS);
    if HAS_CLUSTERED_LIGHTS && shadows.cluster_grid.w > 0u && pos_count > 0u {
        // The cluster's lights, in the frame's order (bit by bit, word by
        // word): the loop below minus lights that add exactly nothing here.
        let base = cluster_words(mesh.world_position);
        for (var w = 0u; w < shadows.cluster_grid.w; w++) {
            var bits = cluster_bits[base + w];
            while bits != 0u {
                let i = w * 32u + firstTrailingBit(bits);
                bits &= bits - 1u;
                color += positional_light(i, mesh.world_position, geometric_normal, n, v, albedo, metallic, roughness, mesh.clip_position);
            }
        }
    } else {
        for (var i = 0u; i < pos_count; i++) {
            color += positional_light(i, mesh.world_position, geometric_normal, n, v, albedo, metallic, roughness, mesh.clip_position);
        }
    }
    // Specular reflection of the probe's surroundings: sharp on smooth
    // surfaces, from blurrier mip levels on rough ones, weighted by the
    // split-sum BRDF (strong on metals, a few percent on dielectrics
    // except at grazing angles).
    if HAS_PROBES && shadows.probe_count > 0u {
        let probe = nearest_probe(mesh.world_position);
        let reflected = sample_probe(probe, probe_lookup(probe, mesh.world_position, reflect(-v, n)), roughness);
        color += screen_or(reflected * occlusion, mesh, n, v, roughness) * specular_weight(albedo, metallic, roughness, n, v);
    } else if has_environment {
        let reflected = sample_environment(reflect(-v, n), roughness);
        color += screen_or(reflected * occlusion, mesh, n, v, roughness) * specular_weight(albedo, metallic, roughness, n, v);
    } else if HAS_SCREEN_REFLECTIONS {
        let screen = screen_reflection(mesh.world_position, n, v, roughness, mesh.clip_position);
        if screen.a > 0.0 {
            // The constant ambient's specular share (in `color` above)
            // gives way to what the screen shows.
            let f0 = mix(vec3<f32>(0.04), albedo, metallic);
            color += (screen.rgb * specular_weight(albedo, metallic, roughness, n, v) - f0 * AMBIENT * occlusion) * screen.a;
        }
    }
    color += material.emissive * material_texture(material.emissive_texture, tex_coord(mesh, material, material.uv_transforms[3], d.uv)).rgb;
    return vec4<f32>(color, base.a);
}

// An opaque surface's colour (the stale-draw colour for a draw read
// through a stale range).
fn opaque_color(mesh: MeshVarying, front_facing: bool) -> vec4<f32> {
    return opaque_color_at(mesh, front_facing, derivatives_of(mesh));
}

// The same with the screen derivatives `d` given (deferred shading computes
// them from the pixel's triangle: mesh/deferred.wgsl).
fn opaque_color_at(mesh: MeshVarying, front_facing: bool, d: Derivatives) -> vec4<f32> {
    let handle = material_handle_of(mesh);
    if handle == INVALID_SLOT {
        return output_color(STALE_DRAW_COLOR.rgb);
    }
    let shaded = shade(mesh, front_facing, material_at(handle), d);
    return output_color(fit_hdr(shaded.rgb));
}

// An alpha-tested surface's colour; discards what its cutoff cuts out.
// Called first thing by its entry points: derivatives in uniform control flow.
fn masked_color(mesh: MeshVarying, front_facing: bool) -> vec4<f32> {
    let d = derivatives_of(mesh);
    let handle = material_handle_of(mesh);
    if handle == INVALID_SLOT {
        return output_color(STALE_DRAW_COLOR.rgb);
    }
    let material = material_at(handle);
    let shaded = shade(mesh, front_facing, material, d);
    if shaded.a < material.alpha_cutoff {
        discard;
    }
    return output_color(fit_hdr(shaded.rgb));
}

// The world point at normalised device coordinates (ndc, depth).
fn unproject(ndc: vec2<f32>, depth: f32) -> vec3<f32> {
    let p = scene.camera.inverse_view_projection * vec4<f32>(ndc, depth, 1.0);
    return p.xyz / p.w;
}
