// Depth pre-pass. The opaque variants have no fragment stage; the masked
// variants discard fragments whose alpha is below the material's cutoff.

#include "mesh/vertex_stage.wgsl"

@fragment
fn fs_alpha_test(io: MeshIo) {
    let mesh = unpack_varying(io);
    // Derivatives first, in uniform control flow, as in the shading pass so
    // both passes test the same mip level's alpha.
    let d = uv_derivatives_of(mesh);
    let material = material_of(mesh);
    if base_color_of(mesh, material, d).a < material.alpha_cutoff {
        discard;
    }
}
