//! Every pass shader parses and validates with naga, without a GPU, so a
//! WGSL mistake fails here with a readable message rather than at pipeline
//! creation on some device.

use oxygen_bindless::TexturePath;
use oxygen_passes::PassKind;

#[test]
fn every_pass_shader_validates_on_both_texture_paths() {
    for (pass, textures) in [PassKind::DepthPrePass, PassKind::Shading, PassKind::ShadingAfterPrePass]
        .into_iter()
        .flat_map(|p| [(p, TexturePath::BindingArray), (p, TexturePath::GroupedArrays)])
    {
        let source = oxygen_passes::shader_source(pass, textures);
        let module = naga::front::wgsl::parse_str(&source)
            .unwrap_or_else(|e| panic!("{pass:?} WGSL does not parse:\n{}", e.emit_to_string(&source)));
        // The binding-array path needs exactly the capabilities its device features grant.
        let capabilities = match textures {
            TexturePath::BindingArray => {
                naga::valid::Capabilities::TEXTURE_AND_SAMPLER_BINDING_ARRAY
                    | naga::valid::Capabilities::TEXTURE_AND_SAMPLER_BINDING_ARRAY_NON_UNIFORM_INDEXING
            }
            TexturePath::GroupedArrays => naga::valid::Capabilities::default(),
        };
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities)
            .validate(&module)
            .unwrap_or_else(|e| panic!("{pass:?} / {textures:?} WGSL does not validate: {e:?}"));
    }
}

#[test]
fn the_tonemap_shader_validates() {
    let module = naga::front::wgsl::parse_str(oxygen_passes::TONEMAP_WGSL)
        .unwrap_or_else(|e| panic!("tonemap WGSL does not parse:\n{}", e.emit_to_string(oxygen_passes::TONEMAP_WGSL)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default())
        .validate(&module)
        .unwrap_or_else(|e| panic!("tonemap WGSL does not validate: {e:?}"));
}
