//! Slot lifetimes over a long run: 10 000 frames in which views and nodes
//! come and go must leak no slot and must not grow the domains past what the
//! busiest frame needed (with room for fragmentation).

use glam::{UVec2, Vec3, Vec4};
use oxygen_bindless::{DomainKind, SlotAllocators};
use oxygen_core::{
    Camera, Geometry, LookAtResolver, Material, NodeKey, Renderable, Scene, Transform, ViewContext, ViewResolver,
};
use oxygen_sceneprep::{ScenePrep, ViewRequest};

#[test]
fn ten_thousand_frames_of_churn_leak_no_slots_and_stay_bounded() {
    let mut scene = Scene::new();
    let meshes = [scene.add_geometry(Geometry::cube(1.0)), scene.add_geometry(Geometry::quad(1.0))];
    let material = scene.add_material(Material::opaque("m", Vec4::ONE));
    let mut nodes: Vec<NodeKey> = Vec::new();
    let mut prep = ScenePrep::with_threads(2);
    let mut slots = SlotAllocators::default();
    let mut state = 0x853c_49e6_748f_ea9bu64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut live_views: Vec<u32> = Vec::new();
    let mut next_view = 0u32;
    let mut peak_draws = 0u64;
    let mut peak_high_water = 0u64;

    for frame in 0..10_000u32 {
        // Churn: add or remove a few nodes, open or close a view.
        for _ in 0..(next() % 4) {
            if nodes.len() < 40 || next() % 2 == 0 {
                let at = Vec3::new((next() % 20) as f32 - 10.0, 0.0, -((next() % 30) as f32) - 2.0);
                let node = scene.add_node(format!("n{frame}"), Transform::from_translation(at));
                let geometry = meshes[(next() % 2) as usize];
                scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
                nodes.push(node);
            } else {
                let victim = nodes.swap_remove((next() % nodes.len() as u64) as usize);
                scene.remove_node(victim).unwrap();
            }
        }
        if live_views.is_empty() || (next() % 8 == 0 && live_views.len() < 6) {
            live_views.push(next_view);
            next_view += 1;
        } else if next() % 8 == 0 {
            let gone = live_views.remove((next() % live_views.len() as u64) as usize);
            prep.forget_view(oxygen_demo::view_id(gone), &mut slots).unwrap();
        }

        let views: Vec<_> = live_views
            .iter()
            .map(|id| {
                let resolver = LookAtResolver {
                    camera: Camera::perspective(1.0 + (*id % 3) as f32 * 0.3, 0.1, Some(100.0)),
                    eye: Vec3::new(0.0, 2.0, 5.0),
                    target: Vec3::new((*id % 5) as f32 - 2.0, 0.0, -10.0),
                    up: Vec3::Y,
                    viewport: UVec2::new(64, 64),
                };
                let ctx =
                    ViewContext { view_id: oxygen_demo::view_id(*id), frame_index: frame as u64, time_seconds: 0.0 };
                resolver.resolve(&ctx, &scene).unwrap()
            })
            .collect();
        let requests: Vec<_> = views.iter().map(|view| ViewRequest { view, options: Default::default() }).collect();
        let frames = prep.prepare(&scene, &requests, &mut slots).unwrap();
        let draws: u64 = frames.iter().map(|f| f.draws().len() as u64).sum();
        peak_draws = peak_draws.max(draws);
        peak_high_water = peak_high_water.max(slots.get(DomainKind::DrawMetadata).high_water() as u64);
    }
    // The GPU buffer follows the high-water mark: bounded by the busiest
    // frame's draws, with at most that much again lost to fragmentation.
    assert!(peak_high_water <= 2 * peak_draws, "draw domain grew to {peak_high_water} for at most {peak_draws} draws");

    // Per-view domains: only the live views' ranges remain; after forgetting
    // them, nothing.
    for id in live_views.drain(..) {
        prep.forget_view(oxygen_demo::view_id(id), &mut slots).unwrap();
    }
    for kind in [DomainKind::DrawMetadata, DomainKind::IndirectArgs] {
        assert_eq!(slots.get(kind).live_allocations(), 0, "{kind:?} leaked");
        assert_eq!(slots.get(kind).high_water(), 0, "{kind:?} free list did not coalesce back");
    }
    // Frame-global domains hold exactly this frame's ranges.
    for kind in [DomainKind::WorldTransforms, DomainKind::NormalTransforms] {
        assert_eq!(slots.get(kind).live_allocations(), 1, "{kind:?}");
        assert_eq!(slots.get(kind).live_slots(), prep.frame_collection().renderables.len() as u64);
        assert!(slots.get(kind).high_water() <= 2 * 80, "{kind:?} grew to {}", slots.get(kind).high_water());
    }
    // Geometry: two meshes, allocated once each, never more.
    assert_eq!(slots.get(DomainKind::Vertices).live_allocations(), 2);
    assert_eq!(slots.get(DomainKind::Vertices).high_water(), 24 + 4);
    assert!(peak_draws > 0);
}
