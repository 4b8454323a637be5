//! Recording scaling: the views' graphs recorded on 1 thread against all
//! worker threads, and the first frame (pipeline compilation included) on 1
//! thread against all.
//!
//! ```text
//! cargo run --release --example record_bench [CUBES] [direct|mdi] [V,V,..]   # default 4 000, direct, 6,24
//! ```
//!
//! A field of CUBES boxes under a sun (each view owns two shadow cascades)
//! with a shadow-casting spot light; V = 6 and V = 24 (or the V given)
//! perspective views (480 × 270) on a circle around the field. For each V and each thread
//! count (1, 2, 4, 8 and every core, up to the machine's cores) a fresh
//! renderer renders 2 warm-up and 8 measured frames, each waited for on the
//! GPU, and reports the median of `FrameReport::record_seconds` (the wall
//! time of recording every view's graph) and its speed-up over 1 thread
//! measured in the same run. The direct draw path records one draw call per
//! draw, so recording is real CPU work; with `mdi` it is a few calls per
//! partition. Then the first frame of a fresh renderer with the largest V
//! (every pipeline compiled during it) on 1 thread against all.
//!
//! With `OXYGEN_RECORD_DIR` set, both tables (with every frame's times) are
//! appended as one record to `$OXYGEN_RECORD_DIR/record_bench.jsonl`
//! (`oxygen_demo::record`).

use std::time::Instant;

use oxygen::core::CascadeSettings;
use oxygen::glam::{Quat, Vec4};
use oxygen::lighting::LocalShadowSettings;
use oxygen::passes::DrawPath;
use oxygen::prelude::*;
use oxygen_demo::record::{Record, Row};

const WARM_UP: usize = 2;
const MEASURED: usize = 8;

/// The benchmarks' field of boxes in four materials, with a shadow-casting
/// spot light above its centre.
fn field_of_boxes(count: usize) -> (Scene, f32) {
    let colors: Vec<Vec4> = (0..4).map(|i| Vec4::new(0.3 + 0.15 * i as f32, 0.6, 0.5, 1.0)).collect();
    let (mut scene, extent) = oxygen_demo::field_of_boxes(count, &colors);
    let spot_at = Vec3::new(extent * 0.5, 12.0, extent * 0.5);
    let spot = scene.add_node(
        "spot",
        Transform::from_translation(spot_at).with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::NEG_Y)),
    );
    scene.set_light(spot, Some(Light::spot(500.0, Some(40.0), 0.4, 0.6))).ok();
    (scene, extent)
}

struct Setup<'a> {
    scene: &'a Scene,
    extent: f32,
    path: DrawPath,
}

/// A renderer on `threads` threads with `views` views around the field.
fn renderer(setup: &Setup<'_>, views: usize, threads: usize) -> Result<Renderer, Box<dyn std::error::Error>> {
    let options = RendererOptions {
        draw_path: Some(setup.path),
        prep_threads: Some(threads),
        local_shadows: Some(LocalShadowSettings { resolution: 512, ..Default::default() }),
        ..Default::default()
    };
    let mut renderer = Renderer::new_headless_with(options)?;
    let centre = Vec3::new(setup.extent * 0.5, 0.0, setup.extent * 0.5);
    let settings = CascadeSettings { count: 2, resolution: 512, max_distance: setup.extent, ..Default::default() };
    for v in 0..views {
        let angle = v as f32 / views as f32 * std::f32::consts::TAU;
        let eye = centre + Vec3::new(angle.cos(), 0.0, angle.sin()) * setup.extent * 0.8 + Vec3::Y * setup.extent * 0.4;
        let camera = LookAtResolver::new(
            Camera::perspective(60f32.to_radians(), 0.5, Some(setup.extent * 3.0)),
            eye,
            centre,
            UVec2::new(480, 270),
        )
        .unwrap();
        renderer.register_view(ViewDesc::new(camera).with_sun_shadows(settings), standard_render_graph)?;
    }
    Ok(renderer)
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(f64::NAN)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let count: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(4_000);
    let path = match args.next().as_deref() {
        None | Some("direct") => DrawPath::Direct,
        Some("mdi") => DrawPath::MultiDrawIndirect,
        Some(other) => return Err(format!("unknown draw path '{other}' (direct or mdi)").into()),
    };
    let view_counts: Vec<usize> = match args.next() {
        Some(list) => list.split(',').map(str::parse).collect::<Result<_, _>>()?,
        None => vec![6, 24],
    };
    if view_counts.contains(&0) {
        return Err("every V must be at least 1".into());
    }
    let most_views = view_counts.iter().copied().max().ok_or("no view count given")?;
    let (scene, extent) = field_of_boxes(count);
    let setup = Setup { scene: &scene, extent, path };
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut thread_counts: Vec<usize> = [1, 2, 4, 8].into_iter().filter(|t| *t <= cores).collect();
    if !thread_counts.contains(&cores) {
        thread_counts.push(cores);
    }
    println!("{count} boxes, {path:?} draw path, {cores} cores");
    println!(
        "| views (incl. shadow views) | threads | record ms (median) | speed-up over 1 thread | per thread | views' busy ms (sum) |"
    );
    println!("|---:|---:|---:|---:|---:|---:|");
    let mut adapter = String::new();
    let mut record = Record::new("record_bench")
        .value("boxes", count)
        .value("draw_path", format!("{path:?}"))
        .value("cores", cores)
        .value("warm_up_frames", WARM_UP)
        .value("measured_frames", MEASURED);
    for &views in &view_counts {
        let mut one_thread = None;
        for &threads in &thread_counts {
            let mut renderer = renderer(&setup, views, threads)?;
            adapter = renderer.gpu().describe();
            record.set_adapter(&renderer.gpu().adapter_info);
            let mut times = Vec::with_capacity(MEASURED);
            let mut busy = Vec::with_capacity(MEASURED);
            let mut recorded = 0;
            for frame in 0..WARM_UP + MEASURED {
                let report = renderer.render_frame(setup.scene)?;
                renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
                recorded = report.views.len();
                if frame >= WARM_UP {
                    times.push(report.record_seconds * 1e3);
                    busy.push(report.views.iter().map(|v| v.record_seconds).sum::<f64>() * 1e3);
                }
            }
            let row = Row::new()
                .value("views", views)
                .value("views_incl_shadow_views", recorded)
                .value("threads", threads)
                .value("record_ms_samples", &times)
                .value("views_busy_ms_sum_samples", &busy);
            let time = median(times);
            let base = *one_thread.get_or_insert(time);
            let speed_up = base / time;
            let busy = median(busy);
            println!(
                "| {views} ({recorded}) | {threads} | {time:.2} | {speed_up:.2} | {:.2} | {busy:.2} |",
                speed_up / threads as f64,
            );
            record.push_row(
                row.value("record_ms_median", time)
                    .value("speed_up_over_one_thread", speed_up)
                    .value("speed_up_per_thread", speed_up / threads as f64)
                    .value("views_busy_ms_sum_median", busy),
            );
        }
    }
    println!();
    println!(
        "| first frame, {most_views} views | threads | record ms (pipelines compiled in it) | frame ms (waited) | pipelines |"
    );
    println!("|---|---:|---:|---:|---:|");
    for threads in [1, cores] {
        let mut renderer = renderer(&setup, most_views, threads)?;
        let started = Instant::now();
        let report = renderer.render_frame(setup.scene)?;
        renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
        let ms = started.elapsed().as_secs_f64() * 1e3;
        let record_ms = report.record_seconds * 1e3;
        let pipelines = renderer.internals().pipelines.pipelines_created();
        println!("| | {threads} | {record_ms:.1} | {ms:.1} | {pipelines} |");
        record.push_row_to(
            "first_frame_rows",
            Row::new()
                .value("views", most_views)
                .value("threads", threads)
                .value("record_ms", record_ms)
                .value("frame_ms_waited", ms)
                .value("pipelines_created", pipelines),
        );
    }
    println!("adapter: {adapter}");
    record.write()?;
    Ok(())
}
