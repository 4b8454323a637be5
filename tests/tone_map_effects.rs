//! The tone map's effects (`StandardGraph::bloom`, `StandardGraph::
//! auto_exposure`): a bloom chain spreads a bright patch's light around
//! it and leaves the far image alone; automatic exposure brings scenes lit
//! ten times apart to nearly the same picture, jumps on the first frame
//! and adapts over time after a change; a view without either records
//! neither and keeps no buffers; bad settings are refused.

mod support;

use oxygen::glam::{Quat, Vec4};
use oxygen::graph::StandardGraph;
use oxygen::lighting::{AutoExposure, Bloom};
use oxygen::prelude::*;

const SIZE: UVec2 = UVec2::new(128, 96);

/// A dark grey floor seen from above with a small emissive square in the
/// middle, and a sun of `sun` lux.
fn scene(sun: f32, emissive: f32) -> Scene {
    let mut scene = Scene::new();
    let floor_material = scene.add_material(Material::opaque("floor", Vec4::new(0.3, 0.3, 0.3, 1.0)));
    let floor = scene.add_geometry(Geometry::plane(20.0));
    let node = scene.add_node("floor", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry: floor, materials: vec![floor_material] }).unwrap();
    let bright = scene.add_material(Material {
        emissive: Vec3::splat(emissive),
        ..Material::opaque("lamp", Vec4::new(1.0, 1.0, 1.0, 1.0))
    });
    let cube = scene.add_geometry(Geometry::cube(0.3));
    let node = scene.add_node("lamp", Transform::from_translation(Vec3::new(0.0, 0.15, 0.0)));
    scene.set_renderable(node, Renderable { geometry: cube, materials: vec![bright] }).unwrap();
    let sun_node = scene.add_node(
        "sun",
        Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::new(0.3, -1.0, 0.2).normalize())),
    );
    scene.set_light(sun_node, Some(Light::directional(sun))).unwrap();
    scene
}

fn camera() -> LookAtResolver {
    LookAtResolver::new(Camera::perspective(0.9, 0.1, None), Vec3::new(0.0, 6.0, 0.01), Vec3::ZERO, SIZE).unwrap()
}

fn luma(p: &image::Rgba<u8>) -> f32 {
    0.2126 * f32::from(p[0]) + 0.7152 * f32::from(p[1]) + 0.0722 * f32::from(p[2])
}

fn mean_luma(image: &image::RgbaImage) -> f32 {
    image.pixels().map(luma).sum::<f32>() / image.pixels().len() as f32
}

#[test]
fn bloom_spreads_a_bright_patch_and_leaves_the_far_image() {
    let mut renderer = support::gpu_renderer();
    let scene = scene(1.0, 40.0);
    let plain = renderer.register_view(ViewDesc::new(camera()), StandardGraph::default()).unwrap();
    let bloom = Bloom { intensity: 0.2, ..Bloom::DEFAULT };
    let bloomed =
        renderer.register_view(ViewDesc::new(camera()), StandardGraph::default().with_bloom(Some(bloom))).unwrap();
    renderer.render_frame(&scene).unwrap();
    let (a, b) = (renderer.read_color(plain).unwrap(), renderer.read_color(bloomed).unwrap());
    // The lamp covers the middle; a ring a few pixels outside it brightens.
    let (cx, cy) = (SIZE.x / 2, SIZE.y / 2);
    let ring: Vec<(u32, u32)> = [(cx + 12, cy), (cx - 12, cy), (cx, cy + 12), (cx, cy - 12)].into();
    for (x, y) in ring {
        let (before, after) = (luma(a.get_pixel(x, y)), luma(b.get_pixel(x, y)));
        eprintln!("ring ({x}, {y}): {before:.2} → {after:.2}");
        // Measured on lavapipe: 14 to 16 levels brighter.
        assert!(after > before + 10.0, "({x}, {y}): {before} without bloom, {after} with");
    }
    // The corners, far from the lamp, stay within two levels (measured: 1).
    for (x, y) in [(2, 2), (SIZE.x - 3, 2), (2, SIZE.y - 3), (SIZE.x - 3, SIZE.y - 3)] {
        let (before, after) = (luma(a.get_pixel(x, y)), luma(b.get_pixel(x, y)));
        eprintln!("corner ({x}, {y}): {before:.2} → {after:.2}");
        assert!((after - before).abs() <= 2.0, "({x}, {y}): {before} without bloom, {after} with");
    }
    // The lamp itself gives some of its light away.
    assert!(luma(b.get_pixel(cx, cy)) <= luma(a.get_pixel(cx, cy)));
}

#[test]
fn automatic_exposure_evens_out_light_levels_and_adapts_over_time() {
    let mut renderer = support::gpu_renderer();
    let auto = AutoExposure { speed_brighter: 3.0, speed_darker: 1.0, ..AutoExposure::DEFAULT };
    let graph = StandardGraph::default().with_auto_exposure(Some(auto));
    let view = renderer.register_view(ViewDesc::new(camera()), graph).unwrap();
    let fixed = renderer.register_view(ViewDesc::new(camera()), StandardGraph::default()).unwrap();
    let (dim, bright) = (scene(0.5, 0.0), scene(5.0, 0.0));
    // The first frame takes the exposure it measures at once.
    renderer.render_frame_at(&dim, 0.0).unwrap();
    let dim_auto = mean_luma(&renderer.read_color(view).unwrap());
    let dim_fixed = mean_luma(&renderer.read_color(fixed).unwrap());
    // Ten times the light: frame by frame, 0.1 s apart, the picture comes
    // down toward the settled one instead of jumping there.
    let mut steps = Vec::new();
    let mut time = 0.0;
    for _ in 0..3 {
        time += 0.1;
        renderer.render_frame_at(&bright, time).unwrap();
        steps.push(mean_luma(&renderer.read_color(view).unwrap()));
    }
    let bright_fixed = mean_luma(&renderer.read_color(fixed).unwrap());
    for _ in 0..40 {
        time += 0.1;
        renderer.render_frame_at(&bright, time).unwrap();
    }
    let bright_auto = mean_luma(&renderer.read_color(view).unwrap());
    eprintln!(
        "fixed: {dim_fixed:.1} → {bright_fixed:.1}; automatic: {dim_auto:.1}, then {steps:.1?}, settled {bright_auto:.1}"
    );
    assert!(bright_fixed > dim_fixed + 40.0, "the fixed exposure shows the change: {dim_fixed} → {bright_fixed}");
    // Measured on lavapipe: 105.1 and 104.9; then 233.1, 194.7 and 167.9.
    assert!((bright_auto - dim_auto).abs() < 1.0, "settled within a level: {dim_auto} and {bright_auto}");
    assert!(steps.windows(2).all(|w| w[1] < w[0] - 15.0), "coming down frame by frame: {steps:?}");
    assert!(steps[2] > bright_auto + 40.0, "still on its way after 0.3 s: {steps:?}, settled {bright_auto}");
}

#[test]
fn views_without_effects_keep_no_buffers_and_bad_settings_are_refused() {
    let mut renderer = support::gpu_renderer();
    let scene = scene(1.0, 2.0);
    renderer.register_view(ViewDesc::new(camera()), StandardGraph::default()).unwrap();
    renderer.render_frame(&scene).unwrap();
    assert_eq!(renderer.internals().lighting.tone_map_effect_views(), 0);
    let bad = Bloom { levels: 0, ..Bloom::DEFAULT };
    let view = renderer.register_view(ViewDesc::new(camera()), StandardGraph::default().with_bloom(Some(bad))).unwrap();
    let frame = renderer.render_frame(&scene).err().map(|e| e.to_string()).unwrap_or_default();
    let read = renderer.read_color(view).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(frame.contains("levels") || read.contains("levels"), "frame: {frame:?}, read: {read:?}");
}
