//! The WGSL twin of `LightingInputs` (in the shading pass's shader) has the
//! Rust layout: the assembled shader parsed with naga, every member offset
//! and the struct size compared with `offset_of!` and `size_of`.

use std::mem::{offset_of, size_of};

use oxygen_bindless::TexturePath;
use oxygen_passes::testing::{LightingInputs, MAX_PROBES, MAX_SHADOW_TILES};
use oxygen_passes::{MAX_CASCADES, PassKind};

/// (name, offset) of each member of struct `name`, and its size.
fn layout(module: &naga::Module, name: &str) -> (Vec<(String, u32)>, u32) {
    let (_, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("struct {name} not in the shading pass's WGSL"));
    match &ty.inner {
        naga::TypeInner::Struct { members, span } => {
            (members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset)).collect(), *span)
        }
        other => panic!("{name} is not a struct: {other:?}"),
    }
}

/// Element count and stride of array member `member` of struct `name`.
fn array_shape(module: &naga::Module, name: &str, member: &str) -> (u32, u32) {
    let (_, ty) = module.types.iter().find(|(_, t)| t.name.as_deref() == Some(name)).expect("struct present");
    let naga::TypeInner::Struct { members, .. } = &ty.inner else { panic!("{name} is not a struct") };
    let m = members.iter().find(|m| m.name.as_deref() == Some(member)).unwrap_or_else(|| panic!("{member} missing"));
    match module.types[m.ty].inner {
        naga::TypeInner::Array { size: naga::ArraySize::Constant(count), stride, .. } => (count.get(), stride),
        ref other => panic!("{name}.{member} is not a fixed-size array: {other:?}"),
    }
}

#[test]
fn lighting_inputs_wgsl_matches_rust_layout() {
    let source = oxygen_passes::testing::shader_source(PassKind::Shading, TexturePath::GroupedArrays);
    let module = naga::front::wgsl::parse_str(&source)
        .unwrap_or_else(|e| panic!("the shading WGSL does not parse:\n{}", e.emit_to_string(&source)));
    let (members, span) = layout(&module, "LightingInputs");
    assert_eq!(span as usize, size_of::<LightingInputs>(), "size of LightingInputs");
    let expected = [
        ("light_view_projection", offset_of!(LightingInputs, light_view_projection)),
        ("texel_world_size", offset_of!(LightingInputs, texel_world_size)),
        ("uv_texel", offset_of!(LightingInputs, uv_texel)),
        ("count", offset_of!(LightingInputs, count)),
        ("pcf_radius", offset_of!(LightingInputs, pcf_radius)),
        ("normal_offset", offset_of!(LightingInputs, normal_offset)),
        ("padding", offset_of!(LightingInputs, padding)),
        ("probe_positions", offset_of!(LightingInputs, probe_positions)),
        ("tile_view_projection", offset_of!(LightingInputs, tile_view_projection)),
        ("tile_texel_angle", offset_of!(LightingInputs, tile_texel_angle)),
        ("tile_count", offset_of!(LightingInputs, tile_count)),
        ("probe_count", offset_of!(LightingInputs, probe_count)),
        ("environment_levels", offset_of!(LightingInputs, environment_levels)),
        ("reserved", offset_of!(LightingInputs, reserved)),
    ];
    assert_eq!(members, expected.map(|(n, o)| (n.to_owned(), o as u32)).to_vec());

    // The arrays hold as many elements as the Rust ones, at the Rust stride.
    assert_eq!(array_shape(&module, "LightingInputs", "light_view_projection"), (MAX_CASCADES as u32, 64));
    assert_eq!(array_shape(&module, "LightingInputs", "probe_positions"), (MAX_PROBES as u32, 16));
    assert_eq!(array_shape(&module, "LightingInputs", "tile_view_projection"), (MAX_SHADOW_TILES as u32, 64));
    // Four tile floats per vec4: a uniform array's stride is 16 bytes.
    assert_eq!(array_shape(&module, "LightingInputs", "tile_texel_angle"), (MAX_SHADOW_TILES as u32 / 4, 16));
}
