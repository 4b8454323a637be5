//! `MeshPass`: the one pass that draws prepared partitions. The depth
//! pre-pass, shadow maps, forward lit shading and transparency are
//! configurations of it: which partitions it draws (include / exclude
//! masks), the pipeline kind (shaders, depth test, blending), and what it
//! does with the colour and depth targets.
//!
//! Every configuration walks the view's partitions the same way: one pipeline
//! per partition (one of the variants, opaque/masked/blend × back-face/
//! double-sided × mirrored), chosen from the partition mask and awaited from
//! the shared [`crate::Pipelines`], then one indirect draw or one direct draw
//! per draw. Shaders find each draw's `DrawMetadata` through
//! `first_instance`.

use oxygen_gpu::{LabelSet, LabelTargets, ViewTargets};
use oxygen_sceneprep::{Partition, PassMask};
use tracing::{Instrument, info_span};

use crate::{CommandRecorder, DepthBias, DrawPath, PassError, PassKind, RecordStats, RenderContext, RenderPass};

/// How the forward lit pass is set up.
#[derive(Clone, Debug, PartialEq)]
pub struct ForwardLitConfig {
    /// Linear colour the HDR target is cleared to.
    pub clear_color: wgpu::Color,
    /// Test against depth from a preceding depth pre-pass (load it,
    /// `GreaterEqual`, no writes) rather than clearing and writing depth.
    pub depth_from_pre_pass: bool,
    /// Sample the view's own sun-shadow cascades, when it has them this frame
    /// (the view asks for them when it is registered).
    pub sun_shadows: bool,
    /// Sample the frame's local-light (spot and point) shadow maps, when the
    /// renderer renders them.
    pub local_shadows: bool,
    /// Reflect the reflection probes the view is linked to (each surface
    /// reflects the nearest).
    pub reflections: bool,
    /// PCF kernel radius in texels: `(2r + 1)²` comparison taps. 0 is the
    /// cheapest (one bilinear comparison), 1 the default, 2 the softest.
    pub shadow_pcf_radius: u32,
    /// Normal offset of shadow lookups, in shadow-map texels: the point
    /// looked up moves this far along the surface normal (texels of the
    /// cascade, or of the local light's map at the point's distance), so a
    /// lit surface does not shadow itself (acne). Larger values detach
    /// shadows from their casters. Default 1.5.
    pub shadow_normal_offset: f32,
    /// How the sun's shadow is filtered: PCF of `shadow_pcf_radius` (the
    /// default), or soft shadows as wide as the sun's disc makes them
    /// ([`ShadowFilter::Pcss`]).
    pub shadow_filter: ShadowFilter,
    /// How a pixel finds the positional lights that reach it: every light
    /// of the frame (the default), or only those of its cluster after a
    /// culling pass ([`crate::LightCulling`]). The image is the same; the
    /// time is not.
    pub light_culling: crate::LightCulling,
    /// Screen-space ambient occlusion dimming the indirect light (ambient,
    /// environment, probes), computed from the depth by an
    /// [`crate::AmbientOcclusionPass`] recorded before this pass (the
    /// standard graph records it, with a depth pre-pass); `None`, the
    /// default, leaves it out: no pass, no buffers, no shader code.
    pub ambient_occlusion: Option<crate::AmbientOcclusion>,
    /// Contact shadows: a short march through the view's depth toward
    /// each light that casts shadows, darkening what the shadow map
    /// misses ([`crate::ContactShadows`]). Reads the depth in metres a
    /// [`crate::LinearDepthPass`] (or the ambient-occlusion pass) records
    /// before this pass (the standard graph records it, with a depth
    /// pre-pass); `None`, the default, leaves it out.
    pub contact_shadows: Option<crate::ContactShadows>,
    /// Screen-space reflections: glossy surfaces reflect what the view
    /// showed last frame where a march through its depth finds it, the
    /// probe or environment elsewhere ([`crate::ScreenSpaceReflections`]).
    /// Reads the depth in metres a [`crate::LinearDepthPass`] records
    /// before this pass and the history a [`crate::ReflectionHistoryPass`]
    /// kept after last frame's (the standard graph records both, and
    /// shades into the HDR target for it); `None`, the default, leaves it
    /// out.
    pub screen_space_reflections: Option<crate::ScreenSpaceReflections>,
}

impl ForwardLitConfig {
    /// The defaults, usable in constants (`standard_render_graph`).
    pub const DEFAULT: ForwardLitConfig = ForwardLitConfig {
        clear_color: wgpu::Color { r: 0.02, g: 0.03, b: 0.05, a: 1.0 },
        depth_from_pre_pass: true,
        sun_shadows: true,
        local_shadows: true,
        reflections: true,
        shadow_pcf_radius: 1,
        shadow_normal_offset: 1.5,
        shadow_filter: ShadowFilter::Pcf,
        light_culling: crate::LightCulling::EveryLight,
        ambient_occlusion: None,
        contact_shadows: None,
        screen_space_reflections: None,
    };
}

impl Default for ForwardLitConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// How a view filters its sun shadow (its cascades) and the shadows of
/// spot lights with a radius (their tiles of the local shadow atlas;
/// point lights' stay PCF).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum ShadowFilter {
    /// Percentage-closer filtering over `(2r + 1)²` taps of
    /// [`ForwardLitConfig::shadow_pcf_radius`]: the same penumbra however far
    /// the caster is.
    #[default]
    Pcf,
    /// Percentage-closer soft shadows for a sun with a disc and for spot
    /// lights with a radius (`Light::source_radius`): a search for the
    /// blockers between the surface and the light, then a filter as wide as
    /// the penumbra the blockers' distance and the disc or sphere make, so
    /// that contact shadows stay sharp and far casters blur. A sun without a
    /// disc is filtered as PCF of one texel, a spot without a radius as
    /// today's 3 × 3 taps.
    Pcss {
        /// Reads per side of the blocker search (`search_taps²`, on a grid
        /// across the widest penumbra), 2 to 16; 8 by default (a read every
        /// 4 texels: a caster narrower than that can be stepped over).
        search_taps: u32,
        /// Comparisons per side of the filter (`filter_taps²`, across the
        /// penumbra found), 2 to 16; 8 by default.
        filter_taps: u32,
        /// Radius of the widest penumbra, and of the blocker search, in
        /// texels of the cascade, 1 to 64; 16 by default. A wider penumbra
        /// is drawn this wide.
        max_penumbra_texels: f32,
    },
}

impl ShadowFilter {
    /// PCSS with an 8 × 8 blocker search, an 8 × 8 filter and penumbrae up
    /// to 16 texels.
    pub const PCSS: ShadowFilter = ShadowFilter::Pcss { search_taps: 8, filter_taps: 8, max_penumbra_texels: 16.0 };

    /// The uniform's `shadow_filter` (settings brought into range; no NaN
    /// reaches the shader).
    pub(crate) fn uniform(self) -> [f32; 4] {
        match self {
            ShadowFilter::Pcf => [0.0; 4],
            ShadowFilter::Pcss { search_taps, filter_taps, max_penumbra_texels } => {
                let radius = if max_penumbra_texels.is_finite() { max_penumbra_texels.clamp(1.0, 64.0) } else { 16.0 };
                [search_taps.clamp(2, 16) as f32, radius, filter_taps.clamp(2, 16) as f32, 0.0]
            }
        }
    }
}

/// What a mesh pass does with the colour target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ColorOps {
    /// No colour attachment (depth only).
    None,
    /// Clear the HDR target to this linear colour, then draw.
    Clear(wgpu::Color),
    /// Draw over what the HDR target holds.
    Load,
    /// Tone-map in the fragment shader with this exposure and write the
    /// view's display (sRGB) target, cleared to the tone-mapped linear
    /// colour: no HDR write and no tone-map pass
    /// ([`MeshPass::tone_mapped`]).
    ClearToneMapped(wgpu::Color, crate::Exposure),
}

impl ColorOps {
    /// The load operation of the colour attachment. A tone-mapped clear
    /// goes through the shader's operator on the CPU ([`crate::pbr_neutral`]),
    /// so the background matches the two-pass path.
    pub(crate) fn load(self) -> wgpu::LoadOp<wgpu::Color> {
        match self {
            ColorOps::Clear(c) => wgpu::LoadOp::Clear(c),
            ColorOps::ClearToneMapped(c, exposure) => {
                let scale = |v: f64| {
                    let v = v as f32 * exposure.get();
                    if v.is_finite() { v.clamp(0.0, 65504.0) } else { 0.0 }
                };
                let [r, g, b] = crate::pbr_neutral([scale(c.r), scale(c.g), scale(c.b)]).map(|v| v.clamp(0.0, 1.0));
                wgpu::LoadOp::Clear(wgpu::Color { r: r.into(), g: g.into(), b: b.into(), a: 1.0 })
            }
            ColorOps::None | ColorOps::Load => wgpu::LoadOp::Load,
        }
    }
}

/// Which of a view's draws a mesh pass draws: they differ only for a view
/// with GPU occlusion culling, whose depth pre-pass runs in two phases
/// around the occlusion test ([`RenderContext::cull_occluded`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DrawList {
    /// Every draw of the view ([`oxygen_sceneprep::PreparedSceneFrame::partitions`]).
    #[default]
    All,
    /// Occlusion culling's first phase: what was visible last frame (every
    /// draw for other views).
    Early,
    /// Occlusion culling's second phase: what the depth pyramid found
    /// visible that the first phase did not draw (nothing for other views).
    Late,
}

/// The mesh pass: draws the partitions that match its masks.
#[derive(Clone, Debug)]
pub struct MeshPass {
    list: DrawList,
    name: &'static str,
    include: PassMask,
    exclude: PassMask,
    kind: PassKind,
    color: ColorOps,
    clear_depth: bool,
    depth_bias: DepthBias,
    lighting: Option<ForwardLitConfig>,
    /// Pipeline statistics (e.g. fragment shader invocations) written into
    /// this query of the set, for benchmarks.
    statistics: Option<(wgpu::QuerySet, u32)>,
    /// With MSAA: whether the multisampled colour is stored after the
    /// resolve (for a later pass that loads it).
    keep_samples: bool,
    /// A shading pass that writes the pixel labels of the views that have
    /// label targets with their colour ([`MeshPass::with_labels`]).
    write_labels: bool,
}

impl MeshPass {
    /// Depth of the opaque and masked partitions into the view's depth
    /// target (cleared to 0, the far value in reverse-Z), so that shading
    /// runs once per visible pixel.
    pub fn depth_pre_pass() -> Self {
        MeshPass {
            list: DrawList::All,
            name: "depth pre-pass",
            include: PassMask::OPAQUE | PassMask::MASKED,
            exclude: PassMask::TRANSPARENT,
            kind: PassKind::DepthPrePass,
            color: ColorOps::None,
            clear_depth: true,
            depth_bias: DepthBias::NONE,
            lighting: None,
            statistics: None,
            keep_samples: true,
            write_labels: false,
        }
    }

    /// A shadow map: the depth of a shadow view's casters with the default
    /// rasterizer bias ([`DepthBias::SHADOW_DEFAULT`]). Same partitions and
    /// variants as the depth pre-pass, so double-sided casters are drawn
    /// unculled.
    pub fn shadow() -> Self {
        Self::shadow_with_bias(DepthBias::SHADOW_DEFAULT)
    }

    /// A shadow map with an explicit rasterizer depth bias.
    pub fn shadow_with_bias(depth_bias: DepthBias) -> Self {
        MeshPass { name: "shadow", kind: PassKind::Shadow, depth_bias, ..Self::depth_pre_pass() }
    }

    /// Metallic-roughness shading of the opaque and masked partitions into
    /// the view's HDR target, lit by the frame's lights, shadowed by the
    /// view's cascades and the local shadow maps, reflecting its linked
    /// probes. Transparent partitions are left to [`MeshPass::transparent`].
    pub fn forward_lit(config: ForwardLitConfig) -> Self {
        let (kind, clear_depth) =
            if config.depth_from_pre_pass { (PassKind::ShadingAfterPrePass, false) } else { (PassKind::Shading, true) };
        MeshPass {
            list: DrawList::All,
            name: "forward lit",
            include: PassMask::OPAQUE | PassMask::MASKED,
            exclude: PassMask::TRANSPARENT,
            kind,
            color: ColorOps::Clear(config.clear_color),
            clear_depth,
            depth_bias: DepthBias::NONE,
            lighting: Some(config),
            statistics: None,
            keep_samples: true,
            write_labels: false,
        }
    }

    /// Blended partitions, back-to-front (ScenePrep's sort key orders them
    /// across materials), over the HDR target with **premultiplied alpha**
    /// (the shader multiplies colour by alpha; blend `One,
    /// OneMinusSrcAlpha`), tested against the opaque depth and never writing
    /// it. Begins no render pass when the view has nothing blended.
    pub fn transparent() -> Self {
        MeshPass {
            list: DrawList::All,
            name: "transparent",
            include: PassMask::TRANSPARENT,
            exclude: PassMask::empty(),
            kind: PassKind::Transparent,
            color: ColorOps::Load,
            clear_depth: false,
            depth_bias: DepthBias::NONE,
            lighting: None,
            statistics: None,
            keep_samples: true,
            write_labels: false,
        }
    }

    /// Per-pixel labels of the opaque and masked partitions into the
    /// view's label targets ([`oxygen_gpu::LabelTargets`], cleared to 0):
    /// the stable id of the node that drew each pixel plus one, and its
    /// world-space normal, tested against the depth shading left
    /// (`GreaterEqual`, no writes), so the labels are those of the visible
    /// surface. For single-sampled views that asked for labels.
    pub fn labels() -> Self {
        MeshPass {
            list: DrawList::All,
            name: "labels",
            include: PassMask::OPAQUE | PassMask::MASKED,
            exclude: PassMask::TRANSPARENT,
            kind: PassKind::Labels,
            color: ColorOps::None,
            clear_depth: false,
            depth_bias: DepthBias::NONE,
            lighting: None,
            statistics: None,
            keep_samples: true,
            write_labels: false,
        }
    }

    /// Deferred shading's visibility pass ([`crate::DeferredShading`]):
    /// the opaque and masked partitions, writing depth (cleared) and, in
    /// the view's deferred visibility target, each pixel's draw and
    /// triangle, with the view's label planes beside them; no colour.
    pub fn visibility() -> Self {
        MeshPass {
            name: "visibility",
            kind: PassKind::Visibility,
            color: ColorOps::Clear(wgpu::Color::TRANSPARENT),
            write_labels: true,
            ..Self::depth_pre_pass()
        }
    }

    /// The same pass, on a multisampled view, dropping the multisampled
    /// colour once it is resolved into the view's HDR target: for the last
    /// pass that draws colour (no later pass may load the samples). A tiled
    /// GPU can then skip storing every sample; on the H100 it measured no
    /// change (`msaa_bench`, docs/performance.md).
    pub fn discarding_samples(self) -> Self {
        MeshPass { keep_samples: false, ..self }
    }

    /// Whether the pass has anything to draw this frame (the transparent
    /// pass skips an empty frame; a graph may skip work after it).
    pub fn has_draws(&self, ctx: &RenderContext<'_>) -> bool {
        self.partitions(ctx).next().is_some()
    }

    /// The same pass drawing the partitions whose mask has any bit of
    /// `include` and none of `exclude` (see
    /// [`oxygen_sceneprep::PreparedSceneFrame::partitions_matching`]).
    pub fn with_masks(self, include: PassMask, exclude: PassMask) -> Self {
        MeshPass { include, exclude, ..self }
    }

    /// The same pass recording pipeline statistics into query `index` of
    /// `set` (a `QueryType::PipelineStatistics` set; needs
    /// `Features::PIPELINE_STATISTICS_QUERY`): how a benchmark counts the
    /// fragments a pass shades.
    pub fn with_statistics(self, set: wgpu::QuerySet, index: u32) -> Self {
        MeshPass { statistics: Some((set, index)), ..self }
    }

    /// The same shading pass also writing the pixel labels (the node that
    /// drew each pixel and its world normal, what [`MeshPass::labels`]
    /// draws in a pass of its own) into the label targets of every view
    /// that has them and is single-sampled: one geometry pass for colour
    /// and labels. Other passes and views are unchanged.
    pub fn with_labels(self) -> Self {
        MeshPass {
            write_labels: matches!(self.kind, PassKind::Shading | PassKind::ShadingAfterPrePass | PassKind::Visibility),
            ..self
        }
    }

    /// The labels this pass writes with `ctx`'s colour: the view's label
    /// planes when the pass writes labels and the view is single-sampled.
    fn labels_in_pass(&self, ctx: &RenderContext<'_>) -> LabelSet {
        match &ctx.targets.labels {
            Some(labels) if self.write_labels && ctx.targets.msaa.is_none() => labels.set(),
            _ => LabelSet::NONE,
        }
    }

    /// The same pass tone-mapping at the end of its fragment shader (the
    /// same operator as [`crate::TonemapPass`], `exposure` as a pipeline
    /// constant) into the view's display target instead of writing HDR. For
    /// a forward lit pass whose HDR image nothing else reads
    /// ([`RenderContext::hdr_read_after_shading`]): saves the HDR write and
    /// the tone-map pass. Passes that load the colour target stay as they are.
    pub fn tone_mapped(self, exposure: f32) -> Self {
        let color = match self.color {
            ColorOps::Clear(c) | ColorOps::ClearToneMapped(c, _) => {
                ColorOps::ClearToneMapped(c, crate::Exposure::new(exposure))
            }
            other => other,
        };
        MeshPass { color, ..self }
    }

    /// The same pass drawing one phase of an occlusion-culled view's draws.
    /// [`DrawList::Late`] keeps the depth the first phase wrote (loads it
    /// instead of clearing).
    pub fn drawing(self, list: DrawList) -> Self {
        let clear_depth = self.clear_depth && list != DrawList::Late;
        let name = match list {
            DrawList::Late => "depth pre-pass (late)",
            _ => self.name,
        };
        MeshPass { list, clear_depth, name, ..self }
    }

    /// The same pass under another name (logs, errors).
    pub fn named(self, name: &'static str) -> Self {
        MeshPass { name, ..self }
    }

    /// The partitions of this view the pass draws.
    fn partitions<'a>(&self, ctx: &'a RenderContext<'_>) -> impl Iterator<Item = &'a Partition> + use<'a> {
        let (include, exclude) = (self.include, self.exclude);
        let prepared = ctx.prepared;
        let plan = prepared.gpu_plan().filter(|p| p.visibility == oxygen_sceneprep::Visibility::GpuOcclusion);
        // Occlusion culling: the GPU's partitions of the phase, then the
        // CPU's (transparent) ones, which are drawn with the first phase.
        let (gpu, cpu): (&[Partition], bool) = match (self.list, plan) {
            (DrawList::Early, Some(plan)) => (&plan.early_partitions, true),
            (DrawList::Late, Some(plan)) => (&plan.late_partitions, false),
            (DrawList::Late, None) => (&[], false),
            _ => (prepared.partitions(), false),
        };
        let cpu_part = prepared.partitions().iter().filter(move |p| cpu && p.gpu_count.is_none());
        gpu.iter().chain(cpu_part).filter(move |p| p.mask.intersects(include) && !p.mask.intersects(exclude))
    }

    /// The colour attachment: the HDR target (whatever format the view's
    /// HDR has), or the display target when tone-mapping in the pass.
    fn color_view<'a>(&self, ctx: &RenderContext<'a>) -> Result<Option<&'a wgpu::TextureView>, PassError> {
        if self.kind == PassKind::Visibility {
            let targets = ctx.targets.deferred.as_ref().ok_or_else(|| PassError::BadInput {
                pass: self.name,
                what: format!("{} has no deferred targets (a batch made for deferred shading has)", ctx.view.view_id),
            })?;
            return Ok(Some(&targets.visibility_view));
        }
        Ok(match self.color {
            ColorOps::None => None,
            ColorOps::ClearToneMapped(..) => Some(
                ctx.color_targets(self.name)?
                    .color_view
                    .as_ref()
                    .ok_or(PassError::NoColorTarget { pass: self.name })?,
            ),
            ColorOps::Clear(_) | ColorOps::Load => Some(&ctx.color_targets(self.name)?.hdr_view),
        })
    }

    fn color_format(&self, ctx: &RenderContext<'_>) -> Option<wgpu::TextureFormat> {
        if self.kind == PassKind::Visibility {
            return Some(oxygen_gpu::DeferredTargets::VISIBILITY_FORMAT);
        }
        match self.color {
            ColorOps::None => None,
            ColorOps::ClearToneMapped(..) => Some(ViewTargets::COLOR_FORMAT),
            ColorOps::Clear(_) | ColorOps::Load => Some(ctx.targets.color.as_ref()?.hdr_format()),
        }
    }

    /// The optional shader code this pass needs for this view this frame:
    /// only what it will bind (the same choices as
    /// `forward_lighting::bind_group`) and what the frame holds.
    pub(crate) fn shader_features(&self, ctx: &RenderContext<'_>) -> crate::ShaderFeatures {
        if !ctx.shading.specialize {
            return crate::ShaderFeatures::ALL;
        }
        let inputs = &ctx.inputs;
        let config = self.lighting.as_ref();
        let probes = config.is_some_and(|c| c.reflections) && !inputs.probes.is_empty();
        crate::ShaderFeatures {
            sun_shadows: config.is_some_and(|c| c.sun_shadows) && !inputs.cascades.is_empty(),
            local_lights: ctx.prepared.slots().positional_lights.count > 0,
            clustered_lights: config.is_some_and(|c| super::forward_lighting::clusters_lights(ctx, c)),
            local_shadows: config.is_some_and(|c| c.local_shadows) && inputs.local_shadows.is_some(),
            soft_shadows: config.is_some_and(|c| {
                matches!(c.shadow_filter, ShadowFilter::Pcss { .. })
                    && ((c.sun_shadows && !inputs.cascades.is_empty())
                        || (c.local_shadows && inputs.local_shadows.is_some()))
            }),
            probes,
            probe_parallax: probes && inputs.probes.iter().any(|p| p.parallax.is_some()),
            textures: ctx.shading.materials.textures,
            uv_transforms: ctx.shading.materials.uv_transforms,
            vertex_attributes: ctx.shading.vertex_attributes,
            ambient_occlusion: config.is_some_and(|c| c.ambient_occlusion.is_some()),
            contact_shadows: config.is_some_and(|c| c.contact_shadows.is_some()),
            screen_reflections: config.is_some_and(|c| c.screen_space_reflections.is_some()),
        }
    }

    fn tone_map(&self) -> Option<crate::Exposure> {
        match self.color {
            ColorOps::ClearToneMapped(_, exposure) => Some(exposure),
            _ => None,
        }
    }
}

impl RenderPass for MeshPass {
    fn name(&self) -> &'static str {
        self.name
    }

    async fn run(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        self.record(ctx, rec).instrument(info_span!("mesh_pass", pass = self.name, view = %ctx.view.view_id)).await
    }
}

impl MeshPass {
    /// Records the pass for every view of a batch ([`oxygen_gpu::TileAtlas`]
    /// tiles, see [`oxygen_gpu::ViewTargets::tile`]) with one render pass
    /// per atlas page: per view only its viewport, its scene constants,
    /// its lighting inputs and its draws. Views that are not tiles get a
    /// render pass each, as [`RenderPass::run`] records them.
    pub async fn run_batch(
        &mut self,
        views: &[&RenderContext<'_>],
        rec: &mut CommandRecorder,
    ) -> Result<(), PassError> {
        let first = views.first().map(|ctx| ctx.view.view_id);
        self.record_views(views, rec)
            .instrument(info_span!("mesh_pass_batch", pass = self.name, views = views.len(), first = ?first))
            .await
    }

    async fn record(&self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        self.record_views(&[ctx], rec).await
    }

    /// The pipeline key of this pass for `ctx` (the variant is each
    /// partition's).
    fn shading_key(&self, ctx: &RenderContext<'_>) -> crate::PipelineKey {
        let color_format = match self.kind {
            PassKind::Labels => None,
            _ => self.color_format(ctx),
        };
        crate::PipelineKey {
            pass: self.kind,
            variant: crate::PipelineVariant::from_mask(PassMask::empty()),
            color_format,
            depth_format: ViewTargets::DEPTH_FORMAT,
            depth_bias: self.depth_bias,
            features: self.shader_features(ctx),
            tone_map: self.tone_map(),
            samples: ctx.targets.samples(),
            labels: match self.kind {
                PassKind::Labels => ctx.targets.labels.as_ref().map_or(LabelSet::NONE, LabelTargets::set),
                _ => self.labels_in_pass(ctx),
            },
            last_tie_wins: ctx.deterministic(),
        }
    }

    async fn record_views(&self, views: &[&RenderContext<'_>], rec: &mut CommandRecorder) -> Result<(), PassError> {
        // The transparent pass alone skips an empty frame: the others clear
        // their targets, which later passes rely on.
        let skippable = self.kind == PassKind::Transparent || self.list == DrawList::Late;
        if skippable && views.iter().all(|ctx| self.partitions(ctx).next().is_none()) {
            return Ok(());
        }
        if self.kind == PassKind::Labels
            && let Some(ctx) = views.iter().find(|ctx| ctx.targets.labels.is_none() || ctx.targets.msaa.is_some())
        {
            return Err(PassError::BadInput {
                pass: self.name,
                what: format!(
                    "{} has no label targets: labels are drawn for single-sampled views that ask for them",
                    ctx.view.view_id
                ),
            });
        }
        if self.tone_map().is_some() && views.iter().any(|ctx| ctx.targets.msaa.is_some()) {
            return Err(PassError::BadInput {
                pass: self.name,
                what: "tone-mapping while shading needs a single-sampled view (MSAA resolves into the HDR target, \
                       which the tone-map pass reads)"
                    .into(),
            });
        }
        // Per view, its pipeline keys (one per partition, all views' in one
        // list: a batch of a thousand cameras makes no list per camera);
        // each distinct key is requested once, however many views of a
        // batch share it, and before the views' lighting inputs are
        // awaited, so that the pipelines compile while the views producing
        // the inputs record.
        let mut shading_keys: Vec<crate::PipelineKey> = Vec::with_capacity(views.len());
        let mut partition_keys: Vec<crate::PipelineKey> = Vec::new();
        let mut key_ranges: Vec<std::ops::Range<usize>> = Vec::with_capacity(views.len());
        let mut distinct: Vec<crate::PipelineKey> = Vec::new();
        for ctx in views {
            let shading = self.shading_key(ctx);
            let start = partition_keys.len();
            for p in self.partitions(ctx) {
                let key = crate::PipelineKey { variant: crate::PipelineVariant::from_mask(p.mask), ..shading };
                if !distinct.contains(&key) {
                    distinct.push(key);
                }
                partition_keys.push(key);
            }
            shading_keys.push(shading);
            key_ranges.push(start..partition_keys.len());
        }
        let pipelines = futures::future::join_all(distinct.iter().map(|key| {
            let ctx = views[0];
            ctx.pipelines.get(&ctx.gpu.device, *key)
        }));
        // Only the views that read a shadow map or a probe have a lighting
        // group to await; the others bind the shared empty group.
        let lit: Vec<usize> = match &self.lighting {
            Some(config) => {
                (0..views.len()).filter(|i| super::forward_lighting::reads_inputs(views[*i], config)).collect()
            }
            None => Vec::new(),
        };
        let lighting = futures::future::try_join_all(lit.iter().map(|i| async move {
            match &self.lighting {
                Some(config) => super::forward_lighting::bind_group(views[*i], config).await,
                None => Ok((None, None)),
            }
        }));
        let (pipelines, lit_groups) = futures::future::join(pipelines, lighting).await;
        let mut lighting: Vec<Option<wgpu::BindGroup>> = vec![None; views.len()];
        let mut cluster_jobs = Vec::new();
        for (i, (group, job)) in lit.into_iter().zip(lit_groups?) {
            lighting[i] = group;
            cluster_jobs.extend(job);
        }
        // The views' light clusters, sorted before any of them shades.
        if let Some(ctx) = views.first() {
            ctx.lighting.clusters().record(rec.encoder(), ctx.heap, &cluster_jobs);
            rec.stats.light_cluster_jobs += u32::try_from(cluster_jobs.len()).unwrap_or(u32::MAX);
        }
        // Every key is in `distinct`, in the order of `pipelines`.
        let partition_pipelines: Vec<wgpu::RenderPipeline> = partition_keys
            .iter()
            .map(|key| pipelines[distinct.iter().position(|k| k == key).unwrap_or(0)].clone())
            .collect();

        // Views sharing a page of an atlas share its render pass; any other
        // view has one of its own.
        let mut passes: Vec<(Option<u32>, Vec<usize>)> = Vec::new();
        for (i, ctx) in views.iter().enumerate() {
            let page = ctx.targets.tile.map(|t| t.page);
            let same_page = |(p, members): &&mut (Option<u32>, Vec<usize>)| {
                page.is_some() && *p == page && views[members[0]].targets.depth == ctx.targets.depth
            };
            match passes.iter_mut().find(same_page) {
                Some((_, members)) => members.push(i),
                None => passes.push((page, vec![i])),
            }
        }
        if self.statistics.is_some() && passes.len() > 1 {
            return Err(PassError::BadInput {
                pass: self.name,
                what: "pipeline statistics are counted in one render pass; this batch needs several".into(),
            });
        }

        let mut stats = rec.stats;
        for (_, members) in &passes {
            let lead = views[members[0]];
            // A page that keeps other cameras' tiles this frame is loaded,
            // and each camera's tile cleared alone (what the pass would
            // clear: the colour when it clears it, depth and labels).
            let clears = self.clear_depth || matches!(self.color, ColorOps::Clear(_) | ColorOps::ClearToneMapped(..));
            let tile_clears = clears && lead.targets.tile.is_some() && lead.targets.page_kept;
            if tile_clears && self.kind == PassKind::Visibility {
                return Err(PassError::BadInput {
                    pass: self.name,
                    what: "a page that keeps other cameras' images is shaded forward (its tiles are cleared alone)"
                        .into(),
                });
            }
            let color_ops =
                if tile_clears && !matches!(self.color, ColorOps::None) { ColorOps::Load } else { self.color };
            let tile_clear_color = match self.color.load() {
                wgpu::LoadOp::Clear(c) => Some([c.r, c.g, c.b, c.a].map(|v| v as f32)),
                _ => None,
            };
            let color = self.color_view(lead)?.map(|view| (view, color_ops));
            // With MSAA the pass draws into the multisampled HDR target and
            // resolves it into the view's HDR target at its end (every
            // colour pass: a later one loads the samples, not the resolve).
            let msaa = lead.targets.msaa.as_ref();
            let store =
                if msaa.is_some() && !self.keep_samples { wgpu::StoreOp::Discard } else { wgpu::StoreOp::Store };
            let color_attachment = color.map(|(view, ops)| wgpu::RenderPassColorAttachment {
                view: msaa.map_or(view, |m| &m.color_view),
                depth_slice: None,
                resolve_target: msaa.map(|_| view),
                ops: wgpu::Operations { load: ops.load(), store },
            });
            let depth_load =
                if self.clear_depth && !tile_clears { wgpu::LoadOp::Clear(0.0) } else { wgpu::LoadOp::Load };
            let labels_load =
                if tile_clears { wgpu::LoadOp::Load } else { wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT) };
            // The labels pass writes its label planes instead.
            let label_attachments = match (&lead.targets.labels, self.kind) {
                (Some(labels), PassKind::Labels) => label_attachments(labels, labels_load),
                // Shading that writes the labels too: colour, then labels.
                (Some(labels), _) if !self.labels_in_pass(lead).is_empty() => {
                    let mut attachments = vec![color_attachment.clone()];
                    attachments.extend(label_attachments(labels, labels_load));
                    attachments
                }
                _ => Vec::new(),
            };
            let mut pass = rec.encoder().begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some(self.name),
                // A depth-only pass has no colour slot at all (not an empty one).
                color_attachments: if !label_attachments.is_empty() {
                    &label_attachments
                } else if color_attachment.is_some() {
                    std::slice::from_ref(&color_attachment)
                } else {
                    &[]
                },
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: lead.targets.render_depth_view(),
                    depth_ops: Some(wgpu::Operations { load: depth_load, store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            stats.render_passes += 1;
            if let Some((set, index)) = &self.statistics {
                pass.begin_pipeline_statistics_query(set, *index);
            }
            // What the views of one render pass share (the heap's groups, the
            // index buffer, often the lighting group and the pipelines) is set
            // when it changes, not once per view: a batch of a thousand
            // cameras records a thousand views into one pass.
            let mut bound = Bound::default();
            for &i in members {
                let ctx = views[i];
                let (lighting, pipelines, shading) =
                    (&lighting[i], &partition_pipelines[key_ranges[i].clone()], &shading_keys[i]);
                if let Some(tile) = ctx.targets.tile {
                    let (w, h) = (ctx.targets.width, ctx.targets.height);
                    pass.set_viewport(tile.x as f32, tile.y as f32, w as f32, h as f32, 0.0, 1.0);
                    pass.set_scissor_rect(tile.x, tile.y, w, h);
                }
                stats.tone_mapped_in_pass |= shading.tone_map.is_some();
                let group3 = lighting.as_ref().unwrap_or(ctx.lighting.no_lighting_inputs());
                bound.view_resources(&mut pass, ctx, group3);
                if tile_clears {
                    bound.pipeline(&mut pass, &ctx.pipelines.tile_clear(&ctx.gpu.device, *shading, tile_clear_color));
                    pass.draw(0..3, 0..1);
                    stats.draw_calls += 1;
                }
                // The environment behind the scene: drawn first by the pass
                // that clears the colour target, meshes then draw over it.
                let clears_color = matches!(self.color, ColorOps::Clear(_) | ColorOps::ClearToneMapped(..));
                let is_shading = matches!(self.kind, PassKind::Shading | PassKind::ShadingAfterPrePass);
                if clears_color && is_shading && ctx.lighting.has_environment() {
                    bound.pipeline(&mut pass, &ctx.pipelines.sky(&ctx.gpu.device, *shading));
                    pass.draw(0..3, 0..1);
                    stats.draw_calls += 1;
                }
                for (partition, pipeline) in self.partitions(ctx).zip(pipelines) {
                    if bound.pipeline(&mut pass, pipeline) {
                        stats.pipeline_binds += 1;
                    }
                    draw_partition(&mut pass, ctx, partition, &mut stats);
                }
            }
            if self.statistics.is_some() {
                pass.end_pipeline_statistics_query();
            }
        }
        rec.stats = stats;
        Ok(())
    }
}

/// What a render pass has bound so far, so that the views recorded into it
/// one after another set only what differs from the view before.
#[derive(Default)]
struct Bound {
    heap: Option<(wgpu::BindGroup, wgpu::BindGroup, wgpu::Buffer)>,
    constants: Option<(wgpu::BindGroup, u32)>,
    lighting: Option<wgpu::BindGroup>,
    pipeline: Option<wgpu::RenderPipeline>,
}

impl Bound {
    /// Sets the bindless groups (0, 2), the lighting inputs (1), the scene
    /// constants (3) and the shared index buffer of `ctx`, each unless
    /// already bound. Only the constants differ from camera to camera of a
    /// batch: as the last group, a change rebinds nothing else.
    fn view_resources(&mut self, pass: &mut wgpu::RenderPass<'_>, ctx: &RenderContext<'_>, lighting: &wgpu::BindGroup) {
        let heap = (ctx.heap.bind_group(), ctx.heap.texture_bind_group(), ctx.heap.index_buffer());
        if self.heap.as_ref().is_none_or(|(a, b, c)| (a, b, c) != heap) {
            pass.set_bind_group(0, heap.0, &[]);
            pass.set_bind_group(2, heap.1, &[]);
            pass.set_index_buffer(heap.2.slice(..), wgpu::IndexFormat::Uint32);
            self.heap = Some((heap.0.clone(), heap.1.clone(), heap.2.clone()));
        }
        if self.lighting.as_ref() != Some(lighting) {
            pass.set_bind_group(1, lighting, &[]);
            self.lighting = Some(lighting.clone());
        }
        // A batch's cameras share one bind group at their own offsets.
        let (constants, offset) = (ctx.scene_constants.bind_group(), ctx.scene_constants.dynamic_offset());
        if self.constants.as_ref().is_none_or(|(group, at)| group != constants || *at != offset) {
            pass.set_bind_group(3, constants, &[offset]);
            self.constants = Some((constants.clone(), offset));
        }
    }

    /// Sets `pipeline` unless it is bound; says whether it set it.
    fn pipeline(&mut self, pass: &mut wgpu::RenderPass<'_>, pipeline: &wgpu::RenderPipeline) -> bool {
        if self.pipeline.as_ref() == Some(pipeline) {
            return false;
        }
        pass.set_pipeline(pipeline);
        self.pipeline = Some(pipeline.clone());
        true
    }
}

/// Draws every draw of `partition` through its commands (one per draw, or
/// one per instanced run). Either way a draw's position in the view's array
/// reaches the shader as `first_instance + instance_index`, which is how the
/// vertex shader finds its `DrawMetadata`.
fn draw_partition(
    pass: &mut wgpu::RenderPass<'_>,
    ctx: &RenderContext<'_>,
    partition: &Partition,
    stats: &mut RecordStats,
) {
    let stride = std::mem::size_of::<oxygen_sceneprep::DrawIndexedIndirect>() as u64;
    let first = ctx.prepared.slots().indirect_args.start as u64 + partition.first_command as u64;
    let buffer = ctx.heap.buffer(oxygen_bindless::DomainKind::IndirectArgs);
    if let Some(counter) = partition.gpu_count {
        // Written by GPU visibility: as many commands as its counter says,
        // at most one per group. The renderer only puts a view on a GPU
        // path where the device counts draws.
        if let Some((counts, base)) = ctx.inputs.visibility.and_then(|v| v.count_buffer(ctx.view.view_id)) {
            pass.multi_draw_indexed_indirect_count(
                buffer,
                first * stride,
                counts,
                base + u64::from(counter) * 4,
                partition.command_count,
            );
            stats.draw_calls += 1;
            stats.draw_commands += partition.command_count;
        }
        return;
    }
    if ctx.draw_path == DrawPath::MultiDrawIndirect {
        pass.multi_draw_indexed_indirect(buffer, first * stride, partition.command_count);
        stats.draw_calls += 1;
        stats.draw_commands += partition.command_count;
        return;
    }
    for command in ctx.prepared.commands_of(partition) {
        let indices = command.first_index..command.first_index + command.index_count;
        let instances = command.first_instance..command.first_instance + command.instance_count;
        pass.draw_indexed(indices, command.base_vertex, instances);
        stats.draw_calls += 1;
        stats.draw_commands += 1;
    }
}

/// The label planes as colour attachments, cleared to 0 (no node, no
/// class, no surface) or loaded (`load`), in [`oxygen_gpu::Label::ALL`]
/// order with none for a plane the view lacks (as the pipelines' targets),
/// trimmed after the last.
fn label_attachments(
    labels: &LabelTargets,
    load: wgpu::LoadOp<wgpu::Color>,
) -> Vec<Option<wgpu::RenderPassColorAttachment<'_>>> {
    let mut attachments: Vec<_> = oxygen_gpu::Label::ALL
        .into_iter()
        .map(|label| {
            labels.plane(label).map(|plane| wgpu::RenderPassColorAttachment {
                view: &plane.view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
            })
        })
        .collect();
    while attachments.last().is_some_and(Option::is_none) {
        attachments.pop();
    }
    attachments
}
