//! `DepthPrePass`: lays down reverse-Z depth for the opaque and masked
//! partitions, so that shading runs once per visible pixel.
//!
//! Reads: the prepared frame's opaque and masked partitions. Writes: the
//! view's depth target (cleared to 0, the far value in reverse-Z).

use oxygen_sceneprep::PassMask;
use tracing::info_span;

use crate::render_context::{draw_partitions, partition_pipelines};
use crate::{CommandRecorder, DepthBias, PassError, PassKind, RenderContext, RenderPass};

/// What a depth pre-pass leaves for later passes: the view's depth target
/// holds reverse-Z depth of the opaque and masked partitions. Published on
/// the [`RenderContext`]'s typed outputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthPrePassOutput {
    /// Draws written into the depth target.
    pub draws: u32,
}

/// The depth pre-pass.
pub struct DepthPrePass {
    /// One pipeline per partition, chosen in `prepare_resources`.
    pipelines: Option<Vec<wgpu::RenderPipeline>>,
    /// `DepthPrePass`, or `Shadow` when it renders a shadow map.
    kind: PassKind,
    /// Rasterizer depth bias: none for the camera, the shadow bias for maps.
    depth_bias: DepthBias,
}

impl Default for DepthPrePass {
    fn default() -> Self {
        DepthPrePass { pipelines: None, kind: PassKind::DepthPrePass, depth_bias: DepthBias::NONE }
    }
}

impl DepthPrePass {
    /// A new pass (cheap: pipelines come from the shared cache).
    pub fn new() -> Self {
        Self::default()
    }
}

/// `ShadowPass`: the depth of a shadow view's casters, with a slope-scaled
/// depth bias in its pipelines (which the camera's depth pre-pass must not
/// have). Same partitions and variants as [`DepthPrePass`] — opaque/masked ×
/// back-face/double-sided — so double-sided casters are drawn unculled.
pub struct ShadowPass(DepthPrePass);

impl ShadowPass {
    /// A new pass with the default bias ([`DepthBias::SHADOW_DEFAULT`]).
    pub fn new() -> Self {
        Self::with_bias(DepthBias::SHADOW_DEFAULT)
    }

    /// A new pass with an explicit rasterizer depth bias.
    pub fn with_bias(depth_bias: DepthBias) -> Self {
        ShadowPass(DepthPrePass { pipelines: None, kind: PassKind::Shadow, depth_bias })
    }
}

impl Default for ShadowPass {
    fn default() -> Self {
        Self::new()
    }
}

impl RenderPass for ShadowPass {
    fn name(&self) -> &'static str {
        "ShadowPass"
    }

    async fn prepare_resources(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        self.0.prepare_resources(ctx, rec).await
    }

    async fn execute(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        self.0.execute(ctx, rec).await
    }
}

/// Partitions this pass draws: opaque and masked, never transparent.
fn partitions<'a>(ctx: &'a RenderContext<'_>) -> impl Iterator<Item = &'a oxygen_sceneprep::Partition> {
    ctx.prepared.partitions_matching(PassMask::OPAQUE | PassMask::MASKED, PassMask::TRANSPARENT)
}

impl RenderPass for DepthPrePass {
    fn name(&self) -> &'static str {
        "DepthPrePass"
    }

    async fn prepare_resources(
        &mut self,
        ctx: &RenderContext<'_>,
        _rec: &mut CommandRecorder,
    ) -> Result<(), PassError> {
        let _span = info_span!("depth_pre_pass_prepare", view = %ctx.view.view_id).entered();
        let pipelines = partition_pipelines(ctx, self.kind, None, self.depth_bias, partitions(ctx));
        self.pipelines = Some(pipelines);
        Ok(())
    }

    async fn execute(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        let _span = info_span!("depth_pre_pass_execute", view = %ctx.view.view_id).entered();
        let pipelines = self.pipelines.as_ref().ok_or(PassError::NotPrepared { pass: self.name() })?;
        let mut stats = rec.stats;
        {
            let mut pass = rec.encoder().begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("depth pre-pass"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &ctx.targets.depth_view,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            stats.render_passes += 1;
            draw_partitions(&mut pass, ctx, partitions(ctx), pipelines, ctx.pipelines.no_lighting_inputs(), &mut stats);
        }
        let draws = partitions(ctx).map(|p| p.len()).sum();
        rec.stats = stats;
        ctx.outputs.publish(DepthPrePassOutput { draws });
        Ok(())
    }
}
