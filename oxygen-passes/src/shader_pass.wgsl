// Simple lit shading: Lambert diffuse plus a Blinn-Phong highlight whose
// strength follows roughness, from every directional and positional light of
// the frame (read through their slots), and a small ambient term. The full
// metallic-roughness BRDF replaces this later.

const PI: f32 = 3.14159265;
const AMBIENT: f32 = 0.06;

fn shade(mesh: MeshVarying, front_facing: bool, material: MaterialRecord) -> vec4<f32> {
    var n = normalize(mesh.world_normal);
    if !front_facing {
        n = -n; // double-sided surfaces are lit on the side we see
    }
    let view_dir = normalize(scene.camera.camera_position.xyz - mesh.world_position);
    let base = base_color_of(mesh, material);
    let albedo = base.rgb;
    let shininess = mix(128.0, 4.0, material.roughness);
    let specular_strength = (1.0 - material.roughness) * 0.25;
    var color = albedo * AMBIENT;

    let dir_count = scene.renderer.directional_light_count;
    for (var i = 0u; i < dir_count; i++) {
        let light = directional_light_domain[scene.renderer.directional_lights_slot + i];
        let l = -light.direction;
        let n_dot_l = max(dot(n, l), 0.0);
        let h = normalize(l + view_dir);
        let spec = pow(max(dot(n, h), 0.0), shininess) * specular_strength * step(0.0, n_dot_l);
        color += (albedo / PI * n_dot_l + vec3<f32>(spec)) * light.color * light.intensity;
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
            let cos_angle = dot(-l, light.direction);
            attenuation *= smoothstep(light.cos_outer, light.cos_inner, cos_angle);
        }
        let n_dot_l = max(dot(n, l), 0.0);
        color += albedo / PI * n_dot_l * light.color * light.intensity * attenuation;
    }
    return vec4<f32>(color, base.a);
}

@fragment
fn fs_opaque(mesh: MeshVarying, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    if mesh.material == INVALID_SLOT {
        return STALE_DRAW_COLOR;
    }
    let shaded = shade(mesh, front_facing, material_of(mesh));
    return vec4<f32>(shaded.rgb, 1.0);
}

@fragment
fn fs_masked(mesh: MeshVarying, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    if mesh.material == INVALID_SLOT {
        return STALE_DRAW_COLOR;
    }
    let material = material_of(mesh);
    let shaded = shade(mesh, front_facing, material);
    if shaded.a < material.alpha_cutoff {
        discard;
    }
    return vec4<f32>(shaded.rgb, 1.0);
}
