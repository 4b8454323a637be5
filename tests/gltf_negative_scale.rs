//! A glTF node with a negative scale, imported and rendered: the mirrored
//! copy lands on the other side, faces the camera, and is lit like the
//! original (ScenePrep flips the winding of mirroring transforms).

mod support;

use oxygen::core::Scene;
use oxygen::import::{ImportOptions, import_gltf_slice};
use oxygen::prelude::*;
use oxygen::sceneprep::PassMask;
use oxygen::views::ViewContext;
use support::encode::base64_encode;
use support::{gpu_renderer, pixel_of};

/// A quad at x ∈ [0.5, 1.5] facing +Z (counter-clockwise from +Z), drawn by
/// two nodes: one as it is at y = +1, one mirrored by scale (−1, 1, 1) at
/// y = −1.
fn mirrored_quad_gltf() -> String {
    let positions: [[f32; 3]; 4] = [[0.5, -0.5, 0.0], [1.5, -0.5, 0.0], [1.5, 0.5, 0.0], [0.5, 0.5, 0.0]];
    let normals = [[0f32, 0.0, 1.0]; 4];
    let indices: [u16; 6] = [0, 1, 2, 0, 2, 3];
    let mut bytes: Vec<u8> = positions.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
    bytes.extend(normals.iter().flatten().flat_map(|c| c.to_le_bytes()));
    bytes.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,1]}}],
        "nodes":[{{"name":"original","mesh":0,"translation":[0,1,0]}},{{"name":"mirrored","mesh":0,"translation":[0,-1,0],"scale":[-1,1,1]}}],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[0.2,0.8,0.3,1],"metallicFactor":0,"roughnessFactor":1}}}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1}},"indices":2,"material":0}}]}}],
        "buffers":[{{"byteLength":{len},"uri":"data:application/octet-stream;base64,{data}"}}],
        "bufferViews":[{{"buffer":0,"byteLength":96}},{{"buffer":0,"byteOffset":96,"byteLength":12}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0.5,-0.5,0],"max":[1.5,0.5,0]}},
                     {{"bufferView":0,"byteOffset":48,"componentType":5126,"count":4,"type":"VEC3"}},
                     {{"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}}]}}"#,
        len = bytes.len(),
        data = base64_encode(&bytes)
    )
}

#[test]
fn a_negatively_scaled_gltf_node_is_imported_mirrored_and_lit_like_the_original() {
    let mut scene = Scene::new();
    let import =
        import_gltf_slice(&mut scene, mirrored_quad_gltf().as_bytes(), "mirrored.gltf", &ImportOptions::default())
            .unwrap();
    assert_eq!(import.renderables, 2);
    let mirrored = scene.nodes().find(|(_, n)| n.name == "mirrored").map(|(k, _)| k).unwrap();
    assert!(scene.world_transform(mirrored).unwrap().determinant() < 0.0);
    let sun = scene.add_node("sun", Transform::IDENTITY);
    scene.set_light(sun, Some(Light::directional(3.0))).unwrap();

    let camera = LookAtResolver::new(
        Camera::orthographic(2.5, 0.1, 50.0),
        Vec3::new(0.0, 0.0, 10.0),
        Vec3::ZERO,
        UVec2::new(96, 96),
    )
    .unwrap();
    let mut renderer = gpu_renderer();
    let view = renderer.register_view(camera, standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    let frame = renderer.prepared_frame(view).unwrap();
    assert!(frame.partitions().iter().any(|p| p.mask.contains(PassMask::MIRRORED)), "{}", frame.dump());

    let image = renderer.read_color(view).unwrap();
    let resolved = camera.resolve(&ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 }, &scene).unwrap();
    let at = |x: f32, y: f32| {
        let (px, py) = pixel_of(&resolved, Vec3::new(x, y, 0.0));
        let p = image.get_pixel(px, py).0;
        [p[0], p[1], p[2]]
    };
    let original = at(1.0, 1.0);
    let mirrored_copy = at(-1.0, -1.0);
    let background = at(0.0, 2.2);
    let diff = |a: [u8; 3], b: [u8; 3]| (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap_or(0);
    assert!(original[1] > 60 && diff(original, background) > 30, "original quad missing: {original:?}");
    assert!(
        diff(mirrored_copy, original) <= 3,
        "the mirrored copy {mirrored_copy:?} is not drawn and lit like the original {original:?}"
    );
    // Nothing where the copy would be without the mirror.
    assert!(diff(at(1.0, -1.0), background) <= 2, "the mirror did not move the copy");
}
