// The vertex stage shared by every mesh pass. Everything per draw arrives
// through slots: the draw's DrawMetadata is found by instance_index (the
// renderer passes the draw's position in the view's array as first_instance),
// and vertex_index already includes the geometry's base vertex.

struct MeshVarying {
    // Invariant so that the shading pass reproduces the pre-pass depth bit
    // for bit and its GreaterEqual test passes exactly on the visible surface.
    @builtin(position) @invariant clip_position: vec4<f32>,
    @location(0) world_position: vec3<f32>,
    @location(1) world_normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) @interpolate(flat) material: u32,
}

@vertex
fn vs_main(@builtin(vertex_index) vertex_index: u32, @builtin(instance_index) draw_index: u32) -> MeshVarying {
    let draw = draw_metadata_domain[scene.renderer.draw_metadata_slot + draw_index];
    let v = vertex_domain[vertex_index];
    let world = world_transform_domain[scene.renderer.world_transforms_slot + draw.transform_index];
    let normal_matrix = normal_transform_domain[scene.renderer.normal_transforms_slot + draw.transform_index];
    let world_position = world * vec4<f32>(v.px, v.py, v.pz, 1.0);
    var out: MeshVarying;
    out.clip_position = scene.camera.view_projection * world_position;
    out.world_position = world_position.xyz;
    out.world_normal = normal_matrix * vec3<f32>(v.nx, v.ny, v.nz);
    out.uv = vec2<f32>(v.u, v.v);
    out.material = draw.material_handle;
    // Debug mode: a draw read through a stale or foreign range carries
    // another generation; flag it (the fragment stages paint it magenta).
    let checking = (scene.renderer.debug_flags & DEBUG_GENERATIONS) != 0u;
    if checking && draw.reserved0 != scene.renderer.draw_metadata_generation {
        out.material = INVALID_SLOT;
    }
    return out;
}

const STALE_DRAW_COLOR: vec4<f32> = vec4<f32>(1.0, 0.0, 1.0, 1.0);

fn material_of(mesh: MeshVarying) -> MaterialRecord {
    if mesh.material == INVALID_SLOT {
        // A flagged draw: an opaque, untextured magenta material.
        return MaterialRecord(STALE_DRAW_COLOR, vec3<f32>(0.0), 1.0, 0.0, 1.0, 0.0, 0u, INVALID_SLOT, INVALID_SLOT, INVALID_SLOT, INVALID_SLOT, INVALID_SLOT, 1.0, 0u, 0u);
    }
    return material_domain[scene.renderer.materials_slot + mesh.material];
}

// Base colour: the material factor times its texture (white when absent).
// `duv_dx`, `duv_dy`: screen derivatives of the UV, taken by the caller in
// uniform control flow, which choose the texture's mip level.
fn base_color_of(mesh: MeshVarying, material: MaterialRecord, duv_dx: vec2<f32>, duv_dy: vec2<f32>) -> vec4<f32> {
    return material.base_color * sample_texture(material.base_color_texture, mesh.uv, duv_dx, duv_dy);
}
