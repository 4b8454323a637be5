//! The depth pyramid against the CPU: every level of a pyramid built from a
//! pseudo-random depth image of odd size equals the minimum of the depth
//! pixels its texels cover, and `hiz_visible`, run for thousands of boxes in
//! one dispatch (neighbouring invocations picking different levels), never
//! hides a box that a pixel of its screen rectangle shows.

mod support;

use oxygen::gpu::{GpuContext, GpuOptions};
use oxygen::passes::testing::{HizPipelines, HizPyramid};

/// Fills a depth target with a per-pixel hash through `frag_depth` (depth
/// textures cannot be copy destinations).
const FILL: &str = r#"
@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.5, 1.0);
}

struct Out { @builtin(frag_depth) depth: f32 }

@fragment
fn fs(@builtin(position) p: vec4<f32>) -> Out {
    var h = u32(p.x) * 73856093u ^ u32(p.y) * 19349663u;
    h = (h ^ (h >> 13u)) * 0x5bd1e995u;
    h = h ^ (h >> 15u);
    return Out(f32(h & 0xffffu) / 65535.0);
}
"#;

/// The test adapter, or `None` (with the reason printed) where GPU
/// visibility, the pyramid's only user, cannot run (the GL backend, whose
/// shading language cannot load depth texels in compute).
fn context() -> Option<GpuContext> {
    let gpu = GpuContext::new_headless(&GpuOptions::default()).expect("GPU tests need an adapter");
    if !oxygen::passes::GpuVisibility::supported(gpu.adapter.features()) {
        support::skip::skip(format_args!(
            "{} cannot run GPU visibility, which the depth pyramid serves",
            gpu.describe()
        ));
        return None;
    }
    Some(gpu)
}

fn hash_depth(x: u32, y: u32) -> f32 {
    let mut h = x.wrapping_mul(73856093) ^ y.wrapping_mul(19349663);
    h = (h ^ (h >> 13)).wrapping_mul(0x5bd1_e995);
    h ^= h >> 15;
    (h & 0xffff) as f32 / 65535.0
}

#[test]
fn every_level_is_the_minimum_of_the_depth_pixels_it_covers() {
    let Some(gpu) = context() else { return };
    // Odd sizes: every level has a last row and column taking a third texel.
    let (width, height) = (203u32, 117u32);
    let (pipelines, pyramid, depth_view) = filled_pyramid(&gpu, width, height);
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    pyramid.build(&gpu.device, &pipelines, &mut encoder, &depth_view);
    gpu.queue.submit([encoder.finish()]);
    let all: Vec<f32> =
        bytemuck::pod_collect_to_vec(&gpu.read_buffer(pyramid.buffer(), 0, pyramid.buffer().size()).unwrap());

    let mut expected: Vec<f32> = (0..height).flat_map(|y| (0..width).map(move |x| hash_depth(x, y))).collect();
    let (mut w, mut h) = (width, height);
    for level in 0..pyramid.levels() {
        if level > 0 {
            // The reference reduction: 2×2, the last row and column also
            // taking the odd texel left over.
            let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
            let mut next = vec![0.0f32; (nw * nh) as usize];
            for y in 0..nh {
                for x in 0..nw {
                    let x_end = if x == nw - 1 { w - 1 } else { (2 * x + 1).min(w - 1) };
                    let y_end = if y == nh - 1 { h - 1 } else { (2 * y + 1).min(h - 1) };
                    let mut m = 1.0f32;
                    for sy in (2 * y).min(h - 1)..=y_end {
                        for sx in (2 * x).min(w - 1)..=x_end {
                            m = m.min(expected[(sy * w + sx) as usize]);
                        }
                    }
                    next[(y * nw + x) as usize] = m;
                }
            }
            (expected, w, h) = (next, nw, nh);
        }
        let (offset, lw, lh) = pyramid.level(level).unwrap();
        assert_eq!((lw, lh), (w, h), "level {level}'s size");
        let actual = &all[offset as usize..(offset + w * h) as usize];
        let wrong = actual.iter().zip(&expected).filter(|(a, e)| a != e).count();
        assert_eq!(wrong, 0, "level {level} ({w}×{h}): {wrong} texels differ from the CPU reduction");
    }
    assert_eq!((w, h), (1, 1), "the pyramid ends at 1×1");
}

/// `hiz_visible` never hides a box some pixel of its (pixel-widened)
/// screen rectangle shows nearer than the depth there: thousands of random
/// boxes of every size against the random depth image.
#[test]
fn hiz_visible_never_hides_a_box_that_some_covered_pixel_shows() {
    use oxygen::core::glam::{Mat4, Vec3, Vec4};
    let Some(gpu) = context() else { return };
    let device = &gpu.device;
    let (width, height) = (192u32, 128u32);
    let (pipelines, pyramid, depth_view) = filled_pyramid(&gpu, width, height);
    let mut encoder = device.create_command_encoder(&Default::default());
    pyramid.build(device, &pipelines, &mut encoder, &depth_view);
    gpu.queue.submit([encoder.finish()]);

    let projection =
        oxygen::core::math::projection::reverse_z_perspective(1.0, width as f32 / height as f32, 0.1, Some(100.0));
    let view = Mat4::look_at_rh(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y);
    let view_projection = projection * view;
    let mut state = 12345u64;
    let mut unit = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let boxes: Vec<[f32; 8]> = (0..4000)
        .map(|_| {
            let center = Vec3::new(unit() * 8.0 - 4.0, unit() * 6.0 - 3.0, -unit() * 60.0);
            let half = Vec3::new(unit(), unit(), unit()) * (0.01 + unit() * unit() * 3.0);
            let (lo, hi) = (center - half, center + half);
            [lo.x, lo.y, lo.z, 0.0, hi.x, hi.y, hi.z, 0.0]
        })
        .collect();
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        // The registry's harness (`visibility/hiz_visible_boxes.wgsl`): one
        // invocation per box, calling `hiz_visible`.
        label: Some("hiz_visible test"),
        source: wgpu::ShaderSource::Wgsl(oxygen::passes::testing::hiz_visible_boxes_wgsl().into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: None,
        layout: None,
        module: &module,
        entry_point: Some("visible_boxes"),
        compilation_options: Default::default(),
        cache: None,
    });
    let buffer = |contents: &[u8], usage| {
        use wgpu::util::DeviceExt;
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: None, contents, usage })
    };
    let mut params = bytemuck::cast_slice::<f32, u8>(&view_projection.to_cols_array()).to_vec();
    params.extend(bytemuck::cast_slice(&[width, height, pyramid.levels(), boxes.len() as u32]));
    let params = buffer(&params, wgpu::BufferUsages::UNIFORM);
    let box_buffer = buffer(bytemuck::cast_slice(&boxes), wgpu::BufferUsages::STORAGE);
    let out = buffer(&vec![0u8; boxes.len() * 4], wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC);
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: box_buffer.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: out.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 3, resource: pyramid.buffer().as_entire_binding() },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups((boxes.len() as u32).div_ceil(64), 1, 1);
    }
    gpu.queue.submit([encoder.finish()]);
    let visible: Vec<u32> = bytemuck::pod_collect_to_vec(&gpu.read_buffer(&out, 0, boxes.len() as u64 * 4).unwrap());

    // The CPU reference: the box's projected rectangle (exact, from its 8
    // corners) and nearest depth; visible when some pixel inside shows a
    // depth at or behind it.
    let (mut hidden, mut wrong) = (0, Vec::new());
    for (i, b) in boxes.iter().enumerate() {
        let corners = (0..8).map(|c| {
            let p = Vec3::new(
                b[if c & 1 == 0 { 0 } else { 4 }],
                b[if c & 2 == 0 { 1 } else { 5 }],
                b[if c & 4 == 0 { 2 } else { 6 }],
            );
            view_projection * Vec4::new(p.x, p.y, p.z, 1.0)
        });
        let corners: Vec<Vec4> = corners.collect();
        if corners.iter().any(|c| c.w <= 1e-5) {
            assert_eq!(visible[i], 1, "box {i} reaches behind the eye");
            continue;
        }
        let ndc: Vec<Vec3> = corners.iter().map(|c| c.truncate() / c.w).collect();
        let nearest = ndc.iter().map(|p| p.z).fold(f32::MIN, f32::max);
        let (x0, x1) =
            (ndc.iter().map(|p| p.x).fold(f32::MAX, f32::min), ndc.iter().map(|p| p.x).fold(f32::MIN, f32::max));
        let (y0, y1) =
            (ndc.iter().map(|p| p.y).fold(f32::MAX, f32::min), ndc.iter().map(|p| p.y).fold(f32::MIN, f32::max));
        let px = |x: f32| ((x * 0.5 + 0.5) * width as f32).floor().clamp(0.0, width as f32 - 1.0) as u32;
        let py = |y: f32| ((0.5 - y * 0.5) * height as f32).floor().clamp(0.0, height as f32 - 1.0) as u32;
        let seen = (py(y1)..=py(y0)).any(|y| (px(x0)..=px(x1)).any(|x| hash_depth(x, y) <= nearest));
        if visible[i] == 0 {
            hidden += 1;
            if seen || nearest >= 1.0 || x1 < -1.0 || x0 > 1.0 || y1 < -1.0 || y0 > 1.0 {
                wrong.push(i);
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "{} boxes hidden that a pixel shows, e.g. {:?}",
        wrong.len(),
        &wrong[..wrong.len().min(5)]
    );
    eprintln!("{hidden} of {} boxes hidden", boxes.len());
    assert!(hidden > 100, "the test should hide some boxes behind the random depth, hid {hidden}");
}

/// Pipelines, a pyramid and a depth target filled with [`hash_depth`].
fn filled_pyramid(gpu: &GpuContext, width: u32, height: u32) -> (HizPipelines, HizPyramid, wgpu::TextureView) {
    let device = &gpu.device;
    let depth = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("test depth"),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Depth32Float,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let depth_view = depth.create_view(&Default::default());
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("fill depth"),
        source: wgpu::ShaderSource::Wgsl(FILL.into()),
    });
    let fill = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("fill depth"),
        layout: None,
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: Some(wgpu::DepthStencilState {
            format: wgpu::TextureFormat::Depth32Float,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Always),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &[],
        }),
        multiview_mask: None,
        cache: None,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("fill"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth_view,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&fill);
        pass.draw(0..3, 0..1);
    }
    gpu.queue.submit([encoder.finish()]);
    let pipelines = HizPipelines::new(device);
    let pyramid = HizPyramid::new(device, &pipelines, width, height);
    (pipelines, pyramid, depth_view)
}
