//! Cascade views are ordinary registered views: culled by the same ScenePrep
//! (casters only, depth only) and sharing its frame phase.

mod support;

use std::sync::Arc;

use oxygen::bindless::SlotAllocators;
use oxygen::core::demo::{main_camera, multi_view_scene};
use oxygen::core::{CascadeResolver, CascadeSettings, NodeFlags};
use oxygen::prelude::*;
use oxygen::sceneprep::{ScenePrep, ViewFilter, ViewRequest};

fn shadow_options() -> ViewPrepOptions {
    ViewPrepOptions { filter: ViewFilter::ShadowCastersOnly, depth_only: true, ..Default::default() }
}

fn depth_only_graph<'a>(
    _id: ViewId,
    ctx: &'a RenderContext<'a>,
    rec: &'a mut CommandRecorder,
) -> RenderGraphFuture<'a> {
    Box::pin(async move {
        let mut depth = DepthPrePass::new();
        depth.prepare_resources(ctx, rec).await?;
        depth.execute(ctx, rec).await
    })
}

#[test]
fn four_cascade_views_share_the_frame_phase() {
    let demo = multi_view_scene();
    let mut renderer = support::gpu_renderer();
    let main: Arc<dyn ViewResolver> = Arc::new(main_camera(UVec2::new(64, 48)));
    let settings = CascadeSettings { count: 4, resolution: 256, max_distance: 40.0, ..Default::default() };
    for index in 0..4 {
        let cascade = CascadeResolver { main: Arc::clone(&main), light: demo.sun, settings, index };
        renderer.register_view_with_options(cascade, shadow_options(), depth_only_graph);
    }
    renderer.register_view(main_camera(UVec2::new(64, 48)), standard_render_graph);
    for _ in 0..3 {
        let report = renderer.render_frame(&demo.scene).unwrap();
        assert_eq!(report.views.len(), 5);
        // The nearest slices end before the grid starts; the farther ones hold it.
        assert!(report.views[..4].iter().any(|v| v.draws > 0), "some cascade sees the casters");
    }
    let stats = renderer.scene_prep().stats();
    assert_eq!(stats.frame_phase_runs, 3, "one frame phase per frame, not per view");
    assert_eq!(stats.frame_phase_reuses, 2, "the static scene is collected once");
    assert_eq!(stats.views_prepared, 15);
}

#[test]
fn cascade_view_prepared_frame_dump() {
    let mut demo = multi_view_scene();
    // The ground receives shadows but casts none.
    demo.scene.set_flags(demo.ground, NodeFlags::VISIBLE).unwrap();
    let main: Arc<dyn ViewResolver> = Arc::new(main_camera(UVec2::new(320, 240)));
    let settings = CascadeSettings { count: 2, resolution: 512, max_distance: 30.0, ..Default::default() };
    // Cascade 1 of 2 covers the grid (cascade 0 ends a few metres from the camera).
    let cascade = CascadeResolver { main, light: demo.sun, settings, index: 1 };
    let view =
        cascade.resolve(&ViewContext { view_id: ViewId(7), frame_index: 1, time_seconds: 0.0 }, &demo.scene).unwrap();
    let mut prep = ScenePrep::new();
    let frames = prep
        .prepare(&demo.scene, &[ViewRequest { view: &view, options: shadow_options() }], &mut SlotAllocators::default())
        .unwrap();
    let frame = &frames[0];
    assert!(frame.draws().iter().all(|d| d.mask().contains(PassMask::CASTS_SHADOWS)));
    assert!(frame.draws().iter().all(|d| d.node_id != oxygen::core::scene::node_index(demo.ground)));
    insta::assert_snapshot!(frame.dump());
}
