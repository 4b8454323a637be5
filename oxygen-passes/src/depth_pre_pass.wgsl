// Depth pre-pass. The opaque variants have no fragment stage; the masked
// variants discard fragments whose alpha is below the material's cutoff.

@fragment
fn fs_alpha_test(mesh: MeshVarying) {
    let material = material_of(mesh);
    if base_color_of(mesh, material).a < material.alpha_cutoff {
        discard;
    }
}
