//! A frame in two steps: `begin_frame` (the frame phase) and then
//! `prepare_views` (every view of that frame), for a renderer that decides
//! which views exist from what the frame phase found. The two steps give
//! exactly what the one-call `prepare` gives.

use glam::{UVec2, Vec3};
use oxygen_bindless::SlotAllocators;
use oxygen_core::{Camera, Light, LookAtResolver, ResolvedView, Scene, Transform, ViewContext, ViewId, ViewResolver};
use oxygen_demo::{main_camera, multi_view_scene, side_camera, view_id};
use oxygen_sceneprep::{PrepError, ScenePrep, ViewFilter, ViewPrepOptions, ViewRequest};

fn ctx(id: u32) -> ViewContext {
    ViewContext { view_id: view_id(id), frame_index: 1, time_seconds: 0.0 }
}

/// The demo's main and side cameras as views 0 and 1.
fn demo_views(scene: &Scene) -> Vec<ResolvedView> {
    let cameras = [main_camera(UVec2::new(320, 240)), side_camera(UVec2::new(160, 120))];
    cameras.iter().enumerate().map(|(i, c)| c.resolve(&ctx(i as u32), scene).expect("demo cameras are valid")).collect()
}

fn requests(views: &[ResolvedView]) -> Vec<ViewRequest<'_>> {
    views.iter().map(|view| ViewRequest { view, options: ViewPrepOptions::default() }).collect()
}

fn dumps(prep: &ScenePrep) -> Vec<String> {
    prep.frames().iter().map(|f| f.dump()).collect()
}

#[test]
fn begin_frame_then_prepare_views_gives_what_prepare_gives() {
    let mut demo = multi_view_scene();
    let views = demo_views(&demo.scene);
    let requests = requests(&views);
    let (mut one_call, mut two_steps) = (ScenePrep::with_threads(1), ScenePrep::with_threads(2));
    let (mut one_call_slots, mut two_step_slots) = (SlotAllocators::default(), SlotAllocators::default());
    for frame in 0..4 {
        // Odd frames move a cube, so both the reused and the re-collected
        // frame phase are compared.
        if frame % 2 == 1 {
            let moved = Transform::from_translation(Vec3::new(0.0, 0.5 + frame as f32, 0.0));
            demo.scene.set_local_transform(demo.cubes[4], moved).expect("the cube exists");
        }
        one_call.prepare(&demo.scene, &requests, &mut one_call_slots).expect("prepare");
        two_steps.begin_frame(&demo.scene, &mut two_step_slots).expect("begin_frame");
        two_steps.prepare_views(&demo.scene, &requests, &mut two_step_slots).expect("prepare_views");
        assert_eq!(dumps(&one_call), dumps(&two_steps), "frame {frame}");
        for (a, b) in one_call.frames().iter().zip(two_steps.frames()) {
            assert_eq!((a.frame_index(), a.slots()), (b.frame_index(), b.slots()));
            assert_eq!(a.indirect_args(), b.indirect_args());
        }
    }
    assert_eq!(one_call.stats(), two_steps.stats());
}

#[test]
fn prepare_views_without_a_frame_begun_is_an_error() {
    let demo = multi_view_scene();
    let views = demo_views(&demo.scene);
    let requests = requests(&views);
    let mut prep = ScenePrep::new();
    let mut slots = SlotAllocators::default();
    let never_begun = prep.prepare_views(&demo.scene, &requests, &mut slots).map(<[_]>::len);
    assert_eq!(never_begun, Err(PrepError::FrameNotBegun));

    prep.prepare(&demo.scene, &requests, &mut slots).expect("prepare");
    let after_prepare = prep.prepare_views(&demo.scene, &requests, &mut slots).map(<[_]>::len);
    assert_eq!(after_prepare, Err(PrepError::FrameNotBegun), "prepare used up its frame");

    prep.begin_frame(&demo.scene, &mut slots).expect("begin_frame");
    prep.prepare_views(&demo.scene, &requests, &mut slots).expect("prepare_views");
    let twice = prep.prepare_views(&demo.scene, &requests, &mut slots).map(<[_]>::len);
    assert_eq!(twice, Err(PrepError::FrameNotBegun), "each begun frame is prepared once");
    assert_eq!(prep.frames().len(), 2, "a refused call leaves the prepared frames alone");
}

#[test]
fn a_duplicate_view_leaves_the_frame_begun_for_a_corrected_retry() {
    let demo = multi_view_scene();
    let views = demo_views(&demo.scene);
    let mut prep = ScenePrep::new();
    let mut slots = SlotAllocators::default();
    prep.begin_frame(&demo.scene, &mut slots).expect("begin_frame");
    let twice = [ViewRequest { view: &views[1], options: Default::default() }; 2];
    let refused = prep.prepare_views(&demo.scene, &twice, &mut slots).map(<[_]>::len);
    assert_eq!(refused, Err(PrepError::DuplicateView(view_id(1))));
    let frames = prep.prepare_views(&demo.scene, &requests(&views), &mut slots).expect("the corrected retry");
    assert_eq!(frames.len(), 2);
}

#[test]
fn prepare_refuses_a_duplicate_view_before_the_frame_phase_runs() {
    let demo = multi_view_scene();
    let views = demo_views(&demo.scene);
    let mut prep = ScenePrep::new();
    let mut slots = SlotAllocators::default();
    prep.prepare(&demo.scene, &requests(&views), &mut slots).expect("prepare");
    let before = (prep.stats(), dumps(&prep));
    let twice = [ViewRequest { view: &views[0], options: Default::default() }; 2];
    let refused = prep.prepare(&demo.scene, &twice, &mut slots).map(<[_]>::len);
    assert_eq!(refused, Err(PrepError::DuplicateView(view_id(0))));
    assert_eq!((prep.stats(), dumps(&prep)), before, "nothing ran, last frame's views are still there");
}

/// A view from `eye` looking at the demo grid: a stand-in for a shadow
/// resolver, which the renderer owns.
fn look_from(eye: Vec3, id: u32, scene: &Scene) -> ResolvedView {
    let camera = LookAtResolver {
        camera: Camera::perspective(1.4, 0.1, Some(50.0)),
        eye,
        target: Vec3::new(0.0, 0.5, 0.0),
        up: Vec3::Z,
        viewport: UVec2::new(64, 64),
    };
    camera.resolve(&ctx(id), scene).expect("a valid shadow camera")
}

#[test]
fn the_views_of_a_frame_can_be_chosen_from_its_frame_collection() {
    let mut demo = multi_view_scene();
    let spot_positions = [Vec3::new(-3.0, 6.0, 0.0), Vec3::new(3.0, 6.0, 0.0)];
    let spots = spot_positions.map(|at| {
        let node = demo.scene.add_node("spot", Transform::from_translation(at));
        demo.scene.set_light(node, Some(Light::spot(20.0, Some(30.0), 0.3, 0.5))).expect("the node was just added");
        node
    });
    let camera = main_camera(UVec2::new(320, 240)).resolve(&ctx(0), &demo.scene).expect("the demo camera is valid");
    let mut prep = ScenePrep::new();
    let mut slots = SlotAllocators::default();

    let frame = prep.begin_frame(&demo.scene, &mut slots).expect("begin_frame");
    assert_eq!(frame.shadow_sun, Some(demo.sun));
    let shadow_views: Vec<ResolvedView> = frame
        .local_shadow_casters
        .iter()
        .zip(1..)
        .map(|(caster, id)| {
            let light = spot_positions[spots.iter().position(|s| *s == caster.node).expect("one of the spots")];
            look_from(light, id, &demo.scene)
        })
        .collect();
    assert_eq!(shadow_views.len(), 2);
    assert!(prep.frames().is_empty(), "no view is prepared before prepare_views");

    let shadow = ViewPrepOptions { filter: ViewFilter::ShadowCastersOnly, depth_only: true, ..Default::default() };
    let mut requests = vec![ViewRequest { view: &camera, options: ViewPrepOptions::default() }];
    requests.extend(shadow_views.iter().map(|view| ViewRequest { view, options: shadow }));
    let frames = prep.prepare_views(&demo.scene, &requests, &mut slots).expect("prepare_views");
    let ids: Vec<ViewId> = frames.iter().map(|f| f.view_id()).collect();
    assert_eq!(ids, vec![view_id(0), view_id(1), view_id(2)]);
    assert!(frames.iter().all(|f| !f.draws().is_empty()));
    assert!(frames.iter().all(|f| f.slots().world_transforms == frames[0].slots().world_transforms), "shared");
}

/// The renderer takes the prepared frames for its later steps and gives
/// them back: while taken, `frames` is empty; once back, they are the same
/// frames; frames never given back are made anew, so the next frame's
/// dumps are what a fresh ScenePrep gives.
#[test]
fn taken_frames_come_back_or_are_made_anew() {
    let demo = multi_view_scene();
    let views = demo_views(&demo.scene);
    let requests = requests(&views);
    let mut prep = ScenePrep::with_threads(1);
    let mut slots = SlotAllocators::default();
    prep.prepare(&demo.scene, &requests, &mut slots).expect("prepare");
    let expected = dumps(&prep);

    let taken = prep.take_frames();
    assert_eq!(taken.len(), 2);
    assert!(prep.frames().is_empty(), "taken frames are not ScenePrep's until they come back");
    assert_eq!(taken.iter().map(|f| f.dump()).collect::<Vec<_>>(), expected);
    prep.return_frames(taken);
    assert_eq!(dumps(&prep), expected, "the same frames, in request order");

    // Taken and dropped: the next frame makes new ones, as a fresh prep does.
    drop(prep.take_frames());
    prep.prepare(&demo.scene, &requests, &mut slots).expect("prepare after frames were lost");
    let mut fresh = ScenePrep::with_threads(1);
    fresh.prepare(&demo.scene, &requests, &mut SlotAllocators::default()).expect("prepare");
    let strip_frame_index = |d: Vec<String>| -> Vec<String> {
        d.into_iter().map(|s| s.lines().filter(|l| !l.contains("frame")).collect::<Vec<_>>().join("\n")).collect()
    };
    assert_eq!(strip_frame_index(dumps(&prep)), strip_frame_index(dumps(&fresh)));
    assert_eq!(prep.frames().len(), 2);
}
