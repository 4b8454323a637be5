//! The depth pre-pass knob, both ways: its time and its benefit.
//!
//! ```text
//! cargo run --release --example prepass_bench [CUBES] [FRAMES]   # default 10 000 and 15
//! ```
//!
//! Scenes at the two ends of the trade: a grid of CUBES cubes seen
//! obliquely (surfaces rarely hide each other), and 32 large walls stacked
//! in front of the camera in four materials, once with the nearest walls in
//! the first material drawn (front-to-back order within each material then
//! hides everything behind them) and once with the farthest walls in the
//! first material drawn (each later material paints over the earlier ones). For each, `PrePass::On`, `Off` and the default `Auto` render 3
//! warm-up and FRAMES measured frames (each waited for on the GPU); the table
//! gives the median frame time, the GPU time between timestamps around the
//! view's passes (where the adapter has timestamps inside encoders), the
//! fragments the forward lit pass shaded (pipeline statistics, where the
//! adapter has them: the benefit), and the view's estimated overdraw that
//! `Auto` decides from.
//!
//! With `OXYGEN_RECORD_DIR` set, the table (with every frame's figures) is
//! appended as one record to `$OXYGEN_RECORD_DIR/prepass_bench.jsonl`
//! (`oxygen_demo::record`).

use std::sync::Arc;
use std::time::Instant;

use oxygen::glam::{Quat, Vec4};
use oxygen::gpu::{GpuContext, GpuOptions};
use oxygen::graph::PrePass;
use oxygen::prelude::*;
use oxygen_demo::record::{Record, Row};

const WARM_UP: usize = 3;
const DEFAULT_MEASURED: usize = 15;

fn grid(count: usize) -> (Scene, LookAtResolver) {
    let mut scene = Scene::new();
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let materials: Vec<_> = (0..4)
        .map(|i| scene.add_material(Material::opaque("m", Vec4::new(0.3 + 0.15 * i as f32, 0.6, 0.5, 1.0))))
        .collect();
    let side = (count as f32).sqrt().ceil() as usize;
    for i in 0..count {
        let at = Vec3::new((i % side) as f32 * 2.0, 0.0, (i / side) as f32 * 2.0);
        let node = scene.add_node("c", Transform::from_translation(at));
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![materials[i % 4]] }).ok();
    }
    sun(&mut scene);
    let extent = side as f32 * 2.0;
    let centre = Vec3::new(extent * 0.5, 0.0, extent * 0.5);
    let camera = LookAtResolver::new(
        Camera::perspective(60f32.to_radians(), 0.5, Some(extent * 4.0)),
        centre + Vec3::new(0.0, extent * 0.5, extent * 0.75),
        centre,
        UVec2::new(960, 540),
    )
    .unwrap();
    (scene, camera)
}

fn walls(far_first: bool) -> (Scene, LookAtResolver) {
    let mut scene = Scene::new();
    // A plane faces +Y; turned a quarter about X it faces +Z, the camera.
    let wall = scene.add_geometry(Geometry::plane(40.0));
    let materials: Vec<_> = (0..4)
        .map(|i| scene.add_material(Material::opaque("w", Vec4::new(0.2 + 0.2 * i as f32, 0.5, 0.7, 1.0))))
        .collect();
    for i in 0..32 {
        let at = Vec3::new(0.0, 0.0, -2.0 - i as f32);
        let node = scene.add_node(
            "wall",
            Transform::from_translation(at).with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2)),
        );
        // Materials are drawn in creation order; `far_first` gives the far
        // walls the first material.
        let material = if far_first { 3 - i / 8 } else { i / 8 };
        scene.set_renderable(node, Renderable { geometry: wall, materials: vec![materials[material]] }).ok();
    }
    sun(&mut scene);
    let camera = LookAtResolver::new(
        Camera::perspective(60f32.to_radians(), 0.1, Some(100.0)),
        Vec3::new(0.0, 0.0, 2.0),
        Vec3::new(0.0, 0.0, -10.0),
        UVec2::new(960, 540),
    )
    .unwrap();
    (scene, camera)
}

fn sun(scene: &mut Scene) {
    let sun = scene.add_node(
        "sun",
        Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::new(0.3, -0.6, -0.7).normalize())),
    );
    scene.set_light(sun, Some(Light::directional(3.0))).ok();
}

/// Queries a frame writes: timestamps before and after the view's passes,
/// the forward pass's pipeline statistics, and where they are read back.
struct Queries {
    timestamps: Option<wgpu::QuerySet>,
    statistics: Option<wgpu::QuerySet>,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let count: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(10_000);
    let measured: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(DEFAULT_MEASURED).max(1);
    let mut record = Record::new("prepass_bench")
        .value("cubes", count)
        .value("warm_up_frames", WARM_UP)
        .value("measured_frames", measured);
    println!(
        "| scene | pre-pass | estimated overdraw | pre-pass ran | frame ms (waited) | GPU ms | fragments shaded by the forward pass |"
    );
    println!("|---|---|---:|---|---:|---:|---:|");
    let mut adapter = String::new();
    let scenes = [
        ("grid of cubes", grid(count)),
        ("32 walls, near ones drawn first", walls(false)),
        ("32 walls, far ones drawn first", walls(true)),
    ];
    for (name, (scene, camera)) in &scenes {
        for pre_pass in [PrePass::On, PrePass::Off, PrePass::DEFAULT] {
            let options = GpuOptions {
                optional_features: Renderer::OPTIONAL_FEATURES
                    | wgpu::Features::TIMESTAMP_QUERY
                    | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS
                    | wgpu::Features::PIPELINE_STATISTICS_QUERY,
                ..Default::default()
            };
            let gpu = GpuContext::new_headless(&options)?;
            adapter = gpu.describe();
            let period_ns = gpu.queue.get_timestamp_period() as f64;
            let queries = Arc::new(Queries {
                timestamps: gpu.features.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS).then(|| {
                    gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                        label: Some("timestamps"),
                        ty: wgpu::QueryType::Timestamp,
                        count: 2,
                    })
                }),
                statistics: gpu.features.contains(wgpu::Features::PIPELINE_STATISTICS_QUERY).then(|| {
                    gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                        label: Some("forward statistics"),
                        ty: wgpu::QueryType::PipelineStatistics(
                            wgpu::PipelineStatisticsTypes::FRAGMENT_SHADER_INVOCATIONS,
                        ),
                        count: 1,
                    })
                }),
                resolve: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("queries"),
                    size: 256 + 8,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
                readback: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("queries readback"),
                    size: 256 + 8,
                    usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                    mapped_at_creation: false,
                }),
            });
            let mut renderer = Renderer::with_options(gpu, RendererOptions::default())?;
            record.set_adapter(&renderer.gpu().adapter_info);
            let graph_queries = Arc::clone(&queries);
            let graph = async move |ctx: &RenderContext<'_>, rec: &mut CommandRecorder| {
                let q = &graph_queries;
                if let Some(set) = &q.timestamps {
                    rec.encoder().write_timestamp(set, 0);
                }
                let pre = pre_pass.wanted(ctx.pre_pass_estimate());
                if pre {
                    MeshPass::depth_pre_pass().run(ctx, rec).await?;
                }
                let mut forward =
                    MeshPass::forward_lit(ForwardLitConfig { depth_from_pre_pass: pre, ..Default::default() });
                if let Some(set) = &q.statistics {
                    forward = forward.with_statistics(set.clone(), 0);
                }
                forward.run(ctx, rec).await?;
                TonemapPass::default().run(ctx, rec).await?;
                if let Some(set) = &q.timestamps {
                    rec.encoder().write_timestamp(set, 1);
                    rec.encoder().resolve_query_set(set, 0..2, &q.resolve, 0);
                }
                if let Some(set) = &q.statistics {
                    rec.encoder().resolve_query_set(set, 0..1, &q.resolve, 256);
                }
                rec.encoder().copy_buffer_to_buffer(&q.resolve, 0, &q.readback, 0, 256 + 8);
                Ok(())
            };
            let view = renderer.register_view(*camera, graph)?;
            let (mut frame_ms, mut gpu_ms, mut fragments) = (Vec::new(), Vec::new(), Vec::new());
            let mut ran = false;
            for frame in 0..WARM_UP + measured {
                let started = Instant::now();
                let report = renderer.render_frame(scene)?;
                renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
                let elapsed = started.elapsed().as_secs_f64() * 1e3;
                let slice = queries.readback.slice(..);
                slice.map_async(wgpu::MapMode::Read, |_| {});
                renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
                let words: Vec<u64> = bytemuck::cast_slice(&slice.get_mapped_range()?).to_vec();
                queries.readback.unmap();
                ran = report.views[0].recorded.render_passes == 3;
                if frame >= WARM_UP {
                    frame_ms.push(elapsed);
                    if queries.timestamps.is_some() {
                        gpu_ms.push(words[1].saturating_sub(words[0]) as f64 * period_ns / 1e6);
                    }
                    if queries.statistics.is_some() {
                        fragments.push(words[32] as f64);
                    }
                }
            }
            let median = |v: &mut Vec<f64>| {
                v.sort_by(f64::total_cmp);
                v.get(v.len() / 2).copied()
            };
            // On a GPU visibility path the estimate is the GPU's, read back.
            let overdraw = match (renderer.gpu_visibility(), renderer.prepared_frame(view)) {
                (Some(gpu), Some(frame)) if frame.gpu_plan().is_some() => {
                    gpu.estimated_overdraw(view).unwrap_or(f32::NAN)
                }
                (_, Some(frame)) => frame.estimated_overdraw(),
                _ => f32::NAN,
            };
            let row = Row::new()
                .value("scene", *name)
                .value("pre_pass", format!("{pre_pass:?}"))
                .value("estimated_overdraw", overdraw.is_finite().then_some(overdraw))
                .value("pre_pass_ran", ran)
                .value("frame_ms_samples", &frame_ms)
                .value("gpu_ms_samples", &gpu_ms)
                .value("fragments_shaded_samples", &fragments);
            let (frame_median, gpu_median, fragments_median) =
                (median(&mut frame_ms), median(&mut gpu_ms), median(&mut fragments));
            println!(
                "| {name} | {pre_pass:?} | {overdraw:.2} | {} | {:.2} | {} | {} |",
                if ran { "yes" } else { "no" },
                frame_median.unwrap_or(f64::NAN),
                gpu_median.map_or("n/a".to_owned(), |g| format!("{g:.2}")),
                fragments_median.map_or("n/a".to_owned(), |f| format!("{f:.0}")),
            );
            record.push_row(
                row.value("frame_ms_median", frame_median)
                    .value("gpu_ms_median", gpu_median)
                    .value("fragments_shaded_median", fragments_median),
            );
        }
    }
    println!();
    println!("adapter: {adapter}; medians of {measured} frames after {WARM_UP} warm-up frames");
    record.write()?;
    Ok(())
}
