//! `TransparentPass`: blended partitions, back-to-front.
//!
//! Reads: the prepared frame's transparent partitions (already sorted
//! back-to-front by the sort key, across materials), the depth the opaque
//! passes left (tested with `GreaterEqual`, never written). Writes: the HDR
//! target, blending with **premultiplied alpha** (the shader multiplies
//! colour by alpha; blend `One, OneMinusSrcAlpha`), which composes correctly
//! and filters without dark fringes.

use oxygen_core::ViewTargets;
use oxygen_sceneprep::PassMask;
use tracing::info_span;

use crate::render_context::{draw_partitions, partition_pipelines};
use crate::{CommandRecorder, PassError, PassKind, RenderContext, RenderPass};

/// The transparent pass.
#[derive(Default)]
pub struct TransparentPass {
    pipelines: Option<Vec<wgpu::RenderPipeline>>,
}

impl TransparentPass {
    /// A new pass.
    pub fn new() -> Self {
        Self::default()
    }
}

fn partitions<'a>(ctx: &'a RenderContext<'_>) -> impl Iterator<Item = &'a oxygen_sceneprep::Partition> {
    ctx.prepared.partitions_matching(PassMask::TRANSPARENT, PassMask::empty())
}

impl RenderPass for TransparentPass {
    fn name(&self) -> &'static str {
        "TransparentPass"
    }

    async fn prepare_resources(
        &mut self,
        ctx: &RenderContext<'_>,
        _rec: &mut CommandRecorder,
    ) -> Result<(), PassError> {
        let _span = info_span!("transparent_pass_prepare", view = %ctx.view.view_id).entered();
        let pipelines = partition_pipelines(
            ctx,
            PassKind::Transparent,
            Some(ViewTargets::HDR_FORMAT),
            crate::DepthBias::NONE,
            partitions(ctx),
        );
        self.pipelines = Some(pipelines);
        Ok(())
    }

    async fn execute(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        let _span = info_span!("transparent_pass_execute", view = %ctx.view.view_id).entered();
        let pipelines = self.pipelines.as_ref().ok_or(PassError::NotPrepared { pass: self.name() })?;
        if pipelines.is_empty() {
            return Ok(()); // nothing blended in this view: no pass at all
        }
        let color = ctx.color_targets(self.name())?;
        let mut stats = rec.stats;
        {
            let mut pass = rec.encoder().begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("transparent pass"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &color.hdr_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &ctx.targets.depth_view,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            stats.render_passes += 1;
            draw_partitions(&mut pass, ctx, partitions(ctx), pipelines, ctx.pipelines.no_lighting_inputs(), &mut stats);
        }
        rec.stats = stats;
        Ok(())
    }
}
