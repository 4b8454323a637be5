//! Golden images of real glTF scenes on lavapipe (see `support/golden.rs`
//! for the comparison rules and how to update a golden).

mod support;

use std::path::PathBuf;

use oxygen::core::Aabb;
use oxygen::glam::Quat;
use oxygen::prelude::*;
use support::golden::{Tolerance, assert_golden};

fn asset(relative: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets").join(relative)
}

/// Imports `file`, adds a sun when the file has no light, and returns the scene and its bounds.
fn load(file: &str) -> (Scene, Aabb) {
    let mut scene = Scene::new();
    let import = import_gltf(&mut scene, asset(file), &SceneChoice::Default).unwrap();
    if import.lights == 0 {
        let sun = scene.add_node(
            "test sun",
            Transform::IDENTITY
                .with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::new(-0.3, -0.8, -0.5).normalize())),
        );
        scene.set_light(sun, Some(Light::directional(2.5))).unwrap();
    }
    (scene, import.bounds.expect("something to draw"))
}

/// A camera on `direction` from the bounds' centre, framing them.
fn framing(bounds: Aabb, direction: Vec3) -> LookAtResolver {
    let radius = bounds.half_extents().length();
    let up = if direction.normalize().dot(Vec3::Y).abs() > 0.99 { Vec3::Z } else { Vec3::Y };
    LookAtResolver {
        camera: Camera::perspective(45f32.to_radians(), radius * 0.01, None),
        eye: bounds.center() + direction.normalize() * radius * 2.0,
        target: bounds.center(),
        up,
        viewport: UVec2::new(240, 180),
    }
}

fn render(scene: &Scene, resolver: LookAtResolver) -> image::RgbaImage {
    let mut renderer = support::gpu_renderer();
    let view = renderer.register_view(resolver, standard_render_graph).unwrap();
    renderer.render_frame(scene).unwrap();
    support::read_lit_color(&renderer, view)
}

#[test]
fn golden_alpha_blend_mode_test() {
    let (scene, bounds) = load("AlphaBlendModeTest/AlphaBlendModeTest.glb");
    assert_golden(
        "alpha_blend_mode_test",
        &render(&scene, framing(bounds, Vec3::new(0.2, 0.25, 1.0))),
        Tolerance::default(),
    );
}

#[test]
fn golden_two_sided_plane_from_both_sides() {
    let (scene, bounds) = load("TwoSidedPlane/TwoSidedPlane.gltf");
    // The plane is horizontal: seen from above and from below, both sides are drawn.
    let front = render(&scene, framing(bounds, Vec3::new(0.2, 1.0, 0.6)));
    let back = render(&scene, framing(bounds, Vec3::new(0.2, -1.0, 0.6)));
    assert_golden("two_sided_plane_front", &front, Tolerance::default());
    assert_golden("two_sided_plane_back", &back, Tolerance::default());
    let background = front.get_pixel(0, 0).0;
    let covered = |img: &image::RgbaImage| img.pixels().filter(|p| p.0 != background).count();
    assert!(covered(&back) > covered(&front) / 2, "the back side must be drawn too");
}

#[test]
fn golden_box_textured() {
    let (scene, bounds) = load("BoxTextured/BoxTextured.glb");
    assert_golden("box_textured", &render(&scene, framing(bounds, Vec3::new(1.0, 0.8, 1.3))), Tolerance::default());
}

#[test]
fn golden_cubes_with_a_punctual_light() {
    let (scene, bounds) = load("Cubes/Cubes.glb");
    assert_golden("cubes", &render(&scene, framing(bounds, Vec3::new(0.45, 0.35, 1.0))), Tolerance::default());
}

#[test]
fn golden_orientation_test() {
    let (scene, bounds) = load("OrientationTest/OrientationTest.glb");
    assert_golden("orientation_test", &render(&scene, framing(bounds, Vec3::new(0.0, 0.0, 1.0))), Tolerance::default());
}

/// A mirrored copy (scale −1 on X) of a shipped mesh must look like the
/// mirror image of the original, not like its inside: the winding flips and
/// back-face culling stays right.
#[test]
fn golden_negative_scale_mirror() {
    let (mut scene, bounds) = load("BoxTextured/BoxTextured.glb");
    // Mirror the file's whole root (its Z-up to Y-up rotation included) so
    // the copy is the exact mirror image of the original.
    let root = *scene.roots().first().expect("a root node");
    let (mesh_node, renderable) =
        scene.nodes().find_map(|(k, n)| n.renderable.clone().map(|r| (k, r))).expect("a mesh node");
    let width = bounds.half_extents().x * 2.0;
    let root_local = scene.node(root).expect("root").local;
    let mirror_root = scene.add_node(
        "mirror",
        Transform::from_translation(Vec3::new(bounds.center().x + width * 1.6, 0.0, 0.0))
            .with_scale(Vec3::new(-1.0, 1.0, 1.0)),
    );
    let copy_root = scene.add_child(mirror_root, "mirrored copy of the root", root_local).unwrap();
    let mesh_local = scene.node(mesh_node).expect("mesh").local;
    let copy =
        if mesh_node == root { copy_root } else { scene.add_child(copy_root, "mirrored mesh", mesh_local).unwrap() };
    scene.set_renderable(copy, renderable).unwrap();
    let both = Aabb::new(bounds.min, bounds.max + Vec3::X * width * 1.6);
    let image = render(&scene, framing(both, Vec3::new(0.2, 0.6, 1.0)));
    assert_golden("negative_scale_mirror", &image, Tolerance::default());
}
