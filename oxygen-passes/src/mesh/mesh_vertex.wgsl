// The vertex stage shared by every mesh pass. Everything per draw arrives
// through slots: the draw's DrawMetadata is found by instance_index (the
// renderer passes the draw's position in the view's array as first_instance),
// and vertex_index already includes the geometry's base vertex.

#include "bindless/constants"
#include "sceneprep/constants"
#include "lighting/constants"
#include "bindless/scene_constants.wgsl"
#include "sceneprep/gpu_records.wgsl"
#include "bindless/domains"
#include "bindless/textures"
#include "mesh/varyings"

// What the fragment functions read of a surface point: the vertex stage's
// outputs unpacked (mesh/varyings: `unpack_varying`). The vertex colour is
// white and the second UV set zero when the module was composed without
// vertex attributes.
struct MeshVarying {
    clip_position: vec4<f32>,
    world_position: vec3<f32>,
    world_normal: vec3<f32>,
    uv: vec2<f32>,
    // The draw's index in the view's draws: the fragment stage reads its
    // DrawMetadata again for the material and the labels.
    draw: u32,
    // Vertex colour (white without COLOR_0) and the second UV set.
    color: vec4<f32>,
    uv1: vec2<f32>,
}

// Vertex `vertex_index` (base vertex included) of the view's draw
// `draw_index`, morphed, skinned and placed in the world and on the camera:
// what the vertex stage passes on, and what deferred shading
// (mesh/deferred.wgsl) rebuilds for each corner of a pixel's triangle.
fn mesh_vertex(draw_index: u32, vertex_index: u32) -> MeshVarying {
    let draw = draw_metadata_domain[scene.renderer.draw_metadata_slot + draw_index];
    let v = vertex_domain[vertex_index];
    // Morph targets first (glTF: morph, then skin): the weighted sum of the
    // targets' displacements, stored after the vertices, target by target;
    // the weights come in a header among the frame's matrices:
    // [vertex count, target count, w0, w1, ...], 16 floats a matrix.
    var position = vec3<f32>(v.px, v.py, v.pz);
    var normal = vec3<f32>(v.nx, v.ny, v.nz);
    if draw.morph_base != INVALID_SLOT {
        let header = scene.renderer.world_transforms_slot + draw.morph_base;
        let vertex_count = u32(world_transform_domain[header][0][0]);
        let targets = u32(world_transform_domain[header][0][1]);
        let local = vertex_index - draw.vertex_slot;
        for (var t = 0u; t < targets; t++) {
            let k = t + 2u;
            let w = world_transform_domain[header + k / 16u][(k % 16u) / 4u][k % 4u];
            if w != 0.0 {
                let d = vertex_domain[draw.vertex_slot + vertex_count * (1u + t) + local];
                position += w * vec3<f32>(d.px, d.py, d.pz);
                normal += w * vec3<f32>(d.nx, d.ny, d.nz);
            }
        }
    }
    var world_position: vec4<f32>;
    var world_normal: vec3<f32>;
    if draw.skin_slot != INVALID_SLOT {
        // Skinned: the weighted sum of the vertex's joint matrices (world
        // of the joint × inverse bind), parallel to the geometry's vertices
        // as joints (px..nx, whole numbers) and weights (ny, nz, u, v).
        let s = vertex_domain[draw.skin_slot + (vertex_index - draw.vertex_slot)];
        let joints = vec4<u32>(u32(s.px), u32(s.py), u32(s.pz), u32(s.nx));
        let weights = vec4<f32>(s.ny, s.nz, s.u, s.v);
        let base = scene.renderer.world_transforms_slot + draw.joint_base;
        let normal_base = scene.renderer.normal_transforms_slot + draw.joint_base;
        var skinned_position = vec4<f32>(0.0);
        var skinned_normal = vec3<f32>(0.0);
        for (var k = 0u; k < 4u; k++) {
            if weights[k] > 0.0 {
                skinned_position += weights[k] * (world_transform_domain[base + joints[k]] * vec4<f32>(position, 1.0));
                skinned_normal += weights[k] * (normal_matrix_of(normal_transform_domain[normal_base + joints[k]]) * normal);
            }
        }
        world_position = vec4<f32>(skinned_position.xyz, 1.0);
        world_normal = skinned_normal;
    } else {
        let world = world_transform_domain[scene.renderer.world_transforms_slot + draw.transform_index];
        let normal_matrix =
            normal_matrix_of(normal_transform_domain[scene.renderer.normal_transforms_slot + draw.transform_index]);
        world_position = world * vec4<f32>(position, 1.0);
        world_normal = normal_matrix * normal;
    }
    var out: MeshVarying;
    out.clip_position = scene.camera.view_projection * world_position;
    out.world_position = world_position.xyz;
    out.world_normal = world_normal;
    out.uv = vec2<f32>(v.u, v.v);
    out.draw = draw_index;
    // Attribute records run parallel to the geometry's vertices (stored as
    // VertexRecords: colour in px..nx, the second UV set in ny, nz).
    out.color = vec4<f32>(1.0);
    out.uv1 = vec2<f32>(0.0);
    if HAS_VERTEX_ATTRIBUTES && draw.attributes_slot != INVALID_SLOT {
        let a = vertex_domain[draw.attributes_slot + (vertex_index - draw.vertex_slot)];
        out.color = vec4<f32>(a.px, a.py, a.pz, a.nx);
        out.uv1 = vec2<f32>(a.ny, a.nz);
    }
    return out;
}

// The draw a fragment belongs to.
fn draw_of(mesh: MeshVarying) -> DrawMetadata {
    return draw_metadata_domain[scene.renderer.draw_metadata_slot + mesh.draw];
}

// The draw's material handle, or INVALID_SLOT in debug mode for a draw read
// through a stale or foreign range (it carries another generation): the
// fragment stages paint it magenta.
fn material_handle_of(mesh: MeshVarying) -> u32 {
    let draw = draw_of(mesh);
    let checking = (scene.renderer.debug_flags & DEBUG_GENERATIONS) != 0u;
    if checking && draw.generation != scene.renderer.draw_metadata_generation {
        return INVALID_SLOT;
    }
    return draw.material_handle;
}

const STALE_DRAW_COLOR: vec4<f32> = vec4<f32>(1.0, 0.0, 1.0, 1.0);

fn material_of(mesh: MeshVarying) -> MaterialRecord {
    return material_at(material_handle_of(mesh));
}

// Material `handle`; INVALID_SLOT gives the stale-draw material.
fn material_at(handle: u32) -> MaterialRecord {
    if handle == INVALID_SLOT {
        // A flagged draw: an opaque, untextured, unlit magenta material.
        var stale: MaterialRecord;
        stale.base_color = STALE_DRAW_COLOR;
        stale.normal_scale = 1.0;
        stale.roughness = 1.0;
        stale.flags = MATERIAL_UNLIT;
        stale.base_color_texture = INVALID_SLOT;
        stale.metallic_roughness_texture = INVALID_SLOT;
        stale.normal_texture = INVALID_SLOT;
        stale.emissive_texture = INVALID_SLOT;
        stale.occlusion_texture = INVALID_SLOT;
        stale.occlusion_strength = 1.0;
        return stale;
    }
    return material_domain[scene.renderer.materials_slot + handle];
}

// Screen derivatives of both UV sets, taken by the caller in uniform
// control flow; they choose each texture's mip level.
struct UvDerivatives {
    dx0: vec2<f32>,
    dy0: vec2<f32>,
    dx1: vec2<f32>,
    dy1: vec2<f32>,
}

// Whether any material reads a second UV set or a texture transform
// (pipelines/features.rs `ShaderFeatures::uv_transforms`); without, set 1's
// derivatives are never taken and every texture reads set 0 as is.
override HAS_UV_TRANSFORMS: bool = true;

fn uv_derivatives_of(mesh: MeshVarying) -> UvDerivatives {
    if !HAS_UV_TRANSFORMS {
        return UvDerivatives(dpdx(mesh.uv), dpdy(mesh.uv), vec2<f32>(0.0), vec2<f32>(0.0));
    }
    return UvDerivatives(dpdx(mesh.uv), dpdy(mesh.uv), dpdx(mesh.uv1), dpdy(mesh.uv1));
}

// Where one texture is read: its UV set through its transform, and the
// transformed derivatives (the transform is affine, so they map by its
// linear part).
struct TexCoord {
    uv: vec2<f32>,
    dx: vec2<f32>,
    dy: vec2<f32>,
}

// The coordinates of the texture whose record is `t`. Without
// MATERIAL_UV_TRANSFORMS every texture reads set 0 as is.
fn tex_coord(mesh: MeshVarying, material: MaterialRecord, t: UvTransformRecord, d: UvDerivatives) -> TexCoord {
    if !HAS_UV_TRANSFORMS || (material.flags & MATERIAL_UV_TRANSFORMS) == 0u {
        return TexCoord(mesh.uv, d.dx0, d.dy0);
    }
    let set1 = t.uv_set == 1u;
    let uv = select(mesh.uv, mesh.uv1, set1);
    let dx = select(d.dx0, d.dx1, set1);
    let dy = select(d.dy0, d.dy1, set1);
    let linear = mat2x2<f32>(vec2<f32>(t.row0.x, t.row1.x), vec2<f32>(t.row0.y, t.row1.y));
    return TexCoord(apply_uv_transform(t, uv), linear * dx, linear * dy);
}

fn sample_at(slot: u32, at: TexCoord) -> vec4<f32> {
    return sample_texture(slot, at.uv, at.dx, at.dy);
}

// Base colour: the material factor times the vertex colour times its
// texture (white when absent).
fn base_color_of(mesh: MeshVarying, material: MaterialRecord, d: UvDerivatives) -> vec4<f32> {
    let at = tex_coord(mesh, material, material.uv_transforms[0], d);
    return material.base_color * mesh.color * sample_at(material.base_color_texture, at);
}
