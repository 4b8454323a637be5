//! `OverlayPass`: the view's overlay ([`oxygen_overlay::Overlay`]: shapes,
//! text, debug lines, a grid) drawn over its final image, after the tone
//! map. The overlay is tessellated on the CPU for the view's camera; the
//! pass uploads the vertices and the atlas rows that changed and draws
//! them all at once: one render pass and one draw a view, whatever the
//! number of shapes. World shapes are depth-tested against the view's
//! depth where it is single-sampled; a multisampled view's depth is not
//! (its samples do not match the display image), so there every world
//! shape is drawn on top. A view without an overlay, or with an empty one,
//! records nothing.

use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

use glam::{DMat4, UVec2};
use oxygen_core::ViewId;
use oxygen_gpu::ViewTargets;
use oxygen_gpu::bindings::{self, LayoutEntries};
use oxygen_overlay::{ATLAS_SIZE, OverlayVertex, OverlayView};
use tracing::info_span;

use crate::{CommandRecorder, PassError, RenderContext, RenderPass};

/// Draws the view's overlay ([`RenderContext::overlay`]) over its display
/// image. The standard graph records it last.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OverlayPass;

/// The pipelines, made on first use.
struct Made {
    layout: wgpu::BindGroupLayout,
    /// World shapes tested against the view's depth.
    with_depth: wgpu::RenderPipeline,
    /// Everything on top (multisampled views).
    without_depth: wgpu::RenderPipeline,
    sampler: wgpu::Sampler,
}

/// A view's vertex buffer and atlas texture, kept across frames.
struct ViewOverlay {
    vertices: wgpu::Buffer,
    atlas: wgpu::Texture,
    bind_group: wgpu::BindGroup,
    /// The atlas generation the texture holds (`None`: nothing yet).
    generation: Option<u64>,
}

/// The overlay pass's pipelines and every view's buffers.
#[derive(Default)]
pub(crate) struct OverlayState {
    made: OnceLock<Made>,
    views: Mutex<HashMap<ViewId, ViewOverlay>>,
}

const ATTRIBUTES: [wgpu::VertexAttribute; 5] = wgpu::vertex_attr_array![
    0 => Float32x4,
    1 => Float32x2,
    2 => Float32x4,
    3 => Unorm8x4,
    4 => Uint32,
];

const _: () = assert!(size_of::<OverlayVertex>() == 48);

impl Made {
    fn new(device: &wgpu::Device) -> Made {
        let layout = LayoutEntries::new(wgpu::ShaderStages::FRAGMENT)
            .push(bindings::texture_2d(bindings::FILTERABLE_FLOAT))
            .push(bindings::sampler_filtering())
            .create_layout(device, "overlay");
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("overlay"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("overlay"),
            source: wgpu::ShaderSource::Wgsl(crate::shaders::OVERLAY.source().into()),
        });
        let pipeline = |depth: bool| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(if depth { "overlay, depth-tested" } else { "overlay" }),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs"),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: size_of::<OverlayVertex>() as u64,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &ATTRIBUTES,
                    })],
                },
                primitive: Default::default(),
                // Reverse-Z: a shape at least as near as the surface shows;
                // screen shapes lie on the near plane (1) and always do.
                depth_stencil: depth.then(|| wgpu::DepthStencilState {
                    format: ViewTargets::DEPTH_FORMAT,
                    depth_write_enabled: Some(false),
                    depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: ViewTargets::COLOR_FORMAT,
                        blend: Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("overlay atlas"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        Made { with_depth: pipeline(true), without_depth: pipeline(false), layout, sampler }
    }
}

impl OverlayState {
    /// Frees the buffers of the views `keep` says no to.
    pub(crate) fn retain(&self, keep: impl Fn(ViewId) -> bool) {
        if let Ok(mut views) = self.views.lock() {
            views.retain(|view, _| keep(*view));
        }
    }

    /// Views holding overlay buffers.
    pub(crate) fn views(&self) -> usize {
        self.views.lock().map_or(0, |views| views.len())
    }
}

impl RenderPass for OverlayPass {
    fn name(&self) -> &'static str {
        "overlay"
    }

    async fn run(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        let Some(overlay) = ctx.overlay else {
            return Ok(());
        };
        let mut overlay = overlay.lock().map_err(|_| PassError::Graph("the view's overlay is poisoned".into()))?;
        if overlay.is_empty() {
            return Ok(());
        }
        let _span = info_span!("overlay", view = %ctx.view.view_id, shapes = overlay.shape_count()).entered();
        let color = ctx.color_targets(self.name())?;
        let target = color.color_view.as_ref().ok_or(PassError::NoColorTarget { pass: self.name() })?;
        // The view's matrices are relative to the render origin; the
        // overlay's shapes are in the world.
        let world_to_view = ctx.view.world_to_view * DMat4::from_translation(-ctx.origin);
        let camera =
            OverlayView::new(ctx.view.projection, world_to_view, UVec2::new(ctx.targets.width, ctx.targets.height));
        let vertices = overlay.tessellate(&camera);
        if vertices.is_empty() {
            return Ok(());
        }
        let device = &ctx.gpu.device;
        let state = ctx.lighting.overlay();
        let made = state.made.get_or_init(|| Made::new(device));
        let mut views = state.views.lock().map_err(|_| PassError::Graph("overlay state poisoned".into()))?;
        let bytes: &[u8] = bytemuck::cast_slice(&vertices);
        let fits = views.get(&ctx.view.view_id).is_some_and(|v| v.vertices.size() >= bytes.len() as u64);
        if !fits {
            let atlas = oxygen_gpu::texture_2d(
                device,
                "overlay atlas",
                wgpu::Extent3d { width: ATLAS_SIZE, height: ATLAS_SIZE, depth_or_array_layers: 1 },
                1,
                wgpu::TextureFormat::Rgba8UnormSrgb,
                wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            );
            let view = atlas.create_view(&Default::default());
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("overlay"),
                layout: &made.layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&made.sampler) },
                ],
            });
            let vertices = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("overlay vertices"),
                size: (bytes.len() as u64).next_power_of_two().max(4096),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            views.insert(ctx.view.view_id, ViewOverlay { vertices, atlas, bind_group, generation: None });
        }
        let view = views.get_mut(&ctx.view.view_id).ok_or_else(|| PassError::Graph("overlay state lost".into()))?;
        ctx.gpu.queue.write_buffer(&view.vertices, 0, bytes);
        // The atlas rows that changed, or all of it when the texture holds
        // another generation (or nothing yet).
        let atlas = overlay.atlas();
        let rows = match view.generation == Some(atlas.generation()) {
            true => atlas.dirty_rows(),
            false => Some(0..ATLAS_SIZE),
        };
        if let Some(rows) = rows.filter(|r| !r.is_empty()) {
            let row_bytes = ATLAS_SIZE as usize * 4;
            ctx.gpu.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &view.atlas,
                    mip_level: 0,
                    origin: wgpu::Origin3d { x: 0, y: rows.start, z: 0 },
                    aspect: wgpu::TextureAspect::All,
                },
                &atlas.pixels()[rows.start as usize * row_bytes..rows.end as usize * row_bytes],
                wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(ATLAS_SIZE * 4), rows_per_image: None },
                wgpu::Extent3d { width: ATLAS_SIZE, height: rows.end - rows.start, depth_or_array_layers: 1 },
            );
        }
        view.generation = Some(atlas.generation());
        overlay.atlas_mut().mark_uploaded();

        // A multisampled view's depth does not match the display image.
        let depth = ctx.targets.msaa.is_none().then_some(&ctx.targets.depth_view);
        let mut pass = rec.encoder().begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("overlay"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: depth.map(|view| wgpu::RenderPassDepthStencilAttachment {
                view,
                depth_ops: None,
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        // A batch camera's own rectangle of the shared page.
        if let Some(tile) = ctx.targets.tile {
            let (w, h) = (ctx.targets.width, ctx.targets.height);
            pass.set_viewport(tile.x as f32, tile.y as f32, w as f32, h as f32, 0.0, 1.0);
            pass.set_scissor_rect(tile.x, tile.y, w, h);
        }
        pass.set_pipeline(if depth.is_some() { &made.with_depth } else { &made.without_depth });
        pass.set_bind_group(0, &view.bind_group, &[]);
        pass.set_vertex_buffer(0, view.vertices.slice(..bytes.len() as u64));
        pass.draw(0..vertices.len() as u32, 0..1);
        drop(pass);
        rec.stats.render_passes += 1;
        rec.stats.draw_calls += 1;
        rec.stats.overlay_vertices += vertices.len() as u64;
        Ok(())
    }
}
