//! A steady-state frame allocates nothing however many draws its views
//! hold: with thousands of draws the sort of each view's keys takes the
//! radix path, whose second buffer is kept across frames, where a standard
//! stable sort would take a heap buffer every frame. Counted by a global
//! allocator wrapper, in a test binary
//! without libtest's harness (`harness = false`): the harness's own thread
//! allocates when it registers a running test, and under load it did so
//! while such a test counted.

use std::sync::atomic::Ordering;

use glam::{UVec2, Vec3, Vec4};
use oxygen_bindless::SlotAllocators;
use oxygen_core::{
    Camera, Geometry, LookAtResolver, Material, Renderable, Scene, Transform, ViewContext, ViewResolver,
};
use oxygen_sceneprep::{ScenePrep, ViewRequest};

mod support;

use support::{ALLOCATIONS, COUNTING};

fn main() {
    a_steady_frame_of_thousands_of_draws_makes_no_heap_allocation();
    println!("a steady frame of thousands of draws allocates nothing: ok");
}

fn a_steady_frame_of_thousands_of_draws_makes_no_heap_allocation() {
    // 2 500 cubes in a 50 × 50 grid, each with a material of its own (so
    // the keys differ in many bytes), all in view.
    let mut scene = Scene::new();
    let cube = scene.add_geometry(Geometry::cube(0.5));
    for i in 0..2500u32 {
        let material = scene.add_material(Material::opaque(format!("m{i}"), Vec4::ONE));
        let at = Vec3::new((i % 50) as f32 - 25.0, (i / 50) as f32 - 25.0, 0.0);
        let node = scene.add_node(format!("cube {i}"), Transform::from_translation(at));
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![material] }).unwrap();
    }
    let camera = LookAtResolver {
        camera: Camera::perspective(1.2, 0.1, Some(500.0)),
        eye: Vec3::new(0.0, 0.0, 60.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        viewport: UVec2::new(256, 256),
    };
    let context = ViewContext { view_id: oxygen_demo::view_id(0), frame_index: 1, time_seconds: 0.0 };
    let view = camera.resolve(&context, &scene).unwrap();
    let requests = [ViewRequest { view: &view, options: Default::default() }];
    let mut prep = ScenePrep::with_threads(2);
    let mut slots = SlotAllocators::default();
    for _ in 0..3 {
        prep.prepare(&scene, &requests, &mut slots).unwrap();
    }
    assert_eq!(prep.frames()[0].draws().len(), 2500, "every cube in view");

    COUNTING.store(true, Ordering::SeqCst);
    for _ in 0..5 {
        prep.prepare(&scene, &requests, &mut slots).unwrap();
    }
    COUNTING.store(false, Ordering::SeqCst);
    assert_eq!(ALLOCATIONS.load(Ordering::SeqCst), 0, "steady-state frames allocated");
}
