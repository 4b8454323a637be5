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
    // Sphere radius √3/2 ≈ 0.87, cot(30°) ≈ 1.73: the diameter (2 × 0.87
    // at distance d, the viewport 2 × d / 1.73 high) covers 1.5 / d of the
    // viewport height.
    assert_eq!(index_count_at(&scene, 3.0, 1.0), 36, "50 % of the height: base mesh");
    assert_eq!(index_count_at(&scene, 15.0, 1.0), 6, "10 %: first LOD (below 40 %)");
    assert_eq!(index_count_at(&scene, 100.0, 1.0), 3, "1.5 %: coarsest LOD (below 5 %)");
}

#[test]
fn lod_bias_trades_detail_for_speed_explicitly() {
    let scene = lod_scene();
    assert_eq!(index_count_at(&scene, 15.0, 5.0), 36, "bias 5 keeps the base mesh at 10 %");
    assert_eq!(index_count_at(&scene, 3.0, 0.2), 6, "bias 0.2 switches at 50 %");
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

/// A 6 × 8 rectangle at the origin, facing +Z: its bounding sphere's radius
/// is exactly 5 (half the diagonal); with a 3-index LOD below `fraction`.
fn rectangle_with_lod(fraction: f32) -> Scene {
    let mut scene = Scene::new();
    let corner = |x: f32, y: f32| oxygen_core::Vertex::new(Vec3::new(x, y, 0.0), Vec3::Z, glam::Vec2::ZERO);
    let corners = vec![corner(-3.0, -4.0), corner(3.0, -4.0), corner(3.0, 4.0), corner(-3.0, 4.0)];
    let submesh = |index_count| vec![oxygen_core::Submesh { first_index: 0, index_count }];
    let rectangle = Geometry::new("rectangle", corners.clone(), vec![0, 1, 2, 0, 2, 3], submesh(6));
    let triangle = Geometry::new("triangle", corners, vec![0, 1, 2], submesh(3));
    let rectangle = scene.add_geometry(rectangle.unwrap());
    let triangle = scene.add_geometry(triangle.unwrap());
    let material = scene.add_material(Material::opaque("m", Vec4::ONE));
    let node = scene.add_node("rectangle", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry: rectangle, materials: vec![material] }).unwrap();
    scene.set_lods(node, vec![LodLevel { geometry: triangle, below_screen_fraction: fraction }]).unwrap();
    scene
}

/// Index count drawn through an orthographic view 16 units high on each
/// side of its axis (32 in all), from `distance` along +Z.
fn orthographic_index_count(scene: &Scene, distance: f32) -> u32 {
    let camera = LookAtResolver {
        camera: Camera::orthographic(16.0, 0.1, 1000.0),
        eye: Vec3::new(0.0, 0.0, distance),
        target: Vec3::ZERO,
        up: Vec3::Y,
        viewport: UVec2::new(100, 100),
    };
    let context = ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 };
    let view = camera.resolve(&context, scene).unwrap();
    let mut prep = ScenePrep::new();
    let request = ViewRequest { view: &view, options: ViewPrepOptions::default() };
    let frames = prep.prepare(scene, &[request], &mut SlotAllocators::default()).unwrap();
    frames[0].draws()[0].index_count
}

/// Through an orthographic view a renderable covers the same share of the
/// view's height at every distance, so it picks the same LOD from near and
/// from far. The quantity compared with `below_screen_fraction` is, on the
/// CPU as in the GPU cull (`cull.wgsl`), the diameter's share of the
/// view's height, as `LodLevel` describes it: here 10 / 32 = 0.3125 (it was
/// twice that, the diameter over the half-height, until issue 27's
/// mutation work found it). A LOD below 0.5 is drawn, one below 0.25 is not.
#[test]
fn an_orthographic_view_picks_lods_by_size_not_distance() {
    let coarse_below_half = rectangle_with_lod(0.5);
    for distance in [10.0, 500.0] {
        assert_eq!(orthographic_index_count(&coarse_below_half, distance), 3, "LOD at distance {distance}");
    }
    let coarse_below_quarter = rectangle_with_lod(0.25);
    for distance in [10.0, 500.0] {
        assert_eq!(orthographic_index_count(&coarse_below_quarter, distance), 6, "base mesh at distance {distance}");
    }
}

/// A LOD is used only when the projected size is strictly below its
/// screen fraction: at exactly the fraction (here 0.3125, see
/// [`an_orthographic_view_picks_lods_by_size_not_distance`], exact in
/// `f32`) the finer mesh is kept, a hair above it the LOD is used.
#[test]
fn a_lod_at_exactly_its_screen_fraction_is_not_used() {
    assert_eq!(orthographic_index_count(&rectangle_with_lod(0.3125), 10.0), 6);
    assert_eq!(orthographic_index_count(&rectangle_with_lod(0.3126), 10.0), 3);
}

/// A frame counts the indices a depth pre-pass would draw: those of its
/// opaque and masked draws, none of its transparent ones (the automatic
/// pre-pass weighs them against the shading it would spare).
#[test]
fn the_depth_pass_counts_opaque_and_masked_indices_only() {
    let mut scene = Scene::new();
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let quad = scene.add_geometry(Geometry::quad(1.0));
    let mut add = |name: &str, geometry, alpha_mode, x: f32| {
        let material = scene.add_material(Material { alpha_mode, ..Material::opaque(name, Vec4::ONE) });
        let node = scene.add_node(name, Transform::from_translation(Vec3::new(x, 0.0, 0.0)));
        scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
    };
    add("opaque cube", cube, AlphaMode::Opaque, -1.0);
    add("masked quad", quad, AlphaMode::Mask { cutoff: 0.5 }, 0.0);
    add("glass cube", cube, AlphaMode::Blend, 1.0);
    let view = view_from(&scene, 5.0);
    let mut prep = ScenePrep::new();
    let request = ViewRequest { view: &view, options: ViewPrepOptions::default() };
    let frames = prep.prepare(&scene, &[request], &mut SlotAllocators::default()).unwrap();
    assert_eq!(frames[0].draws().len(), 3);
    assert_eq!(frames[0].depth_pass_indices(), 36 + 6, "the opaque cube and the masked quad");
}
