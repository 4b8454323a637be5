//! glTF import without a GPU: what comes in, what is refused (clearly), and
//! the prepared frame of a real file.

mod support;

use std::path::PathBuf;

use oxygen::bindless::SlotAllocators;
use oxygen::core::{AlphaMode, Scene, ViewContext, ViewId, ViewResolver};
use oxygen::prelude::*;
use oxygen::sceneprep::{ScenePrep, ViewRequest};
use oxygen::{GltfError, import_gltf};
use support::encode::base64_encode;

fn asset(relative: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets").join(relative)
}

#[test]
fn alpha_blend_mode_test_imports_every_alpha_mode_and_its_cutoffs() {
    let mut scene = Scene::new();
    let import =
        import_gltf(&mut scene, asset("AlphaBlendModeTest/AlphaBlendModeTest.glb"), &SceneChoice::Default).unwrap();
    assert_eq!(import.renderables, 9);
    let modes: Vec<AlphaMode> = scene.materials().map(|(_, m)| m.alpha_mode).collect();
    assert!(modes.contains(&AlphaMode::Opaque));
    assert!(modes.contains(&AlphaMode::Blend));
    for cutoff in [0.25, 0.5, 0.75] {
        assert!(modes.contains(&AlphaMode::Mask { cutoff }), "cutoff {cutoff} missing from {modes:?}");
    }
    assert!(scene.materials().any(|(_, m)| m.base_color_texture.is_some()));
}

#[test]
fn cubes_brings_its_punctual_light_and_cameras_become_resolvers() {
    let mut scene = Scene::new();
    let cubes = import_gltf(&mut scene, asset("Cubes/Cubes.glb"), &SceneChoice::Default).unwrap();
    assert_eq!(cubes.lights, 1);
    let mut scene = Scene::new();
    let cameras = import_gltf(&mut scene, asset("Cameras/Cameras.gltf"), &SceneChoice::Default).unwrap();
    assert_eq!(cameras.cameras.len(), 2);
    for camera in &cameras.cameras {
        let ctx = ViewContext { view_id: ViewId(0), frame_index: 1, time_seconds: 0.0 };
        let view = camera.resolver(UVec2::new(64, 48)).resolve(&ctx, &scene).unwrap();
        assert!(view.view_projection.is_finite());
    }
}

#[test]
fn missing_normals_are_generated_and_missing_indices_synthesized() {
    for file in ["Triangle/Triangle.gltf", "TriangleWithoutIndices/TriangleWithoutIndices.gltf"] {
        let mut scene = Scene::new();
        let import = import_gltf(&mut scene, asset(file), &SceneChoice::Default).unwrap();
        assert!(import.warnings.iter().any(|w| w.contains("normals generated")), "{file}: {:?}", import.warnings);
        let (_, node) = scene.nodes().find(|(_, n)| n.renderable.is_some()).unwrap();
        let geometry = scene.geometry(node.renderable.as_ref().unwrap().geometry).unwrap();
        assert_eq!(geometry.indices().len(), 3);
        // The triangle lies in z = 0 and winds counter-clockwise: its normal is +Z.
        assert!(geometry.vertices().iter().all(|v| (Vec3::from(v.normal) - Vec3::Z).length() < 1e-5));
    }
}

#[test]
fn a_missing_file_is_an_error_naming_it() {
    let err = import_gltf(&mut Scene::new(), asset("nope/missing.glb"), &SceneChoice::Default).unwrap_err();
    assert!(matches!(err, GltfError::Load { .. }));
    assert!(err.to_string().contains("missing.glb"), "{err}");
}

#[test]
fn a_malformed_file_is_an_error_naming_it_not_a_panic() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let path = dir.join("malformed.gltf");
    std::fs::write(&path, b"{ \"asset\": { \"version\": \"2.0\" }, \"meshes\": [ { \"primitives\": [ { \"attributes\": { \"POSITION\": 7 } } ] } ] }").unwrap();
    let err = import_gltf(&mut Scene::new(), &path, &SceneChoice::Default).unwrap_err();
    assert!(err.to_string().contains("malformed.gltf"), "{err}");
    std::fs::write(&path, b"this is not json").unwrap();
    let err = import_gltf(&mut Scene::new(), &path, &SceneChoice::Default).unwrap_err();
    assert!(err.to_string().contains("malformed.gltf"), "{err}");
}

#[test]
fn a_primitive_that_is_not_triangles_is_skipped_with_a_warning() {
    // One point primitive and one triangle primitive over the same three vertices.
    let positions: Vec<u8> = [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
        .iter()
        .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()))
        .collect();
    let uri = format!("data:application/octet-stream;base64,{}", base64_encode(&positions));
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"mode":0}},{{"attributes":{{"POSITION":0}}}}]}}],
        "buffers":[{{"byteLength":36,"uri":"{uri}"}}],"bufferViews":[{{"buffer":0,"byteLength":36}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}]}}"#
    );
    let path = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("points_and_triangles.gltf");
    std::fs::write(&path, json).unwrap();
    let mut scene = Scene::new();
    let import = import_gltf(&mut scene, &path, &SceneChoice::Default).unwrap();
    assert_eq!(import.renderables, 1);
    assert!(import.warnings.iter().any(|w| w.contains("Points")), "{:?}", import.warnings);
}

#[test]
fn a_scene_that_does_not_exist_lists_the_ones_that_do() {
    let err = import_gltf(&mut Scene::new(), asset("Cubes/Cubes.glb"), &SceneChoice::Name("nope".into())).unwrap_err();
    assert!(matches!(err, GltfError::NoSuchScene { .. }));
    assert!(err.to_string().contains("Cubes.glb") && err.to_string().contains("0 ("), "{err}");
}

#[test]
fn alpha_blend_mode_test_prepared_frame_dump() {
    let mut scene = Scene::new();
    import_gltf(&mut scene, asset("AlphaBlendModeTest/AlphaBlendModeTest.glb"), &SceneChoice::Default).unwrap();
    let camera = LookAtResolver {
        camera: Camera::perspective(45f32.to_radians(), 0.05, None),
        eye: Vec3::new(0.0, 2.0, 9.0),
        target: Vec3::new(0.0, 1.0, 0.0),
        up: Vec3::Y,
        viewport: UVec2::new(320, 240),
    };
    let view = camera.resolve(&ViewContext { view_id: ViewId(0), frame_index: 1, time_seconds: 0.0 }, &scene).unwrap();
    let mut prep = ScenePrep::new();
    let frames = prep
        .prepare(&scene, &[ViewRequest { view: &view, options: Default::default() }], &mut SlotAllocators::default())
        .unwrap();
    insta::assert_snapshot!(frames[0].dump());
}
