//! `ShaderPass`: lit shading of the opaque and masked partitions.
//!
//! Reads: the prepared frame's partitions, the frame's light arrays (through
//! their slots), and — when configured to follow a depth pre-pass — the depth
//! it left in the view's depth target, tested with `GreaterEqual` and no
//! writes. Writes: the view's HDR target (cleared to `clear_color`, linear).
//! Transparent partitions belong to the transparent pass and are skipped.

use oxygen_core::ViewTargets;
use oxygen_sceneprep::PassMask;
use tracing::info_span;

use crate::render_context::{draw_partitions, partition_pipelines};
use crate::{CommandRecorder, PassError, PassKind, RenderContext, RenderPass};

/// How the shading pass is set up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShaderPassConfig {
    /// Linear colour the target is cleared to.
    pub clear_color: wgpu::Color,
    /// Test against depth from a preceding [`crate::DepthPrePass`] (load it,
    /// `GreaterEqual`, no writes) rather than clearing and writing depth.
    pub depth_from_pre_pass: bool,
}

impl Default for ShaderPassConfig {
    fn default() -> Self {
        ShaderPassConfig { clear_color: wgpu::Color { r: 0.02, g: 0.03, b: 0.05, a: 1.0 }, depth_from_pre_pass: true }
    }
}

/// The shading pass.
pub struct ShaderPass {
    config: ShaderPassConfig,
    pipelines: Option<Vec<wgpu::RenderPipeline>>,
}

impl ShaderPass {
    /// A pass with `config`.
    pub fn new(config: ShaderPassConfig) -> Self {
        ShaderPass { config, pipelines: None }
    }
}

fn partitions<'a>(ctx: &'a RenderContext<'_>) -> impl Iterator<Item = &'a oxygen_sceneprep::Partition> {
    ctx.prepared.partitions_matching(PassMask::OPAQUE | PassMask::MASKED, PassMask::TRANSPARENT)
}

impl RenderPass for ShaderPass {
    fn name(&self) -> &'static str {
        "ShaderPass"
    }

    async fn prepare_resources(
        &mut self,
        ctx: &RenderContext<'_>,
        _rec: &mut CommandRecorder,
    ) -> Result<(), PassError> {
        let _span = info_span!("shader_pass_prepare", view = %ctx.view.view_id).entered();
        let pass = if self.config.depth_from_pre_pass { PassKind::ShadingAfterPrePass } else { PassKind::Shading };
        let pipelines = partition_pipelines(ctx, pass, Some(ViewTargets::HDR_FORMAT), partitions(ctx));
        self.pipelines = Some(pipelines);
        Ok(())
    }

    async fn execute(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        let _span = info_span!("shader_pass_execute", view = %ctx.view.view_id).entered();
        let pipelines = self.pipelines.as_ref().ok_or(PassError::NotPrepared { pass: self.name() })?;
        let depth_load = if self.config.depth_from_pre_pass { wgpu::LoadOp::Load } else { wgpu::LoadOp::Clear(0.0) };
        let mut stats = rec.stats;
        {
            let mut pass = rec.encoder().begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("shader pass"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &ctx.targets.hdr_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(self.config.clear_color),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &ctx.targets.depth_view,
                    depth_ops: Some(wgpu::Operations { load: depth_load, store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            stats.render_passes += 1;
            draw_partitions(&mut pass, ctx, partitions(ctx), pipelines, &mut stats);
        }
        rec.stats = stats;
        Ok(())
    }
}
