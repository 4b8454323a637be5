//! The local-light shadow atlas: every spot shadow map and every cube face of
//! a point light's shadow of the frame packed into one texture as tiles, so
//! the shading pass binds one atlas however many local lights cast.
//!
//! Local shadow views render depth into their own targets (a view owns its
//! targets); WebGPU copies depth only as whole subresources, so packing is a
//! small draw per map: a full-screen triangle, limited by the viewport to the
//! map's tile, loads the map's depth and writes it to the `R32Float` atlas.
//! The shading pass then compares depths itself (an `R32Float` texture has
//! no comparison sampling), with the same PCF kernel as the cascades.

use std::sync::Mutex;

use bytemuck::{Pod, Zeroable};

use crate::MAX_SHADOW_TILES;

/// Format of the atlas: one 32-bit float depth per texel.
pub const SHADOW_ATLAS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

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
pub(crate) struct ShadowAtlasPacker {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    atlas: Mutex<Option<wgpu::Texture>>,
}

impl ShadowAtlasPacker {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadow atlas pack"),
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
            label: Some("shadow atlas pack"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("shadow atlas pack"),
            source: wgpu::ShaderSource::Wgsl(PACK_WGSL.into()),
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("shadow atlas pack"),
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
                    format: SHADOW_ATLAS_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        ShadowAtlasPacker { layout, pipeline, atlas: Mutex::new(None) }
    }

    /// Packs `maps` (depth view and side, by tile) into a square grid of
    /// tiles just large enough for the highest tile in use (2 × 2 for up to
    /// four, 4 × 4 for sixteen); returns the atlas view and each tile's UV
    /// rectangle (offset xy, scale zw).
    pub(crate) fn pack(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        maps: &[Option<(&wgpu::TextureView, u32)>; MAX_SHADOW_TILES],
    ) -> Result<(wgpu::TextureView, [[f32; 4]; MAX_SHADOW_TILES]), String> {
        let tile = maps.iter().flatten().map(|(_, side)| *side).max().unwrap_or(1).max(1);
        let used = maps.iter().rposition(Option::is_some).map_or(1, |last| last + 1);
        let columns = (1..).find(|c| c * c >= used).unwrap_or(1) as u32;
        let side = tile * columns;
        let limit = device.limits().max_texture_dimension_2d;
        if side > limit {
            return Err(format!(
                "the shadow atlas would be {side} texels wide ({columns} × {columns} tiles of {tile}), over the device limit of {limit}: lower the shadow resolution or the number of shadow-casting lights"
            ));
        }
        let mut slot = self.atlas.lock().unwrap_or_else(|e| e.into_inner());
        let fits = slot.as_ref().is_some_and(|t| t.width() == side);
        if !fits {
            *slot = Some(device.create_texture(&wgpu::TextureDescriptor {
                label: Some("local shadow atlas"),
                size: wgpu::Extent3d { width: side, height: side, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: SHADOW_ATLAS_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            }));
        }
        // Just created or reused: either way an atlas of `side` exists now.
        let atlas = slot.as_ref().expect("atlas exists").create_view(&Default::default());
        let mut rects = [[0.0; 4]; MAX_SHADOW_TILES];
        for (i, map) in maps.iter().enumerate() {
            let Some((view, map_side)) = map else { continue };
            let origin = [(i as u32 % columns) * tile, (i as u32 / columns) * tile];
            rects[i] = [
                origin[0] as f32 / side as f32,
                origin[1] as f32 / side as f32,
                *map_side as f32 / side as f32,
                *map_side as f32 / side as f32,
            ];
            let uniform = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("shadow atlas tile"),
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
                label: Some("shadow atlas tile"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(view) },
                    wgpu::BindGroupEntry { binding: 1, resource: uniform.as_entire_binding() },
                ],
            });
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("shadow atlas pack"),
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
        Ok((atlas, rects))
    }
}
