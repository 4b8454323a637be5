// What a pixel's labels hold, shared by the labels pass (mesh/labels.wgsl)
// and the shading pass that writes them alongside the colour
// (fs_opaque_labelled, fs_masked_labelled in mesh/forward_lit.wgsl).

struct Labels {
    @location(0) instance: u32,
    @location(1) normal: vec4<f32>,
}

// The node that drew the pixel (its stable id plus one: 0 is nothing) and
// the surface's world-space normal. Only double-sided surfaces show back
// faces (the others are culled): their normal faces the camera, as
// shading lights them.
fn labels_of(mesh: MeshVarying, front_facing: bool) -> Labels {
    var n = normalize(mesh.world_normal);
    if !front_facing {
        n = -n;
    }
    return Labels(mesh.node + 1u, vec4<f32>(n, 1.0));
}
