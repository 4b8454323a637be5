// Per-pixel labels, drawn after shading over the same depth: which node
// drew each pixel (its stable id plus one; 0 where nothing was drawn) and
// the surface's world-space normal. Opaque variants label every fragment
// that passes the depth test; masked ones first cut out what their alpha
// cuts out, as shading did.

#include "mesh/mesh_vertex.wgsl"

struct Labels {
    @location(0) instance: u32,
    @location(1) normal: vec4<f32>,
}

fn labels_of(mesh: MeshVarying, front_facing: bool) -> Labels {
    // Only double-sided surfaces show back faces (the others are culled):
    // their normal faces the camera, as shading lights them.
    var n = normalize(mesh.world_normal);
    if !front_facing {
        n = -n;
    }
    return Labels(mesh.node + 1u, vec4<f32>(n, 1.0));
}

@fragment
fn fs_labels(mesh: MeshVarying, @builtin(front_facing) front_facing: bool) -> Labels {
    return labels_of(mesh, front_facing);
}

@fragment
fn fs_labels_masked(mesh: MeshVarying, @builtin(front_facing) front_facing: bool) -> Labels {
    // Derivatives first, in uniform control flow, as the shading pass takes them.
    let d = uv_derivatives_of(mesh);
    let material = material_of(mesh);
    if base_color_of(mesh, material, d).a < material.alpha_cutoff {
        discard;
    }
    return labels_of(mesh, front_facing);
}
