// The visibility pass of deferred shading: for each pixel, the draw seen
// there (its index in the view's draws plus one: 0 is nothing) and its
// triangle (the primitive within the draw), in an Rg32Uint target, and the
// label planes the view asks for beside it; no colour. A compute pass
// (mesh/deferred.wgsl) then shades every pixel once from these two
// numbers. Masked variants cut out what their alpha cuts out, as shading
// does, so the visibility target holds only surfaces that shading keeps.

enable primitive_index;

#include "mesh/vertex_stage.wgsl"
#include "mesh/label_values.wgsl"

struct Visible {
    @location(0) surface: vec2<u32>,
    @location(1) instance: u32,
    @location(2) normal: vec4<f32>,
    @location(3) semantic_class: u32,
    @location(4) linear_depth: u32,
}

fn visible(mesh: MeshVarying, front_facing: bool, triangle: u32) -> Visible {
    let l = labels_of(mesh, front_facing);
    return Visible(vec2<u32>(mesh.draw + 1u, triangle), l.instance, l.normal, l.semantic_class, l.linear_depth);
}

@fragment
fn fs_visibility(
    io: MeshIo,
    @builtin(front_facing) front_facing: bool,
    @builtin(primitive_index) triangle: u32,
) -> Visible {
    return visible(unpack_varying(io), front_facing, triangle);
}

@fragment
fn fs_visibility_masked(
    io: MeshIo,
    @builtin(front_facing) front_facing: bool,
    @builtin(primitive_index) triangle: u32,
) -> Visible {
    let mesh = unpack_varying(io);
    // Derivatives first, in uniform control flow, as the shading pass takes them.
    let d = uv_derivatives_of(mesh);
    let material = material_of(mesh);
    if base_color_of(mesh, material, d).a < material.alpha_cutoff {
        discard;
    }
    return visible(mesh, front_facing, triangle);
}
