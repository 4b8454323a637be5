//! Render graphs: what a view records each frame.
//!
//! A graph is anything implementing [`RenderGraph`]; plain async closures
//! taking the view's [`RenderContext`] and [`CommandRecorder`] are graphs:
//!
//! ```no_run
//! # use oxygen::prelude::*;
//! let graph = async |ctx: &RenderContext<'_>, rec: &mut CommandRecorder| {
//!     MeshPass::depth_pre_pass().run(ctx, rec).await?;
//!     MeshPass::forward_lit(ForwardLitConfig::default()).run(ctx, rec).await?;
//!     TonemapPass::default().run(ctx, rec).await
//! };
//! # let _ = graph;
//! ```
//!
//! The renderer polls every view's graph future together on its worker
//! threads, each into its own command encoder; a pass that awaits a pipeline
//! still compiling, or another view's output, lets its thread record other
//! views meanwhile.

use std::future::Future;
use std::pin::Pin;

use oxygen_passes::{
    CommandRecorder, DepthBias, ForwardLitConfig, MeshPass, PassError, RenderContext, RenderPass, TonemapPass,
};

/// What a view records each frame: a future that awaits its passes.
///
/// Implemented for every async closure
/// `async |ctx: &RenderContext<'_>, rec: &mut CommandRecorder| -> Result<(), PassError>`
/// that is `Send + Sync + 'static`, and for named graphs such as
/// [`StandardGraph`].
pub trait RenderGraph: Send + Sync + 'static {
    /// Records the view's passes into `rec`.
    fn record<'a>(
        &'a self,
        ctx: &'a RenderContext<'a>,
        rec: &'a mut CommandRecorder,
    ) -> impl Future<Output = Result<(), PassError>> + 'a;
}

impl<F> RenderGraph for F
where
    F: AsyncFn(&RenderContext<'_>, &mut CommandRecorder) -> Result<(), PassError> + Send + Sync + 'static,
{
    fn record<'a>(
        &'a self,
        ctx: &'a RenderContext<'a>,
        rec: &'a mut CommandRecorder,
    ) -> impl Future<Output = Result<(), PassError>> + 'a {
        self(ctx, rec)
    }
}

/// A boxed graph future, for the renderer's type-erased storage.
pub(crate) type GraphFuture<'a> = Pin<Box<dyn Future<Output = Result<(), PassError>> + 'a>>;

/// [`RenderGraph`] without the generic return type, so graphs can be stored.
pub(crate) trait ErasedGraph: Send + Sync {
    fn record_boxed<'a>(&'a self, ctx: &'a RenderContext<'a>, rec: &'a mut CommandRecorder) -> GraphFuture<'a>;
}

impl<G: RenderGraph> ErasedGraph for G {
    fn record_boxed<'a>(&'a self, ctx: &'a RenderContext<'a>, rec: &'a mut CommandRecorder) -> GraphFuture<'a> {
        Box::pin(self.record(ctx, rec))
    }
}

/// The standard graph: depth pre-pass, forward lit shading of the opaque and
/// masked partitions into HDR (with the view's sun cascades, the frame's
/// local shadows and the probes it is linked to), blended partitions
/// back-to-front, then the tone map to the view's sRGB target. A view with
/// nothing blended whose HDR image no other view reads
/// ([`RenderContext::hdr_read_after_shading`]) tone-maps at the end of
/// shading straight into its sRGB target: one full-screen pass fewer.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StandardGraph {
    /// The forward lit pass's configuration.
    pub lit: ForwardLitConfig,
    /// Exposure of the tone map.
    pub exposure: f32,
}

impl StandardGraph {
    /// The standard graph with this forward configuration and exposure 1.
    pub fn new(lit: ForwardLitConfig) -> Self {
        StandardGraph { lit, exposure: 1.0 }
    }
}

impl RenderGraph for StandardGraph {
    async fn record(&self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        let lit = self.lit.clone();
        if lit.depth_from_pre_pass {
            MeshPass::depth_pre_pass().run(ctx, rec).await?;
        }
        let exposure = if self.exposure == 0.0 { 1.0 } else { self.exposure };
        // Nothing blends over the HDR image and no other view reads it:
        // shading tone-maps in place and the frame skips the HDR write and
        // the full-screen tone-map pass.
        if !ctx.hdr_read_after_shading() {
            return MeshPass::forward_lit(lit).tone_mapped(exposure).run(ctx, rec).await;
        }
        MeshPass::forward_lit(lit).run(ctx, rec).await?;
        MeshPass::transparent().run(ctx, rec).await?;
        TonemapPass::new(exposure).run(ctx, rec).await
    }
}

/// The default graph ([`StandardGraph`] with default settings), as a value
/// to pass to `register_view`.
#[allow(non_upper_case_globals)] // Reads as the function it replaced: `register_view(camera, standard_render_graph)`.
pub const standard_render_graph: StandardGraph = StandardGraph {
    lit: ForwardLitConfig {
        clear_color: wgpu::Color { r: 0.02, g: 0.03, b: 0.05, a: 1.0 },
        depth_from_pre_pass: true,
        sun_shadows: true,
        local_shadows: true,
        reflections: true,
        shadow_pcf_radius: 1,
        shadow_normal_offset: 1.5,
        shadow_depth_bias: 1e-4,
    },
    exposure: 1.0,
};

/// The standard graph with a chosen forward configuration.
pub fn lit_render_graph(config: ForwardLitConfig) -> StandardGraph {
    StandardGraph::new(config)
}

/// The graph of a shadow view: the depth of its casters with a rasterizer
/// depth bias, nothing else.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowGraph {
    /// The shadow map's rasterizer bias.
    pub bias: DepthBias,
}

impl Default for ShadowGraph {
    fn default() -> Self {
        ShadowGraph { bias: DepthBias::SHADOW_DEFAULT }
    }
}

impl RenderGraph for ShadowGraph {
    async fn record(&self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        MeshPass::shadow_with_bias(self.bias).run(ctx, rec).await
    }
}

/// The graph of a reflection-probe face: depth pre-pass and forward lit
/// shading straight into the face's layer of the probe cube (no
/// transparency, no tone map), then that layer's mip chain, which rough
/// surfaces reflect.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProbeFaceGraph;

impl RenderGraph for ProbeFaceGraph {
    async fn record(&self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        MeshPass::depth_pre_pass().run(ctx, rec).await?;
        MeshPass::forward_lit(ForwardLitConfig::default()).run(ctx, rec).await?;
        let color = ctx.color_targets("probe face")?;
        ctx.lighting.rebuild_probe_mips(&ctx.gpu.device, rec.encoder(), &color.hdr, color.hdr_layer);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_constant_standard_graph_matches_the_default_configuration() {
        assert_eq!(standard_render_graph, StandardGraph::new(ForwardLitConfig::default()));
    }
}
