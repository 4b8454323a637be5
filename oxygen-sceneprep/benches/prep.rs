//! ScenePrep throughput on a synthetic city, against the memory floor.
//!
//! ```text
//! cargo bench -p oxygen-sceneprep --bench prep            # full table (N up to 1M)
//! cargo bench -p oxygen-sceneprep --bench prep -- --quick # N up to 100k
//! cargo test -p oxygen-sceneprep --bench prep -- --smoke  # toy sizes, unoptimised: does it run?
//! ```
//!
//! For each city size N and view count V it reports the mean `prepare` time
//! (frame phase + V view phases + finalization, CPU only), ns per renderable
//! per view, and the ratio to a `memcpy` of the bytes prep must read and
//! write, timed in the same run:
//!
//! * read: each view scans the renderable list (a `RenderableEntry` and a
//!   `SubmeshEntry` per renderable);
//! * write: world + normal matrices once per frame, one `DrawMetadata` per draw.
//!
//! It also times the draw sort: radix sort against `sort_unstable` on the same keys.
//!
//! `--smoke` runs every step at toy sizes (N = 1000, 1 and 6 views, a few
//! milliseconds a measurement): a check that the bench runs, not a
//! measurement. With `OXYGEN_RECORD_DIR` set, every table is appended as
//! one record to `$OXYGEN_RECORD_DIR/prep.jsonl` (`oxygen_demo::record`;
//! a relative directory is under the workspace root, although `cargo bench`
//! runs this in `oxygen-sceneprep/`).

use std::hint::black_box;
use std::time::{Duration, Instant};

use glam::{UVec2, Vec3, Vec4};
use oxygen_bindless::SlotAllocators;
use oxygen_core::{AlphaMode, Camera, Geometry, LookAtResolver, Material, Renderable, ResolvedView, Scene, Transform};
use oxygen_core::{ViewContext, ViewResolver};
use oxygen_demo::record::{Record, Row};
use oxygen_sceneprep::testing::radix_sort_by_key;
use oxygen_sceneprep::{
    CullBound, DrawMetadata, NormalMatrix, RenderableEntry, ScenePrep, SubmeshEntry, ViewPrepOptions, ViewRequest,
};

const SPACING: f32 = 12.0;

/// A square city of `n` buildings: boxes of random heights on a grid, four
/// meshes, eight materials (mostly opaque, some masked and blended).
fn city(n: usize) -> (Scene, f32) {
    let mut scene = Scene::new();
    let meshes: Vec<_> = (0..4).map(|i| scene.add_geometry(Geometry::cube(1.0 + i as f32 * 0.25))).collect();
    let materials: Vec<_> = (0..8)
        .map(|i| {
            let alpha_mode = match i {
                6 => AlphaMode::Mask { cutoff: 0.5 },
                7 => AlphaMode::Blend,
                _ => AlphaMode::Opaque,
            };
            scene.add_material(Material { alpha_mode, ..Material::opaque(format!("m{i}"), Vec4::ONE) })
        })
        .collect();
    let side = (n as f32).sqrt().ceil() as usize;
    let mut state = 0x2545_f491_4f6c_dd1du64;
    for i in 0..n {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let (x, z) = ((i % side) as f32 * SPACING, (i / side) as f32 * SPACING);
        let height = 2.0 + (state % 40) as f32;
        let t = Transform::from_translation(Vec3::new(x, height * 0.5, z)).with_scale(Vec3::new(6.0, height, 6.0));
        let node = scene.add_node(format!("b{i}"), t);
        let renderable = Renderable {
            geometry: meshes[(state >> 8) as usize % 4],
            materials: vec![materials[(state >> 16) as usize % 8]],
        };
        // Handles were created above; this cannot fail.
        scene.set_renderable(node, renderable).expect("valid city handles");
    }
    (scene, side as f32 * SPACING)
}

/// `v` cameras around and above the city, each looking across it.
fn views(scene: &Scene, extent: f32, v: usize) -> Vec<ResolvedView> {
    let center = Vec3::new(extent * 0.5, 0.0, extent * 0.5);
    (0..v)
        .map(|i| {
            let angle = i as f32 / v as f32 * std::f32::consts::TAU;
            let eye = center + Vec3::new(angle.cos(), 0.0, angle.sin()) * extent * 0.35 + Vec3::Y * 60.0;
            let resolver = LookAtResolver {
                camera: Camera::perspective(60f32.to_radians(), 0.5, Some(extent)),
                eye,
                target: center + Vec3::new(-angle.cos(), 0.0, -angle.sin()) * extent * 0.1,
                up: Vec3::Y,
                viewport: UVec2::new(1920, 1080),
            };
            let ctx = ViewContext { view_id: oxygen_demo::view_id(i as u32), frame_index: 1, time_seconds: 0.0 };
            resolver.resolve(&ctx, scene).expect("bench cameras are valid")
        })
        .collect()
}

/// Mean seconds per call of `f`, repeated for about `budget` (at least 3 times).
fn time_it(budget: Duration, mut f: impl FnMut()) -> f64 {
    // Twice: prepared frames alternate between two buffer sets, and both
    // must have grown (and been faulted in) before timing.
    f();
    f();
    let start = Instant::now();
    let mut runs = 0;
    while runs < 3 || start.elapsed() < budget {
        f();
        runs += 1;
    }
    start.elapsed().as_secs_f64() / runs as f64
}

fn main() -> Result<(), oxygen_demo::record::RecordError> {
    let quick = std::env::args().any(|a| a == "--quick");
    let smoke = std::env::args().any(|a| a == "--smoke");
    let sizes: &[usize] = match (smoke, quick) {
        (true, _) => &[1_000],
        (false, true) => &[10_000, 100_000],
        (false, false) => &[10_000, 100_000, 1_000_000],
    };
    let view_counts: &[usize] = if smoke { &[1, 6] } else { &[1, 6, 24] };
    let budget = Duration::from_millis(match (smoke, quick) {
        (true, _) => 5,
        (false, true) => 300,
        (false, false) => 1500,
    });
    let mut record = Record::new("prep")
        .value(
            "mode",
            if smoke {
                "smoke"
            } else if quick {
                "quick"
            } else {
                "full"
            },
        )
        .value("budget_ms_per_measurement", budget.as_secs_f64() * 1e3)
        .value("threads_available", std::thread::available_parallelism().map_or(1, |t| t.get()));

    println!(
        "| N | V | draws/frame | prep ms (static) | ns / renderable / view | memcpy floor ms | prep / floor | V-view / 1-view (static) | prep ms (all moved) | V-view / 1-view (all moved) |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for &n in sizes {
        eprintln!("building a city of {n} renderables…");
        let (scene, extent) = city(n);
        let (mut one_view_seconds, mut one_view_moving) = (0.0, 0.0);
        for &v in view_counts {
            let resolved = views(&scene, extent, v);
            let requests: Vec<_> =
                resolved.iter().map(|view| ViewRequest { view, options: Default::default() }).collect();
            let mut prep = ScenePrep::new();
            let mut slots = SlotAllocators::new(u64::MAX / 2);
            let mut draws = 0;
            let seconds = time_it(budget, || {
                let frames = prep.prepare(&scene, &requests, &mut slots).expect("prepare");
                draws = frames.iter().map(|f| f.draws().len()).sum::<usize>();
                black_box(frames);
            });
            // Every node moved: the frame phase re-collects all transforms,
            // bounds and lights each frame.
            let moving = time_it(budget, || {
                prep.invalidate_frame_cache();
                black_box(prep.prepare(&scene, &requests, &mut slots).expect("prepare").len());
            });
            if v == 1 {
                one_view_seconds = seconds;
                one_view_moving = moving;
            }
            let floor_bytes = v * n * (size_of::<RenderableEntry>() + size_of::<SubmeshEntry>())
                + n * (size_of::<[[f32; 4]; 4]>() + size_of::<NormalMatrix>())
                + draws * size_of::<DrawMetadata>();
            let source = vec![1u8; floor_bytes];
            let mut destination = vec![0u8; floor_bytes];
            let floor = time_it(budget / 4, || {
                destination.copy_from_slice(black_box(&source));
                black_box(&mut destination);
            });
            record.push_row(
                Row::new()
                    .value("renderables", n)
                    .value("views", v)
                    .value("draws_per_frame", draws)
                    .value("prep_ms_static_mean", seconds * 1e3)
                    .value("ns_per_renderable_per_view", seconds * 1e9 / (n * v) as f64)
                    .value("memcpy_floor_ms_mean", floor * 1e3)
                    .value("memcpy_floor_bytes", floor_bytes)
                    .value("prep_over_floor", seconds / floor)
                    .value("v_view_over_one_view_static", seconds / one_view_seconds)
                    .value("v_view_over_one_view_aim", 1.0 + 0.3 * (v as f64 - 1.0))
                    .value("prep_ms_all_moved_mean", moving * 1e3)
                    .value("v_view_over_one_view_all_moved", moving / one_view_moving),
            );
            println!(
                "| {n} | {v} | {draws} | {:.2} | {:.1} | {:.3} | {:.1}× | {:.2} (aim {:.1}) | {:.2} | {:.2} |",
                seconds * 1e3,
                seconds * 1e9 / (n * v) as f64,
                floor * 1e3,
                seconds / floor,
                seconds / one_view_seconds,
                1.0 + 0.3 * (v as f64 - 1.0),
                moving * 1e3,
                moving / one_view_moving,
            );
        }
    }

    // The cull-bound knob: the sphere test is cheaper per object but keeps
    // more draws (the `sphere_culling_keeps_a_superset` test reports how many).
    let n = if smoke { 1_000 } else { 100_000 };
    let (scene, extent) = city(n);
    let resolved = views(&scene, extent, 6);
    println!();
    println!("| cull bound (N = {n}, V = 6) | prep ms | draws/frame |");
    println!("|---|---:|---:|");
    for cull in [CullBound::Aabb, CullBound::Sphere] {
        let options = ViewPrepOptions { cull, ..Default::default() };
        let requests: Vec<_> = resolved.iter().map(|view| ViewRequest { view, options }).collect();
        let mut prep = ScenePrep::new();
        let mut slots = SlotAllocators::new(u64::MAX / 2);
        let mut draws = 0;
        let seconds = time_it(budget, || {
            let frames = prep.prepare(&scene, &requests, &mut slots).expect("prepare");
            draws = frames.iter().map(|f| f.draws().len()).sum::<usize>();
        });
        println!("| {cull:?} | {:.2} | {draws} |", seconds * 1e3);
        record.push_row_to(
            "cull_rows",
            Row::new()
                .value("renderables", n)
                .value("views", 6)
                .value("cull_bound", format!("{cull:?}"))
                .value("prep_ms_mean", seconds * 1e3)
                .value("draws_per_frame", draws),
        );
    }

    // Threads: the same frame on 1 thread and on all of them.
    let requests: Vec<_> = resolved.iter().map(|view| ViewRequest { view, options: Default::default() }).collect();
    let mut per_threads = Vec::new();
    for threads in [1, std::thread::available_parallelism().map_or(1, |t| t.get())] {
        let mut prep = ScenePrep::with_threads(threads);
        let mut slots = SlotAllocators::new(u64::MAX / 2);
        per_threads.push((
            threads,
            time_it(budget, || {
                black_box(prep.prepare(&scene, &requests, &mut slots).map(|f| f.len())).map(|_| ()).expect("prepare")
            }),
        ));
    }
    println!();
    for (threads, seconds) in &per_threads {
        println!("N = {n}, V = 6 on {threads} thread(s): {:.2} ms", seconds * 1e3);
        record.push_row_to(
            "thread_rows",
            Row::new()
                .value("renderables", n)
                .value("views", 6)
                .value("threads", *threads)
                .value("prep_ms_mean", seconds * 1e3),
        );
    }

    // Sort: radix against the standard unstable comparison sort, 100k keys
    // shaped like real ones (few pass classes and materials, varied depth).
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let key_count: u32 = if smoke { 1_000 } else { 100_000 };
    let keys: Vec<(u64, u32)> = (0..key_count)
        .map(|i| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let key = (state % 3) << 62
                | (state >> 20 & 1) << 61
                | (state >> 24 & 63) << 40
                | (state >> 30 & 0xff_ffff) << 16;
            (key, i)
        })
        .collect();
    let mut work = keys.clone();
    let mut scratch = Vec::new();
    let radix = time_it(budget, || {
        work.clone_from(&keys);
        radix_sort_by_key(&mut work, &mut scratch);
    });
    let copy_only = time_it(budget, || work.clone_from(&keys));
    let comparison = time_it(budget, || {
        work.clone_from(&keys);
        work.sort_unstable();
    });
    println!();
    println!(
        "sort of {key_count} draw keys: radix {:.3} ms, sort_unstable {:.3} ms (copy of the input {:.3} ms included in both): radix is {:.2}× faster",
        radix * 1e3,
        comparison * 1e3,
        copy_only * 1e3,
        (comparison - copy_only) / (radix - copy_only)
    );
    let speed_up = (comparison - copy_only) / (radix - copy_only);
    record
        .value("sort_keys", key_count)
        .value("sort_radix_ms_mean", radix * 1e3)
        .value("sort_unstable_ms_mean", comparison * 1e3)
        .value("sort_input_copy_ms_mean", copy_only * 1e3)
        .value("sort_radix_speed_up", speed_up.is_finite().then_some(speed_up))
        .write()?;
    Ok(())
}
