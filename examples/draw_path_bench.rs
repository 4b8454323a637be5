//! Direct draws against one multi-draw-indirect per partition, on whatever
//! adapter is found (the numbers in docs/performance.md come from an H100).
//!
//! ```text
//! cargo run --release --example draw_path_bench [DRAWS]   # default 100 000
//! ```
//!
//! The scene is a grid of DRAWS small cubes under an orthographic camera that
//! sees all of them, with four materials (opaque / masked × single / double
//! sided), so each pass draws four partitions. Three ways to submit them:
//! direct draws, one multi-draw-indirect per partition with wgpu's indirect
//! validation (its default), and the same without it
//! (`GpuOptions::trust_indirect_args`), each with one command per draw and
//! with instanced runs (`Instancing::Adjacent`: the cubes of one material
//! share one mesh, so each partition becomes one command). For each it renders 5 warm-up and 30
//! measured frames and reports the CPU time to record the view's passes and
//! the GPU time between timestamps written before and after them (when the
//! adapter supports timestamps inside encoders).
//!
//! With `OXYGEN_RECORD_DIR` set, one record of the run (a row per line of
//! the table, with every frame's times) is appended to
//! `$OXYGEN_RECORD_DIR/draw_path_bench.jsonl` (`oxygen_demo::record`).

use std::sync::{Arc, Mutex};

use oxygen::core::{AlphaMode, Projection};
use oxygen::glam::Vec4;
use oxygen::gpu::{GpuContext, GpuOptions};
use oxygen::graph::standard_render_graph;
use oxygen::passes::DrawPath;
use oxygen::prelude::*;
use oxygen::sceneprep::{Instancing, ViewPrepOptions};
use oxygen_demo::record::{Record, Row};

const WARM_UP: usize = 5;
const MEASURED: usize = 30;

fn city_of_cubes(draws: usize) -> (Scene, f32) {
    let mut scene = Scene::new();
    let cube = scene.add_geometry(Geometry::cube(0.8));
    let materials: Vec<_> = [
        (AlphaMode::Opaque, false),
        (AlphaMode::Opaque, true),
        (AlphaMode::Mask { cutoff: 0.5 }, false),
        (AlphaMode::Mask { cutoff: 0.5 }, true),
    ]
    .into_iter()
    .enumerate()
    .map(|(i, (alpha_mode, double_sided))| {
        let color = Vec4::new(0.3 + 0.2 * i as f32, 0.5, 0.8 - 0.15 * i as f32, 1.0);
        scene.add_material(Material { alpha_mode, double_sided, ..Material::opaque(format!("m{i}"), color) })
    })
    .collect();
    let side = (draws as f32).sqrt().ceil() as usize;
    for i in 0..draws {
        let (x, z) = ((i % side) as f32, (i / side) as f32);
        let node = scene.add_node("c", Transform::from_translation(Vec3::new(x, 0.0, z)));
        let renderable = Renderable { geometry: cube, materials: vec![materials[i % 4]] };
        scene.set_renderable(node, renderable).expect("valid handles");
    }
    (scene, side as f32)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let draws: usize = std::env::args().nth(1).map(|a| a.parse()).transpose()?.unwrap_or(100_000);
    let (scene, side) = city_of_cubes(draws);
    let center = Vec3::new(side * 0.5, 0.0, side * 0.5);
    let camera = LookAtResolver {
        camera: Camera { projection: Projection::Orthographic { half_height: side * 0.55, near: 1.0, far: 100.0 } },
        eye: center + Vec3::Y * 50.0,
        target: center,
        up: Vec3::NEG_Z,
        viewport: UVec2::new(1024, 1024),
    };

    println!(
        "| path | indirect validation | instancing | draws | partitions per pass | draw calls per frame | draw commands per frame | CPU record ms | GPU ms | frame ms (CPU, prep + record + submit) |"
    );
    println!("|---|---|---|---:|---:|---:|---:|---:|---:|---:|");
    let mut adapter_line = String::new();
    let mut record = Record::new("draw_path_bench")
        .value("draws", draws)
        .value("warm_up_frames", WARM_UP)
        .value("measured_frames", MEASURED);
    let runs = [
        (DrawPath::Direct, false, Instancing::Off),
        (DrawPath::Direct, false, Instancing::Adjacent),
        (DrawPath::MultiDrawIndirect, false, Instancing::Off),
        (DrawPath::MultiDrawIndirect, true, Instancing::Off),
        (DrawPath::MultiDrawIndirect, true, Instancing::Adjacent),
    ];
    for (path, trust_indirect_args, instancing) in runs {
        let options = GpuOptions {
            optional_features: Renderer::OPTIONAL_FEATURES
                | wgpu::Features::TIMESTAMP_QUERY
                | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS,
            trust_indirect_args,
            ..Default::default()
        };
        let gpu = GpuContext::new_headless(&options)?;
        adapter_line = gpu.describe();
        let timestamps = gpu.features.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS);
        let period_ns = gpu.queue.get_timestamp_period() as f64;
        let query_set = timestamps.then(|| {
            gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("bench"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            })
        });
        let resolve = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps"),
            size: 16,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps readback"),
            size: 16,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut renderer =
            Renderer::with_options(gpu, RendererOptions { draw_path: Some(path), ..Default::default() })?;
        record.set_adapter(&renderer.gpu().adapter_info);
        let shared = Arc::new(Mutex::new((query_set.clone(), resolve.clone(), readback.clone())));
        let graph_resources = Arc::clone(&shared);
        let graph = async move |ctx: &RenderContext<'_>, rec: &mut CommandRecorder| {
            let resources = graph_resources.lock().map(|g| g.clone()).ok();
            if let Some((Some(q), _, _)) = &resources {
                rec.encoder().write_timestamp(q, 0);
            }
            standard_render_graph.record(ctx, rec).await?;
            if let Some((Some(q), resolve, readback)) = &resources {
                rec.encoder().write_timestamp(q, 1);
                rec.encoder().resolve_query_set(q, 0..2, resolve, 0);
                rec.encoder().copy_buffer_to_buffer(resolve, 0, readback, 0, 16);
            }
            Ok(())
        };
        let options = ViewPrepOptions { instancing, ..Default::default() };
        let view = renderer.register_view(ViewDesc::new(camera).with_options(options), graph)?;

        let (mut record_ms, mut gpu_ms, mut frame_ms) = (Vec::new(), Vec::new(), Vec::new());
        let mut report = None;
        for frame in 0..WARM_UP + MEASURED {
            let start = std::time::Instant::now();
            let r = renderer.render_frame(&scene)?;
            let cpu = start.elapsed().as_secs_f64() * 1e3;
            renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
            let gpu_time = if timestamps {
                let slice = readback.slice(..);
                slice.map_async(wgpu::MapMode::Read, |_| {});
                renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
                let ticks: Vec<u64> = bytemuck::cast_slice(&slice.get_mapped_range()?).to_vec();
                readback.unmap();
                Some(ticks[1].saturating_sub(ticks[0]) as f64 * period_ns / 1e6)
            } else {
                None
            };
            if frame >= WARM_UP {
                record_ms.push(r.record_seconds * 1e3);
                frame_ms.push(cpu);
                if let Some(g) = gpu_time {
                    gpu_ms.push(g);
                }
            }
            report = Some(r);
        }
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied()
        };
        let report = report.ok_or("no frame rendered")?;
        let partitions = renderer.prepared_frame(view).map_or(0, |f| f.partitions().len());
        let validation = match path {
            DrawPath::Direct => "n/a",
            _ if trust_indirect_args => "off",
            _ => "on (wgpu default)",
        };
        let row = Row::new()
            .value("path", format!("{path:?}"))
            .value("indirect_validation", validation)
            .value("instancing", format!("{instancing:?}"))
            .value("draws", report.views[0].draws)
            .value("partitions_per_pass", partitions)
            .value("draw_calls_per_frame", report.views[0].recorded.draw_calls)
            .value("draw_commands_per_frame", report.views[0].recorded.draw_commands)
            .value("cpu_record_ms_samples", &record_ms)
            .value("gpu_ms_samples", &gpu_ms)
            .value("frame_cpu_ms_samples", &frame_ms);
        let (record_median, gpu_median, frame_median) =
            (median(&mut record_ms), median(&mut gpu_ms), median(&mut frame_ms));
        record.push_row(
            row.value("cpu_record_ms_median", record_median)
                .value("gpu_ms_median", gpu_median)
                .value("frame_cpu_ms_median", frame_median),
        );
        println!(
            "| {path:?} | {validation} | {instancing:?} | {} | {partitions} | {} | {} | {:.3} | {} | {:.3} |",
            report.views[0].draws,
            report.views[0].recorded.draw_calls,
            report.views[0].recorded.draw_commands,
            record_median.unwrap_or(f64::NAN),
            gpu_median.map_or("n/a (no timestamps)".to_owned(), |g| format!("{g:.3}")),
            frame_median.unwrap_or(f64::NAN),
        );
    }
    println!();
    println!("adapter: {adapter_line}; medians of {MEASURED} frames after {WARM_UP} warm-up frames");
    record.write()?;
    Ok(())
}
