// The path-traced reference: one compute invocation per pixel traces
// `samples_this_frame` paths through the same bindless geometry, transforms,
// materials and lights the raster passes read (group 0), with the view's
// camera (group 3) and textures (group 2), and adds them to the view's
// running sum; the HDR target gets the mean, for the same tone map.
//
// The ray scene lives in three compute-only domains of the heap (group 0):
// a two-level bounding volume hierarchy (instances on top, one tree per
// mesh below, all nodes in one range with indices relative to its start),
// the instance records, and a word range (leaf orders, then each instance's
// submesh table). Group 1 holds the tracer's parameters (with the ranges'
// starts), the heap's index buffer, the view's running sum and the output.
//
// Light transport: next-event estimation towards every directional and
// positional light (a shadow ray each), the BRDF of brdf.wgsl for both the
// lights and the sampled bounces (a mix of cosine-weighted diffuse and GGX
// visible-normal sampling), emission counted where a path hits it, the
// renderer's environment where a path escapes (a uniform colour without
// one), Russian roulette after three bounces. With RASTER_MODEL the path
// stops at the first hit and adds the raster pass's ambient term instead
// (the constant, or the environment's harmonics and prefiltered
// reflection): the same light transport as the raster path, shadows traced
// exactly, for comparing the two.

#include "bindless/constants"
#include "sceneprep/constants"
#include "lighting/constants"
#include "bindless/scene_constants.wgsl"
#include "sceneprep/gpu_records.wgsl"
#include "bindless/domains"
#include "bindless/textures"
#include "shaders/brdf.wgsl"
#include "lighting/ibl/environment.wgsl"
#include "reference/constants"
#include "reference/TraceParams"

// Flags (reference/params.rs): RASTER_MODEL; RASTER_REFLECTIONS, with
// RASTER_MODEL also the probe's term, exactly (see radiance());
// ENVIRONMENT_MAP, the renderer has an environment: bindings 7-9 hold it.
const STACK_SIZE: u32 = 48u;
const NO_HIT: u32 = 0xFFFFFFFFu;
// The raster pass's constant ambient (mesh/shading.wgsl's AMBIENT).
const RASTER_AMBIENT: f32 = 0.03;

@group(1) @binding(0) var<uniform> params: TraceParams;
@group(1) @binding(4) var<storage, read> index_words: array<u32>;
@group(1) @binding(5) var<storage, read_write> running_sum: array<vec4<f32>>;
@group(1) @binding(6) var output: texture_storage_2d<rgba16float, write>;
// What the shading pass reads (environment.wgsl): the renderer's
// environment (a placeholder without one) and the split-sum table.
@group(1) @binding(7) var environment_faces: texture_2d_array<f32>;
@group(1) @binding(8) var environment_sampler: sampler;
@group(1) @binding(9) var<uniform> split_sum: array<vec4<u32>, SPLIT_SUM_LUT_SIZE * SPLIT_SUM_LUT_SIZE / 2u>;

fn has_environment_map() -> bool {
    return (params.flags & ENVIRONMENT_MAP) != 0u;
}

// Radiance arriving along `direction` from outside the scene.
fn escaped(direction: vec3<f32>) -> vec3<f32> {
    if has_environment_map() {
        return sample_environment(direction, 0.0);
    }
    return params.environment.rgb;
}

// ---- random numbers: a PCG hash per (pixel, sample, dimension) ----

fn pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

struct Rng {
    state: u32,
}

fn next_u32(rng: ptr<function, Rng>) -> u32 {
    (*rng).state = pcg((*rng).state);
    return (*rng).state;
}

// Uniform in [0, 1): the top 24 bits, so 1.0 is never returned.
fn next_f32(rng: ptr<function, Rng>) -> f32 {
    return f32(next_u32(rng) >> 8u) / 16777216.0;
}

// ---- traversal ----

struct Ray {
    origin: vec3<f32>,
    dir: vec3<f32>,
}

struct Hit {
    t: f32,
    instance: u32,
    triangle: u32,
    u: f32,
    v: f32,
}

// Slab test; the reciprocal direction may hold infinities (axis-parallel
// rays), and the min/max order makes a NaN from 0 × inf fall on the
// "keep testing" side.
fn box_entry(node: BvhNode, origin: vec3<f32>, inv_dir: vec3<f32>, t_max: f32) -> f32 {
    let t0 = (node.min - origin) * inv_dir;
    let t1 = (node.max - origin) * inv_dir;
    let near = max(max(min(t0.x, t1.x), min(t0.y, t1.y)), max(min(t0.z, t1.z), 0.0));
    let far = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), min(max(t0.z, t1.z), t_max));
    return select(-1.0, near, near <= far);
}

fn safe_inverse(d: vec3<f32>) -> vec3<f32> {
    // WGSL leaves 1/0 to the implementation: a component under 1e-30 is
    // taken as ±1e-30, whose reciprocal is finite and as good as infinite
    // for the slab test.
    let tiny = select(vec3<f32>(1e-30), vec3<f32>(-1e-30), d < vec3<f32>(0.0));
    return 1.0 / select(d, tiny, abs(d) < vec3<f32>(1e-30));
}

fn vertex_position(slot: u32) -> vec3<f32> {
    let v = vertex_domain[slot];
    return vec3<f32>(v.px, v.py, v.pz);
}

fn vertex_uv(slot: u32) -> vec2<f32> {
    let v = vertex_domain[slot];
    return vec2<f32>(v.u, v.v);
}

// A vertex's colour and second UV set (mesh_vertex.wgsl's layout of the
// attribute records), white and zero for a mesh without them; `local` is
// the vertex's index within its mesh.
struct VertexExtras {
    color: vec4<f32>,
    uv1: vec2<f32>,
}

fn vertex_extras(instance: RayInstance, local: u32) -> VertexExtras {
    if instance.attributes_slot == INVALID_SLOT {
        return VertexExtras(vec4<f32>(1.0), vec2<f32>(0.0));
    }
    let a = vertex_domain[instance.attributes_slot + local];
    return VertexExtras(vec4<f32>(a.px, a.py, a.pz, a.nx), vec2<f32>(a.ny, a.nz));
}

// A texture's coordinate at a vertex: its set through its transform (the
// rasterizer's tex_coord without derivatives).
fn ray_tex_coord(material: MaterialRecord, t: UvTransformRecord, uv0: vec2<f32>, uv1: vec2<f32>) -> vec2<f32> {
    if (material.flags & MATERIAL_UV_TRANSFORMS) == 0u {
        return uv0;
    }
    return apply_uv_transform(t, select(uv0, uv1, t.uv_set == 1u));
}

// Möller–Trumbore, the twin of oxygen_sceneprep::bvh::ray_triangle;
// returns (t, u, v), t < 0 for a miss. The origin first slides along the
// ray to the point nearest `a` (on `origin - a`, so no large coordinate is
// rounded): far from the mesh the textbook form's dot products cancel and
// edge-on triangles report hits far off them.
fn ray_triangle(origin: vec3<f32>, dir: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> vec3<f32> {
    let e1 = b - a;
    let e2 = c - a;
    let p = cross(dir, e2);
    let det = dot(e1, p);
    if abs(det) < 1e-30 {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    let inv_det = 1.0 / det;
    let s0 = origin - a;
    let t0 = -dot(s0, dir) / max(dot(dir, dir), 1e-30);
    let s = s0 + dir * t0;
    let u = dot(s, p) * inv_det;
    let q = cross(s, e1);
    let v = dot(dir, q) * inv_det;
    if !(u >= 0.0 && v >= 0.0 && u + v <= 1.0) {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    return vec3<f32>(t0 + dot(e2, q) * inv_det, u, v);
}

// The submesh entry (3 words: first triangle, end triangle, material) a
// triangle of an instance belongs to, or NO_HIT when no submesh draws it.
fn submesh_of(instance: RayInstance, triangle: u32) -> u32 {
    for (var s = 0u; s < instance.submesh_count; s++) {
        let entry = instance.submesh_first + 3u * s;
        if triangle >= ray_word_domain[params.word_base + entry] && triangle < ray_word_domain[params.word_base + entry + 1u] {
            return entry;
        }
    }
    return NO_HIT;
}

// Whether a hit on a masked or blended surface counts: a masked one where
// its alpha reaches the cutoff, a blended one with probability alpha
// (stochastic transparency, the same on every ray of a path through it).
fn opaque_here(instance: RayInstance, triangle: u32, u: f32, v: f32, material: MaterialRecord, salt: u32) -> bool {
    let masked = (material.flags & MATERIAL_MASKED) != 0u;
    let blended = (material.flags & MATERIAL_BLEND) != 0u;
    if !masked && !blended {
        return true;
    }
    let base = instance.index_slot + 3u * triangle;
    let w = vec3<f32>(1.0 - u - v, u, v);
    var uv = vec2<f32>(0.0);
    var alpha = 0.0;
    for (var k = 0u; k < 3u; k++) {
        let local = index_words[base + k];
        let extras = vertex_extras(instance, local);
        uv += ray_tex_coord(material, material.uv_transforms[0], vertex_uv(instance.vertex_slot + local), extras.uv1) * w[k];
        alpha += extras.color.a * w[k];
    }
    alpha *= material.base_color.a * sample_texture(material.base_color_texture, uv, vec2<f32>(0.0), vec2<f32>(0.0)).a;
    if masked {
        return alpha >= material.alpha_cutoff;
    }
    return f32(pcg(salt ^ pcg(triangle + 0x9E3779B9u)) >> 8u) / 16777216.0 < alpha;
}

// The closest hit along `ray` before `t_max`; `any` stops at the first
// (shadow rays). `salt` decides blended surfaces.
fn trace(ray: Ray, t_max: f32, any: bool, salt: u32) -> Hit {
    var best = Hit(t_max, NO_HIT, 0u, 0.0, 0.0);
    if params.tlas_root == INVALID_SLOT {
        return best;
    }
    let inv_dir = safe_inverse(ray.dir);
    var stack: array<u32, STACK_SIZE>;
    var top = 0u;
    stack[0] = params.tlas_root;
    top = 1u;
    while top > 0u {
        top -= 1u;
        let node = bvh_node_domain[params.node_base + stack[top]];
        if box_entry(node, ray.origin, inv_dir, best.t) < 0.0 {
            continue;
        }
        if node.count == 0u {
            if top + 2u <= STACK_SIZE {
                stack[top] = node.first;
                stack[top + 1u] = node.first + 1u;
                top += 2u;
            }
            continue;
        }
        for (var k = 0u; k < node.count; k++) {
            let instance_index = ray_word_domain[params.word_base + node.first + k];
            let instance = ray_instance_domain[params.instance_base + instance_index];
            // The ray in the instance's own space: an affine map keeps t.
            let m = mat3x3<f32>(instance.inverse_rows[0].xyz, instance.inverse_rows[1].xyz, instance.inverse_rows[2].xyz);
            let translation = vec3<f32>(instance.inverse_rows[0].w, instance.inverse_rows[1].w, instance.inverse_rows[2].w);
            let origin = ray.origin * m + translation;
            let dir = ray.dir * m;
            let local_inv = safe_inverse(dir);
            var local_stack: array<u32, STACK_SIZE>;
            var local_top = 1u;
            local_stack[0] = instance.blas_root;
            while local_top > 0u {
                local_top -= 1u;
                let local = bvh_node_domain[params.node_base + local_stack[local_top]];
                if box_entry(local, origin, local_inv, best.t) < 0.0 {
                    continue;
                }
                if local.count == 0u {
                    if local_top + 2u <= STACK_SIZE {
                        local_stack[local_top] = local.first;
                        local_stack[local_top + 1u] = local.first + 1u;
                        local_top += 2u;
                    }
                    continue;
                }
                for (var j = 0u; j < local.count; j++) {
                    let triangle = ray_word_domain[params.word_base + local.first + j];
                    let base = instance.index_slot + 3u * triangle;
                    let a = vertex_position(instance.vertex_slot + index_words[base]);
                    let b = vertex_position(instance.vertex_slot + index_words[base + 1u]);
                    let c = vertex_position(instance.vertex_slot + index_words[base + 2u]);
                    let tuv = ray_triangle(origin, dir, a, b, c);
                    if !(tuv.x > 0.0 && tuv.x < best.t) {
                        continue;
                    }
                    let entry = submesh_of(instance, triangle);
                    if entry == NO_HIT {
                        continue;
                    }
                    let material = material_domain[scene.renderer.materials_slot + ray_word_domain[params.word_base + entry + 2u]];
                    if !opaque_here(instance, triangle, tuv.y, tuv.z, material, salt) {
                        continue;
                    }
                    best = Hit(tuv.x, instance_index, triangle, tuv.y, tuv.z);
                    if any {
                        return best;
                    }
                }
            }
        }
    }
    return best;
}

// ---- surfaces ----

struct Surface {
    position: vec3<f32>,
    // Shading normal (vertex normals, normal map), facing the ray.
    normal: vec3<f32>,
    // Triangle normal, facing the ray: where rays leave from.
    geometric: vec3<f32>,
    albedo: vec3<f32>,
    metallic: f32,
    roughness: f32,
    emissive: vec3<f32>,
    // KHR_materials_unlit: `emissive` holds its colour; nothing reflects.
    unlit: bool,
}

fn surface_at(ray: Ray, hit: Hit) -> Surface {
    let instance = ray_instance_domain[params.instance_base + hit.instance];
    let base = instance.index_slot + 3u * hit.triangle;
    let v0 = vertex_domain[instance.vertex_slot + index_words[base]];
    let v1 = vertex_domain[instance.vertex_slot + index_words[base + 1u]];
    let v2 = vertex_domain[instance.vertex_slot + index_words[base + 2u]];
    let w = vec3<f32>(1.0 - hit.u - hit.v, hit.u, hit.v);
    let world = world_transform_domain[scene.renderer.world_transforms_slot + instance.transform_index];
    let normal_matrix =
        normal_matrix_of(normal_transform_domain[scene.renderer.normal_transforms_slot + instance.transform_index]);
    let p0 = (world * vec4<f32>(v0.px, v0.py, v0.pz, 1.0)).xyz;
    let p1 = (world * vec4<f32>(v1.px, v1.py, v1.pz, 1.0)).xyz;
    let p2 = (world * vec4<f32>(v2.px, v2.py, v2.pz, 1.0)).xyz;
    let x0 = vertex_extras(instance, index_words[base]);
    let x1 = vertex_extras(instance, index_words[base + 1u]);
    let x2 = vertex_extras(instance, index_words[base + 2u]);
    let vertex_color = x0.color * w.x + x1.color * w.y + x2.color * w.z;
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    var geometric = normalize_or(cross(e1, e2), -ray.dir);
    let facing = dot(geometric, ray.dir) < 0.0;
    geometric = select(-geometric, geometric, facing);
    let interpolated = normal_matrix * (vec3<f32>(v0.nx, v0.ny, v0.nz) * w.x + vec3<f32>(v1.nx, v1.ny, v1.nz) * w.y + vec3<f32>(v2.nx, v2.ny, v2.nz) * w.z);
    var n = normalize_or(select(-interpolated, interpolated, facing), geometric);
    let entry = submesh_of(instance, hit.triangle);
    let material = material_domain[scene.renderer.materials_slot + ray_word_domain[params.word_base + entry + 2u]];
    // Each texture's coordinate at the hit, interpolated from its vertices'.
    let base_t = material.uv_transforms[0];
    let base_uv = ray_tex_coord(material, base_t, vec2<f32>(v0.u, v0.v), x0.uv1) * w.x
        + ray_tex_coord(material, base_t, vec2<f32>(v1.u, v1.v), x1.uv1) * w.y
        + ray_tex_coord(material, base_t, vec2<f32>(v2.u, v2.v), x2.uv1) * w.z;
    let base_color = material.base_color * vertex_color * sample_texture(material.base_color_texture, base_uv, vec2<f32>(0.0), vec2<f32>(0.0));
    if (material.flags & MATERIAL_UNLIT) != 0u {
        // Unlit: the surface shows its colour and reflects nothing.
        return Surface(ray.origin + ray.dir * hit.t, n, geometric, vec3<f32>(0.0), 0.0, 1.0, base_color.rgb, true);
    }
    if material.normal_texture != INVALID_SLOT {
        let normal_t = material.uv_transforms[2];
        let uv0 = ray_tex_coord(material, normal_t, vec2<f32>(v0.u, v0.v), x0.uv1);
        let uv1 = ray_tex_coord(material, normal_t, vec2<f32>(v1.u, v1.v), x1.uv1);
        let uv2 = ray_tex_coord(material, normal_t, vec2<f32>(v2.u, v2.v), x2.uv1);
        let uv = uv0 * w.x + uv1 * w.y + uv2 * w.z;
        let texel = sample_texture(material.normal_texture, uv, vec2<f32>(0.0), vec2<f32>(0.0)).xyz;
        let decoded = texel * 2.0 - 1.0;
        let tangent_normal = normalize_or(vec3<f32>(decoded.xy * material.normal_scale, decoded.z), vec3<f32>(0.0, 0.0, 1.0));
        // The triangle's own tangent frame from its UVs (glTF: v grows
        // down the image, so the bitangent is -dp/dv).
        let duv1 = uv1 - uv0;
        let duv2 = uv2 - uv0;
        let dp2_perp = cross(e2, n);
        let dp1_perp = cross(n, e1);
        let orientation = select(-1.0, 1.0, dot(e1, dp2_perp) >= 0.0);
        let t = (dp2_perp * duv1.x + dp1_perp * duv2.x) * orientation;
        let b = -(dp2_perp * duv1.y + dp1_perp * duv2.y) * orientation;
        let largest = max(dot(t, t), dot(b, b));
        if largest > 1e-20 {
            let scale = inverseSqrt(largest);
            n = normalize_or(mat3x3<f32>(t * scale, b * scale, n) * tangent_normal, n);
        }
    }
    let mr_t = material.uv_transforms[1];
    let mr_uv = ray_tex_coord(material, mr_t, vec2<f32>(v0.u, v0.v), x0.uv1) * w.x
        + ray_tex_coord(material, mr_t, vec2<f32>(v1.u, v1.v), x1.uv1) * w.y
        + ray_tex_coord(material, mr_t, vec2<f32>(v2.u, v2.v), x2.uv1) * w.z;
    let emissive_t = material.uv_transforms[3];
    let emissive_uv = ray_tex_coord(material, emissive_t, vec2<f32>(v0.u, v0.v), x0.uv1) * w.x
        + ray_tex_coord(material, emissive_t, vec2<f32>(v1.u, v1.v), x1.uv1) * w.y
        + ray_tex_coord(material, emissive_t, vec2<f32>(v2.u, v2.v), x2.uv1) * w.z;
    let metal_rough = sample_texture(material.metallic_roughness_texture, mr_uv, vec2<f32>(0.0), vec2<f32>(0.0));
    let emissive = material.emissive * sample_texture(material.emissive_texture, emissive_uv, vec2<f32>(0.0), vec2<f32>(0.0)).rgb;
    return Surface(
        ray.origin + ray.dir * hit.t,
        n,
        geometric,
        base_color.rgb,
        clamp(material.metallic * metal_rough.b, 0.0, 1.0),
        clamp(material.roughness * metal_rough.g, 0.045, 1.0),
        emissive,
        false,
    );
}

// A point just off the surface on the side `towards` faces, far enough
// that the new ray cannot hit the same triangle again at any distance from
// the render origin (f32 spacing grows with the coordinates).
fn offset_origin(s: Surface, towards: vec3<f32>) -> vec3<f32> {
    let side = select(-s.geometric, s.geometric, dot(towards, s.geometric) >= 0.0);
    let scale = max(max(abs(s.position.x), abs(s.position.y)), max(abs(s.position.z), 1.0));
    return s.position + side * (1e-4 * scale);
}

// The direction towards a directional light for one sample: its centre,
// or for a light with a disc (`angular_radius`) a direction uniform over
// the disc's cone, so that the mean over the samples is the disc's light
// (its illuminance spread over the disc) and its shadows get their
// penumbrae. `salt` is the sample's.
fn sun_direction(light: DirectionalLightRecord, salt: u32) -> vec3<f32> {
    let centre = -light.direction;
    if light.angular_radius <= 0.0 {
        return centre;
    }
    let u1 = f32(pcg(salt ^ 0xA511E9B3u) >> 8u) / 16777216.0;
    let u2 = f32(pcg(salt ^ 0x63D83595u) >> 8u) / 16777216.0;
    let cos_theta = 1.0 - u1 * (1.0 - cos(light.angular_radius));
    let sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
    let phi = 2.0 * PI * u2;
    return tangent_frame(centre) * vec3<f32>(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
}

// A point of positional light `light`'s disc as seen from `position`
// (`l`: the unit direction to its centre): uniform over the disc of its
// radius facing the point; the centre for a point light without one.
fn light_disc_point(light: PositionalLightRecord, position: vec3<f32>, l: vec3<f32>, salt: u32) -> vec3<f32> {
    if light.radius <= 0.0 {
        return light.position;
    }
    let u1 = f32(pcg(salt ^ 0x2C1B3C6Du) >> 8u) / 16777216.0;
    let u2 = f32(pcg(salt ^ 0x297A2D39u) >> 8u) / 16777216.0;
    let r = light.radius * sqrt(u1);
    let phi = 2.0 * PI * u2;
    return light.position + tangent_frame(l) * vec3<f32>(r * cos(phi), r * sin(phi), 0.0);
}

// Light from every light of the frame reaching `s` towards `v`, each through
// one shadow ray.
fn direct_light(s: Surface, v: vec3<f32>, salt: u32) -> vec3<f32> {
    var color = vec3<f32>(0.0);
    for (var i = 0u; i < scene.renderer.directional_light_count; i++) {
        let light = directional_light_domain[scene.renderer.directional_lights_slot + i];
        let l = sun_direction(light, salt ^ (i * 0x632BE5ABu));
        let f = brdf_cosine(s.normal, v, l, s.albedo, s.metallic, s.roughness);
        if all(f == vec3<f32>(0.0)) || dot(l, s.geometric) <= 0.0 {
            continue;
        }
        let shadow = trace(Ray(offset_origin(s, l), l), 3.0e38, true, salt);
        if shadow.instance == NO_HIT {
            color += f * light.color * light.intensity;
        }
    }
    for (var i = 0u; i < scene.renderer.positional_light_count; i++) {
        let light = positional_light_domain[scene.renderer.positional_lights_slot + i];
        let reach = positional_light_at(light, s.position);
        let f = brdf_cosine(s.normal, v, reach.l, s.albedo, s.metallic, s.roughness);
        if reach.attenuation <= 0.0 || all(f == vec3<f32>(0.0)) || dot(reach.l, s.geometric) <= 0.0 {
            continue;
        }
        // The shadow ray goes to a point of the light's disc (its sphere
        // seen from the surface), uniform over it, so that a light with a
        // radius casts penumbrae; the light itself is shaded from its
        // centre, as the raster does.
        let on_light = light_disc_point(light, s.position, reach.l, salt ^ (i * 0x9E3779B9u));
        let towards = normalize(on_light - s.position);
        let origin = offset_origin(s, towards);
        let shadow = trace(Ray(origin, towards), length(on_light - origin) * 0.9999, true, salt);
        if shadow.instance == NO_HIT {
            color += f * light.color * light.intensity * reach.attenuation;
        }
    }
    return color;
}

// ---- bounce sampling: cosine-weighted diffuse mixed with GGX visible normals ----

fn tangent_frame(n: vec3<f32>) -> mat3x3<f32> {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    let bt = vec3<f32>(b, s + n.y * n.y * a, -n.y);
    return mat3x3<f32>(t, bt, n);
}

fn ggx_alpha(roughness: f32) -> f32 {
    return clamp(roughness * roughness, 0.002, 1.0);
}

// Smith G1 for GGX.
fn smith_g1(n_dot_x: f32, a: f32) -> f32 {
    let a2 = a * a;
    return 2.0 * n_dot_x / (n_dot_x + sqrt(a2 + (1.0 - a2) * n_dot_x * n_dot_x));
}

fn ggx_d(n_dot_h: f32, a: f32) -> f32 {
    let a2 = a * a;
    let denom = 1.0 - n_dot_h * n_dot_h * (1.0 - a2);
    return a2 / (PI * denom * denom);
}

// A half vector from the distribution of normals visible from `v_local`
// (tangent space, z = normal), Heitz 2018.
fn sample_vndf(v_local: vec3<f32>, a: f32, u1: f32, u2: f32) -> vec3<f32> {
    let vh = normalize(vec3<f32>(a * v_local.x, a * v_local.y, v_local.z));
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(-vh.y, vh.x, 0.0) * inverseSqrt(len2), len2 > 1e-12);
    let t2 = cross(vh, t1);
    let r = sqrt(u1);
    let phi = 2.0 * PI * u2;
    let p1 = r * cos(phi);
    var p2 = r * sin(phi);
    let s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * p2;
    let nh = p1 * t1 + p2 * t2 + sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
    return normalize(vec3<f32>(a * nh.x, a * nh.y, max(nh.z, 1e-6)));
}

// How often the specular lobe is sampled: more for metals.
fn specular_probability(metallic: f32) -> f32 {
    return mix(0.5, 0.9, metallic);
}

// The mixture's density for direction `l` (world), given the view `v`.
fn bounce_pdf(s: Surface, v: vec3<f32>, l: vec3<f32>) -> f32 {
    let n_dot_l = dot(s.normal, l);
    if n_dot_l <= 0.0 {
        return 0.0;
    }
    let p_spec = specular_probability(s.metallic);
    let a = ggx_alpha(s.roughness);
    let h = normalize_or(v + l, s.normal);
    let n_dot_v = clamp(dot(s.normal, v), 1e-4, 1.0);
    let n_dot_h = clamp(dot(s.normal, h), 0.0, 1.0);
    let v_dot_h = max(dot(v, h), 1e-6);
    let vndf = smith_g1(n_dot_v, a) * v_dot_h * ggx_d(n_dot_h, a) / n_dot_v;
    let spec_pdf = vndf / (4.0 * v_dot_h);
    return p_spec * spec_pdf + (1.0 - p_spec) * n_dot_l / PI;
}

fn sample_bounce(s: Surface, v: vec3<f32>, rng: ptr<function, Rng>) -> vec3<f32> {
    let frame = tangent_frame(s.normal);
    let u1 = next_f32(rng);
    let u2 = next_f32(rng);
    if next_f32(rng) < specular_probability(s.metallic) {
        let v_local = transpose(frame) * v;
        let h = frame * sample_vndf(vec3<f32>(v_local.xy, max(v_local.z, 1e-4)), ggx_alpha(s.roughness), u1, u2);
        return reflect(-v, h);
    }
    let r = sqrt(u1);
    let phi = 2.0 * PI * u2;
    return frame * vec3<f32>(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u1)));
}

// ---- the paths ----

fn camera_ray(pixel: vec2<u32>, jitter: vec2<f32>) -> Ray {
    let size = vec2<f32>(f32(params.width), f32(params.height));
    let ndc = vec2<f32>((f32(pixel.x) + jitter.x) / size.x * 2.0 - 1.0, 1.0 - (f32(pixel.y) + jitter.y) / size.y * 2.0);
    // Reverse-Z: depth 1 is the near plane; 0.5 lies beyond it on every
    // projection the cameras make (perspective, infinite or not, and
    // orthographic), so the two points give the ray for both.
    let near = scene.camera.inverse_view_projection * vec4<f32>(ndc, 1.0, 1.0);
    let mid = scene.camera.inverse_view_projection * vec4<f32>(ndc, 0.5, 1.0);
    let origin = near.xyz / near.w;
    return Ray(origin, normalize_or(mid.xyz / mid.w - origin, vec3<f32>(0.0, 0.0, -1.0)));
}

fn radiance(first: Ray, rng: ptr<function, Rng>) -> vec3<f32> {
    var ray = first;
    var throughput = vec3<f32>(1.0);
    var color = vec3<f32>(0.0);
    let raster_model = (params.flags & RASTER_MODEL) != 0u;
    for (var bounce = 0u; bounce <= params.max_bounces; bounce++) {
        let salt = next_u32(rng);
        let hit = trace(ray, 3.0e38, false, salt);
        if hit.instance == NO_HIT {
            color += throughput * escaped(ray.dir);
            break;
        }
        let s = surface_at(ray, hit);
        let v = -ray.dir;
        if s.unlit {
            // Light stops at an unlit surface: it shows its colour only.
            color += throughput * s.emissive;
            break;
        }
        color += throughput * (s.emissive + direct_light(s, v, salt));
        if raster_model {
            // mesh/shading.wgsl's ambient term, unoccluded, as the raster has
            // it: the environment's irradiance and (without the probe term)
            // its prefiltered reflection, or the constant.
            let f0 = mix(vec3<f32>(0.04), s.albedo, s.metallic);
            if has_environment_map() {
                color += throughput * s.albedo * (1.0 - s.metallic) * environment_irradiance(s.normal) / PI;
                // A probe's faces have no probe: what they show reflects
                // the environment, so past the first hit it is added too.
                if (params.flags & RASTER_REFLECTIONS) == 0u || bounce > 0u {
                    let reflected = sample_environment(reflect(-v, s.normal), s.roughness);
                    color += throughput * reflected * split_sum_brdf(f0, s.roughness, max(dot(s.normal, v), 0.0));
                }
            } else {
                color += throughput * (s.albedo * (1.0 - s.metallic) * RASTER_AMBIENT + f0 * RASTER_AMBIENT);
            }
            // What a perfect reflection probe would add: the surroundings'
            // raster-model radiance along the reflection (GGX-distributed
            // around it for a rough surface, as the probe's blurred mips
            // approximate), weighted by the same environment BRDF. Once:
            // the probe's faces have no probe themselves.
            if (params.flags & RASTER_REFLECTIONS) == 0u || bounce > 0u {
                break;
            }
            let frame = tangent_frame(s.normal);
            let v_local = transpose(frame) * v;
            let h = frame * sample_vndf(vec3<f32>(v_local.xy, max(v_local.z, 1e-4)), ggx_alpha(s.roughness), next_f32(rng), next_f32(rng));
            let l = reflect(-v, h);
            if dot(l, s.geometric) <= 0.0 {
                break;
            }
            throughput *= split_sum_brdf(f0, s.roughness, max(dot(s.normal, v), 0.0));
            ray = Ray(offset_origin(s, l), l);
            continue;
        }
        if bounce == params.max_bounces {
            break;
        }
        let l = sample_bounce(s, v, rng);
        let pdf = bounce_pdf(s, v, l);
        if !(pdf > 1e-8) || dot(l, s.geometric) <= 0.0 {
            break;
        }
        throughput *= brdf_cosine(s.normal, v, l, s.albedo, s.metallic, s.roughness) / pdf;
        if bounce >= 3u {
            let survive = clamp(max(throughput.r, max(throughput.g, throughput.b)), 0.05, 0.95);
            if next_f32(rng) >= survive {
                break;
            }
            throughput /= survive;
        }
        // Paths that blew up (a tiny pdf) would put a firefly in the mean
        // for thousands of samples: drop them, and say so in the docs.
        if !all(throughput < vec3<f32>(1e4)) {
            break;
        }
        ray = Ray(offset_origin(s, l), l);
    }
    return color;
}

@compute @workgroup_size(8, 8)
fn trace_paths(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let pixel = id.y * params.width + id.x;
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < params.samples_this_frame; k++) {
        let sample = params.samples_done + k;
        var rng = Rng(pcg(pixel ^ pcg(sample ^ pcg(params.seed))));
        let jitter = vec2<f32>(next_f32(&rng), next_f32(&rng));
        let c = radiance(camera_ray(id.xy, jitter), &rng);
        // A NaN sample (none should exist) would poison the mean forever.
        sum += select(c, vec3<f32>(0.0), c != c);
    }
    var total = sum;
    if params.samples_done > 0u {
        total += running_sum[pixel].rgb;
    }
    running_sum[pixel] = vec4<f32>(total, 1.0);
    let mean = total / f32(max(params.samples_done + params.samples_this_frame, 1u));
    textureStore(output, id.xy, vec4<f32>(min(mean, vec3<f32>(65000.0)), 1.0));
}
