//! Every pass shader parses and validates with naga, without a GPU, so a
//! WGSL mistake fails here with a readable message rather than at pipeline
//! creation on some device.

use oxygen_passes::PassKind;

#[test]
fn every_pass_shader_validates() {
    for pass in [PassKind::DepthPrePass, PassKind::Shading, PassKind::ShadingAfterPrePass] {
        let source = oxygen_passes::shader_source(pass);
        let module = naga::front::wgsl::parse_str(&source)
            .unwrap_or_else(|e| panic!("{pass:?} WGSL does not parse:\n{}", e.emit_to_string(&source)));
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default())
            .validate(&module)
            .unwrap_or_else(|e| panic!("{pass:?} WGSL does not validate: {e:?}"));
    }
}
