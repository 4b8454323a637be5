//! Every GPU record's WGSL twin in `GPU_RECORDS_WGSL` has the Rust layout:
//! parsed with naga, member offsets and struct sizes compared.

use std::mem::{offset_of, size_of};

use oxygen_core::Vertex;
use oxygen_sceneprep::{DirectionalLightRecord, DrawMetadata, GPU_RECORDS_WGSL, MaterialRecord, PositionalLightRecord};

fn layout(module: &naga::Module, name: &str) -> (Vec<(String, u32)>, u32) {
    let (_, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("{name} missing from GPU_RECORDS_WGSL"));
    match &ty.inner {
        naga::TypeInner::Struct { members, span } => {
            (members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset)).collect(), *span)
        }
        other => panic!("{name} is not a struct: {other:?}"),
    }
}

fn offset(members: &[(String, u32)], name: &str) -> u32 {
    members.iter().find(|(n, _)| n == name).unwrap_or_else(|| panic!("member {name} missing")).1
}

macro_rules! check {
    ($module:expr, $ty:ty, $wgsl:literal, [$($field:ident),*]) => {{
        let (members, span) = layout(&$module, $wgsl);
        assert_eq!(span as usize, size_of::<$ty>(), "size of {}", $wgsl);
        $( assert_eq!(offset(&members, stringify!($field)) as usize, offset_of!($ty, $field), "{}.{}", $wgsl, stringify!($field)); )*
    }};
}

#[test]
fn gpu_records_wgsl_matches_rust_layouts() {
    let module = naga::front::wgsl::parse_str(GPU_RECORDS_WGSL).expect("GPU_RECORDS_WGSL parses");
    check!(
        module,
        DrawMetadata,
        "DrawMetadata",
        [
            vertex_slot,
            index_slot,
            first_index,
            index_count,
            base_vertex,
            instance_count,
            transform_index,
            material_handle,
            pass_mask,
            node_id,
            submesh
        ]
    );
    let (members, _) = layout(&module, "DrawMetadata");
    assert_eq!(offset(&members, "generation") as usize, offset_of!(DrawMetadata, generation));
    assert_eq!(offset(&members, "attributes_slot") as usize, offset_of!(DrawMetadata, attributes_slot));
    assert_eq!(offset(&members, "skin_slot") as usize, offset_of!(DrawMetadata, skin_slot));
    assert_eq!(offset(&members, "joint_base") as usize, offset_of!(DrawMetadata, joint_base));
    assert_eq!(offset(&members, "morph_base") as usize, offset_of!(DrawMetadata, morph_base));
    check!(
        module,
        MaterialRecord,
        "MaterialRecord",
        [
            base_color,
            emissive,
            normal_scale,
            metallic,
            roughness,
            alpha_cutoff,
            flags,
            base_color_texture,
            metallic_roughness_texture,
            normal_texture,
            emissive_texture,
            occlusion_texture,
            occlusion_strength,
            uv_transforms
        ]
    );
    check!(module, oxygen_sceneprep::UvTransformRecord, "UvTransformRecord", [row0, uv_set, row1]);
    check!(module, DirectionalLightRecord, "DirectionalLightRecord", [direction, intensity, color, flags, shadow_slot]);
    check!(
        module,
        PositionalLightRecord,
        "PositionalLightRecord",
        [position, range, direction, intensity, color, kind, cos_inner, cos_outer, flags, shadow_slot]
    );
    let (members, span) = layout(&module, "VertexRecord");
    assert_eq!(span as usize, size_of::<Vertex>());
    assert_eq!(offset(&members, "nx") as usize, offset_of!(Vertex, normal));
    assert_eq!(offset(&members, "u") as usize, offset_of!(Vertex, uv));
    // The path-traced reference's ray scene.
    check!(module, oxygen_sceneprep::ray::BvhNode, "BvhNode", [min, first, max, count]);
    check!(
        module,
        oxygen_sceneprep::RayInstance,
        "RayInstance",
        [transform_index, blas_root, vertex_slot, index_slot, submesh_first, submesh_count, attributes_slot]
    );
    let (members, _) = layout(&module, "RayInstance");
    assert_eq!(offset(&members, "inverse_row0") as usize, offset_of!(oxygen_sceneprep::RayInstance, inverse_rows));
}
