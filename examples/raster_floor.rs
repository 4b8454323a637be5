//! How fast can this adapter rasterise the cubes scene at all? Plain wgpu, no
//! Oxygen: the floor under `cubes_bench`'s GPU time, measured in one run.
//!
//! ```text
//! cargo run --release --example raster_floor [N] [frames]   # default 100000 and 30
//! ```
//!
//! The geometry of `cubes_bench` (N unit cubes, spacing 2 on the XZ plane,
//! 24 vertices and 36 indices each, one 960 × 540 view from radius 0.65 and
//! height 0.35 of the grid's side) drawn as ONE instanced indexed draw into
//! a depth target (and a colour target where a fragment stage runs), GPU time
//! from timestamps around the pass, median of the frames. Six ways, from
//! the least work up:
//!
//! * `culled in vertex stage`: every vertex lands outside the view, so the
//!   number is the vertex stage alone (fixed-function fetch of positions);
//! * `depth only, vertex buffers`: positions and per-instance offsets from
//!   vertex buffers, no fragment stage (what a depth pre-pass costs at best);
//! * `colour, vertex buffers`: the same with a constant-colour fragment stage;
//! * `colour, pulled from storage`: positions, normals and UVs read from a
//!   storage buffer by vertex index and a 4×4 matrix per instance, as
//!   Oxygen's mesh vertex stage does, with its varyings;
//! * the same with `both faces`: back faces not culled (a double-sided
//!   material); every other line culls them, as Oxygen's opaque variant does;
//! * `one merged mesh`: every cube baked into one vertex buffer and drawn as
//!   one instance, which tells whether the cost is per vertex or per
//!   instance (an instance of 24 vertices fills a vertex batch poorly).
//!
//! When the cheapest lines are already near `cubes_bench`'s GPU time, the
//! frame is bound by how fast the adapter takes in geometry, not by Oxygen.
//!
//! With `OXYGEN_RECORD_DIR` set, the run's figures (and every frame's GPU
//! time) are appended to `$OXYGEN_RECORD_DIR/raster_floor.jsonl`
//! (`oxygen_demo::record`).

use std::time::Instant;

use oxygen_demo::record::{Record, Row};
use oxygen_gpu::bindings::{self, LayoutEntries};
use wgpu::util::DeviceExt;

const SIZE: (u32, u32) = (960, 540);

const SHADER: &str = r#"
struct Camera { view_projection: mat4x4<f32>, mode: u32 }
@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var<storage, read> pulled_vertices: array<array<f32, 8>>;
@group(0) @binding(2) var<storage, read> instance_matrices: array<mat4x4<f32>>;

struct Out {
    @builtin(position) position: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) uv: vec2<f32>,
}

@vertex
fn vs_fixed(@location(0) position: vec3<f32>, @location(1) offset: vec3<f32>) -> Out {
    var out: Out;
    out.position = camera.view_projection * vec4<f32>(position + offset, 1.0);
    if camera.mode == 1u {
        out.position = vec4<f32>(2.0, 2.0, 2.0, 1.0);
    }
    out.normal = vec3<f32>(0.0, 1.0, 0.0);
    out.uv = vec2<f32>(0.0);
    return out;
}

@vertex
fn vs_pulled(@builtin(vertex_index) vertex: u32, @builtin(instance_index) instance: u32) -> Out {
    let v = pulled_vertices[vertex];
    let world = instance_matrices[instance];
    var out: Out;
    out.position = camera.view_projection * (world * vec4<f32>(v[0], v[1], v[2], 1.0));
    out.normal = (world * vec4<f32>(v[3], v[4], v[5], 0.0)).xyz;
    out.uv = vec2<f32>(v[6], v[7]);
    return out;
}

@fragment
fn fs_colour(input: Out) -> @location(0) vec4<f32> {
    return vec4<f32>(normalize(input.normal) * 0.5 + 0.5, input.uv.x);
}
"#;

#[derive(Clone, Copy)]
enum Way {
    CulledInVertexStage,
    DepthOnly,
    Colour,
    Pulled,
    PulledBothFaces,
    Merged,
}

impl Way {
    fn name(self) -> &'static str {
        match self {
            Way::CulledInVertexStage => "culled in vertex stage",
            Way::DepthOnly => "depth only, vertex buffers",
            Way::Colour => "colour, vertex buffers",
            Way::Pulled => "colour, pulled from storage",
            Way::PulledBothFaces => "colour, pulled, both faces",
            Way::Merged => "colour, one merged mesh",
        }
    }
}

/// The unit cube: 24 vertices (position, normal, uv) and 36 indices, faces
/// wound counter-clockwise seen from outside.
fn cube() -> (Vec<[f32; 8]>, Vec<u32>) {
    let faces: [([f32; 3], [f32; 3], [f32; 3]); 6] = [
        ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]),
        ([-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
        ([0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]),
        ([0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
        ([0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]),
        ([0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]),
    ];
    let (mut vertices, mut indices) = (Vec::new(), Vec::new());
    for (n, up, right) in faces {
        let base = vertices.len() as u32;
        for (s, t) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let p: Vec<f32> = (0..3).map(|k| 0.5 * (n[k] + s * right[k] + t * up[k])).collect();
            vertices.push([p[0], p[1] + 0.5, p[2], n[0], n[1], n[2], (s + 1.0) / 2.0, (t + 1.0) / 2.0]);
        }
        indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    (vertices, indices)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let count: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(100_000);
    let frames: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(30);
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster_block(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        ..Default::default()
    }))?;
    let info = adapter.get_info();
    let (device, queue) = pollster_block(adapter.request_device(&wgpu::DeviceDescriptor {
        required_features: wgpu::Features::TIMESTAMP_QUERY,
        ..Default::default()
    }))?;

    // The grid and the camera, as cubes_bench builds them.
    let per_row = (count as f32).sqrt().ceil() as usize;
    let half = (per_row - 1) as f32;
    let side = 2.0 * half + 1.0;
    let offsets: Vec<[f32; 3]> =
        (0..count).map(|i| [-half + 2.0 * (i % per_row) as f32, 0.0, -half + 2.0 * (i / per_row) as f32]).collect();
    let matrices: Vec<[f32; 16]> = offsets
        .iter()
        .map(|o| [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, o[0], o[1], o[2], 1.0])
        .collect();
    let eye = glam::Vec3::new(0.65 * side, 0.35 * side, 0.0);
    let view = glam::Mat4::look_at_rh(eye, glam::Vec3::ZERO, glam::Vec3::Y);
    let aspect = SIZE.0 as f32 / SIZE.1 as f32;
    let projection = glam::Mat4::perspective_rh(60f32.to_radians(), aspect, 0.1, 4.0 * side);
    let (vertices, indices) = cube();

    let init = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
    };
    let positions: Vec<[f32; 3]> = vertices.iter().map(|v| [v[0], v[1], v[2]]).collect();
    let position_buffer = init("positions", bytemuck::cast_slice(&positions), wgpu::BufferUsages::VERTEX);
    let offset_buffer = init("offsets", bytemuck::cast_slice(&offsets), wgpu::BufferUsages::VERTEX);
    let index_buffer = init("indices", bytemuck::cast_slice(&indices), wgpu::BufferUsages::INDEX);
    let merged_positions: Vec<[f32; 3]> =
        offsets.iter().flat_map(|o| positions.iter().map(move |p| [p[0] + o[0], p[1] + o[1], p[2] + o[2]])).collect();
    let per_cube = positions.len() as u32;
    let merged_indices: Vec<u32> =
        (0..count as u32).flat_map(|c| indices.iter().map(move |i| i + c * per_cube)).collect();
    // The merged mesh only where one buffer can hold it.
    let merged_fits = (merged_positions.len() * 12) as u64 <= device.limits().max_buffer_size;
    let merged_buffer = merged_fits
        .then(|| init("merged positions", bytemuck::cast_slice(&merged_positions), wgpu::BufferUsages::VERTEX));
    let merged_index_buffer =
        merged_fits.then(|| init("merged indices", bytemuck::cast_slice(&merged_indices), wgpu::BufferUsages::INDEX));
    let zero_offset = init("zero offset", bytemuck::cast_slice(&[[0f32; 3]]), wgpu::BufferUsages::VERTEX);
    let pulled = init("pulled vertices", bytemuck::cast_slice(&vertices), wgpu::BufferUsages::STORAGE);
    let matrix_buffer = init("matrices", bytemuck::cast_slice(&matrices), wgpu::BufferUsages::STORAGE);
    let camera_bytes = |mode: u32| {
        let mut bytes = bytemuck::cast_slice::<f32, u8>(&(projection * view).to_cols_array()).to_vec();
        bytes.extend_from_slice(&[mode, 0, 0, 0].map(u32::to_le_bytes).concat());
        bytes.resize(96, 0);
        bytes
    };
    let camera = [0u32, 1].map(|mode| init("camera", &camera_bytes(mode), wgpu::BufferUsages::UNIFORM));

    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("raster floor"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let visible = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
    // The camera, the pulled positions, the matrices.
    let entries = LayoutEntries::new(visible).push(bindings::uniform()).repeat(2, bindings::storage_read_only());
    let layout =
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: None, entries: entries.entries() });
    let bind_groups = camera.each_ref().map(|camera| {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: camera.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: pulled.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: matrix_buffer.as_entire_binding() },
            ],
        })
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: None,
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let color_format = wgpu::TextureFormat::Rgba8Unorm;
    let fixed_buffers = [
        Some(wgpu::VertexBufferLayout {
            array_stride: 12,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x3],
        }),
        Some(wgpu::VertexBufferLayout {
            array_stride: 12,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &wgpu::vertex_attr_array![1 => Float32x3],
        }),
    ];
    let pipeline = |way: Way| {
        let pulled = matches!(way, Way::Pulled | Way::PulledBothFaces);
        let colour = !matches!(way, Way::DepthOnly | Way::CulledInVertexStage);
        let targets = [Some(wgpu::ColorTargetState::from(color_format))];
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(way.name()),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some(if pulled { "vs_pulled" } else { "vs_fixed" }),
                compilation_options: Default::default(),
                buffers: if pulled { &[] } else { &fixed_buffers },
            },
            primitive: wgpu::PrimitiveState {
                cull_mode: (!matches!(way, Way::PulledBothFaces)).then_some(wgpu::Face::Back),
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: colour.then(|| wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_colour"),
                compilation_options: Default::default(),
                targets: &targets,
            }),
            multiview_mask: None,
            cache: None,
        })
    };
    let target = |format, label| {
        device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width: SIZE.0, height: SIZE.1, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            })
            .create_view(&Default::default())
    };
    let color = target(color_format, "colour");
    let depth = target(wgpu::TextureFormat::Depth32Float, "depth");
    let queries =
        device.create_query_set(&wgpu::QuerySetDescriptor { label: None, ty: wgpu::QueryType::Timestamp, count: 2 });
    let resolved = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: 16,
        usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: 16,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let period_ns = f64::from(queue.get_timestamp_period());

    println!("{} ({:?}), {count} cubes, {}x{}, median of {frames} frames", info.name, info.backend, SIZE.0, SIZE.1);
    let mut record = Record::new("raster_floor")
        .adapter(&info)
        .value("cubes", count)
        .value("viewport_px", [SIZE.0, SIZE.1])
        .value("warm_up_frames", 3)
        .value("measured_frames", frames);
    let ways = [Way::CulledInVertexStage, Way::DepthOnly, Way::Colour, Way::Pulled, Way::PulledBothFaces, Way::Merged];
    for way in ways {
        if matches!(way, Way::Merged) && !merged_fits {
            println!("{:<34} skipped: larger than one buffer may be", way.name());
            record.push_row(Row::new().value("way", way.name()).value("skipped", "larger than one buffer may be"));
            continue;
        }
        let pipeline = pipeline(way);
        let colour = !matches!(way, Way::DepthOnly | Way::CulledInVertexStage);
        let mut gpu_ms = Vec::new();
        let started = Instant::now();
        for frame in 0..frames + 3 {
            let mut encoder = device.create_command_encoder(&Default::default());
            {
                let color_attachment = [Some(wgpu::RenderPassColorAttachment {
                    view: &color,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })];
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some(way.name()),
                    color_attachments: if colour { &color_attachment } else { &[] },
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: &depth,
                        depth_ops: Some(wgpu::Operations {
                            load: wgpu::LoadOp::Clear(1.0),
                            store: wgpu::StoreOp::Store,
                        }),
                        stencil_ops: None,
                    }),
                    timestamp_writes: Some(wgpu::RenderPassTimestampWrites {
                        query_set: &queries,
                        beginning_of_pass_write_index: Some(0),
                        end_of_pass_write_index: Some(1),
                    }),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &bind_groups[usize::from(matches!(way, Way::CulledInVertexStage))], &[]);
                if let (Way::Merged, Some(merged), Some(merged_indices_buffer)) =
                    (way, &merged_buffer, &merged_index_buffer)
                {
                    pass.set_vertex_buffer(0, merged.slice(..));
                    pass.set_vertex_buffer(1, zero_offset.slice(..));
                    pass.set_index_buffer(merged_indices_buffer.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..merged_indices.len() as u32, 0, 0..1);
                } else {
                    pass.set_vertex_buffer(0, position_buffer.slice(..));
                    pass.set_vertex_buffer(1, offset_buffer.slice(..));
                    pass.set_index_buffer(index_buffer.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..indices.len() as u32, 0, 0..count as u32);
                }
            }
            encoder.resolve_query_set(&queries, 0..2, &resolved, 0);
            encoder.copy_buffer_to_buffer(&resolved, 0, &readback, 0, 16);
            queue.submit([encoder.finish()]);
            readback.slice(..).map_async(wgpu::MapMode::Read, |_| {});
            device.poll(wgpu::PollType::wait_indefinitely())?;
            let ticks: Vec<u64> = match readback.slice(..).get_mapped_range() {
                Ok(bytes) => bytemuck::cast_slice(&bytes).to_vec(),
                Err(error) => return Err(format!("timestamp readback: {error:?}").into()),
            };
            readback.unmap();
            if frame >= 3 {
                gpu_ms.push(ticks[1].saturating_sub(ticks[0]) as f64 * period_ns / 1e6);
            }
        }
        let samples = gpu_ms.clone();
        gpu_ms.sort_by(f64::total_cmp);
        let median = gpu_ms.get(gpu_ms.len() / 2).copied();
        let wall = started.elapsed().as_secs_f64() * 1e3 / (frames + 3) as f64;
        println!("{:<34} GPU {:7.3} ms   (wall {wall:6.2} ms/frame)", way.name(), median.unwrap_or(f64::NAN));
        record.push_row(
            Row::new()
                .value("way", way.name())
                .value("gpu_ms_median", median)
                .value("gpu_ms_samples", samples)
                .value("wall_ms_per_frame_mean_incl_warm_up", wall),
        );
    }
    record.write()?;
    Ok(())
}

/// Blocks on a future; this bench has nothing else to do meanwhile.
fn pollster_block<F: std::future::Future>(future: F) -> F::Output {
    futures::executor::block_on(future)
}
