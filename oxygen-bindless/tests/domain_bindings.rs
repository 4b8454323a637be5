//! The domains' WGSL declarations are the contract every shader reads
//! through: each bound domain at its own binding, under its name, as an
//! array of its record type; index and indirect-argument domains unbound.

use oxygen_bindless::DomainKind;

/// The binding table, written out: changing it is an interface change.
const EXPECTED: &[(DomainKind, Option<u32>, &str, &str)] = &[
    (DomainKind::DrawMetadata, Some(0), "draw_metadata_domain", "DrawMetadata"),
    (DomainKind::WorldTransforms, Some(1), "world_transform_domain", "mat4x4<f32>"),
    (DomainKind::NormalTransforms, Some(2), "normal_transform_domain", "NormalMatrix"),
    (DomainKind::Materials, Some(3), "material_domain", "MaterialRecord"),
    (DomainKind::DirectionalLights, Some(4), "directional_light_domain", "DirectionalLightRecord"),
    (DomainKind::PositionalLights, Some(5), "positional_light_domain", "PositionalLightRecord"),
    (DomainKind::Vertices, Some(6), "vertex_domain", "VertexRecord"),
    (DomainKind::Indices, None, "index_domain", "u32"),
    (DomainKind::IndirectArgs, None, "indirect_args_domain", "u32"),
    (DomainKind::TextureLocations, Some(9), "texture_location_domain", "u32"),
    (DomainKind::BvhNodes, Some(10), "bvh_node_domain", "BvhNode"),
    (DomainKind::RayWords, Some(11), "ray_word_domain", "u32"),
    (DomainKind::RayInstances, Some(12), "ray_instance_domain", "RayInstance"),
];

#[test]
fn every_domain_has_its_binding_name_and_record_type() {
    assert_eq!(EXPECTED.len(), DomainKind::COUNT);
    for (kind, binding, name, ty) in EXPECTED {
        assert_eq!(kind.binding(), *binding, "{kind:?}");
        assert_eq!(kind.wgsl(), (*name, *ty), "{kind:?}");
    }
}

#[test]
fn the_generated_declarations_parse_and_declare_each_bound_domain() {
    // The record structs are declared by the including shader; stand-ins do here.
    let stand_ins: String = [
        "DrawMetadata",
        "NormalMatrix",
        "MaterialRecord",
        "DirectionalLightRecord",
        "PositionalLightRecord",
        "VertexRecord",
        "BvhNode",
        "RayInstance",
    ]
    .iter()
    .map(|s| format!("struct {s} {{ x: u32 }}\n"))
    .collect();
    let source = format!("{stand_ins}{}", DomainKind::wgsl_bindings());
    let module = naga::front::wgsl::parse_str(&source).expect("the domain declarations parse");
    let mut declared: Vec<(u32, String)> = module
        .global_variables
        .iter()
        .filter_map(|(_, v)| Some((v.binding.as_ref()?.binding, v.name.clone()?)))
        .collect();
    declared.sort();
    let expected: Vec<(u32, String)> =
        EXPECTED.iter().filter_map(|(_, b, name, _)| Some((b.as_ref().copied()?, (*name).to_owned()))).collect();
    assert_eq!(declared, expected);
    for (_, binding, name, ty) in EXPECTED.iter().filter(|e| e.1.is_some()) {
        let line = format!("@group(0) @binding({}) var<storage, read> {name}: array<{ty}>;", binding.unwrap_or(0));
        assert!(source.contains(&line), "missing: {line}");
    }
}
