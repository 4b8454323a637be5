//! What does one indirect-count draw cost the CPU, as a function of its
//! `max_count`, when the count on the GPU is zero? Plain wgpu (Oxygen only
//! opens the device), so the answer is the driver's and wgpu's, not
//! Oxygen's.
//!
//! ```text
//! cargo run --release --example indirect_count_cost [frames]   # default 60
//! ```
//!
//! GPU visibility draws each partition with
//! `multi_draw_indexed_indirect_count(args, count, max_count)`, where
//! `max_count` is the partition's capacity (every instance that could
//! survive culling) because the CPU does not know the count. A static
//! frame of a million instances therefore records the same few calls as one
//! of ten thousand, with larger `max_count`s. This measures, for `max_count`
//! from 10 000 to 1 000 000 and a count buffer holding 0 (nothing is drawn):
//!
//! * `record_submit_ms`: encoding one render pass with that one call,
//!   finishing and submitting it (median CPU time);
//! * `next_empty_submit_ms`: an empty submit after the GPU finished, which
//!   is where wgpu frees what the previous submission held;
//! * the same two for a pass with no draw, as the control.
//!
//! A difference between the rows that grows with `max_count` is the cost
//! the driver and wgpu put on every frame of a large scene, whatever the
//! renderer does on its side.
//!
//! A second table asks whether a long GPU frame makes the next frame's CPU
//! work slower: a compute pass keeps the GPU busy for `busy_ms` (a spin
//! loop, `examples/support/gpu_spin.rs`; the GPU time is the waited wall clock), the CPU waits for
//! it, then the same no-draw pass is recorded and submitted and an empty
//! submit follows. A large scene's frame is a long GPU frame, so growth
//! here with `busy_ms` is a cost of the scene's GPU time, not of its size
//! on the CPU.
//!
//! With `OXYGEN_RECORD_DIR` set, both tables (with every frame's times) are
//! appended as one record to `$OXYGEN_RECORD_DIR/indirect_count_cost.jsonl`
//! (`oxygen_demo::record`).

use std::time::Instant;

use oxygen::gpu::{GpuContext, GpuOptions};
use oxygen_demo::record::{Record, Row};

#[path = "support/gpu_spin.rs"]
mod gpu_spin;

const SHADER: &str = r#"
@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    return vec4<f32>(f32(i & 1u), f32(i >> 1u), 0.5, 1.0);
}
@fragment
fn fs() -> @location(0) vec4<f32> { return vec4<f32>(1.0); }
"#;

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(f64::NAN)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let frames: usize = std::env::args().nth(1).map(|a| a.parse()).transpose()?.unwrap_or(60).max(1);
    let gpu = GpuContext::new_headless(&GpuOptions {
        optional_features: wgpu::Features::MULTI_DRAW_INDIRECT_COUNT,
        trust_indirect_args: true,
        ..Default::default()
    })?;
    println!("adapter: {}", gpu.describe());
    let device = &gpu.device;
    let mut record = Record::new("indirect_count_cost").adapter(&gpu.adapter_info);
    let supported = device.features().contains(wgpu::Features::MULTI_DRAW_INDIRECT_COUNT);
    record.insert("multi_draw_indirect_count_supported", supported);
    if !supported {
        println!("this adapter has no indirect-count draws: nothing to measure");
        record.write()?;
        return Ok(());
    }
    record.insert("measured_frames", frames);
    record.insert("warm_up_frames", 3);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("indirect count cost"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let format = wgpu::TextureFormat::Rgba8Unorm;
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("indirect count cost"),
        layout: None,
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &[Some(format.into())],
        }),
        multiview_mask: None,
        cache: None,
    });
    let target = device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some("target"),
            size: wgpu::Extent3d { width: 64, height: 64, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        })
        .create_view(&Default::default());
    let index = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("indices"),
        size: 16,
        usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    // wgpu zero-fills both on first use: the count stays 0.
    let count = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("count"),
        size: 4,
        usage: wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let max_counts = [10_000u32, 100_000, 1_000_000];
    let args = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("args"),
        size: u64::from(*max_counts.last().unwrap_or(&1)) * 20,
        usage: wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let wait = || device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ());

    // `None`: a pass with no draw, the control.
    let mut cases: Vec<Option<u32>> = vec![None];
    cases.extend(max_counts.iter().copied().map(Some));
    for round in 0..2 {
        for &case in &cases {
            let (mut record_ms, mut empty) = (Vec::new(), Vec::new());
            for frame in 0..frames + 3 {
                let start = Instant::now();
                let mut encoder = device.create_command_encoder(&Default::default());
                {
                    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                        label: Some("draw"),
                        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                            view: &target,
                            depth_slice: None,
                            resolve_target: None,
                            ops: wgpu::Operations {
                                load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                                store: wgpu::StoreOp::Store,
                            },
                        })],
                        ..Default::default()
                    });
                    pass.set_pipeline(&pipeline);
                    pass.set_index_buffer(index.slice(..), wgpu::IndexFormat::Uint32);
                    if let Some(max_count) = case {
                        pass.multi_draw_indexed_indirect_count(&args, 0, &count, 0, max_count);
                    }
                }
                gpu.queue.submit([encoder.finish()]);
                let recorded = start.elapsed();
                wait()?;
                let encoder = device.create_command_encoder(&Default::default());
                let start = Instant::now();
                gpu.queue.submit([encoder.finish()]);
                let emptied = start.elapsed();
                wait()?;
                if frame >= 3 {
                    record_ms.push(recorded.as_secs_f64() * 1e3);
                    empty.push(emptied.as_secs_f64() * 1e3);
                }
            }
            let name = case.map_or("no draw".to_owned(), |m| format!("max_count {m}"));
            let row = Row::new()
                .value("round", round)
                .value("max_count", case)
                .value("record_submit_ms_samples", &record_ms)
                .value("next_empty_submit_ms_samples", &empty);
            let (record_median, empty_median) = (median(&mut record_ms), median(&mut empty));
            println!(
                "round {round} {name:<18} record_submit_ms={record_median:<7.4} next_empty_submit_ms={empty_median:.4}"
            );
            record.push_row_to(
                "max_count_rows",
                row.value("record_submit_ms_median", record_median).value("next_empty_submit_ms_median", empty_median),
            );
        }
    }
    busy_frames(&gpu, frames, &target, &pipeline, &index, &mut record)?;
    record.write()?;
    Ok(())
}

/// The second table: the CPU cost of a no-draw frame after the GPU was
/// busy for a while.
fn busy_frames(
    gpu: &GpuContext,
    frames: usize,
    target: &wgpu::TextureView,
    pipeline: &wgpu::RenderPipeline,
    index: &wgpu::Buffer,
    record: &mut Record,
) -> Result<(), Box<dyn std::error::Error>> {
    let device = &gpu.device;
    let spin = gpu_spin::GpuSpin::new(gpu)?;
    for round in 0..2 {
        for busy_ms in [0.0f64, 1.0, 5.0, 17.0] {
            let (mut gpu_ms, mut record_ms, mut empty) = (Vec::new(), Vec::new(), Vec::new());
            for frame in 0..frames + 3 {
                let busy_took = spin.busy(gpu, busy_ms)?;
                let start = Instant::now();
                let mut encoder = device.create_command_encoder(&Default::default());
                {
                    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                        label: Some("draw"),
                        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                            view: target,
                            depth_slice: None,
                            resolve_target: None,
                            ops: wgpu::Operations {
                                load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                                store: wgpu::StoreOp::Store,
                            },
                        })],
                        ..Default::default()
                    });
                    pass.set_pipeline(pipeline);
                    pass.set_index_buffer(index.slice(..), wgpu::IndexFormat::Uint32);
                }
                gpu.queue.submit([encoder.finish()]);
                let recorded = start.elapsed();
                let encoder = device.create_command_encoder(&Default::default());
                let start = Instant::now();
                gpu.queue.submit([encoder.finish()]);
                let emptied = start.elapsed();
                device.poll(wgpu::PollType::wait_indefinitely())?;
                if frame >= 3 {
                    gpu_ms.push(busy_took);
                    record_ms.push(recorded.as_secs_f64() * 1e3);
                    empty.push(emptied.as_secs_f64() * 1e3);
                }
            }
            let row = Row::new()
                .value("round", round)
                .value("busy_ms_asked", busy_ms)
                .value("busy_ms_samples", &gpu_ms)
                .value("record_submit_ms_samples", &record_ms)
                .value("then_empty_submit_ms_samples", &empty);
            let (busy_median, record_median, empty_median) =
                (median(&mut gpu_ms), median(&mut record_ms), median(&mut empty));
            println!(
                "round {round} busy_ms={busy_median:<7.2} record_submit_ms={record_median:<7.4} then_empty_submit_ms={empty_median:.4}"
            );
            record.push_row_to(
                "busy_rows",
                row.value("busy_ms_median", busy_median)
                    .value("record_submit_ms_median", record_median)
                    .value("then_empty_submit_ms_median", empty_median),
            );
        }
    }
    Ok(())
}
