//! How fast can this adapter bring a batch's pages to the CPU? Plain wgpu,
//! no Oxygen: the copy a streamed batch makes each frame, three ways, timed
//! in one run.
//!
//! ```text
//! cargo run --release --example readback_probe [WxH] [iterations] [triangles]
//! cargo run --release --example readback_probe 16384x1024 30 8000000
//! ```
//!
//! Three planes of W × H texels, as a batch of 1 024 cameras of 128 × 128
//! streams them (colour `Rgba8Unorm`, depth `Depth32Float`, instance ids
//! `R32Uint`: 4 bytes a texel each), filled by drawing 400 000 small
//! triangles of random colours, ids and depths over them (content that
//! compresses about as little as a rendered frame's), into one buffer the
//! CPU maps:
//!
//! * `copy`: `copy_texture_to_buffer` into a mapped buffer (what
//!   `Renderer::stream_batch` does);
//! * `compute into mapped`: a compute pass reads each texel and writes it
//!   into the mapped buffer itself (a storage binding of host memory,
//!   `Features::MAPPABLE_PRIMARY_BUFFERS`; skipped without it);
//! * `compute, then buffer copy`: the compute pass writes into a device
//!   buffer, then one `copy_buffer_to_buffer` into the mapped one.
//!
//! Each way runs its iterations (a submission and a wait each; the first
//! two not counted) and the median is reported, with the bytes a second;
//! the ways take turns, iteration by iteration. The bytes the three ways
//! bring back are compared once: they must be equal.
//!
//! With a third argument, the overlap ways follow ([`Overlap`]): frames of
//! that many tiny triangles each, rendered and copied back to back, in the
//! orders that decide whether one frame's copy runs beside the next
//! frame's render on wgpu's one queue (default 0: not run).
//!
//! GL adapters are refused (no depth copies into buffers, no depth loads
//! in compute). With `OXYGEN_RECORD_DIR` set, the run's figures are
//! appended to `$OXYGEN_RECORD_DIR/readback_probe.jsonl`
//! (`oxygen_demo::record`).

use std::time::Instant;

use oxygen_demo::record::{Record, Row};
use oxygen_gpu::bindings::{self, LayoutEntries};

const SHADER: &str = r#"
struct Plane { width: u32, height: u32, base: u32, kind: u32 }
@group(0) @binding(0) var<uniform> plane: Plane;
@group(0) @binding(1) var color: texture_2d<f32>;
@group(0) @binding(2) var depth: texture_depth_2d;
@group(0) @binding(3) var ids: texture_2d<u32>;
@group(0) @binding(4) var<storage, read_write> out: array<u32>;

@compute @workgroup_size(64, 4)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= plane.width || id.y >= plane.height {
        return;
    }
    let p = vec2<i32>(id.xy);
    var word: u32;
    switch plane.kind {
        case 0u: { word = pack4x8unorm(textureLoad(color, p, 0)); }
        case 1u: { word = bitcast<u32>(textureLoad(depth, p, 0)); }
        default: { word = textureLoad(ids, p, 0).r; }
    }
    out[plane.base + id.y * plane.width + id.x] = word;
}
"#;

// Random triangles over the planes, each its own colour, depth and id:
// content that compresses as little as a rendered frame's (the planes'
// compression, which copies may have to undo, depends on it).
const FILL: &str = r#"
struct Varying {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) triangle: u32,
}

fn hash(x: u32) -> u32 {
    var h = x * 747796405u + 2891336453u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    return (h >> 22u) ^ h;
}

fn unit(x: u32) -> f32 {
    return f32(hash(x) & 0xffffu) / 65535.0;
}

// Corner `index` of a small triangle around `centre + offset` (wrapped
// onto the page) of half-size `size`, at the triangle's random depth.
fn random_triangle(index: u32, offset: vec2<f32>, size: f32) -> Varying {
    let triangle = index / 3u;
    let centre = vec2<f32>(unit(triangle * 7u), unit(triangle * 7u + 1u)) * 2.0 - 1.0;
    let corner = vec2<f32>(unit(index * 13u + 2u), unit(index * 13u + 3u)) - 0.5;
    let depth = unit(triangle * 7u + 4u);
    let at = fract((centre + offset + 1.0) * 0.5) * 2.0 - 1.0;
    return Varying(vec4<f32>(at + corner * size, depth, 1.0), triangle);
}

// A small triangle somewhere on the page at one random depth.
@vertex
fn vs(@builtin(vertex_index) index: u32) -> Varying {
    return random_triangle(index, vec2<f32>(0.0), 0.02);
}

// The overlap ways' render: `triangles` tiny triangles (a few pixels
// each, so the vertices bound it, as a batch's small cameras are bound),
// moved each frame by an offset written just before the submission (the
// upload every frame makes).
struct Frame { offset: vec2<f32>, pad: vec2<f32> }
@group(0) @binding(0) var<uniform> frame: Frame;

@vertex
fn vs_small(@builtin(vertex_index) index: u32) -> Varying {
    return random_triangle(index, frame.offset, 0.0005);
}

struct Out {
    @location(0) color: vec4<f32>,
    @location(1) id: u32,
}

@fragment
fn fs(v: Varying) -> Out {
    let h = hash(v.triangle ^ (u32(v.position.x) * 31u + u32(v.position.y)));
    let color = vec4<f32>(f32(h & 255u), f32((h >> 8u) & 255u), f32((h >> 16u) & 255u), 255.0) / 255.0;
    return Out(color, v.triangle + 1u);
}
"#;

/// Triangles drawn over the planes before the copies.
const TRIANGLES: u32 = 400_000;

const WARM_UP: usize = 2;

fn texture(device: &wgpu::Device, (w, h): (u32, u32), format: wgpu::TextureFormat) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some("plane"),
        size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let size = args.next().unwrap_or_else(|| "16384x1024".into());
    let (w, h) = oxygen_demo::probe_page_size(&size)?;
    let iterations: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(30);
    let overlap_triangles: u32 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(0);
    let options =
        oxygen_gpu::GpuOptions { optional_features: wgpu::Features::MAPPABLE_PRIMARY_BUFFERS, ..Default::default() };
    let gpu = oxygen_gpu::GpuContext::new_headless(&options)?;
    let device = &gpu.device;
    // GL copies no depth into buffers and loads no depth texels in compute.
    if gpu.adapter_info.backend == wgpu::Backend::Gl {
        return Err(format!(
            "{} is a GL adapter: the probe needs depth copies and loads (use Vulkan)",
            gpu.adapter_info.name
        )
        .into());
    }
    let mapped_storage = gpu.features.contains(wgpu::Features::MAPPABLE_PRIMARY_BUFFERS);
    println!(
        "adapter: {} ({:?}); mapped storage buffers: {mapped_storage}",
        gpu.adapter_info.name, gpu.adapter_info.backend
    );
    let plane_bytes = u64::from(w) * u64::from(h) * 4;
    let total = plane_bytes * 3;
    let limit = device.limits().max_storage_buffer_binding_size;
    if total > limit || total > device.limits().max_buffer_size {
        return Err(format!("{total} bytes exceed the device's storage binding ({limit}) or buffer limit").into());
    }

    let planes = [
        texture(device, (w, h), wgpu::TextureFormat::Rgba8Unorm),
        texture(device, (w, h), wgpu::TextureFormat::Depth32Float),
        texture(device, (w, h), wgpu::TextureFormat::R32Uint),
    ];
    let views: Vec<wgpu::TextureView> = planes.iter().map(|t| t.create_view(&Default::default())).collect();
    let fill = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("fill"),
        source: wgpu::ShaderSource::Wgsl(FILL.into()),
    });
    let fill_pipeline = |entry: &str| {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(entry),
            layout: None,
            vertex: wgpu::VertexState {
                module: &fill,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &fill,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::TextureFormat::Rgba8Unorm.into()), Some(wgpu::TextureFormat::R32Uint.into())],
            }),
            multiview_mask: None,
            cache: None,
        })
    };
    // A render pass over one set of planes (colour, depth, ids), cleared
    // first or loaded.
    let planes_pass = |encoder: &'_ mut wgpu::CommandEncoder, views: &[wgpu::TextureView], clear: bool| {
        let color = |view| wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: if clear { wgpu::LoadOp::Clear(wgpu::Color::BLACK) } else { wgpu::LoadOp::Load },
                store: wgpu::StoreOp::Store,
            },
        };
        encoder
            .begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("planes"),
                color_attachments: &[Some(color(&views[0])), Some(color(&views[2]))],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &views[1],
                    depth_ops: Some(wgpu::Operations {
                        load: if clear { wgpu::LoadOp::Clear(0.0) } else { wgpu::LoadOp::Load },
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            })
            .forget_lifetime()
    };
    // Every plane filled with triangles of their own colour, id and depth.
    {
        let pipeline = fill_pipeline("vs");
        let mut encoder = device.create_command_encoder(&Default::default());
        let mut pass = planes_pass(&mut encoder, &views, true);
        pass.set_pipeline(&pipeline);
        pass.draw(0..TRIANGLES * 3, 0..1);
        drop(pass);
        gpu.queue.submit([encoder.finish()]);
    }

    let buffer = |label, usage| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: total,
            usage,
            mapped_at_creation: false,
        })
    };
    let mapped_copy = buffer("copied", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST);
    let mapped_written =
        mapped_storage.then(|| buffer("written", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::STORAGE));
    let device_written = buffer("device", wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC);
    let mapped_from_device = buffer("from device", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST);

    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("readback probe"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let layout = LayoutEntries::new(wgpu::ShaderStages::COMPUTE)
        .push(bindings::uniform_of::<[u32; 4]>())
        .push(bindings::texture_2d(bindings::FILTERABLE_FLOAT))
        .push(bindings::depth_2d())
        .push(bindings::texture_2d(wgpu::TextureSampleType::Uint))
        .push(bindings::storage_read_write())
        .create_layout(device, "readback probe");
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("readback probe"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("readback probe"),
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let params: Vec<wgpu::Buffer> = (0..3u32)
        .map(|kind| {
            let words = [w, h, kind * w * h, kind];
            let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("plane"),
                size: 16,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            gpu.queue.write_buffer(&buffer, 0, bytemuck::cast_slice(&words));
            buffer
        })
        .collect();
    let groups_of = |out: &wgpu::Buffer, views: &[wgpu::TextureView]| -> Vec<wgpu::BindGroup> {
        params
            .iter()
            .map(|p| {
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("readback probe"),
                    layout: &layout,
                    entries: &[
                        wgpu::BindGroupEntry { binding: 0, resource: p.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&views[0]) },
                        wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&views[1]) },
                        wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&views[2]) },
                        wgpu::BindGroupEntry { binding: 4, resource: out.as_entire_binding() },
                    ],
                })
            })
            .collect()
    };
    let groups = |out: &wgpu::Buffer| groups_of(out, &views);
    let into_mapped = mapped_written.as_ref().map(groups);
    let into_device = groups(&device_written);

    let compute = |encoder: &mut wgpu::CommandEncoder, groups: &[wgpu::BindGroup]| {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        for group in groups {
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(w.div_ceil(64), h.div_ceil(4), 1);
        }
    };
    // Records way `way` into a fresh encoder; the buffer it fills.
    let record = |way: usize| -> (wgpu::CommandBuffer, &wgpu::Buffer) {
        let mut encoder = device.create_command_encoder(&Default::default());
        let filled = match way {
            0 => {
                for (i, plane) in planes.iter().enumerate() {
                    encoder.copy_texture_to_buffer(
                        plane.as_image_copy(),
                        wgpu::TexelCopyBufferInfo {
                            buffer: &mapped_copy,
                            layout: wgpu::TexelCopyBufferLayout {
                                offset: i as u64 * plane_bytes,
                                bytes_per_row: Some(w * 4),
                                rows_per_image: Some(h),
                            },
                        },
                        plane.size(),
                    );
                }
                &mapped_copy
            }
            1 => {
                let (Some(groups), Some(out)) = (&into_mapped, &mapped_written) else { unreachable!() };
                compute(&mut encoder, groups);
                out
            }
            _ => {
                compute(&mut encoder, &into_device);
                encoder.copy_buffer_to_buffer(&device_written, 0, &mapped_from_device, 0, total);
                &mapped_from_device
            }
        };
        (encoder.finish(), filled)
    };
    let read = |buffer: &wgpu::Buffer| -> Result<Vec<u8>, Box<dyn std::error::Error>> {
        buffer.slice(..).map_async(wgpu::MapMode::Read, |_| {});
        device.poll(wgpu::PollType::wait_indefinitely())?;
        let bytes = buffer.slice(..).get_mapped_range()?.to_vec();
        buffer.unmap();
        Ok(bytes)
    };

    let ways: Vec<(usize, &str)> = [(0, "copy"), (1, "compute into mapped"), (2, "compute, then buffer copy")]
        .into_iter()
        .filter(|(way, _)| *way != 1 || mapped_storage)
        .collect();
    let mut samples = vec![Vec::new(); 3];
    for iteration in 0..WARM_UP + iterations {
        for &(way, _) in &ways {
            let (commands, _) = record(way);
            let started = Instant::now();
            gpu.queue.submit([commands]);
            device.poll(wgpu::PollType::wait_indefinitely())?;
            if iteration >= WARM_UP {
                samples[way].push(started.elapsed().as_secs_f64() * 1e3);
            }
        }
    }
    // The same bytes every way.
    let mut first: Option<Vec<u8>> = None;
    for &(way, name) in &ways {
        let (commands, filled) = record(way);
        gpu.queue.submit([commands]);
        let bytes = read(filled)?;
        match &first {
            None => first = Some(bytes),
            Some(expected) if *expected != bytes => return Err(format!("`{name}` brought back other bytes").into()),
            Some(_) => {}
        }
    }

    let mut record = Record::new("readback_probe")
        .value("size", [w, h])
        .value("bytes", total)
        .value("iterations", iterations)
        .value("mapped_storage", mapped_storage);
    record.set_adapter(&gpu.adapter_info);
    println!("{w} x {h} x 3 planes: {:.1} MiB a copy", total as f64 / (1 << 20) as f64);
    for &(way, name) in &ways {
        let mut sorted = samples[way].clone();
        sorted.sort_by(f64::total_cmp);
        let ms = sorted[sorted.len() / 2];
        let gb_s = total as f64 / (ms / 1e3) / 1e9;
        println!("{name:<26} {ms:8.3} ms  {gb_s:6.1} GB/s");
        record.push_row(
            Row::new()
                .value("way", name)
                .value("ms_median", ms)
                .value("gb_per_s", gb_s)
                .value("samples_ms", &samples[way]),
        );
    }
    if overlap_triangles > 0 {
        let overlap = Overlap {
            gpu: &gpu,
            size: (w, h),
            triangles: overlap_triangles,
            iterations,
            copy_into: &mapped_copy,
            drain_into: mapped_written.as_ref(),
            plane_bytes,
        };
        for row in overlap.run(
            &fill_pipeline("vs_small"),
            &planes_pass,
            &|views| mapped_written.as_ref().map(|out| groups_of(out, views)),
            &compute,
        )? {
            record.push_row(row);
        }
    }
    record.write()?;
    Ok(())
}

/// Frames submitted back to back for one sample of an overlap way.
const FRAMES_PER_SAMPLE: usize = 8;

/// The overlap ways: does a frame's copy run beside the next frame's
/// render on wgpu's one queue? Two sets of planes take turns as frames
/// of a stream do (frame `i` renders into set `i % 2` while the copy of
/// frame `i - 1`'s set may still run), each frame an upload (a uniform
/// the render reads, written just before its submission, as every frame
/// writes its constants), then:
///
/// * `render`: the render alone;
/// * `render, then its copy`: the render, then its own planes' copy
///   (today's stream: serial by construction);
/// * `last frame's copy, then render`: the copy of the other set, then the
///   render, which clears its planes in its own pass;
/// * `clear, last frame's copy, then render`: the planes cleared in a pass
///   of their own first, so that the render's barriers come before the
///   copy (a barrier after a copy waits for every copy before it);
/// * `clear, last frame's drain, then render`: as above with a compute pass
///   writing the mapped buffer instead of the copy.
struct Overlap<'a> {
    gpu: &'a oxygen_gpu::GpuContext,
    size: (u32, u32),
    triangles: u32,
    iterations: usize,
    copy_into: &'a wgpu::Buffer,
    drain_into: Option<&'a wgpu::Buffer>,
    plane_bytes: u64,
}

type PlanesPass<'p> = dyn Fn(&mut wgpu::CommandEncoder, &[wgpu::TextureView], bool) -> wgpu::RenderPass<'static> + 'p;
type DrainGroups<'p> = dyn Fn(&[wgpu::TextureView]) -> Option<Vec<wgpu::BindGroup>> + 'p;
type Drain<'p> = dyn Fn(&mut wgpu::CommandEncoder, &[wgpu::BindGroup]) + 'p;

impl Overlap<'_> {
    fn run(
        &self,
        pipeline: &wgpu::RenderPipeline,
        planes_pass: &PlanesPass<'_>,
        drain_groups: &DrainGroups<'_>,
        drain: &Drain<'_>,
    ) -> Result<Vec<Row>, Box<dyn std::error::Error>> {
        let device = &self.gpu.device;
        let sets: Vec<Vec<wgpu::Texture>> = (0..2)
            .map(|_| {
                [wgpu::TextureFormat::Rgba8Unorm, wgpu::TextureFormat::Depth32Float, wgpu::TextureFormat::R32Uint]
                    .map(|format| texture(device, self.size, format))
                    .to_vec()
            })
            .collect();
        let views: Vec<Vec<wgpu::TextureView>> =
            sets.iter().map(|set| set.iter().map(|t| t.create_view(&Default::default())).collect()).collect();
        let drains: Vec<Option<Vec<wgpu::BindGroup>>> = views.iter().map(|v| drain_groups(v)).collect();
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() }],
        });
        let render = |encoder: &mut wgpu::CommandEncoder, set: usize, clear: bool| {
            let mut pass = planes_pass(encoder, &views[set], clear);
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.draw(0..self.triangles * 3, 0..1);
        };
        let copy = |encoder: &mut wgpu::CommandEncoder, set: usize| {
            for (i, plane) in sets[set].iter().enumerate() {
                encoder.copy_texture_to_buffer(
                    plane.as_image_copy(),
                    wgpu::TexelCopyBufferInfo {
                        buffer: self.copy_into,
                        layout: wgpu::TexelCopyBufferLayout {
                            offset: i as u64 * self.plane_bytes,
                            bytes_per_row: Some(self.size.0 * 4),
                            rows_per_image: Some(self.size.1),
                        },
                    },
                    plane.size(),
                );
            }
        };
        let mut ways: Vec<&str> = vec![
            "render",
            "render, then its copy",
            "last frame's copy, then render",
            "clear, last frame's copy, then render",
        ];
        if self.drain_into.is_some() {
            ways.push("clear, last frame's drain, then render");
        }
        let mut samples = vec![Vec::new(); ways.len()];
        let mut frame = 0usize;
        for iteration in 0..WARM_UP + self.iterations {
            for (way, way_samples) in samples.iter_mut().enumerate() {
                let started = Instant::now();
                for _ in 0..FRAMES_PER_SAMPLE {
                    frame += 1;
                    let (this, last) = (frame % 2, (frame + 1) % 2);
                    let offset = [frame as f32 * 0.001, 0.0, 0.0, 0.0];
                    self.gpu.queue.write_buffer(&uniform, 0, bytemuck::cast_slice(&offset));
                    let mut encoder = device.create_command_encoder(&Default::default());
                    match way {
                        0 => render(&mut encoder, this, true),
                        1 => {
                            render(&mut encoder, this, true);
                            copy(&mut encoder, this);
                        }
                        2 => {
                            copy(&mut encoder, last);
                            render(&mut encoder, this, true);
                        }
                        3 => {
                            drop(planes_pass(&mut encoder, &views[this], true));
                            copy(&mut encoder, last);
                            render(&mut encoder, this, false);
                        }
                        _ => {
                            drop(planes_pass(&mut encoder, &views[this], true));
                            let Some(groups) = &drains[last] else { unreachable!() };
                            drain(&mut encoder, groups);
                            render(&mut encoder, this, false);
                        }
                    }
                    self.gpu.queue.submit([encoder.finish()]);
                }
                device.poll(wgpu::PollType::wait_indefinitely())?;
                if iteration >= WARM_UP {
                    way_samples.push(started.elapsed().as_secs_f64() * 1e3 / FRAMES_PER_SAMPLE as f64);
                }
            }
        }
        println!("{} triangles a frame, {FRAMES_PER_SAMPLE} frames back to back a sample:", self.triangles);
        let mut rows = Vec::new();
        for (way, name) in ways.iter().enumerate() {
            let mut sorted = samples[way].clone();
            sorted.sort_by(f64::total_cmp);
            let ms = sorted[sorted.len() / 2];
            println!("{name:<42} {ms:8.3} ms a frame");
            rows.push(
                Row::new()
                    .value("way", *name)
                    .value("triangles", self.triangles)
                    .value("frames_per_sample", FRAMES_PER_SAMPLE)
                    .value("ms_per_frame_median", ms)
                    .value("samples_ms_per_frame", &samples[way]),
            );
        }
        Ok(rows)
    }
}
