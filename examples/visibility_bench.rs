//! Visibility paths side by side: the CPU path (ScenePrep culls, sorts and
//! emits every draw), GPU frustum culling and GPU frustum + occlusion
//! culling, on one adapter, in one run, so the ratios hold on a noisy
//! machine.
//!
//! ```text
//! cargo run --release --example visibility_bench -- [field|city] [N,N,..] [V,V,..] [frames]
//! cargo run --release --example visibility_bench -- field 10000,100000 1,6 20
//! cargo run --release --example visibility_bench -- city 4096 1
//! ```
//!
//! * `field`: N boxes on a square grid (oxygen-demo's field of boxes, four
//!   materials), V views on a circle around it looking at its centre, each
//!   seeing most of the field from above: culling keeps most boxes, so this
//!   measures what a path costs per object.
//! * `city`: N buildings on a grid with streets between them, V views at
//!   street level looking down the streets: most of the city is hidden
//!   behind its first rows, which is what occlusion culling is for.
//!
//! For every path and two motions (`static`: nothing changes; `moving`: one
//! box moves every frame, which makes ScenePrep recollect the scene and the
//! GPU scene diff its records) it renders warm-up frames, then `frames`
//! measured ones, each waited for, and prints per frame (medians): the CPU
//! time of `render_frame` alone (prepare + record + submit), the GPU time between
//! timestamps written before and after the frame (when the adapter has
//! timestamps inside encoders), the whole frame, an empty submit on the idle
//! queue (the floor of wgpu and the driver under every frame's submit), the
//! bytes uploaded, and the draws kept (read back after the last frame). `VISIBILITY_PATHS=cpu,gpu`
//! runs only the paths named (`cpu`, `gpu`, `occlusion`); `VISIBILITY_TRACE=1`
//! prints every `tracing` span's time on stderr. `cull_only` repeats the GPU
//! path with an empty graph: what is left of the GPU time is the culling.
//! `VISIBILITY_GPU_BUSY_MS=T` keeps the GPU busy for T ms before every
//! frame, so a small scene's CPU frame can be compared with a large one's
//! after the same GPU time (the driver makes the frame after a long GPU
//! frame slower whatever is in it; `indirect_count_cost` measures that).
//!
//! With `OXYGEN_RECORD_DIR` set, every line (with every frame's figures)
//! is appended as one record to `$OXYGEN_RECORD_DIR/visibility_bench.jsonl`
//! (`oxygen_demo::record`).

use std::time::Instant;

use oxygen::gpu::{GpuContext, GpuOptions};
use oxygen_demo::record::{Record, Row};

#[path = "support/gpu_spin.rs"]
mod gpu_spin;
use oxygen::glam::{Quat, Vec4};
use oxygen::passes::PassError;
use oxygen::prelude::*;
use oxygen::sceneprep::Visibility;

const WARM_UP: usize = 3;
const VIEWPORT: UVec2 = UVec2::new(640, 360);

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(f64::NAN)
}

/// N buildings 8 wide on a 12-unit grid, heights 6 to 30.
fn city(count: usize) -> (Scene, f32) {
    let mut scene = Scene::new();
    let side = (count as f32).sqrt().ceil() as usize;
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let materials: Vec<_> = [0.7f32, 0.55, 0.4]
        .iter()
        .map(|g| scene.add_material(Material::opaque("wall", Vec4::new(*g, *g, g + 0.05, 1.0))))
        .collect();
    let half = side as f32 * 6.0;
    let ground_material = scene.add_material(Material::opaque("ground", Vec4::splat(0.2)));
    let ground_mesh = scene.add_geometry(Geometry::plane(half * 2.0));
    let ground = scene.add_node("ground", Transform::IDENTITY);
    scene.set_renderable(ground, Renderable { geometry: ground_mesh, materials: vec![ground_material] }).ok();
    for i in 0..count {
        let (x, z) = ((i % side) as f32 * 12.0 - half + 6.0, (i / side) as f32 * 12.0 - half + 6.0);
        let height = 6.0 + ((i * 7919) % 25) as f32;
        let transform =
            Transform::from_translation(Vec3::new(x, height * 0.5, z)).with_scale(Vec3::new(8.0, height, 8.0));
        let node = scene.add_node("building", transform);
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![materials[i % 3]] }).ok();
    }
    let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_x(-0.8)));
    scene.set_light(sun, Some(Light { casts_shadows: false, ..Light::directional(3.0) })).ok();
    (scene, half * 2.0)
}

/// The cameras: above the field looking at its centre, or at street level
/// down the streets of the city.
fn cameras(scene_kind: &str, side: f32, views: usize) -> Vec<LookAtResolver> {
    (0..views)
        .map(|v| {
            let angle = v as f32 / views as f32 * std::f32::consts::TAU;
            let (eye, target) = if scene_kind == "city" {
                // In the street between the first two rows, looking along it.
                let eye = Vec3::new(-side * 0.5 + 12.0, 2.0, -side * 0.5 + 12.0 * (1 + v % 8) as f32);
                (eye, eye + Vec3::new(angle.cos().abs() + 0.5, -0.02, angle.sin() * 0.3))
            } else {
                let center = Vec3::new(side * 0.5, 0.0, side * 0.5);
                (center + Vec3::new(angle.cos() * 0.65 * side, 0.35 * side, angle.sin() * 0.65 * side), center)
            };
            LookAtResolver::new(Camera::perspective(60f32.to_radians(), 0.1, None), eye, target, VIEWPORT).unwrap()
        })
        .collect()
}

struct Timestamps {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    period_ns: f64,
}

impl Timestamps {
    fn new(gpu: &GpuContext) -> Option<Self> {
        if !gpu.features.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS) {
            return None;
        }
        let buffer = |usage| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: None,
                size: 16,
                usage,
                mapped_at_creation: false,
            })
        };
        Some(Timestamps {
            set: gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("frame"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolve: buffer(wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC),
            read: buffer(wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ),
            period_ns: gpu.queue.get_timestamp_period() as f64,
        })
    }

    fn write(&self, gpu: &GpuContext, index: u32) {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        encoder.write_timestamp(&self.set, index);
        if index == 1 {
            encoder.resolve_query_set(&self.set, 0..2, &self.resolve, 0);
            encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.read, 0, 16);
        }
        gpu.queue.submit([encoder.finish()]);
    }

    /// Milliseconds between the two timestamps (after the frame was waited for).
    fn read_ms(&self, gpu: &GpuContext) -> Result<f64, Box<dyn std::error::Error>> {
        self.read.slice(..).map_async(wgpu::MapMode::Read, |_| {});
        gpu.device.poll(wgpu::PollType::wait_indefinitely())?;
        let ticks: [u64; 2] = bytemuck::pod_read_unaligned(&self.read.slice(..).get_mapped_range()?[..16]);
        self.read.unmap();
        Ok(ticks[1].saturating_sub(ticks[0]) as f64 * self.period_ns / 1e6)
    }
}

async fn nothing(_: &RenderContext<'_>, _: &mut CommandRecorder) -> Result<(), PassError> {
    Ok(())
}

fn run(
    scene_kind: &str,
    count: usize,
    views: usize,
    frames: usize,
    visibility: Visibility,
    moving: bool,
    cull_only: bool,
) -> Result<(String, Row), Box<dyn std::error::Error>> {
    let (mut scene, side) = if scene_kind == "city" {
        city(count)
    } else {
        let colors = [Vec4::new(0.8, 0.2, 0.2, 1.0), Vec4::new(0.2, 0.7, 0.3, 1.0), Vec4::new(0.2, 0.3, 0.8, 1.0)];
        oxygen_demo::field_of_boxes(count, &colors)
    };
    let gpu = GpuContext::new_headless(&GpuOptions {
        optional_features: Renderer::OPTIONAL_FEATURES
            | wgpu::Features::TIMESTAMP_QUERY
            | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS,
        trust_indirect_args: true,
        ..Default::default()
    })?;
    let timestamps = Timestamps::new(&gpu);
    let mut renderer =
        Renderer::with_options(gpu, RendererOptions { visibility: Some(visibility), ..Default::default() })?;
    let row = Row::new()
        .value("scene", scene_kind)
        .value("objects", count)
        .value("views", views)
        .value("visibility", format!("{visibility:?}"))
        .value("motion", if moving { "moving" } else { "static" })
        .value("graph", if cull_only { "cull_only" } else { "full" });
    if visibility.on_gpu() && !renderer.gpu_visibility_supported() {
        let line = format!("{visibility:?}: not supported on {}", renderer.gpu().describe());
        return Ok((line, row.value("supported", false)));
    }
    let mut ids = Vec::new();
    for camera in cameras(scene_kind, side, views) {
        let desc = ViewDesc::new(camera).with_visibility(visibility);
        ids.push(if cull_only {
            renderer.register_view(desc, nothing)?
        } else {
            renderer.register_view(desc, standard_render_graph)?
        });
    }
    let mover = scene.nodes().filter(|(_, n)| n.name == "box" || n.name == "building").map(|(k, _)| k).nth(count / 2);
    let (mut cpu, mut gpu_ms, mut whole, mut uploaded) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut empty_submit = Vec::new();
    let busy_ms = busy_before_frames();
    let spin = if busy_ms > 0.0 { Some(gpu_spin::GpuSpin::new(renderer.gpu())?) } else { None };
    for frame in 0..WARM_UP + frames {
        if let (true, Some(node)) = (moving, mover) {
            let at = Vec3::new(frame as f32 * 0.01, 1.0, 0.0);
            scene.set_local_transform(node, Transform::from_translation(at))?;
        }
        if let Some(spin) = &spin {
            spin.busy(renderer.gpu(), busy_ms)?;
        }
        let start = Instant::now();
        if let Some(t) = &timestamps {
            t.write(renderer.gpu(), 0);
        }
        // The CPU time is render_frame's alone: the timestamp's own submit
        // before it does wgpu housekeeping that grows with the scene's
        // buffers and is not the renderer's work.
        let cpu_start = Instant::now();
        let report = renderer.render_frame(&scene)?;
        let cpu_done = cpu_start.elapsed();
        if let Some(t) = &timestamps {
            t.write(renderer.gpu(), 1);
        }
        renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
        let frame_done = start.elapsed();
        // The floor under any frame: one submit of an empty command buffer
        // on an idle queue, with this scene's buffers alive. What it costs
        // is wgpu's and the driver's, and every frame pays it once.
        let device = &renderer.gpu().device;
        let encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("empty") });
        let submit_start = Instant::now();
        renderer.gpu().queue.submit([encoder.finish()]);
        let submit_done = submit_start.elapsed();
        device.poll(wgpu::PollType::wait_indefinitely())?;
        if frame >= WARM_UP {
            cpu.push(cpu_done.as_secs_f64() * 1e3);
            whole.push(frame_done.as_secs_f64() * 1e3);
            empty_submit.push(submit_done.as_secs_f64() * 1e3);
            uploaded.push(report.uploaded_bytes as f64 / 1024.0);
            if let Some(t) = &timestamps {
                gpu_ms.push(t.read_ms(renderer.gpu())?);
            }
        }
    }
    let kept: usize = if cull_only {
        0
    } else {
        ids.iter().map(|id| renderer.view_draws(*id).map_or(0, |d| d.iter().map(|(_, d)| d.len()).sum())).sum()
    };
    let row = row
        .value("supported", true)
        .value("busy_before_ms", busy_ms)
        .value("cpu_ms_samples", &cpu)
        .value("gpu_ms_samples", &gpu_ms)
        .value("frame_ms_samples", &whole)
        .value("empty_submit_ms_samples", &empty_submit)
        .value("upload_kb_samples", &uploaded)
        .value("kept_per_view", kept as f64 / views as f64);
    let gpu_median = (!gpu_ms.is_empty()).then(|| median(&mut gpu_ms));
    let gpu_text = gpu_median.map_or("n/a".to_owned(), |g| format!("{g:.3}"));
    let (cpu_median, frame_median, submit_median, upload_median) =
        (median(&mut cpu), median(&mut whole), median(&mut empty_submit), median(&mut uploaded));
    let line = format!(
        "{scene_kind:<5} N={count:<8} V={views:<3} {:<12} {:<7} {:<9} busy_before_ms={busy_ms:<5} cpu_ms={cpu_median:<8.3} gpu_ms={gpu_text:<8} frame_ms={frame_median:<8.3} empty_submit_ms={submit_median:<6.3} upload_kb={upload_median:<9.1} kept_per_view={:.0}",
        format!("{visibility:?}"),
        if moving { "moving" } else { "static" },
        if cull_only { "cull_only" } else { "full" },
        kept as f64 / views as f64,
    );
    let row = row
        .value("cpu_ms_median", cpu_median)
        .value("gpu_ms_median", gpu_median)
        .value("frame_ms_median", frame_median)
        .value("empty_submit_ms_median", submit_median)
        .value("upload_kb_median", upload_median);
    Ok((line, row))
}

/// `VISIBILITY_GPU_BUSY_MS=T` keeps the GPU busy for T ms (and waits)
/// before every frame: the control that compares a small scene's CPU frame
/// with a large one's after the same GPU time (see `indirect_count_cost`).
fn busy_before_frames() -> f64 {
    std::env::var("VISIBILITY_GPU_BUSY_MS").ok().and_then(|v| v.parse().ok()).unwrap_or(0.0)
}

/// `VISIBILITY_PATHS=cpu,gpu,occlusion` (default all) limits the paths run.
fn wanted(visibility: Visibility) -> bool {
    let name = match visibility {
        Visibility::Cpu => "cpu",
        Visibility::GpuFrustum => "gpu",
        Visibility::GpuOcclusion => "occlusion",
    };
    std::env::var("VISIBILITY_PATHS").map_or(true, |paths| paths.split(',').any(|p| p == name))
}

fn list(arg: Option<String>, default: &[usize]) -> Result<Vec<usize>, std::num::ParseIntError> {
    arg.map_or(Ok(default.to_vec()), |a| a.split(',').map(str::parse).collect())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    if std::env::var_os("VISIBILITY_TRACE").is_some() {
        // Every span's time as it closes, on stderr (for finding where a
        // frame's time goes).
        tracing_subscriber::fmt()
            .with_span_events(tracing_subscriber::fmt::format::FmtSpan::CLOSE)
            .with_writer(std::io::stderr)
            .init();
    }
    let mut args = std::env::args().skip(1);
    let scene_kind = args.next().unwrap_or_else(|| "field".to_owned());
    if scene_kind != "field" && scene_kind != "city" {
        return Err("usage: visibility_bench [field|city] [N,..] [V,..] [frames]".into());
    }
    let counts = list(args.next(), &[10_000, 100_000])?;
    let view_counts = list(args.next(), &[1, 6])?;
    let frames: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(10).max(1);
    let gpu = GpuContext::new_headless(&GpuOptions::default())?;
    println!("adapter: {}", gpu.describe());
    let mut record = Record::new("visibility_bench")
        .adapter(&gpu.adapter_info)
        .value("scene", scene_kind.as_str())
        .value("warm_up_frames", WARM_UP)
        .value("measured_frames", frames)
        .value("viewport_px", [VIEWPORT.x, VIEWPORT.y]);
    drop(gpu);
    let mut line = |(text, row): (String, Row)| {
        println!("{text}");
        record.push_row(row);
    };
    for &count in &counts {
        for &views in &view_counts {
            for moving in [false, true] {
                for visibility in [Visibility::Cpu, Visibility::GpuFrustum, Visibility::GpuOcclusion] {
                    if !wanted(visibility) {
                        continue;
                    }
                    line(run(&scene_kind, count, views, frames, visibility, moving, false)?);
                }
            }
            // (A graph that draws nothing has no pre-pass: occlusion culling
            // would fall back to frustum culling, so only that is timed.)
            line(run(&scene_kind, count, views, frames, Visibility::GpuFrustum, false, true)?);
        }
    }
    record.write()?;
    Ok(())
}
