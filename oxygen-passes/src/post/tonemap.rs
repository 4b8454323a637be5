//! `TonemapPass`: the HDR target to the displayable sRGB target.
//!
//! Reads: the view's HDR target (linear radiance). Writes: the colour target,
//! after `exposure` and the Khronos PBR Neutral operator, which leaves colours
//! below about 0.76 nearly untouched (so a material's base colour under unit
//! light looks like itself) and rolls highlights off towards white.
//! [`pbr_neutral`] is the CPU twin of the shader's operator, for tests.

use oxygen_gpu::ViewTargets;
use tracing::info_span;

use super::params::TonemapParams;
use crate::{CommandRecorder, PassError, RenderContext, RenderPass};

/// The tone-map pass, with its optional effects: bloom and automatic
/// exposure (`post/effects.rs`; each recorded only when asked for).
pub struct TonemapPass {
    exposure: f32,
    bloom: Option<crate::Bloom>,
    auto_exposure: Option<crate::AutoExposure>,
}

impl TonemapPass {
    /// A pass scaling radiance by `exposure` (non-finite or negative values become 1).
    pub fn new(exposure: f32) -> Self {
        let exposure = if exposure.is_finite() && exposure >= 0.0 { exposure } else { 1.0 };
        TonemapPass { exposure, bloom: None, auto_exposure: None }
    }

    /// The same pass with a bloom chain mixed into the image first
    /// (`None`: none).
    pub fn with_bloom(self, bloom: Option<crate::Bloom>) -> Self {
        TonemapPass { bloom, ..self }
    }

    /// The same pass choosing its exposure from the image, times the fixed
    /// one (`None`: the fixed exposure alone).
    pub fn with_auto_exposure(self, auto_exposure: Option<crate::AutoExposure>) -> Self {
        TonemapPass { auto_exposure, ..self }
    }
}

impl Default for TonemapPass {
    fn default() -> Self {
        Self::new(1.0)
    }
}

/// Khronos PBR Neutral on linear RGB (the shader's twin).
pub(crate) fn pbr_neutral(rgb: [f32; 3]) -> [f32; 3] {
    const START: f32 = 0.8 - 0.04;
    const DESATURATION: f32 = 0.15;
    let x = rgb[0].min(rgb[1]).min(rgb[2]);
    let offset = if x < 0.08 { x - 6.25 * x * x } else { 0.04 };
    let mut c = rgb.map(|v| v - offset);
    let peak = c[0].max(c[1]).max(c[2]);
    if peak < START {
        return c;
    }
    let d = 1.0 - START;
    let new_peak = 1.0 - d * d / (peak + d - START);
    c = c.map(|v| v * new_peak / peak);
    let g = 1.0 - 1.0 / (DESATURATION * (peak - new_peak) + 1.0);
    c.map(|v| v + (new_peak - v) * g)
}

impl RenderPass for TonemapPass {
    fn name(&self) -> &'static str {
        "TonemapPass"
    }

    async fn run(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        let _span = info_span!("tonemap", view = %ctx.view.view_id).entered();
        let device = &ctx.gpu.device;
        let color = ctx.color_targets(self.name())?;
        let Some(color_view) = color.color_view.as_ref() else {
            return Err(PassError::NoColorTarget { pass: self.name() });
        };
        let (pipeline, bind_group, label) = if self.bloom.is_some() || self.auto_exposure.is_some() {
            let effects = ctx.lighting.effects().record(
                ctx,
                rec.encoder(),
                &color.hdr,
                &color.hdr_view,
                ViewTargets::COLOR_FORMAT,
                self.exposure,
                self.bloom.as_ref(),
                self.auto_exposure.as_ref(),
            )?;
            (effects.pipeline, effects.bind_group, "tonemap with effects")
        } else {
            let (pipeline, layout) = ctx.pipelines.tonemap(device, ViewTargets::COLOR_FORMAT);
            let params = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("tonemap params"),
                size: std::mem::size_of::<TonemapParams>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            ctx.gpu.queue.write_buffer(
                &params,
                0,
                bytemuck::bytes_of(&TonemapParams { exposure: self.exposure, pad0: 0.0, pad1: 0.0, pad2: 0.0 }),
            );
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("tonemap"),
                layout: &layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&color.hdr_view) },
                    wgpu::BindGroupEntry { binding: 1, resource: params.as_entire_binding() },
                ],
            });
            (pipeline, bind_group, "tonemap")
        };
        let mut pass = crate::pipelines::fullscreen_pass(rec.encoder(), color_view, label);
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.draw(0..3, 0..1);
        drop(pass);
        rec.stats.render_passes += 1;
        rec.stats.pipeline_binds += 1;
        rec.stats.draw_calls += 1;
        rec.stats.draw_commands += 1;
        Ok(())
    }
}
