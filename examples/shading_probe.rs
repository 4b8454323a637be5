//! Where does per-pixel work run fastest on this adapter: in a fragment
//! shader or in a compute shader? Plain wgpu, no Oxygen: the same work for
//! every pixel of a W × H image (a loop of `LOOPS` rounds of the
//! arithmetic a lit pixel does: normalisations, dot products, a power),
//! written once by a full-screen triangle's fragments into a colour
//! target and once by a compute pass into a storage texture, taking turns.
//!
//! ```text
//! cargo run --release --example shading_probe [WxH] [loops] [iterations]
//! cargo run --release --example shading_probe 16384x1024 64 20
//! ```
//!
//! Some GPUs run fragments on a part of their cores only (NVIDIA documents
//! that two of an H100's TPCs are graphics-capable), so a forward shader's
//! cost per pixel there is not what the chip's compute rate suggests. Each
//! way runs its iterations (a submission and a wait each, the first two not
//! counted, timed by timestamps around the pass where the adapter has them,
//! else by the wall clock); the medians are reported with the pixels a
//! second. The two images are compared once: the same work must give the
//! same bytes (within one unit, for rounding between stages).
//! With `OXYGEN_RECORD_DIR` set, the figures are appended to
//! `$OXYGEN_RECORD_DIR/shading_probe.jsonl` (`oxygen_demo::record`).

use std::time::Instant;

use oxygen_demo::record::{Record, Row};

const SHADER: &str = r#"
struct Params { width: u32, height: u32, loops: u32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var image: texture_storage_2d<rgba8unorm, write>;

// What one pixel costs: `loops` rounds of a lit surface's arithmetic,
// seeded by the pixel so that nothing folds away.
fn work(p: vec2<u32>) -> vec4<f32> {
    var n = normalize(vec3<f32>(f32(p.x % 97u) - 48.0, 40.0, f32(p.y % 89u) - 44.0));
    var c = vec3<f32>(0.0);
    for (var i = 0u; i < params.loops; i++) {
        let l = normalize(vec3<f32>(sin(f32(i)), 1.0, cos(f32(i))));
        let h = normalize(l + vec3<f32>(0.0, 0.0, 1.0));
        let ndl = max(dot(n, l), 0.0);
        let ndh = max(dot(n, h), 0.0);
        c += vec3<f32>(ndl * 0.5, pow(ndh, 32.0) * 0.25, ndl * ndh * 0.25);
        n = normalize(n + c * 0.001);
    }
    return vec4<f32>(c / f32(max(params.loops, 1u)), 1.0);
}

@vertex
fn vs(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn fs(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    return work(vec2<u32>(position.xy));
}

@compute @workgroup_size(8, 8)
fn cs(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    textureStore(image, id.xy, work(id.xy));
}
"#;

const WARM_UP: usize = 2;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let size = args.next().unwrap_or_else(|| "16384x1024".into());
    let (w, h) = oxygen_demo::probe_page_size(&size)?;
    let loops: u32 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(64);
    let iterations: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(20);
    if iterations == 0 {
        return Err("at least one iteration".into());
    }
    let options = oxygen_gpu::GpuOptions { optional_features: wgpu::Features::TIMESTAMP_QUERY, ..Default::default() };
    let gpu = oxygen_gpu::GpuContext::new_headless(&options)?;
    let device = &gpu.device;
    let timed = gpu.features.contains(wgpu::Features::TIMESTAMP_QUERY);
    println!("adapter: {} ({:?}); timestamps: {timed}", gpu.adapter_info.name, gpu.adapter_info.backend);
    let limit = device.limits().max_texture_dimension_2d;
    if w > limit || h > limit {
        return Err(format!("{w} x {h} exceeds the device's {limit} texels a side").into());
    }

    let texture = |label| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        })
    };
    let drawn = texture("drawn");
    let computed = texture("computed");
    let drawn_view = drawn.create_view(&Default::default());
    let computed_view = computed.create_view(&Default::default());
    let params = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("params"),
        size: 16,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    gpu.queue.write_buffer(&params, 0, bytemuck::cast_slice(&[w, h, loops, 0u32]));
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("shading probe"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let render = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("fragments"),
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
            targets: &[Some(wgpu::TextureFormat::Rgba8Unorm.into())],
        }),
        multiview_mask: None,
        cache: None,
    });
    let compute = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("compute"),
        layout: None,
        module: &module,
        entry_point: Some("cs"),
        compilation_options: Default::default(),
        cache: None,
    });
    let render_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("fragments"),
        layout: &render.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() }],
    });
    let compute_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("compute"),
        layout: &compute.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&computed_view) },
        ],
    });
    let queries = timed.then(|| {
        device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("pass times"),
            ty: wgpu::QueryType::Timestamp,
            count: 2,
        })
    });
    let resolve = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("pass times"),
        size: 16,
        usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let times = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("pass times readback"),
        size: 16,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let period_ns = f64::from(gpu.queue.get_timestamp_period());

    // One iteration of way 0 (fragments) or 1 (compute), in milliseconds.
    let run = |way: usize| -> Result<f64, Box<dyn std::error::Error>> {
        let mut encoder = device.create_command_encoder(&Default::default());
        if way == 0 {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("fragments"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &drawn_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: queries.as_ref().map(|q| wgpu::RenderPassTimestampWrites {
                    query_set: q,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&render);
            pass.set_bind_group(0, &render_group, &[]);
            pass.draw(0..3, 0..1);
        } else {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("compute"),
                timestamp_writes: queries.as_ref().map(|q| wgpu::ComputePassTimestampWrites {
                    query_set: q,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
            });
            pass.set_pipeline(&compute);
            pass.set_bind_group(0, &compute_group, &[]);
            pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
        }
        if let Some(q) = &queries {
            encoder.resolve_query_set(q, 0..2, &resolve, 0);
            encoder.copy_buffer_to_buffer(&resolve, 0, &times, 0, 16);
        }
        let started = Instant::now();
        gpu.queue.submit([encoder.finish()]);
        device.poll(wgpu::PollType::wait_indefinitely())?;
        let wall = started.elapsed().as_secs_f64() * 1e3;
        if queries.is_none() {
            return Ok(wall);
        }
        times.slice(..).map_async(wgpu::MapMode::Read, |_| {});
        device.poll(wgpu::PollType::wait_indefinitely())?;
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&times.slice(..).get_mapped_range()?);
        times.unmap();
        Ok(ticks[1].saturating_sub(ticks[0]) as f64 * period_ns * 1e-6)
    };
    let ways = ["fragment shader", "compute shader"];
    let mut samples = [Vec::new(), Vec::new()];
    for iteration in 0..WARM_UP + iterations {
        for (way, way_samples) in samples.iter_mut().enumerate() {
            let ms = run(way)?;
            if iteration >= WARM_UP {
                way_samples.push(ms);
            }
        }
    }

    // The same work gives the same image both ways.
    let read = |texture: &wgpu::Texture| -> Result<Vec<u8>, Box<dyn std::error::Error>> {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("image"),
            size: u64::from(w) * u64::from(h) * 4,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(w * 4), rows_per_image: Some(h) },
            },
            texture.size(),
        );
        gpu.queue.submit([encoder.finish()]);
        buffer.slice(..).map_async(wgpu::MapMode::Read, |_| {});
        device.poll(wgpu::PollType::wait_indefinitely())?;
        let bytes = buffer.slice(..).get_mapped_range()?.to_vec();
        Ok(bytes)
    };
    let (a, b) = (read(&drawn)?, read(&computed)?);
    let differing = a.iter().zip(&b).filter(|(x, y)| x.abs_diff(**y) > 1).count();
    if differing > 0 {
        return Err(format!("the two ways wrote different images: {differing} bytes differ by more than 1").into());
    }

    let pixels = f64::from(w) * f64::from(h);
    let mut record = Record::new("shading_probe")
        .value("size", [w, h])
        .value("loops", loops)
        .value("iterations", iterations)
        .value("timestamps", timed);
    record.set_adapter(&gpu.adapter_info);
    println!("{w} x {h} pixels, {loops} rounds a pixel:");
    let mut medians = [0.0; 2];
    for (way, name) in ways.iter().enumerate() {
        let mut sorted = samples[way].clone();
        sorted.sort_by(f64::total_cmp);
        let ms = sorted[sorted.len() / 2];
        medians[way] = ms;
        let gpix = pixels / (ms / 1e3) / 1e9;
        println!("{name:<16} {ms:8.3} ms  {gpix:7.2} G pixels/s");
        record.push_row(
            Row::new()
                .value("way", *name)
                .value("ms_median", ms)
                .value("g_pixels_per_s", gpix)
                .value("samples_ms", &samples[way]),
        );
    }
    println!("fragment / compute: {:.2}", medians[0] / medians[1]);
    record.write()?;
    Ok(())
}
