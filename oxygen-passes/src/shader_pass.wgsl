// Metallic-roughness shading: Cook-Torrance specular (GGX distribution,
// height-correlated Smith visibility, Schlick Fresnel) plus Lambert diffuse,
// with base-colour, metallic-roughness, normal and emissive textures,
// from every directional and positional light of the frame (read through
// their slots), and a small constant ambient term. Writes linear radiance to
// the HDR target; the tone-map step makes it displayable.

const PI: f32 = 3.14159265;
const AMBIENT: f32 = 0.03;

// Group 3: what this view reads from other views (see lighting_inputs.rs):
// cascade shadow maps and one reflection probe.
struct LightingInputs {
    light_view_projection: array<mat4x4<f32>, 4>,
    texel_world_size: vec4<f32>,
    uv_texel: vec4<f32>,
    count: u32,
    pcf_radius: u32,
    normal_offset: f32,
    depth_bias: f32,
    probe_positions: array<vec4<f32>, 4>,
    tile_view_projection: array<mat4x4<f32>, 16>,
    // 16 floats packed four to a vec4 (uniform arrays have a 16-byte stride).
    tile_texel_angle: array<vec4<f32>, 4>,
    tile_count: u32,
    probe_count: u32,
    reserved0: u32,
    reserved1: u32,
}
@group(3) @binding(0) var shadow_map_0: texture_depth_2d;
@group(3) @binding(1) var shadow_map_1: texture_depth_2d;
@group(3) @binding(2) var shadow_map_2: texture_depth_2d;
@group(3) @binding(3) var shadow_map_3: texture_depth_2d;
@group(3) @binding(4) var shadow_sampler: sampler_comparison;
@group(3) @binding(5) var<uniform> shadows: LightingInputs;
@group(3) @binding(6) var probe_sampler: sampler;
@group(3) @binding(8) var probe_faces_0: texture_2d_array<f32>;
@group(3) @binding(9) var probe_faces_1: texture_2d_array<f32>;
@group(3) @binding(10) var probe_faces_2: texture_2d_array<f32>;
@group(3) @binding(11) var probe_faces_3: texture_2d_array<f32>;

// The probe nearest to `position` (the surface reflects what that probe saw).
fn nearest_probe(position: vec3<f32>) -> u32 {
    var best = 0u;
    var best_distance = 3.4e38;
    for (var i = 0u; i < shadows.probe_count; i++) {
        let offset = shadows.probe_positions[i].xyz - position;
        let d = dot(offset, offset);
        if d < best_distance {
            best_distance = d;
            best = i;
        }
    }
    return best;
}

// `roughness` picks the mip level: a rough surface reflects a blurrier
// level (levels are 2 x 2 box-filtered, see probe_mips.rs).
fn sample_probe_face(probe: u32, uv: vec2<f32>, face: u32, roughness: f32) -> vec3<f32> {
    switch probe {
        case 0u: { return textureSampleLevel(probe_faces_0, probe_sampler, uv, face, probe_lod(textureNumLevels(probe_faces_0), roughness)).rgb; }
        case 1u: { return textureSampleLevel(probe_faces_1, probe_sampler, uv, face, probe_lod(textureNumLevels(probe_faces_1), roughness)).rgb; }
        case 2u: { return textureSampleLevel(probe_faces_2, probe_sampler, uv, face, probe_lod(textureNumLevels(probe_faces_2), roughness)).rgb; }
        default: { return textureSampleLevel(probe_faces_3, probe_sampler, uv, face, probe_lod(textureNumLevels(probe_faces_3), roughness)).rgb; }
    }
}
// Level for `roughness`: perceptual roughness across the chain, leaving the
// last few (tiny) levels unused so even a rough reflection keeps some shape.
fn probe_lod(levels: u32, roughness: f32) -> f32 {
    let usable = max(f32(levels) - 3.0, 0.0);
    return clamp(roughness, 0.0, 1.0) * usable;
}
// Scale and bias applied to F0 by the split-sum specular integral,
// approximated analytically (Karis 2014, "Physically Based Shading on
// Mobile"): what fraction of the prefiltered environment a surface reflects.
fn environment_brdf(f0: vec3<f32>, roughness: f32, n_dot_v: f32) -> vec3<f32> {
    let r = roughness * vec4<f32>(-1.0, -0.0275, -0.572, 0.022) + vec4<f32>(1.0, 0.0425, 1.04, -0.04);
    let a004 = min(r.x * r.x, exp2(-9.28 * n_dot_v)) * r.x + r.y;
    let ab = vec2<f32>(-1.04, 1.04) * a004 + r.zw;
    return f0 * ab.x + ab.y;
}
@group(3) @binding(7) var shadow_atlas: texture_depth_2d_array;

// Fraction of a shadow-casting local light's light reaching `world_position`
// through atlas tile `slot` (a spot's map, or one cube face of a point
// light's) (3 × 3 PCF; the normal offset grows with the distance from the light).
fn tile_visibility(slot: u32, light_position: vec3<f32>, world_position: vec3<f32>, geometric_normal: vec3<f32>) -> f32 {
    if slot >= shadows.tile_count {
        return 1.0;
    }
    let distance = length(light_position - world_position);
    let offset = geometric_normal * distance * shadows.tile_texel_angle[slot / 4u][slot % 4u] * 1.5;
    let clip = shadows.tile_view_projection[slot] * vec4<f32>(world_position + offset, 1.0);
    if clip.w <= 0.0 {
        return 1.0;
    }
    let ndc = clip.xyz / clip.w;
    if any(abs(ndc.xy) > vec2<f32>(1.0)) || ndc.z < 0.0 || ndc.z > 1.0 {
        return 1.0;
    }
    // The map is layer `slot` of the atlas; 3 x 3 taps one texel apart,
    // each a bilinear comparison (reverse-Z: lit when at least as close to
    // the light as the stored depth).
    let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
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

// The cube face (PROBE_FACE_AXES order: +X, -X, +Y, -Y, +Z, -Z) whose
// camera looks along the major axis of `direction`.
fn cube_face(direction: vec3<f32>) -> u32 {
    let a = abs(direction);
    if a.x >= a.y && a.x >= a.z {
        return select(1u, 0u, direction.x >= 0.0);
    }
    if a.y >= a.z {
        return select(3u, 2u, direction.y >= 0.0);
    }
    return select(5u, 4u, direction.z >= 0.0);
}

// Radiance the probe saw along `direction`. Faces are rendered by ordinary
// cameras (forward, up as in PROBE_FACE_AXES), so the lookup projects the
// direction onto the face's camera instead of using cube-map conventions.
fn sample_probe(probe: u32, direction: vec3<f32>, roughness: f32) -> vec3<f32> {
    let face = cube_face(direction);
    var forwards = array<vec3<f32>, 6>(
        vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(-1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0),
        vec3<f32>(0.0, -1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(0.0, 0.0, -1.0),
    );
    var ups = array<vec3<f32>, 6>(
        vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, -1.0),
        vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 1.0, 0.0),
    );
    let forward = forwards[face];
    let up = ups[face];
    let right = cross(forward, up);
    let depth = dot(direction, forward);
    let ndc = vec2<f32>(dot(direction, right), dot(direction, up)) / depth;
    let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
    return sample_probe_face(probe, uv, face, roughness);
}

fn compare_cascade(cascade: u32, uv: vec2<f32>, depth: f32) -> f32 {
    switch cascade {
        case 0u: { return textureSampleCompareLevel(shadow_map_0, shadow_sampler, uv, depth); }
        case 1u: { return textureSampleCompareLevel(shadow_map_1, shadow_sampler, uv, depth); }
        case 2u: { return textureSampleCompareLevel(shadow_map_2, shadow_sampler, uv, depth); }
        default: { return textureSampleCompareLevel(shadow_map_3, shadow_sampler, uv, depth); }
    }
}

// Fraction of the light reaching `world_position`: the first cascade whose
// box holds the point, a normal offset against acne, (2r + 1)² PCF taps.
fn shadow_visibility(world_position: vec3<f32>, geometric_normal: vec3<f32>) -> f32 {
    for (var i = 0u; i < shadows.count; i++) {
        let offset = geometric_normal * shadows.texel_world_size[i] * shadows.normal_offset;
        let clip = shadows.light_view_projection[i] * vec4<f32>(world_position + offset, 1.0);
        let ndc = clip.xyz / clip.w;
        if all(abs(ndc.xy) < vec2<f32>(0.98)) && ndc.z >= 0.0 && ndc.z <= 1.0 {
            let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
            let r = i32(shadows.pcf_radius);
            var lit = 0.0;
            for (var y = -r; y <= r; y++) {
                for (var x = -r; x <= r; x++) {
                    let tap = uv + vec2<f32>(f32(x), f32(y)) * shadows.uv_texel[i];
                    lit += compare_cascade(i, tap, ndc.z + shadows.depth_bias);
                }
            }
            let taps = f32((2 * r + 1) * (2 * r + 1));
            return lit / taps;
        }
    }
    return 1.0;
}

fn surface_normal(mesh: MeshVarying, front_facing: bool, material: MaterialRecord) -> vec3<f32> {
    let n = normalize(mesh.world_normal);
    // Double-sided surfaces are lit on the side we see; single-sided ones
    // only show their front (culling), so their normal stands as it is.
    let double_sided = (material.flags & 4u) != 0u;
    return select(n, -n, double_sided && !front_facing);
}

// Radiance reflected towards `v` from light arriving along `l`, per unit
// incoming irradiance at normal incidence.
fn brdf_cosine(n: vec3<f32>, v: vec3<f32>, l: vec3<f32>, albedo: vec3<f32>, metallic: f32, roughness: f32) -> vec3<f32> {
    let n_dot_l = max(dot(n, l), 0.0);
    if n_dot_l <= 0.0 {
        return vec3<f32>(0.0);
    }
    let h = normalize(v + l);
    let n_dot_v = max(dot(n, v), 1e-4);
    let n_dot_h = max(dot(n, h), 0.0);
    let v_dot_h = max(dot(v, h), 0.0);
    let a = max(roughness * roughness, 0.002);
    let a2 = a * a;
    let denom = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
    let distribution = a2 / (PI * denom * denom);
    let visibility = 0.5 / (n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2) + n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2));
    let f0 = mix(vec3<f32>(0.04), albedo, metallic);
    let fresnel = f0 + (vec3<f32>(1.0) - f0) * pow(1.0 - v_dot_h, 5.0);
    let diffuse = (vec3<f32>(1.0) - fresnel) * (1.0 - metallic) * albedo / PI;
    return (diffuse + distribution * visibility * fresnel) * n_dot_l;
}

// Screen-space derivatives, taken at the top of each fragment entry point
// (uniform control flow) for normal mapping without stored tangents.
struct Derivatives {
    dp_dx: vec3<f32>,
    dp_dy: vec3<f32>,
    duv_dx: vec2<f32>,
    duv_dy: vec2<f32>,
}

fn derivatives_of(mesh: MeshVarying) -> Derivatives {
    return Derivatives(dpdx(mesh.world_position), dpdy(mesh.world_position), dpdx(mesh.uv), dpdy(mesh.uv));
}

// Tangent frame from position and UV derivatives (a cotangent frame), so a
// tangent-space normal map needs no per-vertex tangents. glTF's v axis points
// down the image, hence the bitangent's sign.
fn perturb_normal(n: vec3<f32>, d: Derivatives, tangent_normal: vec3<f32>) -> vec3<f32> {
    let dp2_perp = cross(d.dp_dy, n);
    let dp1_perp = cross(n, d.dp_dx);
    let t = dp2_perp * d.duv_dx.x + dp1_perp * d.duv_dy.x;
    let b = -(dp2_perp * d.duv_dx.y + dp1_perp * d.duv_dy.y);
    let largest = max(dot(t, t), dot(b, b));
    if !(largest > 1e-20) {
        return n; // no UV variation here: keep the geometric normal
    }
    let scale = inverseSqrt(largest);
    return normalize(mat3x3<f32>(t * scale, b * scale, n) * tangent_normal);
}

fn shade(mesh: MeshVarying, front_facing: bool, material: MaterialRecord, d: Derivatives) -> vec4<f32> {
    var n = surface_normal(mesh, front_facing, material);
    let geometric_normal = n;
    if material.normal_texture != INVALID_SLOT {
        var tangent_normal = sample_texture(material.normal_texture, mesh.uv, d.duv_dx, d.duv_dy).xyz * 2.0 - 1.0;
        tangent_normal = vec3<f32>(tangent_normal.xy * material.normal_scale, tangent_normal.z);
        n = perturb_normal(n, d, normalize(tangent_normal));
    }
    let v = normalize(scene.camera.camera_position.xyz - mesh.world_position);
    let base = base_color_of(mesh, material, d.duv_dx, d.duv_dy);
    let albedo = base.rgb;
    // glTF packs roughness in G and metallic in B.
    let metal_rough = sample_texture(material.metallic_roughness_texture, mesh.uv, d.duv_dx, d.duv_dy);
    let metallic = clamp(material.metallic * metal_rough.b, 0.0, 1.0);
    let roughness = clamp(material.roughness * metal_rough.g, 0.045, 1.0);
    // Ambient occlusion dims indirect light only: the ambient term and the
    // probe reflection, not the lights.
    let occlusion = mix(1.0, sample_texture(material.occlusion_texture, mesh.uv, d.duv_dx, d.duv_dy).r, material.occlusion_strength);
    var color = (albedo * (1.0 - metallic) * AMBIENT + mix(vec3<f32>(0.04), albedo, metallic) * AMBIENT) * occlusion;

    let dir_count = scene.renderer.directional_light_count;
    var shadowed_light_done = false;
    for (var i = 0u; i < dir_count; i++) {
        let light = directional_light_domain[scene.renderer.directional_lights_slot + i];
        var visibility = 1.0;
        // The cascades belong to the first shadow-casting directional light.
        if (light.flags & 1u) != 0u && !shadowed_light_done {
            shadowed_light_done = true;
            visibility = shadow_visibility(mesh.world_position, geometric_normal);
        }
        color += brdf_cosine(n, v, -light.direction, albedo, metallic, roughness) * light.color * light.intensity * visibility;
    }

    let pos_count = scene.renderer.positional_light_count;
    for (var i = 0u; i < pos_count; i++) {
        let light = positional_light_domain[scene.renderer.positional_lights_slot + i];
        let to_light = light.position - mesh.world_position;
        let distance_sq = max(dot(to_light, to_light), 1e-4);
        let l = to_light * inverseSqrt(distance_sq);
        var attenuation = 1.0 / distance_sq;
        if light.range > 0.0 {
            let ratio = sqrt(distance_sq) / light.range;
            attenuation *= clamp(1.0 - ratio * ratio * ratio * ratio, 0.0, 1.0);
        }
        if light.kind == 1u {
            attenuation *= smoothstep(light.cos_outer, light.cos_inner, dot(-l, light.direction));
            if light.shadow_slot != INVALID_SLOT {
                attenuation *= tile_visibility(light.shadow_slot, light.position, mesh.world_position, geometric_normal);
            }
        } else if light.shadow_slot != INVALID_SLOT {
            // A point light's six faces follow its first tile, in
            // PROBE_FACE_AXES order: the face is the major axis of -l.
            let tile = light.shadow_slot + cube_face(-l);
            attenuation *= tile_visibility(tile, light.position, mesh.world_position, geometric_normal);
        }
        color += brdf_cosine(n, v, l, albedo, metallic, roughness) * light.color * light.intensity * attenuation;
    }
    // Specular reflection of the probe's surroundings: sharp on smooth
    // surfaces, from blurrier mip levels on rough ones, weighted by the
    // environment BRDF (strong on metals, a few percent on dielectrics
    // except at grazing angles).
    if shadows.probe_count > 0u {
        let reflected = sample_probe(nearest_probe(mesh.world_position), reflect(-v, n), roughness);
        let f0 = mix(vec3<f32>(0.04), albedo, metallic);
        color += reflected * environment_brdf(f0, roughness, max(dot(n, v), 0.0)) * occlusion;
    }
    color += material.emissive * sample_texture(material.emissive_texture, mesh.uv, d.duv_dx, d.duv_dy).rgb;
    return vec4<f32>(color, base.a);
}

@fragment
fn fs_opaque(mesh: MeshVarying, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let d = derivatives_of(mesh);
    if mesh.material == INVALID_SLOT {
        return STALE_DRAW_COLOR;
    }
    let shaded = shade(mesh, front_facing, material_of(mesh), d);
    return vec4<f32>(shaded.rgb, 1.0);
}

@fragment
fn fs_masked(mesh: MeshVarying, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let d = derivatives_of(mesh);
    if mesh.material == INVALID_SLOT {
        return STALE_DRAW_COLOR;
    }
    let material = material_of(mesh);
    let shaded = shade(mesh, front_facing, material, d);
    if shaded.a < material.alpha_cutoff {
        discard;
    }
    return vec4<f32>(shaded.rgb, 1.0);
}

// Transparent surfaces: premultiplied alpha (blend One, OneMinusSrcAlpha).
@fragment
fn fs_blend(mesh: MeshVarying, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let d = derivatives_of(mesh);
    if mesh.material == INVALID_SLOT {
        return STALE_DRAW_COLOR;
    }
    let shaded = shade(mesh, front_facing, material_of(mesh), d);
    let alpha = clamp(shaded.a, 0.0, 1.0);
    return vec4<f32>(shaded.rgb * alpha, alpha);
}
