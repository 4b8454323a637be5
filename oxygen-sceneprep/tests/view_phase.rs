//! View-phase choices: LOD selection by projected size, depth-only views.

use glam::{UVec2, Vec3, Vec4};
use oxygen_bindless::SlotAllocators;
use oxygen_core::{
    AlphaMode, Camera, Geometry, LodLevel, LookAtResolver, Material, Renderable, ResolvedView, Scene, Transform,
    ViewContext, ViewIds, ViewResolver,
};
use oxygen_sceneprep::{PassMask, ScenePrep, ViewPrepOptions, ViewRequest};

fn view_from(scene: &Scene, distance: f32) -> ResolvedView {
    let camera = LookAtResolver {
        camera: Camera::perspective(60f32.to_radians(), 0.1, None),
        eye: Vec3::new(0.0, 0.0, distance),
        target: Vec3::ZERO,
        up: Vec3::Y,
        viewport: UVec2::new(100, 100),
    };
    camera
        .resolve(&ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 }, scene)
        .unwrap()
}

/// A unit cube (36 indices) with a 2-triangle LOD below 40 % of the screen
/// and a 1-triangle LOD below 5 %.
fn lod_scene() -> Scene {
    let mut scene = Scene::new();
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let quad = scene.add_geometry(Geometry::quad(1.0));
    let triangle = scene.add_geometry(
        Geometry::new(
            "triangle",
            Geometry::quad(1.0).vertices()[..3].to_vec(),
            vec![0, 1, 2],
            vec![oxygen_core::Submesh { first_index: 0, index_count: 3 }],
        )
        .unwrap(),
    );
    let material = scene.add_material(Material::opaque("m", Vec4::ONE));
    let node = scene.add_node("lodded", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry: cube, materials: vec![material] }).unwrap();
    scene
        .set_lods(
            node,
            vec![
                LodLevel { geometry: triangle, below_screen_fraction: 0.05 },
                LodLevel { geometry: quad, below_screen_fraction: 0.4 },
            ],
        )
        .unwrap();
    scene
}

fn index_count_at(scene: &Scene, distance: f32, lod_bias: f32) -> u32 {
    let view = view_from(scene, distance);
    let mut prep = ScenePrep::new();
    let options = ViewPrepOptions { lod_bias, ..Default::default() };
    prep.prepare(scene, &[ViewRequest { view: &view, options }], &mut SlotAllocators::default()).unwrap();
    prep.frames()[0].draws()[0].index_count
}

#[test]
fn lod_follows_projected_size() {
    let scene = lod_scene();
    // Sphere radius √3/2 ≈ 0.87, cot(30°) ≈ 1.73: the diameter covers
    // 3/d of the viewport height at distance d.
    assert_eq!(index_count_at(&scene, 3.0, 1.0), 36, "100 % of the screen: base mesh");
    assert_eq!(index_count_at(&scene, 15.0, 1.0), 6, "20 %: first LOD");
    assert_eq!(index_count_at(&scene, 100.0, 1.0), 3, "3 %: coarsest LOD");
}

#[test]
fn lod_bias_trades_detail_for_speed_explicitly() {
    let scene = lod_scene();
    assert_eq!(index_count_at(&scene, 15.0, 4.0), 36, "bias 4 keeps the base mesh at 20 %");
    assert_eq!(index_count_at(&scene, 3.0, 0.1), 6, "bias 0.1 switches at 100 %");
}

#[test]
fn a_mismatched_lod_is_a_clear_error() {
    let mut scene = lod_scene();
    let two = scene.add_geometry(
        Geometry::new(
            "two submeshes",
            Geometry::quad(1.0).vertices().to_vec(),
            vec![0, 1, 2, 0, 2, 3],
            vec![
                oxygen_core::Submesh { first_index: 0, index_count: 3 },
                oxygen_core::Submesh { first_index: 3, index_count: 3 },
            ],
        )
        .unwrap(),
    );
    let node = scene.nodes().next().unwrap().0;
    let err = scene.set_lods(node, vec![LodLevel { geometry: two, below_screen_fraction: 0.1 }]).unwrap_err();
    assert!(err.to_string().contains("2 submeshes"), "{err}");
}

#[test]
fn a_depth_only_view_drops_transparency_and_sorts_by_depth_not_material() {
    let mut scene = Scene::new();
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let mut add = |name: &str, z: f32, alpha_mode| {
        let material = scene.add_material(Material { alpha_mode, ..Material::opaque(name, Vec4::ONE) });
        let node = scene.add_node(name, Transform::from_translation(Vec3::new(0.0, 0.0, z)));
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![material] }).unwrap();
    };
    add("far opaque, first material", -6.0, AlphaMode::Opaque);
    add("near opaque, second material", 0.0, AlphaMode::Opaque);
    add("glass", -3.0, AlphaMode::Blend);
    let view = view_from(&scene, 5.0);
    let mut prep = ScenePrep::new();
    let options = ViewPrepOptions { depth_only: true, ..Default::default() };
    prep.prepare(&scene, &[ViewRequest { view: &view, options }], &mut SlotAllocators::default()).unwrap();
    let frame = &prep.frames()[0];
    assert_eq!(frame.draws().len(), 2);
    assert!(frame.draws().iter().all(|d| !d.mask().contains(PassMask::TRANSPARENT)));
    assert_eq!(frame.partitions().len(), 1, "one opaque partition");
    // Front to back, although the far cube's material sorts first in a colour view.
    assert!(frame.draws()[0].material_handle > frame.draws()[1].material_handle);
}
