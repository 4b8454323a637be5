//! `CompositePass`: another view's final image drawn into a rectangle of
//! this view, after its own tone map: insets, picture-in-picture, walls of
//! cameras. The source is a linked output ([`oxygen_core::Color`]), so the
//! renderer records the source view first and the pass waits for it.

use std::sync::OnceLock;

use oxygen_core::{Color, Output};
use oxygen_gpu::ViewTargets;
use oxygen_gpu::bindings::{self, LayoutEntries};
use tracing::info_span;

use super::params::CompositeParams;
use crate::{CommandRecorder, PassError, RenderContext, RenderPass};

/// Draws a linked view's final colour into `rect` of this view's display
/// image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompositePass {
    /// The image drawn: another view's colour, linked to this view
    /// (`ViewDesc::reads(view.color())`).
    pub source: Output<Color>,
    /// Where, as fractions of this view's image: `[x, y, width, height]`,
    /// from its top-left corner; clamped to the image.
    pub rect: [f32; 4],
}

/// The composition pipeline, made on first use and shared by every view.
static PIPELINE: OnceLock<Made> = OnceLock::new();

struct Made {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    sampler: wgpu::Sampler,
}

impl CompositePass {
    /// `source` drawn into `rect` (fractions of this view's image).
    pub fn new(source: Output<Color>, rect: [f32; 4]) -> Self {
        CompositePass { source, rect }
    }

    /// The destination rectangle in pixels of a `width × height` image
    /// (`[x, y, width, height]`, at least one pixel, inside the image);
    /// `None` for a rectangle with a non-finite corner or nothing inside.
    pub fn pixels(&self, width: u32, height: u32) -> Option<[u32; 4]> {
        let [x, y, w, h] = self.rect;
        if !self.rect.iter().all(|v| v.is_finite()) {
            return None;
        }
        let (fw, fh) = (width as f32, height as f32);
        let (x0, y0) = ((x * fw).round().clamp(0.0, fw), (y * fh).round().clamp(0.0, fh));
        let (x1, y1) = (((x + w) * fw).round().clamp(0.0, fw), ((y + h) * fh).round().clamp(0.0, fh));
        (x1 > x0 && y1 > y0).then_some([x0 as u32, y0 as u32, (x1 - x0) as u32, (y1 - y0) as u32])
    }
}

impl RenderPass for CompositePass {
    fn name(&self) -> &'static str {
        "CompositePass"
    }

    async fn run(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        let source = ctx.input(self.source).await?;
        let _span = info_span!("composite", view = %ctx.view.view_id).entered();
        let color = ctx.color_targets(self.name())?;
        let target = color.color_view.as_ref().ok_or(PassError::NoColorTarget { pass: self.name() })?;
        let (width, height) = (ctx.targets.width, ctx.targets.height);
        let Some([x, y, w, h]) = self.pixels(width, height) else {
            return Err(PassError::BadInput {
                pass: self.name(),
                what: format!("rectangle {:?} holds no pixel of a {width}×{height} view", self.rect),
            });
        };
        // This view's own rectangle in its texture (a batch camera's tile).
        let (ox, oy) = ctx.targets.tile.map_or((0, 0), |t| (t.x, t.y));
        let device = &ctx.gpu.device;
        let made = PIPELINE.get_or_init(|| {
            let layout = LayoutEntries::new(wgpu::ShaderStages::FRAGMENT)
                .push(bindings::texture_2d(bindings::FILTERABLE_FLOAT))
                .push(bindings::sampler_filtering())
                .push(bindings::uniform_of::<CompositeParams>())
                .create_layout(device, "composite");
            let wgsl = crate::shaders::COMPOSITE.source();
            let pipeline = crate::fullscreen_pipeline(
                device,
                "composite",
                &layout,
                &wgsl,
                ("vs", "fs"),
                ViewTargets::COLOR_FORMAT,
            );
            let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("composite"),
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                ..Default::default()
            });
            Made { layout, pipeline, sampler }
        });
        let [sx, sy, sw, sh] = source.rect.map(|v| v as f32);
        let [tw, th] = source.size.map(|v| v.max(1) as f32);
        let params = CompositeParams { uv_offset: [sx / tw, sy / th], uv_scale: [sw / tw, sh / th] };
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("composite params"),
            size: std::mem::size_of::<CompositeParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM,
            mapped_at_creation: true,
        });
        // Mapped at creation with exactly this size, so the copy fits.
        buffer
            .slice(..)
            .get_mapped_range_mut()
            .expect("mapped at creation")
            .copy_from_slice(bytemuck::bytes_of(&params));
        buffer.unmap();
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("composite"),
            layout: &made.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(source.image) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&made.sampler) },
                wgpu::BindGroupEntry { binding: 2, resource: buffer.as_entire_binding() },
            ],
        });
        let mut pass = rec.encoder().begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("composite"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_viewport((ox + x) as f32, (oy + y) as f32, w as f32, h as f32, 0.0, 1.0);
        pass.set_scissor_rect(ox + x, oy + y, w, h);
        pass.set_pipeline(&made.pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.draw(0..3, 0..1);
        drop(pass);
        rec.stats.render_passes += 1;
        rec.stats.draw_calls += 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rectangles_become_pixels_inside_the_image() {
        let source = oxygen_core::ViewIds::default().allocate().color();
        let pass = |rect| CompositePass::new(source, rect);
        assert_eq!(pass([0.0, 0.0, 1.0, 1.0]).pixels(64, 48), Some([0, 0, 64, 48]));
        assert_eq!(pass([0.75, 0.0, 0.25, 0.25]).pixels(64, 48), Some([48, 0, 16, 12]));
        // Past the edges: clamped.
        assert_eq!(pass([0.5, 0.5, 1.0, 1.0]).pixels(64, 48), Some([32, 24, 32, 24]));
        assert_eq!(pass([1.5, 0.0, 0.5, 0.5]).pixels(64, 48), None);
        assert_eq!(pass([0.0, 0.0, f32::NAN, 0.5]).pixels(64, 48), None);
        assert_eq!(pass([0.0, 0.0, 0.001, 0.5]).pixels(64, 48), None, "less than half a pixel");
    }
}
