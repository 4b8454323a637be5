//! Snapshot of the `PreparedSceneFrame` dump for the fixed demo scene and
//! camera: "this scene, this camera → these draws, in this order, in these
//! partitions, at these slots".

use glam::UVec2;
use oxygen_bindless::SlotAllocators;
use oxygen_core::{ViewContext, ViewResolver};
use oxygen_demo::{main_camera, multi_view_scene, side_camera, view_id};
use oxygen_sceneprep::{ScenePrep, ViewPrepOptions, ViewRequest};

fn resolve(resolver: &dyn ViewResolver, id: u32, scene: &oxygen_core::Scene) -> oxygen_core::ResolvedView {
    let ctx = ViewContext { view_id: view_id(id), frame_index: 1, time_seconds: 0.0 };
    resolver.resolve(&ctx, scene).expect("demo cameras resolve")
}

#[test]
fn demo_scene_main_camera_dump() {
    let demo = multi_view_scene();
    let view = resolve(&main_camera(UVec2::new(320, 240)), 0, &demo.scene);
    let mut prep = ScenePrep::new();
    let mut slots = SlotAllocators::default();
    let frames = prep
        .prepare(&demo.scene, &[ViewRequest { view: &view, options: ViewPrepOptions::default() }], &mut slots)
        .unwrap();
    insta::assert_snapshot!(frames[0].dump());
}

#[test]
fn two_views_share_the_frame_phase_and_cull_differently() {
    let demo = multi_view_scene();
    let main = resolve(&main_camera(UVec2::new(320, 240)), 0, &demo.scene);
    let side = resolve(&side_camera(UVec2::new(200, 200)), 1, &demo.scene);
    let mut prep = ScenePrep::new();
    let mut slots = SlotAllocators::default();
    let options = ViewPrepOptions::default();
    prep.prepare(
        &demo.scene,
        &[ViewRequest { view: &main, options }, ViewRequest { view: &side, options }],
        &mut slots,
    )
    .unwrap();
    assert_eq!(prep.stats().frame_phase_runs, 1);
    let frames = prep.frames();
    assert!(std::sync::Arc::ptr_eq(frames[0].transforms(), frames[1].transforms()));
    assert!(frames[1].draws().len() < frames[0].draws().len(), "the close-up side view culls part of the grid");
    insta::assert_snapshot!(format!("{}\n{}", frames[0].dump(), frames[1].dump()));
}
