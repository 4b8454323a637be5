//! Views on a schedule ([`oxygen::schedule`]): a view every Nth frame, at a
//! rate, once, on demand or "when changed" renders exactly then, keeps its
//! last image in between (and views linked to it read that image), and the
//! frame report says why each view rendered or stayed idle.

mod support;

use oxygen::glam::Vec4;
use oxygen::prelude::*;
use oxygen::schedule::{Change, IdleReason, RenderReason, Schedule};
use oxygen::{FrameReport, RenderError};

/// Whether `view` rendered in the frame `report` describes, and why.
fn why(report: &FrameReport, view: ViewId) -> Option<RenderReason> {
    report.views.iter().find(|v| v.view == view).and_then(|v| v.why)
}

/// Why `view` stayed idle in that frame, if it did.
fn idle(report: &FrameReport, view: ViewId) -> Option<IdleReason> {
    report.idle.iter().find(|v| v.view == view).map(|v| v.reason)
}

/// Moves the demo's first cube to height `y` (it is in front of the main
/// camera).
fn lift(demo: &mut oxygen_demo::DemoScene, y: f32) {
    let at = Transform::from_translation(Vec3::new(0.0, y, 0.0));
    demo.scene.set_local_transform(demo.cubes[0], at).unwrap();
}

#[test]
fn every_third_frame_renders_on_frames_one_four_seven_and_keeps_its_image_between() {
    let mut demo = oxygen_demo::multi_view_scene();
    let mut renderer = support::gpu_renderer();
    let size = UVec2::new(64, 48);
    let every = renderer.register_view(oxygen_demo::main_camera(size), standard_render_graph).unwrap();
    let third = renderer
        .register_view(
            ViewDesc::new(oxygen_demo::main_camera(size)).with_schedule(Schedule::EveryNth(3)),
            standard_render_graph,
        )
        .unwrap();
    let mut rendered = Vec::new();
    let mut last_image = None;
    for frame in 1..=7u64 {
        // Something moves every frame: an idle view would show it if it rendered.
        lift(&mut demo, 0.5 + frame as f32 * 0.3);
        let report = renderer.render_frame(&demo.scene).unwrap();
        assert_eq!(why(&report, every), Some(RenderReason::EveryFrame));
        let image = renderer.read_color(third).unwrap();
        match why(&report, third) {
            Some(reason) => {
                rendered.push(frame);
                let want = if frame == 1 { RenderReason::FirstFrame } else { RenderReason::Due };
                assert_eq!(reason, want, "frame {frame}");
                // It shows this frame's scene: the every-frame view's picture.
                assert_eq!(image, renderer.read_color(every).unwrap(), "frame {frame}: rendered now");
            }
            None => {
                let next = [4, 7, 10].into_iter().find(|f| *f > frame).unwrap();
                assert_eq!(idle(&report, third), Some(IdleReason::NotDue { next_frame: next }), "frame {frame}");
                assert_eq!(Some(&image), last_image.as_ref(), "frame {frame}: its last image, unchanged");
                assert_ne!(image, renderer.read_color(every).unwrap(), "frame {frame}: the scene moved since");
            }
        }
        last_image = Some(image);
    }
    assert_eq!(rendered, [1, 4, 7]);
}

#[test]
fn a_rate_renders_at_its_rate_of_frame_time() {
    let demo = oxygen_demo::multi_view_scene();
    let mut renderer = support::gpu_renderer();
    let sensor = ViewDesc::new(oxygen_demo::main_camera(UVec2::new(32, 24))).with_schedule(Schedule::Rate(30.0));
    let sensor = renderer.register_view(sensor, standard_render_graph).unwrap();
    // 100 frames a second for one second: a 30 Hz sensor renders 30 times,
    // at the first frame at or after each thirtieth of a second.
    let mut times = Vec::new();
    for i in 0..100 {
        let t = f64::from(i) * 0.01;
        let report = renderer.render_frame_at(&demo.scene, t).unwrap();
        if why(&report, sensor).is_some() {
            times.push(t);
        } else {
            assert!(matches!(idle(&report, sensor), Some(IdleReason::RateNotDue { .. })), "{t}");
        }
    }
    assert_eq!(times.len(), 30, "{times:?}");
    for (k, t) in times.iter().enumerate() {
        let due = k as f64 / 30.0;
        assert!(*t >= due - 1e-6 && *t < due + 0.01 + 1e-6, "render {k} at {t}, due at {due}");
    }
    // A bad rate is refused, with the reason.
    let bad = ViewDesc::new(oxygen_demo::main_camera(UVec2::new(8, 8))).with_schedule(Schedule::Rate(0.0));
    let refused = renderer.register_view(bad, standard_render_graph);
    assert!(
        matches!(&refused, Err(RenderError::InvalidSchedule { reason, .. }) if reason.contains("rate")),
        "{refused:?}"
    );
    assert!(renderer.set_schedule(sensor, Schedule::EveryNth(0)).is_err());
}

#[test]
fn once_and_on_demand_render_when_asked() {
    let mut demo = oxygen_demo::multi_view_scene();
    let mut renderer = support::gpu_renderer();
    let size = UVec2::new(32, 24);
    let once = ViewDesc::new(oxygen_demo::main_camera(size)).with_schedule(Schedule::Once);
    let once = renderer.register_view(once, standard_render_graph).unwrap();
    let asked = ViewDesc::new(oxygen_demo::main_camera(size)).with_schedule(Schedule::OnDemand);
    let asked = renderer.register_view(asked, standard_render_graph).unwrap();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(why(&report, once), Some(RenderReason::FirstFrame));
    assert_eq!(idle(&report, asked), Some(IdleReason::NotRequested));
    // Never rendered: its readback says why.
    assert!(matches!(renderer.read_color(asked), Err(RenderError::NotRendered(_))));
    lift(&mut demo, 2.0);
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(idle(&report, once), Some(IdleReason::NotRequested));
    renderer.request_render(asked).unwrap();
    renderer.request_render(once).unwrap();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(why(&report, asked), Some(RenderReason::Requested));
    assert_eq!(why(&report, once), Some(RenderReason::Requested));
    assert_eq!(renderer.read_color(asked).unwrap(), renderer.read_color(once).unwrap());
    // Asked once, rendered once.
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(idle(&report, asked), Some(IdleReason::NotRequested));
    renderer.unregister_view(asked).unwrap();
    assert!(matches!(renderer.request_render(asked), Err(RenderError::NoSuchView(_))), "an unknown view");
}

#[test]
fn when_changed_renders_for_changes_in_its_frustum_and_not_for_others() {
    let mut demo = oxygen_demo::multi_view_scene();
    // A box far behind the camera, outside its frustum.
    let grey = demo.scene.add_material(Material::opaque("grey", Vec4::splat(0.5)));
    let cube = demo.scene.add_geometry(Geometry::cube(1.0));
    let behind = demo.scene.add_node("behind", Transform::from_translation(Vec3::new(30.0, 30.0, 60.0)));
    demo.scene.set_renderable(behind, Renderable { geometry: cube, materials: vec![grey] }).unwrap();
    let mut renderer = support::gpu_renderer();
    let size = UVec2::new(48, 36);
    let camera = oxygen_demo::main_camera(size);
    let watcher = ViewDesc::new(camera).with_schedule(Schedule::WhenChanged);
    let watcher = renderer.register_view(watcher, standard_render_graph).unwrap();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(why(&report, watcher), Some(RenderReason::FirstFrame));
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(idle(&report, watcher), Some(IdleReason::Unchanged), "nothing changed");
    // A node outside its frustum moves (and stays outside): still idle.
    demo.scene.set_local_transform(behind, Transform::from_translation(Vec3::new(31.0, 30.0, 60.0))).unwrap();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(idle(&report, watcher), Some(IdleReason::Unchanged), "a node outside moved");
    // A node inside moves: it renders.
    lift(&mut demo, 2.0);
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(why(&report, watcher), Some(RenderReason::Changed(Change::Node(demo.cubes[0]))));
    // A node outside moves into view: it renders.
    demo.scene.set_local_transform(behind, Transform::from_translation(Vec3::new(0.0, 0.5, 0.0))).unwrap();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(why(&report, watcher), Some(RenderReason::Changed(Change::Node(behind))));
    // A light changes: it renders.
    demo.scene.set_light(demo.sun, Some(Light::directional(0.5))).unwrap();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(why(&report, watcher), Some(RenderReason::Changed(Change::Light(demo.sun))));
    // A material replaced: it renders.
    demo.scene.set_material(grey, Material::opaque("red", Vec4::new(1.0, 0.0, 0.0, 1.0))).unwrap();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(why(&report, watcher), Some(RenderReason::Changed(Change::Assets)));
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(idle(&report, watcher), Some(IdleReason::Unchanged), "settled again");
    // Paused and resumed: the frames between were not watched.
    renderer.set_view_active(watcher, false).unwrap();
    renderer.render_frame(&demo.scene).unwrap();
    renderer.set_view_active(watcher, true).unwrap();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(why(&report, watcher), Some(RenderReason::Changed(Change::Unwatched)));
    // Its camera moves (a resolver that follows a shared eye): it renders,
    // and its picture is the moved camera's, rendered every frame.
    renderer.unregister_view(watcher).unwrap();
    let eye = std::sync::Arc::new(std::sync::Mutex::new(camera.eye));
    let follows = {
        let eye = std::sync::Arc::clone(&eye);
        move |ctx: &oxygen::views::ViewContext, scene: &Scene| {
            let at = *eye.lock().unwrap();
            oxygen::views::ViewResolver::resolve(&LookAtResolver { eye: at, ..camera }, ctx, scene)
        }
    };
    let watcher = renderer
        .register_view(ViewDesc::new(follows).with_schedule(Schedule::WhenChanged), standard_render_graph)
        .unwrap();
    renderer.render_frame(&demo.scene).unwrap();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(idle(&report, watcher), Some(IdleReason::Unchanged));
    let moved = LookAtResolver { eye: Vec3::new(5.0, 7.0, 12.0), ..camera };
    *eye.lock().unwrap() = moved.eye;
    let plain = renderer.register_view(moved, standard_render_graph).unwrap();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(why(&report, watcher), Some(RenderReason::Changed(Change::Camera)));
    assert_eq!(renderer.read_color(watcher).unwrap(), renderer.read_color(plain).unwrap());
}

/// A picture-in-picture view reading an idle view sees its last image; a
/// "when changed" reader renders when its source does.
#[test]
fn a_view_reading_an_idle_view_sees_its_last_image() {
    use oxygen::passes::{CommandRecorder, CompositePass, PassError, RenderContext};
    let demo = oxygen_demo::multi_view_scene();
    let mut renderer = support::gpu_renderer();
    let size = UVec2::new(48, 36);
    let source = ViewDesc::new(oxygen_demo::main_camera(size)).with_schedule(Schedule::EveryNth(2));
    let source = renderer.register_view(source, standard_render_graph).unwrap();
    let graph = async move |ctx: &RenderContext<'_>, rec: &mut CommandRecorder| -> Result<(), PassError> {
        oxygen::graph::RenderGraph::record(&standard_render_graph, ctx, rec).await?;
        CompositePass::new(source.color(), [0.0, 0.0, 1.0, 1.0]).run(ctx, rec).await
    };
    let reader =
        renderer.register_view(ViewDesc::new(oxygen_demo::side_camera(size)).reads(source.color()), graph).unwrap();
    let watcher =
        ViewDesc::new(oxygen_demo::side_camera(size)).reads(source.color()).with_schedule(Schedule::WhenChanged);
    let watcher = renderer.register_view(watcher, graph).unwrap();
    // Nothing else changes: the "when changed" reader wakes for its input alone.
    for frame in 1..=4u64 {
        let report = renderer.render_frame(&demo.scene).unwrap();
        let source_rendered = why(&report, source).is_some();
        assert_eq!(source_rendered, frame % 2 == 1, "frame {frame}");
        // The reader composes the source's image, rendered now or kept.
        assert_eq!(renderer.read_color(reader).unwrap(), renderer.read_color(source).unwrap(), "frame {frame}");
        if frame > 1 {
            if source_rendered {
                assert_eq!(why(&report, watcher), Some(RenderReason::Changed(Change::Input(source))), "frame {frame}");
            } else {
                assert_eq!(idle(&report, watcher), Some(IdleReason::Unchanged), "frame {frame}");
            }
        }
    }
}

/// A batch camera on a schedule keeps its tile (colour and labels) while
/// the other cameras of its page render over the moving scene; those, and
/// it when it renders, draw exactly what the same batch draws with every
/// camera every frame (their page cleared whole there, tile by tile here).
#[test]
fn an_idle_batch_camera_keeps_its_tile_while_the_others_render() {
    let mut demo = oxygen_demo::multi_view_scene();
    let size = UVec2::new(40, 30);
    let cameras = [
        support::looking_at_origin(50.0, Vec3::new(6.0, 7.0, 12.0), size),
        support::looking_at_origin(50.0, Vec3::new(-9.0, 5.0, 8.0), size),
        support::looking_at_origin(50.0, Vec3::new(10.0, 4.0, -6.0), size),
    ];
    // The wall under test (its second camera every other frame) and the
    // same wall with every camera every frame.
    let wall = |slow: Schedule| {
        let mut renderer = support::gpu_renderer();
        let batch = renderer.register_batch(oxygen::batch::BatchDesc::new("wall", size).with_labels()).unwrap();
        let ids: Vec<ViewId> = cameras
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let schedule = if i == 1 { slow } else { Schedule::EveryFrame };
                renderer.add_camera(batch, ViewDesc::new(*c).with_schedule(schedule)).unwrap()
            })
            .collect();
        (renderer, ids)
    };
    let (mut renderer, ids) = wall(Schedule::EveryNth(2));
    let (mut reference, reference_ids) = wall(Schedule::EveryFrame);
    let mut kept = None;
    for frame in 1..=4u64 {
        lift(&mut demo, 0.5 + frame as f32 * 0.4);
        let report = renderer.render_frame(&demo.scene).unwrap();
        reference.render_frame(&demo.scene).unwrap();
        let images = |r: &Renderer, id: ViewId| (r.read_color(id).unwrap(), r.read_labels(id).unwrap());
        for k in [0, 2] {
            let same = images(&renderer, ids[k]) == images(&reference, reference_ids[k]);
            assert!(same, "frame {frame}: camera {k} differs from the every-frame wall's");
        }
        let image = images(&renderer, ids[1]);
        let now = images(&reference, reference_ids[1]);
        if frame % 2 == 1 {
            assert!(why(&report, ids[1]).is_some(), "frame {frame}");
            assert!(image == now, "frame {frame}: rendered now, as the every-frame wall's");
        } else {
            assert_eq!(idle(&report, ids[1]), Some(IdleReason::NotDue { next_frame: frame + 1 }));
            assert!(Some(&image) == kept.as_ref(), "frame {frame}: its tile (colour and labels) kept as it was");
            assert!(image.0 != now.0, "frame {frame}: the scene moved since");
        }
        kept = Some(image);
    }
    // A bad schedule is refused for a batch camera as for any view.
    assert!(matches!(renderer.set_schedule(ids[0], Schedule::EveryNth(0)), Err(RenderError::InvalidSchedule { .. })));
}

/// Each view's GPU time comes with its report (a frame or two late): a
/// lone view's own, a batch's at its first camera; and the views' times
/// fit inside the frame's.
#[test]
fn each_view_reports_its_gpu_time() {
    let demo = oxygen_demo::multi_view_scene();
    let mut renderer = support::gpu_renderer();
    let wanted = oxygen::wgpu::Features::TIMESTAMP_QUERY | oxygen::wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS;
    if !renderer.gpu().features.contains(wanted) {
        support::skip::skip("the adapter writes no timestamps inside command encoders");
        return;
    }
    let size = UVec2::new(48, 36);
    let main = renderer.register_view(oxygen_demo::main_camera(size), standard_render_graph).unwrap();
    let side = renderer.register_view(oxygen_demo::side_camera(size), standard_render_graph).unwrap();
    let batch = renderer.register_batch(oxygen::batch::BatchDesc::new("pair", size)).unwrap();
    let first = renderer.add_camera(batch, oxygen_demo::main_camera(size)).unwrap();
    let second = renderer.add_camera(batch, oxygen_demo::side_camera(size)).unwrap();
    let mut report = renderer.render_frame(&demo.scene).unwrap();
    // Times arrive without waiting: a few frames, then a wait for the GPU.
    for _ in 0..8 {
        renderer.gpu().device.poll(oxygen::wgpu::PollType::wait_indefinitely()).unwrap();
        report = renderer.render_frame(&demo.scene).unwrap();
        if report.views.iter().all(|v| v.view == second || v.gpu_seconds.is_some()) {
            break;
        }
    }
    let time = |view: ViewId| report.views.iter().find(|v| v.view == view).and_then(|v| v.gpu_seconds);
    for view in [main, side, first] {
        let t = time(view).unwrap_or_else(|| panic!("{view} has no GPU time"));
        assert!(t.is_finite() && t > 0.0, "{view}: {t}");
    }
    assert_eq!(time(second), None, "a batch's time is its first camera's");
    let frame = report.gpu_seconds.expect("the frame's GPU time");
    let views: f64 = [main, side, first].into_iter().filter_map(time).sum();
    // The views' and the frame's times come from one frame's timestamps,
    // and the jobs run one after another inside the frame (which also holds
    // the shadow views and the timer's own work): together they never pass
    // the frame's. No lower bound: on lavapipe the timestamps are the CPU's
    // clock, and tests running beside this one stretch the frame between
    // jobs (alone the views measured 0.94 to 0.98 of the frame, beside the
    // other tests 0.35).
    assert!(views <= frame, "views {views} s against the frame's {frame} s");
}

/// Under a frame budget the highest-priority due view renders and the
/// others are deferred, lowest priority first, never more than the bound:
/// with no budget at all (0 s) each frame renders its first view, and every
/// view comes up within `max_deferral` + 1 frames.
#[test]
fn a_frame_budget_defers_the_lowest_priorities_and_starves_none() {
    use oxygen::schedule::FrameBudget;
    let demo = oxygen_demo::multi_view_scene();
    let mut renderer = support::gpu_renderer();
    let size = UVec2::new(16, 12);
    // Priorities 3, 2, 1, 0.
    let views: Vec<ViewId> = (0..4u32)
        .map(|k| {
            let desc = ViewDesc::new(oxygen_demo::main_camera(size)).with_priority(3 - k);
            renderer.register_view(desc, standard_render_graph).unwrap()
        })
        .collect();
    assert!(renderer.set_frame_budget(Some(FrameBudget::new(-1.0))).is_err());
    let budget = FrameBudget { seconds: 0.0, max_deferral: 3 };
    renderer.set_frame_budget(Some(budget)).unwrap();
    // Frame 1: nothing measured yet, so nothing is known to cost: all render.
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert!(views.iter().all(|v| why(&report, *v).is_some()), "frame 1: every view");
    let mut last_rendered = [1u64; 4];
    for frame in 2..=14u64 {
        let report = renderer.render_frame(&demo.scene).unwrap();
        let rendered: Vec<bool> = views.iter().map(|v| why(&report, *v).is_some()).collect();
        let forced: Vec<usize> =
            (0..4).filter(|k| frame - last_rendered[*k] > u64::from(budget.max_deferral)).collect();
        if forced.is_empty() {
            // Only the highest priority: the others deferred, lowest first.
            assert_eq!(rendered, [true, false, false, false], "frame {frame}");
        } else {
            for k in &forced {
                assert!(rendered[*k], "frame {frame}: view {k} deferred past the bound");
            }
        }
        for (k, view) in views.iter().enumerate() {
            if rendered[k] {
                last_rendered[k] = frame;
            } else {
                let frames = (frame - last_rendered[k]) as u32;
                assert_eq!(idle(&report, *view), Some(IdleReason::Deferred { frames }), "frame {frame}: view {k}");
            }
            assert!(frame - last_rendered[k] <= u64::from(budget.max_deferral), "frame {frame}: view {k} starved");
        }
    }
    // Lifted: every view every frame again.
    renderer.set_frame_budget(None).unwrap();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert!(views.iter().all(|v| why(&report, *v).is_some()));
}

/// The budget holds for a batch's cameras as for any view: with no budget
/// at all only the highest-priority camera renders (the others keep their
/// tiles) until the bound brings the others up.
#[test]
fn a_frame_budget_holds_for_a_batchs_cameras() {
    use oxygen::schedule::FrameBudget;
    let demo = oxygen_demo::multi_view_scene();
    let mut renderer = support::gpu_renderer();
    let size = UVec2::new(16, 12);
    let batch = renderer.register_batch(oxygen::batch::BatchDesc::new("wall", size)).unwrap();
    let cameras: Vec<ViewId> = (0..3u32)
        .map(|k| {
            let camera = support::looking_at_origin(50.0, Vec3::new(6.0 - 3.0 * k as f32, 7.0, 12.0), size);
            renderer.add_camera(batch, ViewDesc::new(camera).with_priority(10 - k)).unwrap()
        })
        .collect();
    renderer.set_frame_budget(Some(FrameBudget { seconds: 0.0, max_deferral: 2 })).unwrap();
    renderer.render_frame(&demo.scene).unwrap();
    let kept: Vec<_> = cameras.iter().map(|c| renderer.read_color(*c).unwrap()).collect();
    let report = renderer.render_frame(&demo.scene).unwrap();
    let rendered: Vec<bool> = cameras.iter().map(|c| why(&report, *c).is_some()).collect();
    assert_eq!(rendered, [true, false, false]);
    assert_eq!(idle(&report, cameras[2]), Some(IdleReason::Deferred { frames: 1 }));
    for k in 1..3 {
        assert!(renderer.read_color(cameras[k]).unwrap() == kept[k], "camera {k} keeps its tile");
    }
    renderer.render_frame(&demo.scene).unwrap();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert!(why(&report, cameras[1]).is_some() && why(&report, cameras[2]).is_some(), "brought up by the bound");
}

/// A scene of one grey unit cube at the origin, and a function that adds
/// another at a place.
fn one_cube() -> (Scene, impl Fn(&mut Scene, Vec3)) {
    let mut scene = Scene::new();
    let grey = scene.add_material(Material::opaque("grey", Vec4::splat(0.5)));
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let add = move |scene: &mut Scene, at: Vec3| {
        let node = scene.add_node("cube", Transform::from_translation(at));
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![grey] }).unwrap();
    };
    add(&mut scene, Vec3::ZERO);
    (scene, add)
}

/// A view's report counts the triangles it drew on the CPU path: one cube
/// in view is 12, two are 24.
#[test]
fn a_views_report_counts_its_triangles() {
    let (mut scene, add_cube) = one_cube();
    let mut renderer = support::gpu_renderer();
    let camera = support::looking_at_origin(50.0, Vec3::new(0.0, 2.0, 6.0), UVec2::new(16, 12));
    let view = renderer
        .register_view(ViewDesc::new(camera).with_visibility(oxygen::sceneprep::Visibility::Cpu), standard_render_graph)
        .unwrap();
    let triangles = |report: &FrameReport| report.views.iter().find(|v| v.view == view).and_then(|v| v.triangles);
    assert_eq!(triangles(&renderer.render_frame(&scene).unwrap()), Some(12));
    add_cube(&mut scene, Vec3::new(1.5, 0.0, 0.0));
    assert_eq!(triangles(&renderer.render_frame(&scene).unwrap()), Some(24));
}

/// On a GPU visibility path the GPU counts the draws it keeps and their
/// indices; the report reads the counts back without waiting, so they
/// arrive a frame or two late: one cube in view is 1 draw of 12 triangles,
/// two are 2 of 24.
#[test]
fn a_gpu_views_report_counts_its_draws_and_triangles_from_the_gpus_count() {
    let (mut scene, add_cube) = one_cube();
    let mut renderer = support::gpu_renderer();
    if !renderer.gpu_visibility_supported() {
        support::skip::skip(format_args!("{} cannot run GPU visibility", renderer.gpu().describe()));
        return;
    }
    let camera = support::looking_at_origin(50.0, Vec3::new(0.0, 2.0, 6.0), UVec2::new(16, 12));
    let desc = ViewDesc::new(camera).with_visibility(oxygen::sceneprep::Visibility::GpuFrustum);
    let view = renderer.register_view(desc, standard_render_graph).unwrap();
    // The counts of the latest frame read back, within a few frames.
    let settled = |renderer: &mut Renderer, scene: &Scene, want: (usize, u64)| {
        let mut seen = Vec::new();
        for _ in 0..6 {
            let report = renderer.render_frame(scene).unwrap();
            let counts = report.views.iter().find(|v| v.view == view).map(|v| (v.draws, v.triangles));
            seen.push(counts);
            if counts == Some((want.0, Some(want.1))) {
                return;
            }
            renderer.gpu().device.poll(oxygen::wgpu::PollType::wait_indefinitely()).unwrap();
        }
        panic!("the report never counted {want:?} draws and triangles: {seen:?}");
    };
    settled(&mut renderer, &scene, (1, 12));
    add_cube(&mut scene, Vec3::new(1.5, 0.0, 0.0));
    settled(&mut renderer, &scene, (2, 24));
}

/// A view's report counts the bytes written for it alone: its camera's
/// constants once (while the camera stands still), its draws and commands
/// every frame (64 and 20 bytes each).
#[test]
fn a_views_report_counts_the_bytes_written_for_it() {
    let (mut scene, add_cube) = one_cube();
    let mut renderer = support::gpu_renderer();
    let camera = support::looking_at_origin(50.0, Vec3::new(0.0, 2.0, 6.0), UVec2::new(16, 12));
    // One command per draw, so that each draw adds exactly 64 + 20 bytes.
    let options = oxygen::sceneprep::ViewPrepOptions {
        instancing: oxygen::sceneprep::Instancing::Off,
        visibility: oxygen::sceneprep::Visibility::Cpu,
        ..Default::default()
    };
    let view = renderer.register_view(ViewDesc::new(camera).with_options(options), standard_render_graph).unwrap();
    let uploaded = |report: &FrameReport| report.views.iter().find(|v| v.view == view).map(|v| v.uploaded_bytes);
    let first_frame = uploaded(&renderer.render_frame(&scene).unwrap()).unwrap();
    let still = uploaded(&renderer.render_frame(&scene).unwrap()).unwrap();
    assert!(still >= 64 + 20, "{still} bytes: at least the draw and its command");
    assert!(first_frame > still, "the camera's constants are written once: {first_frame} then {still}");
    add_cube(&mut scene, Vec3::new(1.5, 0.0, 0.0));
    let two = uploaded(&renderer.render_frame(&scene).unwrap()).unwrap();
    assert_eq!(two, still + 64 + 20, "one more draw and command");
}
