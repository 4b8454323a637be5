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
    AmbientOcclusionPass, AutoExposure, Bloom, CommandRecorder, DeferredShading, DepthBias, DrawList, ForwardLitConfig,
    LinearDepthPass, MeshPass, OverlayPass, PassError, PrePassEstimate, ReferencePass, ReferenceSettings,
    ReflectionHistoryPass, RenderContext, RenderPass, TonemapPass,
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

    /// Whether the graph runs occlusion culling's two phases (a depth
    /// pre-pass of [`oxygen_passes::DrawList::Early`], then
    /// [`RenderContext::cull_occluded`], then one of
    /// [`oxygen_passes::DrawList::Late`]) when the view asks for
    /// [`oxygen_sceneprep::Visibility::GpuOcclusion`]. A graph that does not
    /// gets frustum culling instead. [`StandardGraph`] does.
    fn runs_occlusion_phases(&self) -> bool {
        false
    }

    /// Whether the graph's passes read the view's depth in a shader
    /// (ambient occlusion, contact shadows, screen-space reflections:
    /// [`oxygen_passes::LinearDepthPass`]).
    /// A multisampled view's depth is then made readable where the backend
    /// allows it (not on GL); otherwise it stays a render attachment only,
    /// and those passes refuse the view. [`StandardGraph`] says so when its
    /// forward configuration asks for one of them.
    fn reads_screen_depth(&self) -> bool {
        false
    }
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
    fn two_phase(&self) -> bool;
    fn screen_depth(&self) -> bool;
}

impl<G: RenderGraph> ErasedGraph for G {
    fn record_boxed<'a>(&'a self, ctx: &'a RenderContext<'a>, rec: &'a mut CommandRecorder) -> GraphFuture<'a> {
        Box::pin(self.record(ctx, rec))
    }
    fn two_phase(&self) -> bool {
        self.runs_occlusion_phases()
    }
    fn screen_depth(&self) -> bool {
        self.reads_screen_depth()
    }
}

/// The standard graph: a depth pre-pass when it pays ([`PrePass`]) or when
/// the view has ambient occlusion, contact shadows or screen-space
/// reflections (which read that depth, [`ForwardLitConfig::ambient_occlusion`],
/// [`ForwardLitConfig::contact_shadows`],
/// [`ForwardLitConfig::screen_space_reflections`]), forward
/// lit shading of the opaque and masked partitions into HDR (with the view's
/// sun cascades, the frame's local shadows and the probes it is linked to),
/// blended partitions back-to-front, the HDR image kept for next frame's
/// screen-space reflections when the view has them
/// ([`ReflectionHistoryPass`]), then the tone map to the view's sRGB
/// target (with a bloom chain and automatic exposure when asked for). A
/// view with nothing blended whose HDR image no other view reads
/// ([`RenderContext::hdr_read_after_shading`]) and without those effects
/// tone-maps at the end of shading straight into its sRGB target: one
/// full-screen pass fewer. Last, the view's overlay, when it has one
/// ([`crate::Renderer::overlay`], [`OverlayPass`]).
#[derive(Clone, Debug, PartialEq)]
pub struct StandardGraph {
    /// The forward lit pass's configuration; its `depth_from_pre_pass` is
    /// decided by `pre_pass`.
    pub lit: ForwardLitConfig,
    /// Exposure of the tone map.
    pub exposure: f32,
    /// Whether to lay down depth first.
    pub pre_pass: PrePass,
    /// A bloom chain mixed into the image before the tone map
    /// ([`oxygen_passes::Bloom`]); `None`, the default, records none.
    pub bloom: Option<Bloom>,
    /// Exposure chosen from the image and adapted over time, times
    /// `exposure` ([`oxygen_passes::AutoExposure`]); `None`, the default,
    /// keeps `exposure` alone.
    pub auto_exposure: Option<AutoExposure>,
}

impl Default for StandardGraph {
    fn default() -> Self {
        standard_render_graph
    }
}

impl StandardGraph {
    /// The standard graph with this forward configuration, exposure 1, and
    /// the pre-pass as `lit.depth_from_pre_pass` says (on or off).
    pub fn new(lit: ForwardLitConfig) -> Self {
        let pre_pass = if lit.depth_from_pre_pass { PrePass::On } else { PrePass::Off };
        StandardGraph { lit, exposure: 1.0, pre_pass, bloom: None, auto_exposure: None }
    }

    /// The same graph with another pre-pass choice.
    pub fn with_pre_pass(self, pre_pass: PrePass) -> Self {
        StandardGraph { pre_pass, ..self }
    }

    /// The same graph with a bloom chain (`None`: none).
    pub fn with_bloom(self, bloom: Option<Bloom>) -> Self {
        StandardGraph { bloom, ..self }
    }

    /// The same graph with automatic exposure (`None`: the fixed exposure).
    pub fn with_auto_exposure(self, auto_exposure: Option<AutoExposure>) -> Self {
        StandardGraph { auto_exposure, ..self }
    }
}

/// Whether a view lays down depth before shading: a speed/accuracy-neutral
/// trade of one more geometry pass against shading hidden fragments. The
/// pre-pass pays when surfaces hide each other a lot (each pixel is then
/// shaded once instead of several times) and costs when they do not, or
/// when the geometry is dense (every index is drawn twice, and on some
/// adapters vertices, not pixels, are what a frame costs).
/// `examples/prepass_bench.rs` measures both on a scene of each kind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PrePass {
    /// Always.
    On,
    /// Never: the forward pass writes depth itself.
    Off,
    /// Decided per view and per frame from the view's
    /// [`PrePassEstimate`]: the pre-pass
    /// runs when the expected overdraw reaches `min_overdraw` and the
    /// fragments it spares shading, `(overdraw − 1) × pixels`, are at least
    /// `fragments_per_index` times the indices it draws.
    Auto {
        /// The overdraw threshold.
        min_overdraw: f32,
        /// Spared fragments one drawn index must buy. 0 ignores the
        /// geometry's cost.
        fragments_per_index: f32,
    },
}

impl PrePass {
    /// The default: automatic, from an expected overdraw of 2 and one
    /// spared fragment per index drawn.
    pub const DEFAULT: PrePass = PrePass::Auto { min_overdraw: 2.0, fragments_per_index: 1.0 };

    /// Whether a view with this estimate gets the pre-pass.
    pub fn wanted(self, estimate: PrePassEstimate) -> bool {
        match self {
            PrePass::On => true,
            PrePass::Off => false,
            PrePass::Auto { min_overdraw, fragments_per_index } => {
                // NaN never reaches the threshold: no pre-pass, the safe side.
                if estimate.overdraw.is_nan() || estimate.overdraw < min_overdraw {
                    return false;
                }
                // Infinite overdraw (not known yet) spares everything.
                if estimate.overdraw.is_infinite() {
                    return true;
                }
                let spared = (f64::from(estimate.overdraw) - 1.0) * estimate.pixels as f64;
                spared >= f64::from(fragments_per_index) * estimate.indices as f64
            }
        }
    }
}

impl PrePass {
    /// Whether `ctx`'s view gets the pre-pass this frame: [`PrePass::wanted`]
    /// of its estimate. The estimate differs between visibility paths and,
    /// on a GPU path, is read back from an earlier frame; the deterministic
    /// mode ([`RenderContext::deterministic`]) still follows it, because
    /// there the shading pass without a pre-pass lets the last of two
    /// surfaces at exactly the same depth show, as it does after one
    /// ([`oxygen_passes::PipelineKey::last_tie_wins`]): the choice changes
    /// the time, not the pixels.
    pub fn resolved(self, ctx: &RenderContext<'_>) -> bool {
        self.wanted(ctx.pre_pass_estimate())
    }
}

impl Default for PrePass {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl RenderGraph for StandardGraph {
    async fn record(&self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        let mut lit = self.lit.clone();
        // Occlusion culling builds its pyramid from the pre-pass's depth,
        // and ambient occlusion is computed from it before shading.
        let occlusion = ctx.occlusion_culling();
        let screen_space = self.reads_screen_depth();
        lit.depth_from_pre_pass = occlusion || screen_space || self.pre_pass.resolved(ctx);
        if lit.depth_from_pre_pass {
            MeshPass::depth_pre_pass().drawing(DrawList::Early).run(ctx, rec).await?;
        }
        if occlusion {
            ctx.cull_occluded(rec);
            MeshPass::depth_pre_pass().drawing(DrawList::Late).run(ctx, rec).await?;
        }
        if let Some(settings) = lit.ambient_occlusion {
            AmbientOcclusionPass::new(settings).run(ctx, rec).await?;
        }
        // Records nothing when the occlusion pass wrote the depth already.
        if lit.contact_shadows.is_some() || lit.screen_space_reflections.is_some() {
            LinearDepthPass.run(ctx, rec).await?;
        }
        let exposure = tone_map_exposure(self.exposure);
        // Nothing blends over the HDR image, no other view reads it and the
        // tone map has no effect that reads it whole: shading tone-maps in
        // place and the frame skips the HDR write and the full-screen
        // tone-map pass.
        // Screen-space reflections keep the HDR image for the next frame.
        let reflections = lit.screen_space_reflections.is_some();
        let effects = self.bloom.is_some() || self.auto_exposure.is_some() || reflections;
        if !ctx.hdr_read_after_shading() && !effects {
            MeshPass::forward_lit(lit).with_labels().tone_mapped(exposure).run(ctx, rec).await?;
            // Records nothing for a view without an overlay.
            return OverlayPass.run(ctx, rec).await;
        }
        let mut transparent = MeshPass::transparent();
        let mut shading = MeshPass::forward_lit(lit).with_labels();
        if !transparent.has_draws(ctx) {
            // Shading is the last colour pass: a multisampled view keeps
            // only the resolve.
            shading = shading.discarding_samples();
        }
        shading.run(ctx, rec).await?;
        // Records nothing on a frame without blended draws.
        transparent.run(ctx, rec).await?;
        if reflections {
            ReflectionHistoryPass.run(ctx, rec).await?;
        }
        TonemapPass::new(exposure).with_bloom(self.bloom).with_auto_exposure(self.auto_exposure).run(ctx, rec).await?;
        OverlayPass.run(ctx, rec).await
    }

    fn runs_occlusion_phases(&self) -> bool {
        true
    }

    fn reads_screen_depth(&self) -> bool {
        self.lit.ambient_occlusion.is_some()
            || self.lit.contact_shadows.is_some()
            || self.lit.screen_space_reflections.is_some()
    }
}

/// The exposure a graph's tone map applies: its own, 1 for an exposure of
/// 0 (a graph written with every field zeroed shows its scene, not black).
fn tone_map_exposure(exposure: f32) -> f32 {
    if exposure == 0.0 { 1.0 } else { exposure }
}

/// The default graph ([`StandardGraph`] with default settings), as a value
/// to pass to `register_view`.
#[allow(non_upper_case_globals)] // Reads as the function it replaced: `register_view(camera, standard_render_graph)`.
pub const standard_render_graph: StandardGraph = StandardGraph {
    lit: ForwardLitConfig::DEFAULT,
    exposure: 1.0,
    pre_pass: PrePass::DEFAULT,
    bloom: None,
    auto_exposure: None,
};

/// The graph of a path-traced reference view
/// ([`ViewDesc::path_traced`](crate::ViewDesc::path_traced)): the frame's
/// samples added to the view's running mean in its HDR target
/// ([`ReferencePass`]), then the same tone map as the raster graphs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceGraph {
    /// How to trace.
    pub settings: ReferenceSettings,
    /// Exposure before the tone map, as [`StandardGraph::exposure`].
    pub exposure: f32,
}

impl RenderGraph for ReferenceGraph {
    async fn record(&self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        ReferencePass { settings: self.settings }.run(ctx, rec).await?;
        let exposure = tone_map_exposure(self.exposure);
        TonemapPass::new(exposure).run(ctx, rec).await
    }
}

/// The reference graph with default settings ([`ReferenceSettings::DEFAULT`]).
#[allow(non_upper_case_globals)] // Reads like `standard_render_graph`.
pub const reference_render_graph: ReferenceGraph =
    ReferenceGraph { settings: ReferenceSettings::DEFAULT, exposure: 1.0 };

/// The graph every camera of a batch records ([`crate::batch`]): each pass
/// once for the whole batch ([`MeshPass::run_batch`]: one render pass per
/// page of the batch's atlas, per camera only its viewport, constants and
/// draws). Forward lit shading of the opaque and masked partitions,
/// tone-mapped while shading into the display atlas when nothing blends
/// and nobody reads the HDR image; otherwise into the HDR atlas, then the
/// blended partitions, then one tone map per page. Last, each camera's
/// overlay over its tile ([`OverlayPass`]: a render pass for each camera
/// that has one, none for the others). With [`BatchShading::Deferred`]
/// a frame that allows it (see [`oxygen_passes::DeferredShading::applies`])
/// draws a visibility pass instead of the forward pass and shades in one
/// compute dispatch per page.
#[derive(Clone, Debug, PartialEq)]
pub struct BatchGraph {
    /// The forward lit pass's configuration; `depth_from_pre_pass` lays
    /// down depth first (off by default: small cameras are bound by their
    /// vertices, which a pre-pass draws twice).
    pub lit: ForwardLitConfig,
    /// Exposure of the tone map.
    pub exposure: f32,
    /// Where the cameras' pixels are shaded.
    pub shading: BatchShading,
}

/// Where a batch's pixels are shaded: a speed knob, its time in
/// `examples/batch_bench.rs` (`BATCH_BENCH_SHADING`) and its difference
/// from forward shading in `tests/deferred_batch.rs` (docs/performance.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BatchShading {
    /// In the forward pass's fragment shader, as every view is.
    #[default]
    Forward,
    /// In a compute pass after a visibility pass
    /// ([`oxygen_passes::DeferredShading`]): the atlas gets a visibility
    /// target (4 bytes a pixel, counted in the target
    /// budget), and the adapter's compute stage must bind the shading
    /// inputs (registering the batch fails otherwise: GL cannot). A frame
    /// deferred shading cannot take (an HDR image read after shading,
    /// blended surfaces, shadow maps, probes, clustered lights,
    /// screen-space effects, a page that keeps cameras not rendered, more
    /// draws than a 32-bit surface id can name beside the largest mesh's
    /// vertices) is shaded forward, with the reason
    /// logged (debug); the frame report's `recorded.deferred_views` counts
    /// the cameras shaded deferred.
    Deferred,
}

/// The default batch graph: no depth pre-pass, no sun cascades (batch
/// cameras own none), exposure 1.
#[allow(non_upper_case_globals)] // Reads like `standard_render_graph`.
pub const standard_batch_graph: BatchGraph = BatchGraph {
    lit: ForwardLitConfig { depth_from_pre_pass: false, sun_shadows: false, ..ForwardLitConfig::DEFAULT },
    exposure: 1.0,
    shading: BatchShading::Forward,
};

impl Default for BatchGraph {
    fn default() -> Self {
        standard_batch_graph
    }
}

impl BatchGraph {
    /// Records the batch's cameras `views` (their contexts in tile order).
    pub async fn record_batch(&self, views: &[&RenderContext<'_>], rec: &mut CommandRecorder) -> Result<(), PassError> {
        if views.is_empty() {
            return Ok(());
        }
        let exposure = tone_map_exposure(self.exposure);
        let lit = self.lit.clone();
        let deferred = DeferredShading::new(lit.clone(), exposure);
        let deferred = match self.shading {
            BatchShading::Deferred => match deferred.applies(views) {
                Ok(()) => Some(deferred),
                Err(why) => {
                    // Every frame the condition lasts: debug, not warn.
                    tracing::debug!(first = %views[0].view.view_id, "batch shaded forward this frame: {why}");
                    None
                }
            },
            BatchShading::Forward => None,
        };
        match deferred {
            Some(deferred) => {
                MeshPass::visibility().run_batch(views, rec).await?;
                deferred.run_batch(views, rec).await?;
            }
            None => self.shade_forward(views, rec, lit, exposure).await?,
        }
        // Each camera's overlay over its tile (nothing for a camera
        // without one).
        for ctx in views {
            OverlayPass.run(ctx, rec).await?;
        }
        Ok(())
    }

    /// The cameras shaded forward: the depth pre-pass when asked for, then
    /// the forward pass tone-mapping in place when nothing reads the HDR
    /// image; otherwise into the HDR atlas, the blended partitions and one
    /// tone map per page.
    async fn shade_forward(
        &self,
        views: &[&RenderContext<'_>],
        rec: &mut CommandRecorder,
        lit: ForwardLitConfig,
        exposure: f32,
    ) -> Result<(), PassError> {
        if lit.depth_from_pre_pass {
            MeshPass::depth_pre_pass().run_batch(views, rec).await?;
        }
        if !views.iter().any(|ctx| ctx.hdr_read_after_shading()) {
            return MeshPass::forward_lit(lit).with_labels().tone_mapped(exposure).run_batch(views, rec).await;
        }
        MeshPass::forward_lit(lit).with_labels().run_batch(views, rec).await?;
        MeshPass::transparent().run_batch(views, rec).await?;
        // The tone map covers its whole target: once per page of the
        // batch's atlas (per view for a view with targets of its own).
        let mut toned_pages: Vec<u32> = Vec::new();
        for ctx in views {
            if let Some(tile) = ctx.targets.tile {
                if toned_pages.contains(&tile.page) {
                    continue;
                }
                toned_pages.push(tile.page);
            }
            TonemapPass::new(exposure).run(ctx, rec).await?;
        }
        Ok(())
    }
}

impl RenderGraph for BatchGraph {
    async fn record(&self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        self.record_batch(&[ctx], rec).await
    }
}

/// The standard graph with a chosen forward configuration; the pre-pass as
/// `config.depth_from_pre_pass` says.
pub fn lit_render_graph(config: ForwardLitConfig) -> StandardGraph {
    StandardGraph::new(config)
}

/// The graph of a shadow view: the depth of its casters with a rasterizer
/// depth bias, nothing else.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ShadowGraph {
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
/// transparency, no tone map). Once all six faces have recorded, the
/// renderer prefilters the cube's levels across them (GGX, as the
/// environment's), which rough surfaces reflect.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct ProbeFaceGraph;

impl RenderGraph for ProbeFaceGraph {
    async fn record(&self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        MeshPass::depth_pre_pass().run(ctx, rec).await?;
        MeshPass::forward_lit(ForwardLitConfig::default()).run(ctx, rec).await
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_zero_exposure_tone_maps_at_one_and_any_other_as_itself() {
        assert_eq!(tone_map_exposure(0.0), 1.0);
        assert_eq!(tone_map_exposure(2.5), 2.5);
        assert_eq!(tone_map_exposure(1.0), 1.0);
    }

    #[test]
    fn the_standard_batch_graph_has_no_pre_pass_and_no_sun_cascades() {
        // Batch cameras are small and own no cascades (see its docs); the
        // rest is the forward default.
        let lit = standard_batch_graph.lit.clone();
        assert!(!lit.depth_from_pre_pass && !lit.sun_shadows, "{lit:?}");
        let rest = ForwardLitConfig { depth_from_pre_pass: true, sun_shadows: true, ..lit };
        assert_eq!(rest, ForwardLitConfig::DEFAULT);
        assert_eq!(standard_batch_graph.exposure, 1.0);
        assert_eq!(BatchGraph::default(), standard_batch_graph);
    }

    #[test]
    fn the_constant_standard_graph_matches_the_default_configuration() {
        let default = StandardGraph::new(ForwardLitConfig::default()).with_pre_pass(PrePass::DEFAULT);
        assert_eq!(standard_render_graph, default);
        assert_eq!(StandardGraph::default(), default);
    }

    /// The standard graph reads its depth in a shader exactly when its
    /// forward configuration has ambient occlusion or contact shadows; a
    /// closure graph says it does not.
    #[test]
    fn only_screen_space_effects_make_the_standard_graph_read_its_depth() {
        assert!(!standard_render_graph.reads_screen_depth());
        let with = |lit: ForwardLitConfig| StandardGraph::new(lit).reads_screen_depth();
        let ao = oxygen_passes::AmbientOcclusion::DEFAULT;
        assert!(with(ForwardLitConfig { ambient_occlusion: Some(ao), ..ForwardLitConfig::DEFAULT }));
        let contact = oxygen_passes::ContactShadows::DEFAULT;
        assert!(with(ForwardLitConfig { contact_shadows: Some(contact), ..ForwardLitConfig::DEFAULT }));
        let closure = async |_: &RenderContext<'_>, _: &mut CommandRecorder| -> Result<(), PassError> { Ok(()) };
        assert!(!closure.reads_screen_depth());
        assert!(ErasedGraph::screen_depth(&StandardGraph::new(ForwardLitConfig {
            ambient_occlusion: Some(ao),
            ..ForwardLitConfig::DEFAULT
        })));
    }

    /// The standard graph runs occlusion culling's two phases; a graph
    /// written as a closure does not (its views get frustum culling), and
    /// the renderer's type-erased store says the same.
    #[test]
    fn only_the_standard_graph_runs_the_occlusion_phases() {
        let closure = async |_: &RenderContext<'_>, _: &mut CommandRecorder| -> Result<(), PassError> { Ok(()) };
        assert!(!closure.runs_occlusion_phases());
        assert!(!ErasedGraph::two_phase(&closure));
        assert!(standard_render_graph.runs_occlusion_phases());
        assert!(ErasedGraph::two_phase(&standard_render_graph));
    }

    /// Choosing the pre-pass keeps the rest of the graph.
    #[test]
    fn choosing_the_pre_pass_keeps_the_rest_of_the_graph() {
        let lit = ForwardLitConfig { shadow_pcf_radius: 3, ..ForwardLitConfig::DEFAULT };
        let graph = StandardGraph { exposure: 0.5, ..StandardGraph::new(lit.clone()) }.with_pre_pass(PrePass::Off);
        assert_eq!(graph.pre_pass, PrePass::Off);
        assert_eq!(graph.lit, lit);
        assert_eq!(graph.exposure, 0.5);
    }

    #[test]
    fn the_automatic_pre_pass_follows_the_threshold_and_refuses_nan() {
        let auto = PrePass::Auto { min_overdraw: 2.0, fragments_per_index: 0.0 };
        let light = |overdraw| PrePassEstimate { overdraw, indices: 36, pixels: 1000 };
        assert!(!auto.wanted(light(1.2)));
        assert!(auto.wanted(light(2.0)));
        assert!(auto.wanted(light(7.5)));
        assert!(!auto.wanted(light(f32::NAN)));
        assert!(auto.wanted(light(f32::INFINITY)), "unknown overdraw: pre-pass");
        assert!(PrePass::On.wanted(light(0.0)) && !PrePass::Off.wanted(light(100.0)));
    }

    #[test]
    fn dense_geometry_turns_the_automatic_pre_pass_off() {
        // 960 × 540 pixels under an expected overdraw of 2.5: the pre-pass
        // spares 777 600 fragments.
        let estimate = |indices| PrePassEstimate { overdraw: 2.5, indices, pixels: 960 * 540 };
        let auto = PrePass::DEFAULT;
        assert!(auto.wanted(estimate(1_000)), "a few walls");
        assert!(auto.wanted(estimate(777_600)), "one index per spared fragment");
        assert!(!auto.wanted(estimate(777_601)));
        assert!(!auto.wanted(estimate(3_300_000)), "92 000 cubes");
        let ignoring_geometry = PrePass::Auto { min_overdraw: 2.0, fragments_per_index: 0.0 };
        assert!(ignoring_geometry.wanted(estimate(3_300_000)));
        // Not known yet (a GPU path's first frame): the pre-pass runs.
        assert!(auto.wanted(PrePassEstimate { overdraw: f32::INFINITY, indices: 0, pixels: 0 }));
    }
}
