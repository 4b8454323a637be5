//! glTF import without a GPU: what comes in, what is refused (clearly), and
//! the prepared frame of a real file.

mod support;

use std::path::PathBuf;

use oxygen::bindless::SlotAllocators;
use oxygen::core::{AlphaMode, NodeKey, Scene, ViewContext, ViewIds, ViewResolver};
use oxygen::import::{GltfError, ImportOptions, import_gltf};
use oxygen::prelude::*;
use oxygen::sceneprep::{ScenePrep, ViewRequest};
use support::encode::{base64_encode, data_uri, png_chunk};

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
        let ctx = ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 };
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

/// A scene is chosen by its index, the first as well as the last; an index
/// one past the last is refused with the scenes listed, not read past the
/// list.
#[test]
fn a_scene_is_chosen_by_index_and_one_past_the_last_is_refused() {
    let json = r#"{"asset":{"version":"2.0"},"scenes":[{"name":"day","nodes":[0]},{"name":"night","nodes":[1]}],
        "nodes":[{"name":"Sun"},{"name":"Moon"}]}"#;
    let import = |index| {
        let options = ImportOptions { scene: SceneChoice::Index(index), ..ImportOptions::default() };
        oxygen::import::import_gltf_slice(&mut Scene::new(), json.as_bytes(), "sky.gltf", &options)
    };
    for (index, present, absent) in [(0, "Sun", "Moon"), (1, "Moon", "Sun")] {
        let chosen = import(index).unwrap_or_else(|e| panic!("scene {index}: {e}"));
        assert!(chosen.node(present).is_some() && chosen.node(absent).is_none(), "scene {index}");
    }
    let err = import(2).unwrap_err();
    assert!(matches!(err, GltfError::NoSuchScene { .. }), "{err}");
    assert!(err.to_string().contains("0 (day), 1 (night)"), "{err}");
}

/// KHR_lights_punctual: each light reaches its node with its own kind,
/// colour and intensity (none of them the white directional light a
/// `Light` starts from).
#[test]
fn punctual_lights_keep_their_kind_colour_and_intensity() {
    let json = r#"{"asset":{"version":"2.0"},"extensionsUsed":["KHR_lights_punctual"],
        "extensions":{"KHR_lights_punctual":{"lights":[
            {"type":"point","color":[1,0.5,0.25],"intensity":3,"range":7},
            {"type":"spot","color":[0,0.5,1],"intensity":40,"spot":{"innerConeAngle":0.25,"outerConeAngle":0.5}}]}},
        "scene":0,"scenes":[{"nodes":[0,1]}],
        "nodes":[{"name":"Bulb","extensions":{"KHR_lights_punctual":{"light":0}}},
                 {"name":"Torch","extensions":{"KHR_lights_punctual":{"light":1}}}]}"#;
    let mut scene = Scene::new();
    let import =
        oxygen::import::import_gltf_slice(&mut scene, json.as_bytes(), "lights.gltf", &ImportOptions::default())
            .unwrap();
    assert_eq!(import.lights, 2);
    let light = |name| scene.node(import.node(name).unwrap()).unwrap().light.clone().unwrap();
    assert_eq!(light("Bulb"), Light { color: Vec3::new(1.0, 0.5, 0.25), ..Light::point(3.0, Some(7.0)) });
    assert_eq!(light("Torch"), Light { color: Vec3::new(0.0, 0.5, 1.0), ..Light::spot(40.0, None, 0.25, 0.5) });
}

#[test]
fn alpha_blend_mode_test_prepared_frame_dump() {
    let mut scene = Scene::new();
    import_gltf(&mut scene, asset("AlphaBlendModeTest/AlphaBlendModeTest.glb"), &SceneChoice::Default).unwrap();
    let camera = support::model_camera(Vec3::new(0.0, 2.0, 9.0), Vec3::new(0.0, 1.0, 0.0), UVec2::new(320, 240));
    let view = camera
        .resolve(&ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 }, &scene)
        .unwrap();
    let mut prep = ScenePrep::new();
    let frames = prep
        .prepare(&scene, &[ViewRequest { view: &view, options: Default::default() }], &mut SlotAllocators::default())
        .unwrap();
    insta::assert_snapshot!(frames[0].dump());
}

#[test]
fn nodes_are_found_by_the_name_the_file_gives_them() {
    let mut scene = Scene::new();
    let import =
        import_gltf(&mut scene, asset("AlphaBlendModeTest/AlphaBlendModeTest.glb"), &SceneChoice::Default).unwrap();
    let key = import.node("TestBlend").expect("AlphaBlendModeTest has a node called TestBlend");
    let node = scene.node(key).unwrap();
    assert_eq!(node.name, "TestBlend");
    assert!(node.renderable.is_some());
    assert_eq!(import.nodes_named("TestBlend").collect::<Vec<_>>(), vec![key]);
    assert_eq!(import.node("NoSuchNode"), None);
    assert_eq!(import.nodes_named("NoSuchNode").count(), 0);
}

#[test]
fn duplicate_node_names_resolve_to_the_first_in_the_file_not_the_first_walked() {
    // File node 0 is a root listed after node 2, whose child is node 1: the
    // walk meets node 1 before node 0, the file lists node 0 first. Node 3 has
    // no name and must not answer to the "node 3" it is given in the scene.
    let json = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[2,0,3]}],
        "nodes":[{"name":"Lamp"},{"name":"Lamp"},{"name":"Rig","children":[1]},{}]}"#;
    let mut scene = Scene::new();
    let import =
        oxygen::import::import_gltf_slice(&mut scene, json.as_bytes(), "lamps.gltf", &ImportOptions::default())
            .unwrap();
    let lamps: Vec<NodeKey> = import.nodes_named("Lamp").collect();
    assert_eq!(lamps.len(), 2);
    assert_eq!(import.node("Lamp"), Some(lamps[0]));
    assert_eq!(scene.node(lamps[0]).unwrap().parent, None, "file node 0 is a root");
    assert_eq!(scene.node(lamps[1]).unwrap().parent, import.node("Rig"), "file node 1 is Rig's child");
    assert_eq!(import.node("node 3"), None);
}

#[test]
fn cameras_are_found_by_name() {
    let json = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1]}],
        "nodes":[{"name":"Tripod","camera":0},{"name":"Crane","camera":1}],
        "cameras":[{"name":"Wide","type":"perspective","perspective":{"yfov":1.2,"znear":0.1}},
                   {"type":"orthographic","orthographic":{"xmag":2,"ymag":1,"znear":0,"zfar":10}}]}"#;
    let mut scene = Scene::new();
    let import =
        oxygen::import::import_gltf_slice(&mut scene, json.as_bytes(), "cameras.gltf", &ImportOptions::default())
            .unwrap();
    let wide = import.camera("Wide").expect("the camera's own name");
    assert_eq!(Some(wide.node), import.node("Tripod"));
    let crane = import.camera("Crane").expect("an unnamed camera answers to its node's name");
    assert_eq!(Some(crane.node), import.node("Crane"));
    assert!(import.camera("Tripod").is_none(), "a named camera does not answer to its node's name");
}

/// A camera's aspect ratio is a perspective camera's own, an orthographic
/// one's `xmag / ymag` (3 / 2 here, where a product or a remainder differs).
/// One that is zero, negative or not finite (1e39 reads as infinity) is
/// dropped, so a view through the camera takes its viewport's, and the
/// camera is imported without a warning: it renders.
#[test]
fn a_cameras_aspect_ratio_is_kept_when_positive_and_finite_and_dropped_quietly_otherwise() {
    use serde_json::json;
    let perspective =
        |aspect: f64| json!({"type": "perspective", "perspective": {"yfov": 1, "znear": 0.1, "aspectRatio": aspect}});
    let orthographic =
        |xmag: f64| json!({"type": "orthographic", "orthographic": {"xmag": xmag, "ymag": 2, "znear": 0, "zfar": 10}});
    let cases = [
        (perspective(1.5), Some(1.5)),
        (perspective(0.0), None),
        (perspective(-2.0), None),
        (perspective(1e39), None),
        (orthographic(3.0), Some(1.5)),
        (orthographic(0.0), None),
        (orthographic(-3.0), None),
    ];
    let json = serde_json::to_vec(&json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": (0..cases.len()).collect::<Vec<_>>()}],
        "nodes": (0..cases.len()).map(|i| json!({"name": format!("c{i}"), "camera": i})).collect::<Vec<_>>(),
        "cameras": cases.iter().map(|(c, _)| c.clone()).collect::<Vec<_>>(),
    }))
    .unwrap();
    let mut scene = Scene::new();
    let import =
        oxygen::import::import_gltf_slice(&mut scene, &json, "aspects.gltf", &ImportOptions::default()).unwrap();
    for (i, (camera, expected)) in cases.iter().enumerate() {
        let imported = import.camera(&format!("c{i}")).expect("every camera is imported");
        assert_eq!(imported.aspect_ratio, *expected, "{camera}");
    }
    assert!(import.warnings.is_empty(), "{:?}", import.warnings);
}

/// A triangle whose material's base-colour texture is `png`, all in `data:`
/// URIs.
fn textured_triangle(png: &[u8]) -> String {
    let positions: Vec<u8> = [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
        .iter()
        .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()))
        .collect();
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"material":0}}]}}],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}}}}}}],
        "textures":[{{"source":0}}],"images":[{{"uri":"{}"}}],
        "buffers":[{{"byteLength":36,"uri":"{}"}}],"bufferViews":[{{"buffer":0,"byteLength":36}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}]}}"#,
        data_uri("image/png", png),
        data_uri("application/octet-stream", &positions)
    )
}

/// A 1 × 1 RGBA8 PNG carrying a `tEXt` chunk of `text_bytes` bytes.
fn one_texel_png_with_text(text_bytes: usize) -> Vec<u8> {
    let mut encoded = std::io::Cursor::new(Vec::new());
    image::RgbaImage::from_pixel(1, 1, image::Rgba([255, 128, 0, 255]))
        .write_to(&mut encoded, image::ImageFormat::Png)
        .expect("a 1 x 1 PNG encodes");
    let encoded = encoded.into_inner();
    // The signature (8 bytes) and the IHDR chunk (25) come first.
    let (head, rest) = encoded.split_at(8 + 25);
    let mut text = b"Comment\0".to_vec();
    text.resize(text.len() + text_bytes, b'x');
    let mut png = head.to_vec();
    png_chunk(&mut png, b"tEXt", &text);
    png.extend(rest);
    png
}

/// The decoder's allocations are capped at 12 bytes a texel plus 1 MiB:
/// a 1 × 1 picture carrying 64 KiB of text decodes, one carrying 2 MiB is
/// refused as invalid, naming its image. A cap of 12 bytes a texel times
/// 1 MiB (12 MiB here) would take the 2 MiB.
#[test]
fn a_small_picture_carrying_megabytes_of_metadata_is_refused_by_the_decoders_allocation_cap() {
    let import = |text_bytes| {
        let file = textured_triangle(&one_texel_png_with_text(text_bytes));
        oxygen::import::import_gltf_slice(&mut Scene::new(), file.as_bytes(), "texel.gltf", &ImportOptions::default())
    };
    let small = import(64 << 10).expect("64 KiB of text fits under the cap");
    assert_eq!(small.renderables, 1);
    match import(2 << 20) {
        Err(err @ GltfError::Invalid { .. }) => {
            let text = err.to_string();
            assert!(text.contains("image 0") && text.contains("limit"), "{text}");
        }
        Err(other) => panic!("expected the image to be refused as invalid, got {other}"),
        Ok(_) => panic!("2 MiB of text passed the decoder's allocation cap"),
    }
}
