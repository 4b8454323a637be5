//! Camera-relative rendering: a small scene a million units from the world
//! origin must render like the same scene at the origin.
//!
//! `f32` spaces numbers 1/16 apart at 1e6, so a 0.2-unit cube rendered with
//! absolute coordinates is snapped out of shape and the view matrix loses the
//! camera's fine position; with the default [`RenderOrigin`] the renderer
//! rebases everything near the camera in `f64` first. The test measures both:
//! the default must match the reference picture within the golden tolerance,
//! and the absolute mode must not (which is the error the knob costs, and
//! proves the comparison can fail). Near plane 1e-3, infinite far plane.

mod support;

use oxygen::RenderOrigin;
use oxygen::core::glam::DVec3;
use oxygen::glam::{Quat, Vec4};
use oxygen::prelude::*;
use oxygen::views::ViewContext;
use support::golden::compare;
use support::{gpu_renderer_with, region_mean};

const SIZE: u32 = 128;
/// Exactly representable in `f32`, like the offsets below, so both scenes
/// describe the same geometry and cameras: the only difference is where the
/// numbers are rounded on the way to the GPU.
const FAR_AWAY: Vec3 = Vec3::new(1.0e6, 0.0, -1.0e6);

/// Ground, three small cubes and a point light under a root node at
/// `offset`; children are composed with their root in `f64`.
fn scene_at(offset: Vec3) -> Scene {
    let mut scene = Scene::new();
    let root = scene.add_node("root", Transform::from_translation(offset));
    let ground_material = scene.add_material(Material::opaque("ground", Vec4::new(0.6, 0.6, 0.6, 1.0)));
    let colours = [Vec4::new(0.9, 0.2, 0.1, 1.0), Vec4::new(0.1, 0.8, 0.2, 1.0), Vec4::new(0.2, 0.3, 0.9, 1.0)];
    let ground = scene.add_geometry(Geometry::plane(4.0));
    let cube = scene.add_geometry(Geometry::cube(0.2));
    let node = scene.add_child(root, "ground", Transform::IDENTITY).unwrap();
    scene.set_renderable(node, Renderable { geometry: ground, materials: vec![ground_material] }).unwrap();
    for (i, colour) in colours.into_iter().enumerate() {
        let material = scene.add_material(Material::opaque(format!("cube {i}"), colour));
        let at = Vec3::new(-0.3 + 0.3 * i as f32, 0.1, -0.1 * i as f32);
        let node = scene
            .add_child(
                root,
                format!("cube {i}"),
                Transform::from_translation(at).with_rotation(Quat::from_rotation_y(0.4)),
            )
            .unwrap();
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![material] }).unwrap();
    }
    let lamp = scene.add_child(root, "lamp", Transform::from_translation(Vec3::new(0.2, 0.6, 0.4))).unwrap();
    scene.set_light(lamp, Some(Light { color: Vec3::new(1.0, 0.85, 0.6), ..Light::point(3.0, Some(5.0)) })).unwrap();
    let sun = scene.add_child(root, "sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_x(-1.0))).unwrap();
    scene.set_light(sun, Some(Light::directional(0.3))).unwrap();
    scene
}

fn camera_at(offset: Vec3) -> LookAtResolver {
    LookAtResolver::new(
        Camera::perspective(50f32.to_radians(), 1e-3, None),
        offset + Vec3::new(0.5, 0.625, 1.25),
        offset + Vec3::new(0.0, 0.0625, 0.0),
        UVec2::splat(SIZE),
    )
    .unwrap()
}

fn render(offset: Vec3, origin: RenderOrigin) -> image::RgbaImage {
    let mut renderer = gpu_renderer_with(RendererOptions { origin, ..Default::default() });
    let view = renderer.register_view(camera_at(offset), oxygen::graph::standard_render_graph).unwrap();
    renderer.render_frame(&scene_at(offset)).unwrap();
    support::read_lit_color(&renderer, view)
}

#[test]
fn a_scene_a_million_units_out_renders_like_the_same_scene_at_the_origin() {
    let reference = render(Vec3::ZERO, RenderOrigin::default());
    // The picture is not empty: the lamp lights the cubes and the ground.
    assert!(region_mean(&reference, (SIZE / 2, SIZE / 2), 6) > 0.1, "reference picture is dark");

    let relative = compare(&render(FAR_AWAY, RenderOrigin::default()), &reference, 10);
    let absolute = compare(&render(FAR_AWAY, RenderOrigin::Absolute), &reference, 10);
    let fixed =
        compare(&render(FAR_AWAY, RenderOrigin::Fixed(FAR_AWAY.as_dvec3() + DVec3::splat(3.0))), &reference, 10);
    eprintln!(
        "pixels differing from the origin scene by more than 10 levels, scene at {FAR_AWAY}: \
         camera-relative {} ({:.2} %), fixed origin nearby {} ({:.2} %), absolute f32 {} ({:.2} %), of {}",
        relative.differing,
        100.0 * relative.differing as f64 / relative.total as f64,
        fixed.differing,
        100.0 * fixed.differing as f64 / fixed.total as f64,
        absolute.differing,
        100.0 * absolute.differing as f64 / absolute.total as f64,
        relative.total
    );
    let allowed = relative.total / 200;
    assert!(relative.differing <= allowed, "camera-relative rendering differs in {} pixels", relative.differing);
    assert!(fixed.differing <= allowed, "a fixed nearby origin differs in {} pixels", fixed.differing);
    assert!(
        absolute.differing > 4 * allowed,
        "absolute f32 rendering should visibly lose precision here ({} pixels differ)",
        absolute.differing
    );
}

#[test]
fn the_default_origin_follows_the_first_view_in_grid_steps() {
    let view = camera_at(FAR_AWAY)
        .resolve(
            &ViewContext { view_id: oxygen::core::ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 },
            &Scene::new(),
        )
        .unwrap();
    let origin = RenderOrigin::default().resolve(Some(&view));
    assert_eq!(origin % 1024.0, DVec3::ZERO, "snapped to the 1024-unit grid: {origin}");
    assert!((origin - view.camera_position_f64()).abs().max_element() <= 512.0);
    assert_eq!(RenderOrigin::Absolute.resolve(Some(&view)), DVec3::ZERO);
    assert_eq!(RenderOrigin::default().resolve(None), DVec3::ZERO);
    assert_eq!(RenderOrigin::Fixed(DVec3::NAN).resolve(Some(&view)), DVec3::ZERO, "a non-finite origin is ignored");
}
