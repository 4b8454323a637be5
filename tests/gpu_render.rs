//! Renders on a real device (lavapipe in CI) and checks the pictures with
//! tolerances: per-pixel colour error and a cap on the number of pixels that
//! may differ, never exact bytes.

mod support;

use oxygen::core::AlphaMode;
use oxygen::glam::{Quat, Vec4};
use oxygen::graph::{PrePass, lit_render_graph};
use oxygen::passes::{DrawPath, PassError};
use oxygen::prelude::*;
use oxygen::sceneprep::{PassMask, ViewPrepOptions};
use oxygen::views::ViewContext;
use support::{Rgb, assert_region, gpu_renderer, linear_to_srgb8, pixel_of, region_mean};

/// A distinctive clear colour, so "background" cannot be confused with shading.
const CLEAR: wgpu::Color = wgpu::Color { r: 0.5, g: 0.0, b: 0.5, a: 1.0 };

async fn graph_with_clear(ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
    MeshPass::depth_pre_pass().run(ctx, rec).await?;
    let config = ForwardLitConfig { clear_color: CLEAR, depth_from_pre_pass: true, ..Default::default() };
    MeshPass::forward_lit(config).run(ctx, rec).await?;
    TonemapPass::default().run(ctx, rec).await?;
    Ok(())
}

fn add_cube(
    scene: &mut Scene,
    name: &str,
    at: Vec3,
    size: f32,
    material: oxygen::core::MaterialHandle,
) -> oxygen::core::NodeKey {
    let geometry = scene.add_geometry(Geometry::cube(size));
    let node = scene.add_node(name, Transform::from_translation(at));
    scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
    node
}

fn add_sun(scene: &mut Scene, travelling: Vec3, intensity: f32) {
    let sun = scene.add_node(
        "sun",
        Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, travelling.normalize())),
    );
    scene.set_light(sun, Some(Light::directional(intensity))).unwrap();
}

/// A small green cube 3 units down −Z in front of a large red one 10 units
/// down, lit head-on by a sun travelling along −Z.
fn near_and_far_cubes() -> Scene {
    let mut scene = Scene::new();
    // The near cube's material is created first, so its partition is drawn
    // first: only a working reverse-Z depth test keeps the far cube from
    // painting over it.
    let green = scene.add_material(Material::opaque("near green", Vec4::new(0.0, 1.0, 0.0, 1.0)));
    let red = scene.add_material(Material::opaque("far red", Vec4::new(1.0, 0.0, 0.0, 1.0)));
    add_cube(&mut scene, "near", Vec3::new(0.0, 0.0, -3.0), 0.5, green);
    add_cube(&mut scene, "far", Vec3::new(0.0, 0.0, -10.0), 4.0, red);
    add_sun(&mut scene, Vec3::new(0.0, 0.0, -1.0), 3.0);
    scene
}

fn camera(eye: Vec3, target: Vec3, size: u32) -> LookAtResolver {
    LookAtResolver::new(Camera::perspective(60f32.to_radians(), 0.1, None), eye, target, UVec2::splat(size)).unwrap()
}

#[test]
fn near_object_occludes_far_one_and_background_keeps_the_clear_colour() {
    let scene = near_and_far_cubes();

    let mut renderer = gpu_renderer();
    let cam = camera(Vec3::ZERO, Vec3::NEG_Z, 96);
    let view = renderer.register_view(cam, graph_with_clear).unwrap();
    renderer.render_frame(&scene).unwrap();
    let image = support::read_lit_color(&renderer, view);
    let resolved = cam.resolve(&ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 }, &scene).unwrap();

    // Hue tests, not exact values: a head-on highlight whitens the faces.
    let is_green = |p: Rgb| p.g > 150 && p.g as i32 > p.r as i32 + 60 && p.g as i32 > p.b as i32 + 60;
    let is_red = |p: Rgb| p.r > 150 && p.r as i32 > p.g as i32 + 60 && p.r as i32 > p.b as i32 + 60;
    // Centre: the near cube (face towards the camera, lit head-on).
    assert_region(&image, pixel_of(&resolved, Vec3::new(0.0, 0.0, -2.75)), 3, is_green, 0, "near cube at the centre");
    // Beside the near cube but inside the far one: the far cube.
    assert_region(&image, pixel_of(&resolved, Vec3::new(1.2, 0.0, -8.0)), 3, is_red, 0, "far cube around the near one");
    // A corner: nothing there, so the clear colour within 2 levels per channel.
    let clear = Rgb::new(linear_to_srgb8(CLEAR.r), linear_to_srgb8(CLEAR.g), linear_to_srgb8(CLEAR.b));
    assert_region(&image, (4, 4), 3, |p| p.max_channel_error(clear) <= 2, 0, "background corner");
}

#[test]
fn the_lit_side_of_a_cube_is_brighter_than_the_unlit_side() {
    let mut scene = Scene::new();
    let white = scene.add_material(Material::opaque("white", Vec4::new(0.8, 0.8, 0.8, 1.0)));
    add_cube(&mut scene, "cube", Vec3::ZERO, 1.0, white);
    // Light travels towards −X: it hits the +X face head-on and grazes +Z.
    add_sun(&mut scene, Vec3::NEG_X, 3.0);

    let mut renderer = gpu_renderer();
    let cam = camera(Vec3::new(2.5, 1.5, 2.5), Vec3::ZERO, 128);
    let view = renderer.register_view(cam, graph_with_clear).unwrap();
    renderer.render_frame(&scene).unwrap();
    let image = support::read_lit_color(&renderer, view);
    let resolved = cam.resolve(&ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 }, &scene).unwrap();

    let lit = region_mean(&image, pixel_of(&resolved, Vec3::new(0.5, 0.0, 0.0)), 4);
    let unlit = region_mean(&image, pixel_of(&resolved, Vec3::new(0.0, 0.0, 0.5)), 4);
    assert!(lit > 2.0 * unlit && lit > 120.0, "lit face {lit:.1} should be much brighter than unlit face {unlit:.1}");
    assert!(unlit > 5.0, "the unlit face still gets ambient light ({unlit:.1})");
}

#[test]
fn masked_quad_is_kept_above_its_cutoff_dropped_below_and_visible_from_behind() {
    let mut scene = Scene::new();
    let quad = scene.add_geometry(Geometry::quad(2.0));
    let masked = |scene: &mut Scene, name: &str, alpha: f32| {
        scene.add_material(Material {
            roughness: 1.0,
            alpha_mode: AlphaMode::Mask { cutoff: 0.5 },
            double_sided: true,
            ..Material::opaque(name, Vec4::new(1.0, 1.0, 0.0, alpha))
        })
    };
    let kept = masked(&mut scene, "kept", 0.9);
    let dropped = masked(&mut scene, "dropped", 0.2);
    for (name, x, material) in [("kept", -1.2, kept), ("dropped", 1.2, dropped)] {
        let node = scene.add_node(name, Transform::from_translation(Vec3::new(x, 0.0, 0.0)));
        scene.set_renderable(node, Renderable { geometry: quad, materials: vec![material] }).unwrap();
    }
    add_sun(&mut scene, Vec3::new(0.0, 0.0, -1.0), 3.0);
    add_sun(&mut scene, Vec3::new(0.0, 0.0, 1.0), 3.0);

    let clear = Rgb::new(linear_to_srgb8(CLEAR.r), linear_to_srgb8(CLEAR.g), linear_to_srgb8(CLEAR.b));
    let is_yellow = |p: Rgb| p.r > 150 && p.g > 150 && p.b < 40;
    // Front (+Z) and back (−Z): the quad is double-sided, so both show it.
    for eye in [Vec3::new(0.0, 0.0, 4.0), Vec3::new(0.0, 0.0, -4.0)] {
        let mut renderer = gpu_renderer();
        let cam = camera(eye, Vec3::ZERO, 96);
        let view = renderer.register_view(cam, graph_with_clear).unwrap();
        renderer.render_frame(&scene).unwrap();
        let image = support::read_lit_color(&renderer, view);
        let resolved = cam.resolve(&ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 }, &scene).unwrap();
        assert_region(&image, pixel_of(&resolved, Vec3::new(-1.2, 0.0, 0.0)), 4, is_yellow, 0, "quad above cutoff");
        assert_region(
            &image,
            pixel_of(&resolved, Vec3::new(1.2, 0.0, 0.0)),
            4,
            |p| p.max_channel_error(clear) <= 2,
            0,
            "quad below cutoff",
        );
    }
}

/// A masked surface below its cutoff hides nothing behind it when the depth
/// pre-pass lays the depth: the pre-pass cuts it out as the shading pass
/// does, so the blue wall behind shows through where the depth test would
/// otherwise keep the cut-out surface's depth and show the clear colour.
#[test]
fn a_masked_surface_below_its_cutoff_leaves_no_depth_in_the_pre_pass() {
    let mut scene = Scene::new();
    let quad = scene.add_geometry(Geometry::quad(2.0));
    let wall = scene.add_geometry(Geometry::quad(6.0));
    let dropped = scene.add_material(Material {
        alpha_mode: AlphaMode::Mask { cutoff: 0.5 },
        ..Material::opaque("dropped", Vec4::new(1.0, 1.0, 0.0, 0.2))
    });
    let blue =
        scene.add_material(Material { roughness: 1.0, ..Material::opaque("blue", Vec4::new(0.0, 0.0, 1.0, 1.0)) });
    let node = scene.add_node("dropped", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry: quad, materials: vec![dropped] }).unwrap();
    let node = scene.add_node("wall", Transform::from_translation(Vec3::new(0.0, 0.0, -2.0)));
    scene.set_renderable(node, Renderable { geometry: wall, materials: vec![blue] }).unwrap();
    add_sun(&mut scene, Vec3::new(0.0, 0.0, -1.0), 3.0);

    let mut renderer = gpu_renderer();
    let cam = camera(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, 64);
    let view = renderer.register_view(cam, graph_with_clear).unwrap();
    renderer.render_frame(&scene).unwrap();
    let image = support::read_lit_color(&renderer, view);
    let resolved = cam.resolve(&ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 }, &scene).unwrap();
    let is_blue = |p: Rgb| p.b > 150 && p.r < 40 && p.g < 40;
    assert_region(&image, pixel_of(&resolved, Vec3::ZERO), 6, is_blue, 0, "the wall behind the cut-out quad");
}

#[test]
fn pipelines_are_created_once_and_reused_across_frames() {
    let demo = oxygen_demo::multi_view_scene();
    let mut renderer = gpu_renderer();
    // The pre-pass forced on, so that the count does not follow the
    // automatic choice's estimate.
    let graph = standard_render_graph.with_pre_pass(PrePass::On);
    let main = renderer.register_view(oxygen_demo::main_camera(UVec2::new(64, 48)), graph.clone()).unwrap();
    let side = renderer.register_view(oxygen_demo::side_camera(UVec2::new(48, 48)), graph).unwrap();
    renderer.render_frame(&demo.scene).unwrap();
    support::assert_hdr_finite(&renderer, main);
    support::assert_hdr_finite(&renderer, side);
    let after_first = renderer.internals().pipelines.pipelines_created();
    // Opaque + masked-double-sided partitions × (depth pre-pass, shading), plus the tone map.
    assert_eq!(after_first, 5);
    for _ in 0..3 {
        renderer.render_frame(&demo.scene).unwrap();
    }
    assert_eq!(renderer.internals().pipelines.pipelines_created(), after_first);
}

#[test]
fn views_render_in_registration_order_and_can_be_unregistered() {
    let demo = oxygen_demo::multi_view_scene();
    let mut renderer = gpu_renderer();
    let a = renderer.register_view(oxygen_demo::main_camera(UVec2::new(32, 32)), standard_render_graph).unwrap();
    let b = renderer.register_view(oxygen_demo::side_camera(UVec2::new(32, 32)), standard_render_graph).unwrap();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(report.views.iter().map(|v| v.view).collect::<Vec<_>>(), vec![a, b]);
    assert!(report.views.iter().all(|v| v.recorded.draw_calls > 0));
    // Recording a view's passes takes time, and the report says how much.
    assert!(report.views.iter().all(|v| v.record_seconds > 0.0), "{:?}", report.views);
    renderer.unregister_view(a).unwrap();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(report.views.len(), 1);
    support::assert_hdr_finite(&renderer, b);
    assert!(matches!(renderer.read_color(a), Err(oxygen::RenderError::NoSuchView(_))));
    assert!(matches!(renderer.read_hdr(a), Err(oxygen::RenderError::NoSuchView(_))));
    assert!(renderer.unregister_view(a).is_err());
}

#[test]
fn a_closure_factory_can_render_without_a_depth_pre_pass() {
    let scene = near_and_far_cubes();

    let mut renderer = gpu_renderer();
    let cam = camera(Vec3::ZERO, Vec3::NEG_Z, 64);
    let graph = async |ctx: &RenderContext<'_>, rec: &mut CommandRecorder| {
        let config = ForwardLitConfig { clear_color: CLEAR, depth_from_pre_pass: false, ..Default::default() };
        MeshPass::forward_lit(config).run(ctx, rec).await?;
        TonemapPass::default().run(ctx, rec).await
    };
    let view = renderer.register_view(cam, graph).unwrap();
    let report = renderer.render_frame(&scene).unwrap();
    assert_eq!(report.views[0].recorded.render_passes, 2, "shading and tone map only");
    let image = support::read_lit_color(&renderer, view);
    let resolved = cam.resolve(&ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 }, &scene).unwrap();
    let is_green = |p: Rgb| p.g > 150 && p.g as i32 > p.r as i32 + 60;
    assert_region(
        &image,
        pixel_of(&resolved, Vec3::new(0.0, 0.0, -2.75)),
        2,
        is_green,
        0,
        "near cube without pre-pass",
    );
}

#[test]
fn multi_draw_indirect_and_direct_draws_produce_the_same_image() {
    let demo = oxygen_demo::multi_view_scene();
    let render = |path: DrawPath, trust_indirect_args: bool| {
        let options = RendererOptions { draw_path: Some(path), keep_hdr: true, ..Default::default() };
        let gpu_options = oxygen::gpu::GpuOptions {
            optional_features: Renderer::OPTIONAL_FEATURES,
            trust_indirect_args,
            ..Default::default()
        };
        let gpu = oxygen::gpu::GpuContext::new_headless(&gpu_options).expect("a test adapter");
        let mut renderer = match Renderer::with_options(gpu, options) {
            Ok(r) => r,
            Err(e) => panic!("{path:?} must be available on the test adapter: {e}"),
        };
        assert_eq!(renderer.draw_path(), path);
        // One command per draw and the pre-pass always on, so the call
        // counts below follow from the scene alone.
        let options = ViewPrepOptions { instancing: oxygen::sceneprep::Instancing::Off, ..Default::default() };
        let desc = ViewDesc::new(oxygen_demo::main_camera(UVec2::new(160, 120))).with_options(options);
        let view = renderer.register_view(desc, lit_render_graph(ForwardLitConfig::default())).unwrap();
        let report = renderer.render_frame(&demo.scene).unwrap();
        (support::read_lit_color(&renderer, view), report.views[0].recorded.draw_calls)
    };
    let (direct, direct_calls) = render(DrawPath::Direct, false);
    let (indirect, indirect_calls) = render(DrawPath::MultiDrawIndirect, false);
    // Without wgpu's indirect validation: the same picture.
    let (trusted, _) = render(DrawPath::MultiDrawIndirect, true);
    // One call per draw against one call per partition (two passes each),
    // plus the tone map's full-screen triangle.
    assert_eq!(direct_calls, 2 * 11 + 1);
    assert_eq!(indirect_calls, 2 * 2 + 1);
    for (name, image) in [("multi-draw-indirect", &indirect), ("unvalidated multi-draw-indirect", &trusted)] {
        let differing = direct
            .pixels()
            .zip(image.pixels())
            .filter(|(a, b)| a.0.iter().zip(b.0.iter()).any(|(x, y)| x.abs_diff(*y) > 1))
            .count();
        assert_eq!(differing, 0, "{name}: {differing} pixels differ from direct draws by more than 1 level");
    }
}

#[test]
fn materials_and_geometry_upload_only_when_new_or_changed() {
    let mut demo = oxygen_demo::multi_view_scene();
    let mut renderer = gpu_renderer();
    let view = renderer.register_view(oxygen_demo::main_camera(UVec2::new(48, 32)), standard_render_graph).unwrap();
    for _ in 0..3 {
        renderer.render_frame(&demo.scene).unwrap();
    }
    support::assert_hdr_finite(&renderer, view);
    let stats = renderer.internals().scene_prep.stats();
    assert_eq!(stats.material_uploads, 1, "static materials are uploaded once");
    // Plane, cube and quad: three meshes, each uploaded once.
    assert_eq!(stats.geometry_uploads, 3);

    // A new material (and a mesh nobody draws) changes only the material table.
    demo.scene.add_material(Material::opaque("new", Vec4::ONE));
    demo.scene.add_geometry(Geometry::cube(3.0));
    renderer.render_frame(&demo.scene).unwrap();
    let stats = renderer.internals().scene_prep.stats();
    assert_eq!(stats.material_uploads, 2);
    assert_eq!(stats.geometry_uploads, 3, "an undrawn mesh is never uploaded");
    assert_eq!(renderer.internals().scene_prep.resident_geometry(), 3);
}

#[test]
fn a_mirrored_cube_is_lit_and_culled_like_its_original() {
    let mut scene = Scene::new();
    let white = scene.add_material(Material::opaque("white", Vec4::splat(0.8)));
    let cube = scene.add_geometry(Geometry::cube(1.0));
    for (x, sx) in [(-1.0f32, 1.0f32), (1.0, -1.0)] {
        let node = scene
            .add_node("cube", Transform::from_translation(Vec3::new(x, 0.0, 0.0)).with_scale(Vec3::new(sx, 1.0, 1.0)));
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![white] }).unwrap();
    }
    add_sun(&mut scene, Vec3::NEG_Y, 3.0);
    let mut renderer = gpu_renderer();
    let cam = camera(Vec3::new(0.0, 3.0, 5.0), Vec3::ZERO, 128);
    let view = renderer.register_view(cam, graph_with_clear).unwrap();
    renderer.render_frame(&scene).unwrap();
    let frame = renderer.prepared_frame(view).unwrap();
    assert!(
        frame.partitions().iter().any(|p| p.mask.contains(PassMask::MIRRORED)),
        "mirrored draws get their own variant"
    );
    let image = support::read_lit_color(&renderer, view);
    let resolved = cam.resolve(&ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 }, &scene).unwrap();
    let top = |x: f32| region_mean(&image, pixel_of(&resolved, Vec3::new(x, 0.5, 0.0)), 2);
    let (original, mirrored) = (top(-1.0), top(1.0));
    // With the winding wrong, the mirrored cube would show its (dark) inside.
    assert!(
        original > 150.0 && (original - mirrored).abs() < 3.0,
        "top faces: original {original}, mirrored {mirrored}"
    );
}
