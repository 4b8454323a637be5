// What a pixel's labels hold, shared by the labels pass (mesh/labels.wgsl)
// and the shading pass that writes them alongside the colour
// (fs_opaque_labelled, fs_masked_labelled in mesh/forward_lit.wgsl). Every
// plane is always written; a pipeline whose view asked for fewer planes has
// no target at the others' locations, and their values go nowhere.

struct Labels {
    @location(0) instance: u32,
    @location(1) normal: vec4<f32>,
    @location(2) semantic_class: u32,
    // The bits of an f32 (the plane is R32Uint: renderable on every backend).
    @location(3) linear_depth: u32,
}

// Which planes the pipeline's view draws (pipelines/key.rs sets them from
// its LabelSet): a plane not drawn has no target, and its value is not
// computed either (an H200 spent a third of the label planes' cost, 0.7 ms
// of a 1 024-camera frame, on values no target kept).
override LABEL_INSTANCE: bool = true;
override LABEL_NORMAL: bool = true;
override LABEL_SEMANTIC: bool = true;
override LABEL_LINEAR_DEPTH: bool = true;

// The node that drew the pixel (its stable id plus one: 0 is nothing), the
// surface's world-space normal, the node's semantic class and the
// surface's distance from the camera's plane along its view direction.
// Only double-sided surfaces show back faces (the others are culled):
// their normal faces the camera, as shading lights them.
fn labels_of(mesh: MeshVarying, front_facing: bool) -> Labels {
    var labels = Labels(0u, vec4<f32>(0.0), 0u, 0u);
    // The node and its class come from the draw (the class in the padding
    // lane of the node's normal record), not from varyings: see MeshVarying.
    if LABEL_INSTANCE || LABEL_SEMANTIC {
        let draw = draw_of(mesh);
        if LABEL_INSTANCE {
            labels.instance = draw.node_id + 1u;
        }
        if LABEL_SEMANTIC {
            labels.semantic_class = normal_transform_domain[scene.renderer.normal_transforms_slot + draw.transform_index].semantic_class;
        }
    }
    if LABEL_NORMAL {
        var n = normalize(mesh.world_normal);
        if !front_facing {
            n = -n;
        }
        labels.normal = vec4<f32>(n, 1.0);
    }
    if LABEL_LINEAR_DEPTH {
        // The camera looks down its view space's −z.
        let linear_depth = -(scene.camera.view * vec4<f32>(mesh.world_position, 1.0)).z;
        labels.linear_depth = bitcast<u32>(linear_depth);
    }
    return labels;
}
