// Per-pixel labels, drawn after shading over the same depth: which node
// drew each pixel (its stable id plus one; 0 where nothing was drawn) and
// the surface's world-space normal. Opaque variants label every fragment
// that passes the depth test; masked ones first cut out what their alpha
// cuts out, as shading did.

#include "mesh/vertex_stage.wgsl"
#include "mesh/label_values.wgsl"

@fragment
fn fs_labels(io: MeshIo, @builtin(front_facing) front_facing: bool) -> Labels {
    let mesh = unpack_varying(io);
    return labels_of(mesh, front_facing);
}

@fragment
fn fs_labels_masked(io: MeshIo, @builtin(front_facing) front_facing: bool) -> Labels {
    let mesh = unpack_varying(io);
    // Derivatives first, in uniform control flow, as the shading pass takes them.
    let d = uv_derivatives_of(mesh);
    let material = material_of(mesh);
    if base_color_of(mesh, material, d).a < material.alpha_cutoff {
        discard;
    }
    return labels_of(mesh, front_facing);
}
