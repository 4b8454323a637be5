//! The spot-shadow atlas: every spot shadow map of the frame packed into one
//! texture, so the shading pass binds one atlas however many spots cast.
//!
//! Spot shadow views render depth into their own targets (a view owns its
//! targets); WebGPU copies depth only as whole subresources, so packing is a
//! small draw per map: a full-screen triangle, limited by the viewport to the
//! map's tile, loads the map's depth and writes it to the `R32Float` atlas.
//! The shading pass then compares depths itself (an `R32Float` texture has
//! no comparison sampling), with the same PCF kernel as the cascades.

use std::sync::Mutex;

use bytemuck::{Pod, Zeroable};

use crate::MAX_SPOT_SHADOWS;

/// Format of the atlas: one 32-bit float depth per texel.
pub const SPOT_ATLAS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

const PACK_WGSL: &str = r#"
struct Tile { origin: vec2<i32>, pad: vec2<i32> }
@group(0) @binding(0) var map: texture_depth_2d;
@group(0) @binding(1) var<uniform> tile: Tile;
@vertex
fn vs(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}
@fragment
fn fs(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let texel = vec2<i32>(position.xy) - tile.origin;
    return vec4<f32>(textureLoad(map, texel, 0), 0.0, 0.0, 1.0);
}
"#;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Tile {
    origin: [i32; 2],
    pad: [i32; 2],
}

/// The packer's pipeline and the atlas texture, kept across frames.
pub(crate) struct SpotAtlasPacker {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    atlas: Mutex<Option<wgpu::Texture>>,
}

impl SpotAtlasPacker {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("spot atlas pack"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Depth,
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("spot atlas pack"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("spot atlas pack"),
            source: wgpu::ShaderSource::Wgsl(PACK_WGSL.into()),
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("spot atlas pack"),
            layout: Some(&pipeline_layout),
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
                targets: &[Some(wgpu::ColorTargetState {
                    format: SPOT_ATLAS_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        SpotAtlasPacker { layout, pipeline, atlas: Mutex::new(None) }
    }

    /// Packs `maps` (depth view and side, by spot slot) into 2 × 2 tiles of
    /// the atlas; returns the atlas view and each slot's UV rectangle
    /// (offset xy, scale zw).
    pub(crate) fn pack(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        maps: &[Option<(&wgpu::TextureView, u32)>; MAX_SPOT_SHADOWS],
    ) -> (wgpu::TextureView, [[f32; 4]; MAX_SPOT_SHADOWS]) {
        let tile = maps.iter().flatten().map(|(_, side)| *side).max().unwrap_or(1).max(1);
        let side = tile * 2;
        let mut slot = self.atlas.lock().unwrap_or_else(|e| e.into_inner());
        let fits = slot.as_ref().is_some_and(|t| t.width() == side);
        if !fits {
            *slot = Some(device.create_texture(&wgpu::TextureDescriptor {
                label: Some("spot shadow atlas"),
                size: wgpu::Extent3d { width: side, height: side, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: SPOT_ATLAS_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            }));
        }
        // Just created or reused: either way an atlas of `side` exists now.
        let atlas = slot.as_ref().expect("atlas exists").create_view(&Default::default());
        let mut rects = [[0.0; 4]; MAX_SPOT_SHADOWS];
        for (i, map) in maps.iter().enumerate() {
            let Some((view, map_side)) = map else { continue };
            let origin = [(i as u32 % 2) * tile, (i as u32 / 2) * tile];
            rects[i] = [
                origin[0] as f32 / side as f32,
                origin[1] as f32 / side as f32,
                *map_side as f32 / side as f32,
                *map_side as f32 / side as f32,
            ];
            let uniform = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("spot atlas tile"),
                size: std::mem::size_of::<Tile>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            queue.write_buffer(
                &uniform,
                0,
                bytemuck::bytes_of(&Tile { origin: [origin[0] as i32, origin[1] as i32], pad: [0; 2] }),
            );
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("spot atlas tile"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(view) },
                    wgpu::BindGroupEntry { binding: 1, resource: uniform.as_entire_binding() },
                ],
            });
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("spot atlas pack"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &atlas,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_viewport(origin[0] as f32, origin[1] as f32, *map_side as f32, *map_side as f32, 0.0, 1.0);
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.draw(0..3, 0..1);
        }
        (atlas, rects)
    }
}
