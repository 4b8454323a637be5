//! The `Renderer` facade: view registration and the two-phase frame.
//!
//! Ownership: the renderer owns the GPU context, the bindless heap, ScenePrep
//! and the pipeline cache; each registered view owns its resolver, its
//! factory, its targets and its `SceneConstants` buffer. A frame borrows the
//! scene immutably. Prepared frames of the last frame are kept for inspection
//! until the next frame replaces them.

use std::collections::BTreeMap;
use std::future::Future;
use std::pin::Pin;
use std::time::Instant;

use oxygen_bindless::{BindlessHeap, CameraConstants, SceneConstantsBuffer, TexturePath};
use oxygen_core::{
    GpuContext, GpuError, GpuOptions, ResolvedView, Scene, ViewContext, ViewError, ViewId, ViewResolver, ViewTargets,
};
use oxygen_passes::{
    CommandRecorder, DepthPrePass, DrawPath, FrameViews, PassError, PipelineCache, RecordStats, RenderContext,
    RenderPass, ShaderPass, ShaderPassConfig, TonemapPass, TransparentPass,
};
use oxygen_sceneprep::{PrepError, PreparedSceneFrame, ScenePrep, ViewPrepOptions, ViewRequest};
use thiserror::Error;
use tracing::{info, info_span, warn};

/// The future a render-graph factory returns: it awaits the view's passes.
pub type RenderGraphFuture<'a> = Pin<Box<dyn Future<Output = Result<(), PassError>> + 'a>>;

type Factory = Box<dyn for<'a> Fn(ViewId, &'a RenderContext<'a>, &'a mut CommandRecorder) -> RenderGraphFuture<'a>>;

/// Why a frame (or a renderer) failed.
#[derive(Debug, Error)]
pub enum RenderError {
    /// No usable GPU.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// A view's resolver failed.
    #[error("resolving a view: {0}")]
    View(#[from] ViewError),
    /// ScenePrep failed.
    #[error(transparent)]
    Prep(#[from] PrepError),
    /// A pass failed while recording.
    #[error("{view}: {source}")]
    Pass {
        /// The view whose graph failed.
        view: ViewId,
        /// The pass error.
        source: PassError,
    },
    /// An option the device cannot honour.
    #[error("not supported: {0}")]
    Unsupported(String),
    /// The view id is not (or no longer) registered.
    #[error("{0} is not registered")]
    NoSuchView(ViewId),
    /// The view is depth-only (a shadow view), so it has no image.
    #[error("{0} is depth-only: it has no colour target to read")]
    DepthOnly(ViewId),
    /// The view has not been rendered yet, so it has no image.
    #[error("{0} has not been rendered yet")]
    NotRendered(ViewId),
    /// A view's targets would pass the renderer's target memory budget.
    #[error(
        "{view}: targets of {width}x{height} would take {} MiB; the target budget is {} MiB, of which {} MiB are taken \
         (RendererOptions::target_budget_bytes)",
        bytes >> 20, budget >> 20, taken >> 20
    )]
    TargetBudget {
        /// The view.
        view: ViewId,
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// What its targets would take.
        bytes: u64,
        /// The budget.
        budget: u64,
        /// What other views' targets take already.
        taken: u64,
    },
    /// A resolved viewport exceeds the device's texture size limit.
    #[error("{view}: viewport {width}x{height} exceeds the device limit of {limit}")]
    ViewportTooLarge {
        /// The view.
        view: ViewId,
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// `max_texture_dimension_2d`.
        limit: u32,
    },
}

/// What one view did in a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewReport {
    /// The view.
    pub view: ViewId,
    /// Draws after culling.
    pub draws: usize,
    /// Partitions.
    pub partitions: usize,
    /// What its passes recorded.
    pub recorded: RecordStats,
    /// Seconds of its own ScenePrep work (view phase and finalization).
    pub prep_seconds: f64,
    /// Seconds to record its render graph.
    pub record_seconds: f64,
}

/// Something a frame left out. One bad object or view costs only itself: the
/// frame goes on without it and says so here (and in a `tracing` warning).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FrameWarning {
    /// A view was not rendered this frame (its resolver failed, or its
    /// targets would pass the device limit or the target budget); it keeps
    /// its last image, and every other view rendered.
    ViewSkipped {
        /// The view.
        view: ViewId,
        /// Why, as the error would have said it.
        reason: String,
    },
    /// A node (or its light) was left out by ScenePrep: a non-finite or
    /// singular transform, non-finite bounds, a light with non-finite values.
    NodeSkipped {
        /// The node.
        node: oxygen_core::NodeKey,
        /// Its name.
        name: String,
        /// Why.
        reason: &'static str,
    },
}

impl std::fmt::Display for FrameWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FrameWarning::ViewSkipped { view, reason } => write!(f, "{view} skipped: {reason}"),
            FrameWarning::NodeSkipped { name, reason, .. } => write!(f, "node '{name}' skipped: {reason}"),
        }
    }
}

/// What a frame did.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameReport {
    /// Frame sequence number.
    pub frame_index: u64,
    /// Per view, in submission order.
    pub views: Vec<ViewReport>,
    /// Seconds spent in PreRender (resolve + ScenePrep + upload).
    pub prepare_seconds: f64,
    /// Seconds spent driving the views' render graphs.
    pub record_seconds: f64,
    /// What the frame left out (views and nodes), in view then node order.
    pub warnings: Vec<FrameWarning>,
}

/// Choices made when the renderer is created.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RendererOptions {
    /// Force a draw path; `None` picks the fastest the device supports.
    pub draw_path: Option<DrawPath>,
    /// Threads for ScenePrep's per-view phases; `None` uses every core.
    pub prep_threads: Option<usize>,
    /// Force a texture path; `None` picks the binding array where supported.
    pub texture_path: Option<TexturePath>,
    /// Debug mode: shaders check each draw's slot generation and paint draws
    /// read through a stale range magenta.
    pub debug_generations: bool,
    /// Where the GPU's coordinates are centred (camera-relative rendering).
    pub origin: RenderOrigin,
    /// Skip wgpu's indirect-argument validation on the device the renderer
    /// creates ([`Renderer::new_headless_with`]); see
    /// [`GpuOptions::trust_indirect_args`]. A renderer given a context uses
    /// that context's setting.
    pub trust_indirect_args: bool,
    /// GPU memory all views' targets may take together, bytes
    /// ([`ViewTargets::bytes_for`] says what one view takes). A view whose
    /// targets would pass it is skipped with a [`FrameWarning`] instead of
    /// allocated; default 2 GiB (about 130 views of 1920×1080).
    pub target_budget_bytes: u64,
}

impl Default for RendererOptions {
    fn default() -> Self {
        RendererOptions {
            draw_path: None,
            prep_threads: None,
            texture_path: None,
            debug_generations: false,
            origin: RenderOrigin::default(),
            trust_indirect_args: false,
            target_budget_bytes: 2 << 30,
        }
    }
}

/// Where the GPU's coordinate system is centred each frame.
///
/// `f32` has 24 bits of mantissa: a million units from its origin, positions
/// are rounded to 1/16 of a unit, enough to make nearby geometry visibly
/// shake and crack. Oxygen composes transforms in `f64` and, under the
/// default [`RenderOrigin::FollowFirstView`], moves the origin next to the
/// camera before anything is rounded to `f32` for the GPU. The precision this
/// buys is measured by `tests/huge_world.rs`; its cost is a frame-phase
/// re-collection whenever the origin moves (a camera crossing a grid cell),
/// no more than a frame in which every node moved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RenderOrigin {
    /// World coordinates go to the GPU as they are: exact near the world
    /// origin, 1/16-unit steps a million units out.
    Absolute,
    /// Centred on the camera of the first active view (lowest id) that
    /// renders colour (shadow views are passed over when there is another),
    /// snapped to a grid of `grid` units so that it moves, and the frame's
    /// matrices are rebuilt, only when that camera crosses a cell.
    FollowFirstView {
        /// Cell size in world units (positive and finite; otherwise the
        /// origin is not snapped).
        grid: f64,
    },
    /// Centred on a fixed world position.
    Fixed(glam::DVec3),
}

impl Default for RenderOrigin {
    fn default() -> Self {
        RenderOrigin::FollowFirstView { grid: 1024.0 }
    }
}

impl RenderOrigin {
    /// The origin for a frame in which [`RenderOrigin::FollowFirstView`]
    /// follows `followed` (the renderer passes its first active colour view).
    pub fn resolve(self, followed: Option<&ResolvedView>) -> glam::DVec3 {
        match self {
            RenderOrigin::Absolute => glam::DVec3::ZERO,
            RenderOrigin::Fixed(origin) if origin.is_finite() => origin,
            RenderOrigin::Fixed(_) => glam::DVec3::ZERO,
            RenderOrigin::FollowFirstView { grid } => {
                let Some(eye) = followed.map(ResolvedView::camera_position_f64) else {
                    return glam::DVec3::ZERO;
                };
                if !eye.is_finite() {
                    return glam::DVec3::ZERO;
                }
                if grid.is_finite() && grid > 0.0 { (eye / grid).round() * grid } else { eye }
            }
        }
    }
}

struct RegisteredView {
    resolver: Box<dyn ViewResolver>,
    factory: Factory,
    options: ViewPrepOptions,
    targets: Option<ViewTargets>,
    constants: SceneConstantsBuffer,
    active: bool,
}

/// The renderer: views in, images out.
pub struct Renderer {
    gpu: GpuContext,
    heap: BindlessHeap,
    prep: ScenePrep,
    pipelines: PipelineCache,
    views: BTreeMap<ViewId, RegisteredView>,
    draw_path: DrawPath,
    next_view: u32,
    frame_index: u64,
    started: Instant,
    origin: RenderOrigin,
    target_budget_bytes: u64,
}

/// The default render graph: depth pre-pass, metallic-roughness shading of
/// opaque and masked partitions into HDR, blended partitions back-to-front,
/// then the tone map to the view's sRGB target.
pub fn standard_render_graph<'a>(
    _view: ViewId,
    ctx: &'a RenderContext<'a>,
    rec: &'a mut CommandRecorder,
) -> RenderGraphFuture<'a> {
    Box::pin(run_lit_graph(ShaderPassConfig::default(), ctx, rec))
}

/// The standard graph with a chosen shading configuration (clear colour,
/// shadow views, reflection probe).
pub fn lit_render_graph(
    config: ShaderPassConfig,
) -> impl for<'a> Fn(ViewId, &'a RenderContext<'a>, &'a mut CommandRecorder) -> RenderGraphFuture<'a> + 'static {
    move |_view, ctx, rec| Box::pin(run_lit_graph(config.clone(), ctx, rec))
}

async fn run_lit_graph(
    config: ShaderPassConfig,
    ctx: &RenderContext<'_>,
    rec: &mut CommandRecorder,
) -> Result<(), PassError> {
    DepthPrePass::new().run(ctx, rec).await?;
    ShaderPass::new(config).run(ctx, rec).await?;
    TransparentPass::new().run(ctx, rec).await?;
    TonemapPass::default().run(ctx, rec).await
}

impl Renderer {
    /// The device features Oxygen uses when the adapter has them.
    pub const OPTIONAL_FEATURES: wgpu::Features =
        wgpu::Features::INDIRECT_FIRST_INSTANCE.union(TexturePath::BINDING_ARRAY_FEATURES);

    /// A renderer on a headless device chosen by [`GpuContext::new_headless`].
    pub fn new_headless() -> Result<Self, RenderError> {
        Self::new_headless_with(RendererOptions::default())
    }

    /// A headless renderer with explicit options.
    pub fn new_headless_with(options: RendererOptions) -> Result<Self, RenderError> {
        let gpu_options = GpuOptions {
            optional_features: Self::OPTIONAL_FEATURES,
            trust_indirect_args: options.trust_indirect_args,
            ..Default::default()
        };
        Self::with_options(GpuContext::new_headless(&gpu_options)?, options)
    }

    /// A renderer on an existing GPU context.
    pub fn new(gpu: GpuContext) -> Self {
        // Default options never name an unsupported path, so this cannot fail.
        Self::with_options(gpu, RendererOptions::default()).expect("default renderer options are always supported")
    }

    /// A renderer on an existing GPU context with explicit options; fails
    /// when a forced draw path is not supported by the device.
    pub fn with_options(gpu: GpuContext, options: RendererOptions) -> Result<Self, RenderError> {
        let downlevel = gpu.adapter.get_downlevel_capabilities();
        let draw_path = match options.draw_path {
            Some(path) if !path.is_supported(gpu.features, &downlevel) => {
                return Err(RenderError::Unsupported(format!("{path:?} draw path on {}", gpu.describe())));
            }
            Some(path) => path,
            None => DrawPath::best_for(gpu.features, &downlevel),
        };
        let limits = gpu.device.limits();
        let texture_path = match options.texture_path {
            Some(path) if !path.is_supported(gpu.features, &limits) => {
                return Err(RenderError::Unsupported(format!("{path:?} texture path on {}", gpu.describe())));
            }
            Some(path) => path,
            None => TexturePath::best_for(gpu.features, &limits),
        };
        info!(?draw_path, ?texture_path, "draw and texture paths chosen");
        let heap = BindlessHeap::new(&gpu.device, &gpu.queue, texture_path);
        let pipelines = PipelineCache::new(&gpu.device, &heap);
        let mut prep = match options.prep_threads {
            Some(threads) => ScenePrep::with_threads(threads),
            None => ScenePrep::new(),
        };
        prep.set_debug_generations(options.debug_generations);
        Ok(Renderer {
            origin: options.origin,
            target_budget_bytes: options.target_budget_bytes,
            gpu,
            heap,
            prep,
            pipelines,
            views: BTreeMap::new(),
            draw_path,
            next_view: 0,
            frame_index: 0,
            started: Instant::now(),
        })
    }

    /// How textures are bound on this device.
    pub fn texture_path(&self) -> TexturePath {
        self.heap.texture_path()
    }

    /// How partitions are drawn on this device.
    pub fn draw_path(&self) -> DrawPath {
        self.draw_path
    }

    /// Registers a view with default ScenePrep options. Views are prepared
    /// and submitted in registration order.
    ///
    /// The factory is called once per frame with the view's context and
    /// recorder and returns a future that awaits the view's passes;
    /// [`standard_render_graph`] is the default.
    pub fn register_view<R, F>(&mut self, resolver: R, factory: F) -> ViewId
    where
        R: ViewResolver + 'static,
        F: for<'a> Fn(ViewId, &'a RenderContext<'a>, &'a mut CommandRecorder) -> RenderGraphFuture<'a> + 'static,
    {
        self.register_view_with_options(resolver, ViewPrepOptions::default(), factory)
    }

    /// Registers a view with explicit ScenePrep options (filter, cull bound).
    pub fn register_view_with_options<R, F>(&mut self, resolver: R, options: ViewPrepOptions, factory: F) -> ViewId
    where
        R: ViewResolver + 'static,
        F: for<'a> Fn(ViewId, &'a RenderContext<'a>, &'a mut CommandRecorder) -> RenderGraphFuture<'a> + 'static,
    {
        let id = ViewId(self.next_view);
        self.next_view += 1;
        let constants = SceneConstantsBuffer::new(
            &self.gpu.device,
            self.heap.scene_constants_layout(),
            &format!("{id} scene constants"),
        );
        self.views.insert(
            id,
            RegisteredView {
                resolver: Box::new(resolver),
                factory: Box::new(factory),
                options,
                targets: None,
                constants,
                active: true,
            },
        );
        info!(view = %id, "view registered");
        id
    }

    /// Removes a view and frees its slots.
    pub fn unregister_view(&mut self, id: ViewId) -> Result<(), RenderError> {
        self.views.remove(&id).ok_or(RenderError::NoSuchView(id))?;
        self.prep.forget_view(id, &mut self.heap.slots)?;
        Ok(())
    }

    /// Pauses (`false`) or resumes a view: a paused view is neither resolved,
    /// prepared nor rendered, and keeps its last image (e.g. a reflection
    /// probe updated every N frames).
    pub fn set_view_active(&mut self, id: ViewId, active: bool) -> Result<(), RenderError> {
        self.views.get_mut(&id).ok_or(RenderError::NoSuchView(id))?.active = active;
        Ok(())
    }

    /// Registered views in submission order.
    pub fn views(&self) -> impl Iterator<Item = ViewId> + '_ {
        self.views.keys().copied()
    }

    /// Renders one frame of `scene` through every registered view.
    pub fn render_frame(&mut self, scene: &Scene) -> Result<FrameReport, RenderError> {
        self.frame_index += 1;
        let frame_index = self.frame_index;
        let time_seconds = self.started.elapsed().as_secs_f32();
        let _span = info_span!("render_frame", frame = frame_index, views = self.views.len()).entered();

        // PreRender: resolve, prepare, upload.
        let prepare_start = Instant::now();
        let (resolved, mut warnings) = self.resolve_views(scene, frame_index, time_seconds);
        let requests: Vec<ViewRequest<'_>> =
            resolved.iter().map(|view| ViewRequest { view, options: self.views[&view.view_id].options }).collect();
        let followed = resolved.iter().find(|v| !self.views[&v.view_id].options.depth_only).or(resolved.first());
        let origin = self.origin.resolve(followed);
        self.prep.set_render_origin(origin);
        self.prep.prepare(scene, &requests, &mut self.heap.slots)?;
        self.prep.upload(&mut self.heap, &self.gpu.device, &self.gpu.queue)?;
        let frames = self.prep.frames();
        let prepare_seconds = prepare_start.elapsed().as_secs_f64();

        // The passes see every view relative to the render origin, as the
        // world matrices and lights were uploaded.
        let gpu_views: Vec<ResolvedView> = resolved.iter().map(|view| view.relative_to(origin)).collect();

        // Render: each view's graph, submitted in view order.
        let record_start = Instant::now();
        let mut command_buffers = Vec::with_capacity(frames.len());
        let mut reports = Vec::with_capacity(frames.len());
        // Targets and constants first, for every view, so that a view's graph
        // can read what earlier views render (shadow maps, probe faces).
        for (view, frame) in gpu_views.iter().zip(frames) {
            let registered = self.views.get_mut(&view.view_id).ok_or(RenderError::NoSuchView(view.view_id))?;
            // Depth-only views (shadow maps) get no colour targets.
            let with_color = !registered.options.depth_only;
            let targets_fit =
                registered.targets.as_ref().is_some_and(|t| t.fits(view.viewport.x, view.viewport.y, with_color));
            if !targets_fit {
                let (width, height, label) = (view.viewport.x, view.viewport.y, view.view_id.to_string());
                registered.targets = Some(if with_color {
                    ViewTargets::new(&self.gpu.device, width, height, &label)
                } else {
                    ViewTargets::depth_only(&self.gpu.device, width, height, &label)
                });
            }
            registered.constants.set_camera(
                &self.gpu.queue,
                &CameraConstants::new(
                    view.view,
                    view.projection,
                    view.view_projection,
                    view.inverse_view_projection,
                    view.camera_position,
                ),
            );
            registered.constants.set_renderer(&self.gpu.queue, &frame.renderer_constants(time_seconds));
        }
        let frame_views = FrameViews {
            entries: gpu_views
                .iter()
                .filter_map(|view| self.views[&view.view_id].targets.as_ref().map(|t| (view.view_id, view, t)))
                .collect(),
        };
        for (view, frame) in gpu_views.iter().zip(frames) {
            let registered = &self.views[&view.view_id];
            let Some(targets) = registered.targets.as_ref() else { continue };
            let ctx = RenderContext {
                gpu: &self.gpu,
                view,
                prepared: frame,
                scene_constants: &registered.constants,
                heap: &self.heap,
                targets,
                pipelines: &self.pipelines,
                draw_path: self.draw_path,
                outputs: Default::default(),
                frame_views: &frame_views,
                origin,
            };
            let record_started = Instant::now();
            let mut recorder = CommandRecorder::new(&self.gpu.device, &view.view_id.to_string());
            let _view_span = info_span!("render_graph", view = %view.view_id).entered();
            futures::executor::block_on((registered.factory)(view.view_id, &ctx, &mut recorder))
                .map_err(|source| RenderError::Pass { view: view.view_id, source })?;
            let (buffer, recorded) = recorder.finish();
            command_buffers.push(buffer);
            reports.push(ViewReport {
                view: view.view_id,
                draws: frame.draws().len(),
                partitions: frame.partitions().len(),
                recorded,
                prep_seconds: frame.prep_seconds() as f64,
                record_seconds: record_started.elapsed().as_secs_f64(),
            });
        }
        self.gpu.queue.submit(command_buffers);
        let record_seconds = record_start.elapsed().as_secs_f64();

        warnings.extend(self.prep.frame_collection().skipped.iter().map(|s| FrameWarning::NodeSkipped {
            node: s.node,
            name: s.name.clone(),
            reason: s.reason,
        }));
        Ok(FrameReport { frame_index, views: reports, prepare_seconds, record_seconds, warnings })
    }

    /// What the targets of a `viewport`-sized view take, bytes (colour and
    /// depth, or depth only).
    pub fn target_bytes(viewport: glam::UVec2, depth_only: bool) -> u64 {
        ViewTargets::bytes_for(viewport.x, viewport.y, !depth_only)
    }

    /// Bytes the registered views' targets take now.
    pub fn target_memory(&self) -> u64 {
        self.views.values().filter_map(|v| v.targets.as_ref()).map(ViewTargets::bytes).sum()
    }

    /// The target budget ([`RendererOptions::target_budget_bytes`]).
    pub fn target_budget(&self) -> u64 {
        self.target_budget_bytes
    }

    /// Checks, before anything is allocated, that views of these sizes
    /// (`(viewport, depth_only)`) fit the target budget together; returns
    /// their total. `view` numbers the first that does not fit in the error.
    pub fn check_target_budget(&self, views: &[(glam::UVec2, bool)]) -> Result<u64, RenderError> {
        let mut taken = 0u64;
        for (i, (viewport, depth_only)) in views.iter().enumerate() {
            self.admit_targets(ViewId(i as u32), *viewport, !depth_only, &mut taken)?;
        }
        Ok(taken)
    }

    /// Adds a `viewport`-sized view's targets to `taken`, or says they would
    /// pass the target budget (leaving `taken` as it was).
    fn admit_targets(
        &self,
        view: ViewId,
        viewport: glam::UVec2,
        with_color: bool,
        taken: &mut u64,
    ) -> Result<(), RenderError> {
        let bytes = ViewTargets::bytes_for(viewport.x, viewport.y, with_color);
        if taken.saturating_add(bytes) > self.target_budget_bytes {
            let (width, height, budget) = (viewport.x, viewport.y, self.target_budget_bytes);
            return Err(RenderError::TargetBudget { view, width, height, bytes, budget, taken: *taken });
        }
        *taken += bytes;
        Ok(())
    }

    /// Resolves every active view. A view that cannot be rendered this frame
    /// (its resolver fails, its viewport passes the device limit, its
    /// targets would pass the budget) is left out with a warning; the others
    /// go on.
    fn resolve_views(
        &self,
        scene: &Scene,
        frame_index: u64,
        time_seconds: f32,
    ) -> (Vec<ResolvedView>, Vec<FrameWarning>) {
        let _span = info_span!("resolve_views").entered();
        let limit = self.gpu.device.limits().max_texture_dimension_2d;
        // Paused views keep their targets: their memory stays taken.
        let mut taken: u64 =
            self.views.values().filter(|v| !v.active).filter_map(|v| v.targets.as_ref()).map(ViewTargets::bytes).sum();
        let mut resolved = Vec::with_capacity(self.views.len());
        let mut warnings = Vec::new();
        for (id, registered) in self.views.iter().filter(|(_, registered)| registered.active) {
            let ctx = ViewContext { view_id: *id, frame_index, time_seconds };
            let attempt = registered.resolver.resolve(&ctx, scene).map_err(RenderError::from).and_then(|mut view| {
                // The id is the renderer's, whatever the resolver wrote.
                view.view_id = *id;
                let (width, height) = (view.viewport.x, view.viewport.y);
                if width > limit || height > limit {
                    return Err(RenderError::ViewportTooLarge { view: *id, width, height, limit });
                }
                self.admit_targets(*id, view.viewport, !registered.options.depth_only, &mut taken)?;
                Ok(view)
            });
            match attempt {
                Ok(view) => resolved.push(view),
                Err(e) => {
                    warn!(view = %id, "view skipped this frame: {e}");
                    warnings.push(FrameWarning::ViewSkipped { view: *id, reason: e.to_string() });
                }
            }
        }
        (resolved, warnings)
    }

    /// The view's colour target as an image (waits for the GPU).
    pub fn read_color(&self, id: ViewId) -> Result<image::RgbaImage, RenderError> {
        let view = self.views.get(&id).ok_or(RenderError::NoSuchView(id))?;
        let targets = view.targets.as_ref().ok_or(RenderError::NotRendered(id))?;
        let color = targets.color.as_ref().ok_or(RenderError::DepthOnly(id))?;
        Ok(self.gpu.read_rgba8(&color.color)?)
    }

    /// Reads back a rendered view's linear HDR target (what shading wrote,
    /// before the tone map), NaN and infinities included.
    pub fn read_hdr(&self, id: ViewId) -> Result<oxygen_core::gpu::HdrImage, RenderError> {
        let view = self.views.get(&id).ok_or(RenderError::NoSuchView(id))?;
        let targets = view.targets.as_ref().ok_or(RenderError::NotRendered(id))?;
        let color = targets.color.as_ref().ok_or(RenderError::DepthOnly(id))?;
        Ok(self.gpu.read_rgba16_float(&color.hdr)?)
    }

    /// The view's prepared frame from the last `render_frame`.
    pub fn prepared_frame(&self, id: ViewId) -> Option<&PreparedSceneFrame> {
        if !self.views.contains_key(&id) {
            return None;
        }
        self.prep.frames().iter().find(|f| f.view_id() == id)
    }

    /// The GPU context.
    pub fn gpu(&self) -> &GpuContext {
        &self.gpu
    }

    /// The pipeline cache (e.g. to check how many pipelines exist).
    pub fn pipelines(&self) -> &PipelineCache {
        &self.pipelines
    }

    /// ScenePrep (counters, the last frame collection).
    pub fn scene_prep(&self) -> &ScenePrep {
        &self.prep
    }

    /// The bindless heap.
    pub fn heap(&self) -> &BindlessHeap {
        &self.heap
    }
}
