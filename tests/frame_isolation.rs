//! One bad object or view costs only itself: a view whose resolver fails or
//! whose targets would pass the budget, and a node with non-finite bounds,
//! are left out with a `FrameWarning` while everything else renders. And
//! one scene costs only itself: a renderer that renders another scene draws
//! that scene's meshes and textures, not the last one's.

mod support;

use oxygen::FrameWarning;
use oxygen::core::{Projection, Scene};
use oxygen::glam::{Quat, Vec4};
use oxygen::import::NodeCameraResolver;
use oxygen::prelude::*;
use support::{gpu_renderer, gpu_renderer_with};

/// A lit red cube at the origin, and a camera node looking at it.
fn lit_cube_scene() -> (Scene, oxygen::core::NodeKey) {
    let mut scene = Scene::new();
    let red = scene.add_material(Material::opaque("red", Vec4::new(0.8, 0.1, 0.1, 1.0)));
    let geometry = scene.add_geometry(Geometry::cube(1.0));
    let cube = scene.add_node("cube", Transform::IDENTITY);
    scene.set_renderable(cube, Renderable { geometry, materials: vec![red] }).unwrap();
    let sun = scene.add_node(
        "sun",
        Transform::IDENTITY
            .with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::new(-0.3, -1.0, -0.5).normalize())),
    );
    scene.set_light(sun, Some(Light::directional(3.0))).unwrap();
    let eye = scene.add_node("camera", Transform::from_translation(Vec3::new(0.0, 0.0, 4.0)));
    (scene, eye)
}

fn front_view(size: u32) -> LookAtResolver {
    support::looking_at_origin(50.0, Vec3::new(0.0, 0.0, 4.0), UVec2::splat(size))
}

fn centre_is_lit_red(renderer: &Renderer, view: ViewId) {
    let image = support::read_lit_color(renderer, view);
    let [r, g, b, _] = image.get_pixel(image.width() / 2, image.height() / 2).0;
    assert!(r > 60 && r > 2 * g && r > 2 * b, "{view}: centre ({r}, {g}, {b}) is not the lit red cube");
}

#[test]
fn a_camera_that_cannot_be_resolved_skips_its_view_and_the_others_render() {
    let (scene, eye) = lit_cube_scene();
    let mut renderer = gpu_renderer();
    let good_before = renderer.register_view(front_view(64), standard_render_graph).unwrap();
    // A glTF camera with yfov 0, as a crafted file can hold.
    let broken = Camera { projection: Projection::Perspective { fov_y: 0.0, near: 0.1, far: Some(100.0) } };
    let bad = renderer
        .register_view(
            NodeCameraResolver { node: eye, camera: broken, viewport: UVec2::splat(64) },
            standard_render_graph,
        )
        .unwrap();
    let good_after = renderer.register_view(front_view(64), standard_render_graph).unwrap();
    let report = renderer.render_frame(&scene).expect("a bad view must not fail the frame");
    let rendered: Vec<ViewId> = report.views.iter().map(|v| v.view).collect();
    assert_eq!(rendered, vec![good_before, good_after]);
    assert!(
        matches!(&report.warnings[..], [FrameWarning::ViewSkipped { view, .. }] if *view == bad),
        "{:?}",
        report.warnings
    );
    centre_is_lit_red(&renderer, good_before);
    centre_is_lit_red(&renderer, good_after);
    // Reading the skipped view says why it has no image.
    let reason = match &report.warnings[0] {
        FrameWarning::ViewSkipped { reason, .. } => reason.clone(),
        other => panic!("{other:?}"),
    };
    match renderer.read_color(bad) {
        Err(oxygen::RenderError::Skipped { view, reason: why }) => assert_eq!((view, why), (bad, reason)),
        other => panic!("reading the skipped view: {other:?}"),
    }
}

#[test]
fn views_carry_their_names_and_sun_shadows_without_a_sun_are_a_warning() {
    let (mut scene, _) = lit_cube_scene();
    // The sun lights the cube but casts no shadow.
    let sun = scene.nodes().find(|(_, n)| n.name == "sun").map(|(key, _)| key).expect("the sun");
    scene.set_light(sun, Some(Light { casts_shadows: false, ..Light::directional(3.0) })).unwrap();
    let mut renderer = gpu_renderer();
    let front = renderer
        .register_view(
            ViewDesc::new(front_view(32)).named("front").with_sun_shadows(Default::default()),
            standard_render_graph,
        )
        .unwrap();
    let side = renderer.register_view(front_view(32), standard_render_graph).unwrap();
    assert_eq!(renderer.view_name(front), Some("front"));
    assert_eq!(renderer.find_view("front"), Some(front));
    let report = renderer.render_frame(&scene).unwrap();
    let names: Vec<_> = report.views.iter().map(|v| (v.view, v.name.as_deref())).collect();
    assert_eq!(names, vec![(front, Some("front")), (side, None)]);
    // No light casts a sun shadow: the view that asked
    // for sun shadows is told, the other is not.
    let warned: Vec<_> = report
        .warnings
        .iter()
        .filter_map(|w| match w {
            FrameWarning::NoSunForShadows { view } => Some(*view),
            _ => None,
        })
        .collect();
    assert_eq!(warned, vec![front]);
}

#[test]
fn a_node_with_non_finite_bounds_is_skipped_with_a_warning_and_the_rest_renders() {
    let (mut scene, _) = lit_cube_scene();
    let blue = scene.add_material(Material::opaque("blue", Vec4::new(0.1, 0.1, 0.8, 1.0)));
    let geometry = scene.add_geometry(Geometry::cube(1.0));
    let broken = scene.add_node(
        "broken",
        Transform::from_translation(Vec3::new(0.5, 0.0, 1.0)).with_scale(Vec3::splat(f32::INFINITY)),
    );
    scene.set_renderable(broken, Renderable { geometry, materials: vec![blue] }).unwrap();
    let mut renderer = gpu_renderer();
    let view = renderer.register_view(front_view(64), standard_render_graph).unwrap();
    let report = renderer.render_frame(&scene).unwrap();
    assert!(
        report.warnings.iter().any(|w| matches!(w, FrameWarning::NodeSkipped { name, .. } if name == "broken")),
        "{:?}",
        report.warnings
    );
    assert_eq!(report.views.len(), 1);
    centre_is_lit_red(&renderer, view);
    // The warning is repeated every frame the node stays broken, also when
    // the frame phase reuses its collection.
    let again = renderer.render_frame(&scene).unwrap();
    assert_eq!(again.warnings, report.warnings);
}

#[test]
fn an_oversized_target_request_is_refused_before_anything_is_allocated() {
    let (scene, _) = lit_cube_scene();
    // 64 KiB of targets is one 64×64 view (16 bytes a pixel), not two.
    let budget = Renderer::target_bytes(UVec2::splat(64), false);
    assert_eq!(budget, 64 * 64 * 16);
    let mut renderer = gpu_renderer_with(RendererOptions { target_budget_bytes: budget, ..Default::default() });
    let first = renderer.register_view(front_view(64), standard_render_graph).unwrap();
    let second = renderer.register_view(ViewDesc::new(front_view(64)).named("second"), standard_render_graph).unwrap();
    let err = renderer.check_target_budget(&[(UVec2::splat(64), false), (UVec2::splat(64), false)]).unwrap_err();
    assert!(err.to_string().contains("target budget"), "{err}");
    renderer.check_target_budget(&[(UVec2::splat(64), false)]).unwrap();

    let report = renderer.render_frame(&scene).unwrap();
    assert_eq!(report.views.iter().map(|v| v.view).collect::<Vec<_>>(), vec![first]);
    match &report.warnings[..] {
        [warning @ FrameWarning::ViewSkipped { view, name, reason }] => {
            assert_eq!((*view, name.as_deref()), (second, Some("second")));
            assert!(reason.contains("64x64") && reason.contains("budget"), "{reason}");
            // The warning names the view by its name too.
            assert!(warning.to_string().contains("(second) skipped"), "{warning}");
        }
        other => panic!("expected one skipped view, got {other:?}"),
    }
    assert_eq!(renderer.target_memory(), budget, "only the admitted view's targets exist");
    centre_is_lit_red(&renderer, first);
}

#[test]
fn a_huge_viewport_is_skipped_not_allocated() {
    let (scene, _) = lit_cube_scene();
    let mut renderer = gpu_renderer();
    let huge = renderer
        .register_view(LookAtResolver { viewport: UVec2::new(16384, 16384), ..front_view(64) }, standard_render_graph)
        .unwrap();
    let small = renderer.register_view(front_view(64), standard_render_graph).unwrap();
    let report = renderer.render_frame(&scene).unwrap();
    // 16384² × 16 bytes = 4 GiB: over the default 2 GiB budget (or over the
    // device's texture limit, whichever is checked first).
    assert!(
        matches!(&report.warnings[..], [FrameWarning::ViewSkipped { view, .. }] if *view == huge),
        "{:?}",
        report.warnings
    );
    assert!(renderer.target_memory() < 1 << 20);
    centre_is_lit_red(&renderer, small);
}

/// Asset handles are slot indices, alike in every scene: the first mesh and
/// texture of two scenes have equal handles. A renderer that draws one
/// scene and then another must draw the second's own mesh and texture
/// (regression: it drew the first scene's cube in the second's place).
#[test]
fn a_renderer_switching_scenes_draws_the_new_scenes_meshes_and_textures() {
    let (first, _) = lit_cube_scene();
    let second = || {
        let mut scene = Scene::new();
        let texture = scene.add_texture(oxygen::core::TextureImage::checker(
            "checker",
            8,
            2,
            [20, 200, 40, 255],
            [240, 240, 240, 255],
        ));
        let material = scene
            .add_material(Material { base_color_texture: Some(texture), ..Material::opaque("checkered", Vec4::ONE) });
        let geometry = scene.add_geometry(Geometry::uv_sphere(0.7, 24, 12));
        let node = scene.add_node("sphere", Transform::IDENTITY);
        scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
        let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_x(-0.6)));
        scene.set_light(sun, Some(Light::directional(3.0))).unwrap();
        scene
    };
    let mut switched = gpu_renderer();
    let view = switched.register_view(front_view(96), standard_render_graph).unwrap();
    switched.render_frame(&first).unwrap();
    switched.render_frame(&second()).unwrap();
    let after_switch = support::read_lit_color(&switched, view);
    let mut fresh = gpu_renderer();
    let fresh_view = fresh.register_view(front_view(96), standard_render_graph).unwrap();
    fresh.render_frame(&second()).unwrap();
    let expected = support::read_lit_color(&fresh, fresh_view);
    let c = support::golden::compare(&after_switch, &expected, 2);
    assert_eq!(c.differing, 0, "{} of {} pixels differ from a fresh renderer's picture", c.differing, c.total);
}
