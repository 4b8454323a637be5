// Depth pre-pass. The opaque variants have no fragment stage; the masked
// variants discard fragments whose alpha is below the material's cutoff.

@fragment
fn fs_alpha_test(mesh: MeshVarying) {
    // Derivatives first, in uniform control flow, as in the shading pass so
    // both passes test the same mip level's alpha.
    let duv_dx = dpdx(mesh.uv);
    let duv_dy = dpdy(mesh.uv);
    let material = material_of(mesh);
    if base_color_of(mesh, material, duv_dx, duv_dy).a < material.alpha_cutoff {
        discard;
    }
}
