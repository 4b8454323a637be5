//! The WGSL twin of `SceneConstants` must have the Rust layout: parse it with
//! naga and compare every member offset and the struct size.

use std::mem::{offset_of, size_of};

use oxygen_bindless::{CameraConstants, RendererConstants, SCENE_CONSTANTS_WGSL, SceneConstants};

fn members(module: &naga::Module, name: &str) -> (Vec<(String, u32)>, u32) {
    let ty = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("struct {name} not in WGSL"))
        .1;
    match &ty.inner {
        naga::TypeInner::Struct { members, span } => {
            (members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset)).collect(), *span)
        }
        other => panic!("{name} is not a struct: {other:?}"),
    }
}

#[test]
fn scene_constants_wgsl_matches_rust_layout() {
    let module = naga::front::wgsl::parse_str(SCENE_CONSTANTS_WGSL).expect("SCENE_CONSTANTS_WGSL parses");

    let (camera, camera_size) = members(&module, "CameraConstants");
    assert_eq!(camera_size as usize, size_of::<CameraConstants>());
    let expected_camera = [
        ("view", offset_of!(CameraConstants, view)),
        ("projection", offset_of!(CameraConstants, projection)),
        ("view_projection", offset_of!(CameraConstants, view_projection)),
        ("inverse_view_projection", offset_of!(CameraConstants, inverse_view_projection)),
        ("camera_position", offset_of!(CameraConstants, camera_position)),
    ];
    assert_eq!(camera, expected_camera.map(|(n, o)| (n.to_owned(), o as u32)).to_vec());

    let (renderer, renderer_size) = members(&module, "RendererConstants");
    assert_eq!(renderer_size as usize, size_of::<RendererConstants>());
    let expected_renderer = [
        ("frame_sequence", offset_of!(RendererConstants, frame_sequence)),
        ("time_seconds_bits", offset_of!(RendererConstants, time_seconds_bits)),
        ("draw_metadata_slot", offset_of!(RendererConstants, draw_metadata_slot)),
        ("draw_count", offset_of!(RendererConstants, draw_count)),
        ("world_transforms_slot", offset_of!(RendererConstants, world_transforms_slot)),
        ("normal_transforms_slot", offset_of!(RendererConstants, normal_transforms_slot)),
        ("materials_slot", offset_of!(RendererConstants, materials_slot)),
        ("directional_lights_slot", offset_of!(RendererConstants, directional_lights_slot)),
        ("directional_light_count", offset_of!(RendererConstants, directional_light_count)),
        ("positional_lights_slot", offset_of!(RendererConstants, positional_lights_slot)),
        ("positional_light_count", offset_of!(RendererConstants, positional_light_count)),
        ("debug_flags", offset_of!(RendererConstants, debug_flags)),
        ("draw_metadata_generation", offset_of!(RendererConstants, draw_metadata_generation)),
        ("reserved0", offset_of!(RendererConstants, reserved)),
        ("reserved1", offset_of!(RendererConstants, reserved) + 4),
        ("reserved2", offset_of!(RendererConstants, reserved) + 8),
    ];
    assert_eq!(renderer, expected_renderer.map(|(n, o)| (n.to_owned(), o as u32)).to_vec());

    let (scene, scene_size) = members(&module, "SceneConstants");
    assert_eq!(scene_size as usize, size_of::<SceneConstants>());
    assert_eq!(scene[1], ("renderer".to_owned(), offset_of!(SceneConstants, renderer) as u32));
}
