//! A steady-state frame allocates nothing: after warm-up, `prepare` (or
//! `begin_frame` and `prepare_views`) of the same scene through several
//! views (on several threads) makes no heap allocation. Counted by a global allocator wrapper, in a test binary
//! without libtest's harness (`harness = false`): the harness's own thread
//! allocates when it registers a running test, and under load it did so
//! while this test counted (seen in `cargo test` runs beside other builds).

use std::sync::atomic::Ordering;

use glam::{UVec2, Vec3};
use oxygen_bindless::SlotAllocators;
use oxygen_core::{LookAtResolver, Transform, ViewContext, ViewResolver};
use oxygen_demo::{main_camera, multi_view_scene, side_camera};
use oxygen_sceneprep::{CullBound, ScenePrep, ViewFilter, ViewPrepOptions, ViewRequest};

mod support;

use support::{ALLOCATIONS, COUNTING};

fn main() {
    steady_state_prepare_makes_no_heap_allocation();
    println!("a steady-state frame allocates nothing: ok");
}

fn steady_state_prepare_makes_no_heap_allocation() {
    let mut demo = multi_view_scene();
    let ctx = |id| ViewContext { view_id: oxygen_demo::view_id(id), frame_index: 1, time_seconds: 0.0 };
    let cameras: [LookAtResolver; 3] =
        [main_camera(UVec2::new(640, 480)), side_camera(UVec2::new(320, 240)), side_camera(UVec2::new(100, 300))];
    let views: Vec<_> =
        cameras.iter().enumerate().map(|(i, c)| c.resolve(&ctx(i as u32), &demo.scene).unwrap()).collect();
    let options = [
        ViewPrepOptions::default(),
        ViewPrepOptions { cull: CullBound::Sphere, ..Default::default() },
        ViewPrepOptions { filter: ViewFilter::ShadowCastersOnly, ..Default::default() },
    ];
    let requests: Vec<_> = views.iter().zip(options).map(|(view, options)| ViewRequest { view, options }).collect();
    let mut prep = ScenePrep::with_threads(3);
    let mut slots = SlotAllocators::default();
    for _ in 0..3 {
        prep.prepare(&demo.scene, &requests, &mut slots).unwrap();
    }

    COUNTING.store(true, Ordering::SeqCst);
    let mut draws = 0;
    for frame in 0..20 {
        // Half the frames move a cube, so the frame phase really re-collects.
        if frame % 2 == 0 {
            let moved = Transform::from_translation(Vec3::new(0.0, 0.5 + frame as f32 * 0.01, 0.0));
            demo.scene.set_local_transform(demo.cubes[4], moved).unwrap();
        }
        // Every other pair of frames takes the two-step path, reading the
        // frame collection in between as a renderer does.
        let frames = if frame % 4 < 2 {
            prep.prepare(&demo.scene, &requests, &mut slots).unwrap()
        } else {
            let collection = prep.begin_frame(&demo.scene, &mut slots).unwrap();
            assert_eq!(collection.shadow_sun, Some(demo.sun));
            prep.prepare_views(&demo.scene, &requests, &mut slots).unwrap()
        };
        draws += frames.iter().map(|f| f.draws().len()).sum::<usize>();
    }
    COUNTING.store(false, Ordering::SeqCst);

    assert!(draws > 0);
    assert_eq!(prep.stats().frame_phase_reuses, 2 + 10, "warm-up reuses 2, then every other frame");
    assert_eq!(ALLOCATIONS.load(Ordering::SeqCst), 0, "steady-state frames allocated");
}
