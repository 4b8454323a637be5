//! glTF node animation: channels on translation, rotation and scale are
//! imported, sampled at a time the application gives, and rendered.
//! Without a GPU: what the importer reads and what sampling gives at
//! keyframes and between them; on lavapipe: goldens of the shipped animated
//! files at two times each (the pictures must differ: they move), and a
//! renderer that follows the scene from one time to another.

mod support;

use std::path::PathBuf;

use oxygen::core::Animation;
use oxygen::glam::Quat;
use oxygen::import::{GltfImport, ImportOptions};
use oxygen::prelude::*;
use support::encode::data_uri;
use support::golden::{Tolerance, assert_golden, compare};

fn asset(relative: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets").join(relative)
}

fn import(file: &str) -> (Scene, GltfImport) {
    let mut scene = Scene::new();
    let import = import_gltf(&mut scene, asset(file), &SceneChoice::Default).unwrap();
    assert!(!import.warnings.iter().any(|w| w.contains("animation")), "{:?}", import.warnings);
    (scene, import)
}

#[test]
fn the_shipped_files_animations_are_imported_with_every_channel() {
    let (_, boxed) = import("BoxAnimated/BoxAnimated.glb");
    assert_eq!(boxed.animations.len(), 1);
    assert_eq!(boxed.animations[0].channels.len(), 2);
    assert!((boxed.animations[0].duration() - 3.70833).abs() < 1e-4, "{}", boxed.animations[0].duration());
    let (_, cube) = import("AnimatedCube/AnimatedCube.gltf");
    assert_eq!(cube.animations[0].name, "animation_AnimatedCube");
    assert_eq!(cube.animations[0].duration(), 2.0);
}

#[test]
fn sampling_gives_the_keyframes_and_blends_between_them() {
    let (mut scene, import) = import("BoxAnimated/BoxAnimated.glb");
    let animation = &import.animations[0];
    // The translation channel lifts node 0 from y = 0 to 2.52 by 1.25 s,
    // holds it until 2.5 s and brings it back down by 3.708 s.
    let lifted = animation
        .channels
        .iter()
        .find(|c| matches!(c.values, oxygen::core::ChannelValues::Translation(_)))
        .expect("a translation channel")
        .node;
    for (time, y) in [(-1.0, 0.0), (0.0, 0.0), (0.625, 1.26), (1.25, 2.52), (2.0, 2.52), (3.1041665, 1.26), (10.0, 0.0)]
    {
        animation.apply(&mut scene, time).unwrap();
        let t = scene.node(lifted).unwrap().local.translation;
        assert!((t.y - y).abs() < 1e-4, "t = {time}: {t}");
    }
    // AnimatedCube turns about +Y, half a turn a second: a quarter at 0.5 s.
    let (mut scene, import) = self::import("AnimatedCube/AnimatedCube.gltf");
    let animation = &import.animations[0];
    let node = animation.channels[0].node;
    animation.apply(&mut scene, 0.5).unwrap();
    let rotation = scene.node(node).unwrap().local.rotation;
    let quarter = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
    let angle = rotation.angle_between(quarter).min(rotation.angle_between(quarter.inverse()));
    assert!(angle < 1e-3, "{rotation:?} is not a quarter turn about Y");
}

/// A view on `eye_direction` framing a sphere of `radius` around `center`
/// (what the animation sweeps, not only the rest pose's bounds).
fn camera(center: Vec3, radius: f32, eye_direction: Vec3) -> LookAtResolver {
    LookAtResolver::new(
        Camera::perspective(45f32.to_radians(), radius * 0.01, None),
        center + eye_direction.normalize() * radius * 2.8,
        center,
        UVec2::new(200, 150),
    )
    .unwrap()
}

fn with_sun(scene: &mut Scene) {
    let sun = scene.add_node(
        "sun",
        Transform::IDENTITY
            .with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::new(-0.3, -0.8, -0.5).normalize())),
    );
    scene.set_light(sun, Some(Light::directional(2.5))).unwrap();
}

fn render_at(scene: &mut Scene, animation: &Animation, time: f32, resolver: LookAtResolver) -> image::RgbaImage {
    animation.apply(scene, time).unwrap();
    let mut renderer = support::gpu_renderer();
    let view = renderer.register_view(resolver, standard_render_graph).unwrap();
    renderer.render_frame(scene).unwrap();
    support::read_lit_color(&renderer, view)
}

fn golden_pair(file: &str, name: &str, times: [f32; 2], resolver: LookAtResolver) {
    let (mut scene, import) = import(file);
    with_sun(&mut scene);
    let images = times.map(|t| render_at(&mut scene, &import.animations[0], t, resolver));
    let c = compare(&images[0], &images[1], 10);
    assert!(c.differing > c.total / 50, "{name}: the two times look alike ({} of {} differ)", c.differing, c.total);
    for (image, time) in images.iter().zip(times) {
        assert_golden(&format!("{name}_t{}", (time * 100.0).round() as u32), image, Tolerance::default());
    }
}

#[test]
fn golden_box_animated_at_two_times() {
    // The inner box rises from the outer one (y 0 → 2.52) and turns.
    let resolver = camera(Vec3::new(0.0, 1.3, 0.0), 1.9, Vec3::new(1.0, 0.6, 1.4));
    golden_pair("BoxAnimated/BoxAnimated.glb", "box_animated", [1.0, 2.0], resolver);
}

#[test]
fn golden_animated_cube_at_two_times() {
    let resolver = camera(Vec3::ZERO, 1.8, Vec3::new(0.3, 0.5, 1.0));
    golden_pair("AnimatedCube/AnimatedCube.gltf", "animated_cube", [0.25, 0.6], resolver);
}

/// One renderer, the scene posed at 0.5 s and rendered, then posed at
/// 1.25 s: its second frame equals a fresh render at 1.25 s (nothing of the
/// first pose is left in the GPU scene).
#[test]
fn a_renderer_follows_the_animation_from_frame_to_frame() {
    let (mut scene, import) = import("AnimatedCube/AnimatedCube.gltf");
    with_sun(&mut scene);
    let resolver = camera(Vec3::ZERO, 1.8, Vec3::new(0.3, 0.5, 1.0));
    let animation = &import.animations[0];
    let mut renderer = support::gpu_renderer();
    let view = renderer.register_view(resolver, standard_render_graph).unwrap();
    animation.apply(&mut scene, 0.5).unwrap();
    renderer.render_frame(&scene).unwrap();
    animation.apply(&mut scene, 1.25).unwrap();
    renderer.render_frame(&scene).unwrap();
    let followed = support::read_lit_color(&renderer, view);
    let fresh = render_at(&mut scene, animation, 1.25, resolver);
    let c = compare(&followed, &fresh, 2);
    assert!(c.differing == 0, "{} of {} pixels differ from a fresh render", c.differing, c.total);
}

/// A one-node file with one translation channel whose keyframe times and
/// values are `times` and `ys` (as y).
fn channel_file(times: &[f32], ys: &[f32], target_node: usize) -> Vec<u8> {
    let mut bin: Vec<u8> = times.iter().flat_map(|t| t.to_le_bytes()).collect();
    let values_offset = bin.len();
    bin.extend(ys.iter().flat_map(|y| [0.0f32, *y, 0.0]).flat_map(|v| v.to_le_bytes()));
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"name":"moved"}},{{"name":"elsewhere"}}],
        "animations":[{{"name":"lift","channels":[{{"sampler":0,"target":{{"node":{target_node},"path":"translation"}}}}],
        "samplers":[{{"input":0,"output":1,"interpolation":"LINEAR"}}]}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":{n},"type":"SCALAR"}},{{"bufferView":1,"componentType":5126,"count":{m},"type":"VEC3"}}],
        "bufferViews":[{{"buffer":0,"byteLength":{values_offset}}},{{"buffer":0,"byteOffset":{values_offset},"byteLength":{vb}}}],
        "buffers":[{{"byteLength":{len},"uri":"{uri}"}}]}}"#,
        n = times.len(),
        m = ys.len(),
        vb = ys.len() * 12,
        len = bin.len(),
        uri = data_uri("application/octet-stream", &bin)
    )
    .into_bytes()
}

#[test]
fn malformed_channels_fail_the_import_naming_the_animation_and_channel() {
    let import = |bytes: &[u8]| {
        let mut scene = Scene::new();
        oxygen::import::import_gltf_slice(&mut scene, bytes, "anim.gltf", &ImportOptions::default())
    };
    assert!(import(&channel_file(&[0.0, 1.0], &[0.0, 2.0], 0)).is_ok());
    for (what, file) in [
        ("times that go back", channel_file(&[0.0, 1.0, 0.5], &[0.0, 1.0, 2.0], 0)),
        ("fewer values than times", channel_file(&[0.0, 1.0, 2.0], &[0.0, 1.0], 0)),
        ("a non-finite time", channel_file(&[0.0, f32::INFINITY], &[0.0, 1.0], 0)),
    ] {
        let err = import(&file).expect_err(what).to_string();
        assert!(err.contains("animation 0 ('lift'), channel 0"), "{what}: {err}");
    }
    // A channel on a node outside the imported scene is skipped, said aloud.
    let skipped = import(&channel_file(&[0.0, 1.0], &[0.0, 2.0], 1)).unwrap();
    assert!(skipped.animations[0].channels.is_empty());
    assert!(skipped.warnings.iter().any(|w| w.contains("not in the imported scene")), "{:?}", skipped.warnings);
}

/// RiggedSimple: a cylinder skinned to two bones, the upper one bending it
/// back and forth. Posed at two times, the pictures differ and have
/// goldens; and the posed picture is not the bind pose's (the skin moves
/// the vertices on the GPU).
#[test]
fn golden_rigged_simple_bends_with_its_bones() {
    let (mut scene, import) = import("RiggedSimple/RiggedSimple.glb");
    with_sun(&mut scene);
    // Side view: the bend is in the file's YZ plane.
    let resolver = camera(Vec3::ZERO, 5.0, Vec3::new(1.0, 0.1, 0.0));
    golden_pair("RiggedSimple/RiggedSimple.glb", "rigged_simple", [0.05, 1.05], resolver);
    let posed = render_at(&mut scene, &import.animations[0], 1.05, resolver);
    let skinned = scene.nodes().find(|(_, n)| n.skin.is_some()).map(|(k, _)| k).expect("a skinned node");
    scene.set_skin(skinned, None).unwrap();
    let rigid = render_at(&mut scene, &import.animations[0], 1.05, resolver);
    let c = compare(&posed, &rigid, 10);
    assert!(c.differing > c.total / 100, "the skin must bend the mesh: {} of {} differ", c.differing, c.total);
}

/// Found in review: an animation accessor without a buffer view claiming
/// 2^62 keyframes overflowed the byte count (a panic); and a skin listing a
/// joint twice allocated per listing. Both are refused with a message now.
#[test]
fn absurd_keyframe_counts_and_repeated_joints_are_refused_not_a_panic() {
    let import = |json: &str| {
        let mut scene = Scene::new();
        oxygen::import::import_gltf_slice(&mut scene, json.as_bytes(), "hostile.gltf", &ImportOptions::default())
    };
    let huge = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{}],
        "animations":[{"channels":[{"sampler":0,"target":{"node":0,"path":"translation"}}],
        "samplers":[{"input":0,"output":1}]}],
        "accessors":[{"componentType":5126,"count":4611686018427387904,"type":"SCALAR"},
                     {"componentType":5126,"count":4611686018427387904,"type":"VEC3"}]}"#;
    let err = import(huge).expect_err("2^62 keyframes");
    assert!(err.to_string().contains("animation 0"), "{err}");
    let twice = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1]}],
        "nodes":[{"mesh":0,"skin":0},{}],"skins":[{"joints":[1,1]}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
        "bufferViews":[{"buffer":0,"byteLength":36}],
        "buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}]}"#;
    let err = import(twice).expect_err("a joint listed twice");
    assert!(err.to_string().contains("listed twice"), "{err}");
}
