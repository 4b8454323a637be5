//! The `Renderer`: views in, images out.
//!
//! Ownership: the renderer owns the GPU context, the bindless heap, ScenePrep,
//! the pipelines and lighting resources, the registry of views ([`Views`])
//! and the views it creates itself (shadow cascades, local-light shadows);
//! per view it keeps the targets and the `SceneConstants` buffer. A frame
//! borrows the scene immutably; it runs in four steps, one module each:
//! `resolve` (views and the render origin), `prepare` (ScenePrep, shadow
//! views planned from the frame's lights, upload), `targets` (allocation and
//! constants) and `record` (every view's graph, polled together on the
//! worker threads, submitted in link order). Prepared frames of the last
//! frame are kept for inspection until the next frame replaces them.

mod gpu_timer;
mod prepare;
mod present;
mod record;
mod resolve;
mod targets;

use std::collections::{BTreeMap, HashMap};
use std::time::Instant;

use oxygen_bindless::{BindlessHeap, SceneConstantsBuffer, TexturePath};
use oxygen_core::{NodeKey, ResolvedView, Scene, ViewError, ViewId};
use oxygen_gpu::{GpuContext, GpuError, GpuOptions, HdrFormat, ViewTargets};
use oxygen_passes::{
    DepthBias, DrawPath, EnvironmentQuality, GPU_VISIBILITY_FEATURES, GpuVisibility, LightingResources, Output,
    PassError, Pipelines, ProbeId, RecordStats,
};
use oxygen_sceneprep::{
    DrawMetadata, PassMask, PrepError, PreparedSceneFrame, RenderOrigin, ScenePrep, ViewPrepOptions, Visibility,
};
use thiserror::Error;
use tracing::{info, info_span, warn};

use crate::graph::RenderGraph;
use crate::shadows::{LocalShadowSettings, ShadowViews};
use crate::views::{ViewDesc, Views};

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
    /// The probe is not registered with this renderer.
    #[error("{0} is not registered")]
    NoSuchProbe(ProbeId),
    /// A link would make a view wait for itself.
    #[error(
        "linking {view} to the output of {output} would close a cycle: {output} already reads, through its links, what {view} renders"
    )]
    LinkCycle {
        /// The view being linked.
        view: ViewId,
        /// Whose output it was linked to.
        output: String,
    },
    /// The view has no displayable colour target (a probe face, which
    /// renders into its probe's cube and is never tone-mapped).
    #[error("{0} has no display target (it is not tone-mapped)")]
    NoDisplayTarget(ViewId),
    /// The view is depth-only (a shadow view), so it has no image.
    #[error("{0} is depth-only: it has no colour target to read")]
    DepthOnly(ViewId),
    /// The view's last frame tone-mapped while shading, so its HDR target
    /// holds no image of that frame.
    #[error("{0} did not write its HDR target (it tone-maps while shading; set RendererOptions::keep_hdr)")]
    HdrNotWritten(ViewId),
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
    /// Entry `index` of the sizes given to [`Renderer::check_target_budget`]
    /// would pass the target memory budget (with the entries before it).
    #[error(
        "entry {index}: targets of {width}x{height} would take {} MiB; the target budget is {} MiB, of which {} MiB \
         are taken by the entries before it (RendererOptions::target_budget_bytes)",
        bytes >> 20, budget >> 20, taken >> 20
    )]
    TargetBudgetEntry {
        /// Its position in the list.
        index: usize,
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// What its targets would take.
        bytes: u64,
        /// The budget.
        budget: u64,
        /// What the entries before it take.
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
    /// No window with this id.
    #[error("{0} does not exist")]
    NoSuchWindow(crate::WindowId),
    /// The window has not been composed yet (no frame since it was added
    /// or resized from zero).
    #[error("{0} has presented nothing yet")]
    NothingPresented(crate::WindowId),
}

/// What a view of the frame is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewRole {
    /// A view the application registered.
    Registered,
    /// Cascade `index` of the sun shadows `owner` asked for.
    SunCascade {
        /// The view that owns the cascade.
        owner: ViewId,
        /// Which cascade, nearest first.
        index: u32,
    },
    /// Face `face` of the shadow of the local light on `light`, rendered
    /// into layer `tile` of the local shadow atlas.
    LocalShadow {
        /// The light's node.
        light: NodeKey,
        /// 0 for a spot light, 0..6 for a point light's cube faces.
        face: u32,
        /// The atlas layer.
        tile: u32,
    },
    /// Face `face` of reflection probe `probe`.
    ProbeFace {
        /// The probe.
        probe: ProbeId,
        /// Which face (+X, −X, +Y, −Y, +Z, −Z).
        face: u32,
    },
}

/// What one view did in a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewReport {
    /// The view.
    pub view: ViewId,
    /// What it is for.
    pub role: ViewRole,
    /// Draws after culling on the CPU (on a GPU path only the transparent
    /// ones: the GPU's count stays on the GPU).
    pub draws: usize,
    /// Where its visibility was decided.
    pub visibility: Visibility,
    /// Partitions.
    pub partitions: usize,
    /// What its passes recorded.
    pub recorded: RecordStats,
    /// Seconds of its own ScenePrep work (view phase and finalization).
    pub prep_seconds: f64,
    /// Seconds its graph's future spent being polled (recording), not
    /// counting the time it waited for pipelines or other views.
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
    /// A window was not presented this frame (its surface was lost,
    /// outdated, occluded or timed out; it was reconfigured).
    WindowSkipped {
        /// The window.
        window: crate::WindowId,
        /// Why.
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
            FrameWarning::WindowSkipped { window, reason } => write!(f, "{window} not presented: {reason}"),
        }
    }
}

/// What a frame did.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameReport {
    /// Frame sequence number.
    pub frame_index: u64,
    /// Per view, in submission order (producers before the views that read
    /// them).
    pub views: Vec<ViewReport>,
    /// Seconds spent in PreRender (resolve + ScenePrep + upload).
    pub prepare_seconds: f64,
    /// Seconds spent recording every view's graph (wall clock, all threads).
    pub record_seconds: f64,
    /// Threads the views were recorded on.
    pub record_threads: usize,
    /// What the frame left out (views and nodes), in view then node order.
    pub warnings: Vec<FrameWarning>,
    /// Distinct mesh pipelines the frame's passes used (pass, variant,
    /// formats, shader features): what specialising shaders to the scene
    /// costs in pipeline state ([`Pipelines::used_this_frame`] lists them).
    pub pipelines_used: usize,
    /// Pipelines created during this frame (zero once every combination
    /// the scene needs exists).
    pub pipelines_created: u64,
    /// Bytes this frame wrote into GPU buffers: the bindless heap's records
    /// (matrices, lights, materials, meshes, CPU-path draws), the GPU
    /// scene's changed records, and per-view constants and cull parameters
    /// that changed. Textures are not counted. A static scene seen by a
    /// still camera on a GPU visibility path uploads next to nothing.
    pub uploaded_bytes: u64,
    /// Windows composed and presented (offscreen ones composed).
    pub windows_presented: usize,
    /// GPU time of a recent frame's views (from a timestamp before its
    /// first command buffer to one after its last), read back without
    /// waiting, so one or two frames old; `None` before the first readback
    /// and on devices without timestamps inside encoders.
    pub gpu_seconds: Option<f64>,
}

/// Choices made when the renderer is created.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RendererOptions {
    /// Force a draw path; `None` picks the fastest the device supports.
    pub draw_path: Option<DrawPath>,
    /// Threads for ScenePrep's per-view phases and for recording the views'
    /// graphs; `None` uses every core.
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
    /// Render shadow maps for shadow-casting spot and point lights
    /// ([`Renderer::set_local_shadows`]); `None` renders none.
    pub local_shadows: Option<LocalShadowSettings>,
    /// Rasterizer depth bias of every shadow map the renderer renders (sun
    /// cascades and local shadows), against acne; see [`DepthBias`].
    pub shadow_bias: DepthBias,
    /// Format of every view's HDR target. [`HdrFormat::Rg11b10Ufloat`]
    /// halves its memory and bandwidth at the price of coarser gradients
    /// (measured in docs/performance.md); on an adapter without
    /// `Features::RG11B10UFLOAT_RENDERABLE` the renderer falls back to
    /// `Rgba16Float` with a warning ([`Renderer::hdr_format`] says which).
    pub hdr_format: HdrFormat,
    /// Write every view's HDR target even when nothing reads it, so that
    /// [`Renderer::read_hdr`] sees what shading wrote (tests, debugging).
    /// Off, a view without transparent surfaces whose HDR no other view
    /// reads tone-maps at the end of shading and skips the tone-map pass.
    pub keep_hdr: bool,
    /// Specialise shading pipelines to what each view has this frame
    /// (see `oxygen_passes::ShaderFeatures`); `false` runs the fully featured
    /// shader everywhere.
    pub specialize_shaders: bool,
    /// Where views decide visibility unless they say
    /// ([`crate::ViewDesc::with_visibility`]); `None` picks per adapter:
    /// [`Visibility::GpuFrustum`] on a hardware GPU that counts indirect
    /// draws, [`Visibility::Cpu`] on a CPU adapter (lavapipe, llvmpipe:
    /// compute there runs on the same cores as ScenePrep, measured in
    /// docs/performance.md) and wherever the GPU paths cannot run.
    /// [`Renderer::visibility`] reports the choice.
    pub visibility: Option<Visibility>,
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
            local_shadows: None,
            shadow_bias: DepthBias::SHADOW_DEFAULT,
            hdr_format: HdrFormat::Rgba16Float,
            keep_hdr: false,
            specialize_shaders: true,
            visibility: None,
        }
    }
}

/// Targets that would pass the target budget; the caller names whose.
struct OverBudget {
    width: u32,
    height: u32,
    bytes: u64,
    budget: u64,
    taken: u64,
}

impl OverBudget {
    /// The error for `view`'s targets.
    fn for_view(self, view: ViewId) -> RenderError {
        let OverBudget { width, height, bytes, budget, taken } = self;
        RenderError::TargetBudget { view, width, height, bytes, budget, taken }
    }
}

/// A probe's cube and position, kept by the renderer.
pub(crate) struct ProbeResources {
    pub(crate) texture: wgpu::Texture,
    pub(crate) position: glam::Vec3,
}

/// What the renderer keeps per view on the GPU.
pub(crate) struct ViewGpu {
    pub(crate) targets: Option<ViewTargets>,
    pub(crate) constants: SceneConstantsBuffer,
    /// The view as last rendered (relative to that frame's origin), for
    /// views reading a paused view's output.
    pub(crate) last_view: Option<ResolvedView>,
    /// Whether the last frame that rendered the view wrote its HDR target
    /// (false when shading tone-mapped in place).
    pub(crate) hdr_written: bool,
}

/// The renderer: views in, images out.
pub struct Renderer {
    gpu: GpuContext,
    heap: BindlessHeap,
    prep: ScenePrep,
    pipelines: Pipelines,
    lighting: LightingResources,
    pub(crate) views: Views,
    shadows: ShadowViews,
    gpu_views: HashMap<ViewId, ViewGpu>,
    probes: BTreeMap<ProbeId, ProbeResources>,
    /// GGX samples per texel when a probe's levels are prefiltered.
    probe_filter_samples: u32,
    draw_path: DrawPath,
    frame_index: u64,
    started: Instant,
    origin: RenderOrigin,
    target_budget_bytes: u64,
    /// The last frame's views in submission order, with their roles.
    last_frame: Vec<(ViewId, ViewRole)>,
    /// The graph of every shadow view the renderer creates.
    shadow_graph: std::sync::Arc<dyn crate::graph::ErasedGraph>,
    /// The HDR format in use (the option, or its fallback).
    hdr_format: HdrFormat,
    keep_hdr: bool,
    specialize_shaders: bool,
    /// Whether any material of the frame's scene has a texture.
    textured_materials: bool,
    /// Whether any material reads a second UV set or a texture transform.
    uv_transforms: bool,
    /// GPU-driven visibility, where the device can run it.
    visibility: Option<GpuVisibility>,
    /// The path-traced reference's tracer, made when a view first asks.
    reference: Option<oxygen_passes::ReferenceTracer>,
    /// The views' default visibility path.
    default_visibility: Visibility,
    /// Windows views are shown in.
    windows: BTreeMap<crate::WindowId, present::Window>,
    /// The next window's id.
    next_window: u32,
    /// Frame timestamps, where the device has them.
    gpu_timer: Option<gpu_timer::GpuTimer>,
    /// Views shown with `show_in_window` (no resizing).
    shown_views: BTreeMap<ViewId, (crate::WindowId, crate::WindowRect)>,
    compositor: present::Compositor,
    /// Ids of reflection probes' face views: a range of the renderer's own.
    probe_face_ids: oxygen_core::ViewIds,
}

impl Renderer {
    /// The device features Oxygen uses when the adapter has them.
    pub const OPTIONAL_FEATURES: wgpu::Features = wgpu::Features::INDIRECT_FIRST_INSTANCE
        .union(GPU_VISIBILITY_FEATURES)
        .union(gpu_timer::GpuTimer::FEATURES)
        .union(TexturePath::BINDING_ARRAY_FEATURES)
        .union(wgpu::Features::RG11B10UFLOAT_RENDERABLE)
        // MSAA counts beyond WebGPU's guaranteed 1 and 4 (2× on most GPUs).
        .union(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES);

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
        Self::with_views(gpu, options, Views::new())
    }

    /// A renderer that renders views registered beforehand without a GPU
    /// (their ids stay the same).
    pub fn with_views(gpu: GpuContext, options: RendererOptions, views: Views) -> Result<Self, RenderError> {
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
        let hdr_format = if gpu.features.contains(options.hdr_format.required_features()) {
            options.hdr_format
        } else {
            warn!(
                asked = ?options.hdr_format,
                adapter = %gpu.describe(),
                "the adapter cannot render into this HDR format; using Rgba16Float"
            );
            HdrFormat::Rgba16Float
        };
        // GPU visibility draws through multi-draw-indirect with counts.
        let gpu_visibility = (draw_path == DrawPath::MultiDrawIndirect && GpuVisibility::supported(gpu.features))
            .then(|| GpuVisibility::new(&gpu.device));
        let cpu_adapter = gpu.adapter_info.device_type == wgpu::DeviceType::Cpu;
        let default_visibility = match options.visibility {
            Some(v) if v.on_gpu() && gpu_visibility.is_none() => {
                warn!(asked = ?v, adapter = %gpu.describe(), "GPU visibility needs multi-draw-indirect with counts; using the CPU path");
                Visibility::Cpu
            }
            Some(v) => v,
            None if gpu_visibility.is_some() && !cpu_adapter => Visibility::GpuFrustum,
            None => Visibility::Cpu,
        };
        info!(?draw_path, ?texture_path, ?hdr_format, ?default_visibility, "draw, texture and visibility paths chosen");
        let heap = BindlessHeap::new(&gpu.device, &gpu.queue, texture_path);
        let lighting = LightingResources::new(&gpu.device, &gpu.queue);
        let compositor = present::Compositor::new(&gpu.device);
        let gpu_timer = gpu_timer::GpuTimer::new(&gpu.device, &gpu.queue, gpu.features);
        let pipelines = Pipelines::new(&gpu.device, &heap, &lighting);
        let mut prep = match options.prep_threads {
            Some(threads) => ScenePrep::with_threads(threads),
            None => ScenePrep::new(),
        };
        prep.set_debug_generations(options.debug_generations);
        let shadows = ShadowViews::new(options.local_shadows);
        Ok(Renderer {
            origin: options.origin,
            target_budget_bytes: options.target_budget_bytes,
            gpu,
            heap,
            prep,
            pipelines,
            lighting,
            views,
            shadows,
            gpu_views: HashMap::new(),
            probes: BTreeMap::new(),
            probe_filter_samples: oxygen_passes::PROBE_FILTER_SAMPLES,
            draw_path,
            frame_index: 0,
            started: Instant::now(),
            last_frame: Vec::new(),
            shadow_graph: std::sync::Arc::new(crate::ShadowGraph { bias: options.shadow_bias }),
            hdr_format,
            keep_hdr: options.keep_hdr,
            specialize_shaders: options.specialize_shaders,
            textured_materials: true,
            uv_transforms: true,
            visibility: gpu_visibility,
            reference: None,
            default_visibility,
            windows: BTreeMap::new(),
            shown_views: BTreeMap::new(),
            next_window: 0,
            gpu_timer,
            compositor,
            probe_face_ids: oxygen_core::ViewIds::new(oxygen_core::ViewIdRange::ProbeFace),
        })
    }

    /// Where views decide visibility unless they say otherwise (the option,
    /// or the choice made for the adapter).
    pub fn visibility(&self) -> Visibility {
        self.default_visibility
    }

    /// GPU visibility's state (count buffers, depth pyramids, coverage
    /// estimates), where the device runs it.
    pub fn gpu_visibility(&self) -> Option<&GpuVisibility> {
        self.visibility.as_ref()
    }

    /// Samples per pixel a path-traced view's image holds
    /// ([`ViewDesc::path_traced`](crate::ViewDesc::path_traced)); 0 for other views.
    pub fn reference_samples(&self, view: ViewId) -> u32 {
        self.reference.as_ref().map_or(0, |r| r.samples(view))
    }

    /// Whether the device runs the GPU visibility paths.
    pub fn gpu_visibility_supported(&self) -> bool {
        self.visibility.is_some()
    }

    /// The path a view gets: what it asked for or the default; a GPU path
    /// the device lacks becomes the CPU path, and occlusion culling becomes
    /// frustum culling for a view without a depth pre-pass to build the
    /// pyramid from (depth-only views, graphs that do not run the two
    /// phases).
    pub(crate) fn view_visibility(&self, asked: Option<Visibility>, depth_only: bool, two_phase: bool) -> Visibility {
        match asked.unwrap_or(self.default_visibility) {
            v if v.on_gpu() && self.visibility.is_none() => Visibility::Cpu,
            Visibility::GpuOcclusion if depth_only || !two_phase => Visibility::GpuFrustum,
            v => v,
        }
    }

    /// Samples per pixel a view asking for `msaa` gets: what it asks
    /// where the adapter can multisample the HDR and depth formats at that
    /// count, else the largest count below it that it can (1 at least).
    pub fn msaa_samples(&self, msaa: oxygen_gpu::Msaa) -> u32 {
        let asked = msaa.samples();
        // The adapter's own counts only count once the device has enabled
        // them; without the feature, WebGPU guarantees 1 and 4.
        let adapter_specific = self.gpu.features.contains(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES);
        let supports = |samples: u32| {
            [self.hdr_format.texture_format(), ViewTargets::DEPTH_FORMAT].iter().all(|f| {
                if adapter_specific {
                    self.gpu.adapter.get_texture_format_features(*f).flags.sample_count_supported(samples)
                } else {
                    f.guaranteed_format_features(self.gpu.features).flags.sample_count_supported(samples)
                }
            })
        };
        [4, 2, 1].into_iter().find(|s| *s <= asked && (*s == 1 || supports(*s))).unwrap_or(1)
    }

    /// How textures are bound on this device.
    pub fn texture_path(&self) -> TexturePath {
        self.heap.texture_path()
    }

    /// How partitions are drawn on this device.
    pub fn draw_path(&self) -> DrawPath {
        self.draw_path
    }

    /// The format of the views' HDR targets ([`RendererOptions::hdr_format`],
    /// or `Rgba16Float` where the adapter cannot render the one asked for).
    pub fn hdr_format(&self) -> HdrFormat {
        self.hdr_format
    }

    /// Registers a view: a resolver (camera → matrices, each frame) or a
    /// [`ViewDesc`] (resolver plus ScenePrep options, links to other views'
    /// outputs, sun shadows), and the [`RenderGraph`] it records each frame
    /// ([`standard_render_graph`](crate::standard_render_graph) is the
    /// default). The renderer records views after the views whose outputs
    /// they read, whatever the registration order.
    pub fn register_view(&mut self, desc: impl Into<ViewDesc>, graph: impl RenderGraph) -> Result<ViewId, RenderError> {
        let desc = desc.into();
        let (asked, samples) = (desc.msaa.samples(), self.msaa_samples(desc.msaa));
        let id = self.views.register(desc, graph)?;
        if samples != asked {
            warn!(view = %id, asked, samples, "the adapter cannot multisample the view's targets as asked");
        }
        Ok(id)
    }

    /// Registers a view with explicit ScenePrep options (filter, cull bound).
    pub fn register_view_with_options(
        &mut self,
        resolver: impl oxygen_core::ViewResolver + 'static,
        options: ViewPrepOptions,
        graph: impl RenderGraph,
    ) -> Result<ViewId, RenderError> {
        self.views.register(ViewDesc::new(resolver).with_options(options), graph)
    }

    /// Links `view` to `output` after registration ([`Views::link`]).
    pub fn link<K>(&mut self, view: impl Into<ViewId>, output: Output<K>) -> Result<(), RenderError> {
        self.views.link(view, output)
    }

    /// Removes a view, the shadow cascades it owns, and frees their slots.
    pub fn unregister_view(&mut self, id: impl Into<ViewId>) -> Result<(), RenderError> {
        let id = id.into();
        self.views.unregister(id)?;
        let owned: Vec<ViewId> = self.shadows.cascades_of(id).collect();
        self.shadows.forget_owner(id);
        for view in std::iter::once(id).chain(owned) {
            self.release_view(view)?;
        }
        Ok(())
    }

    /// Frees a view's slots, targets and constants.
    pub(crate) fn release_view(&mut self, id: ViewId) -> Result<(), RenderError> {
        self.gpu_views.remove(&id);
        self.prep.forget_view(id, &mut self.heap.slots)?;
        Ok(())
    }

    /// Pauses (`false`) or resumes a view: a paused view is neither resolved,
    /// prepared nor rendered, and keeps its last image (e.g. a reflection
    /// probe updated every N frames).
    pub fn set_view_active(&mut self, id: impl Into<ViewId>, active: bool) -> Result<(), RenderError> {
        self.views.set_active(id, active)
    }

    /// Lights the scene with an environment (image-based lighting;
    /// `None`: the constant ambient term), converted to a cube and
    /// prefiltered on the GPU at the default [`EnvironmentQuality`] (128²
    /// faces, 64 GGX samples a texel; `set_environment_with_quality` picks
    /// another). Every view's shading then takes its ambient diffuse light
    /// (nine irradiance harmonics) and specular light (the GGX levels,
    /// weighted by the split-sum table) from it — reflection probes, where
    /// a view has them, still give the specular part — and draws it behind
    /// the scene.
    pub fn set_environment(&mut self, environment: Option<&oxygen_core::Environment>) {
        self.set_environment_with_quality(environment, EnvironmentQuality::default());
    }

    /// [`Renderer::set_environment`] at a chosen quality: faces of
    /// `quality.size` (sharper mirror reflections, more memory and time)
    /// and `quality.samples` GGX samples per texel (less noise in the
    /// rough levels, more time); `examples/environment_bench.rs` measures
    /// both.
    pub fn set_environment_with_quality(
        &mut self,
        environment: Option<&oxygen_core::Environment>,
        quality: EnvironmentQuality,
    ) {
        self.lighting.set_environment(&self.gpu.device, &self.gpu.queue, environment, quality);
    }

    /// [`Renderer::set_environment`] with an environment prefiltered on
    /// the CPU ([`oxygen_core::Environment::prefilter`], the slow reference
    /// the GPU's is tested against), uploaded as it is.
    pub fn set_prefiltered_environment(&mut self, environment: Option<&oxygen_core::PrefilteredEnvironment>) {
        self.lighting.set_prefiltered_environment(&self.gpu.device, &self.gpu.queue, environment);
    }

    /// Reads the environment back as the GPU holds it (the prefiltered
    /// levels and the irradiance harmonics, half floats widened), for tools
    /// and tests; `None` without one. Waits for the GPU.
    pub fn read_environment(&self) -> Result<Option<oxygen_core::PrefilteredEnvironment>, RenderError> {
        let Some(texture) = self.lighting.environment_texture() else { return Ok(None) };
        let rgb = |image: oxygen_gpu::HdrImage| -> Vec<glam::Vec3> {
            image.pixels.iter().map(|p| glam::Vec3::new(p[0], p[1], p[2])).collect()
        };
        let mut levels = Vec::with_capacity(texture.mip_level_count() as usize);
        for level in 0..texture.mip_level_count() {
            let mut faces: [Vec<glam::Vec3>; 6] = Default::default();
            for (face, texels) in faces.iter_mut().enumerate() {
                *texels = rgb(self.gpu.read_rgba16_float_layer(texture, level, face as u32)?);
            }
            levels.push(faces);
        }
        let block = rgb(self.gpu.read_rgba16_float_layer(texture, 0, oxygen_passes::HARMONICS_LAYER)?);
        let side = texture.width() as usize;
        let irradiance_sh = std::array::from_fn(|i| block[(i / 3) * side + i % 3] * oxygen_passes::HARMONICS_SCALE);
        Ok(Some(oxygen_core::PrefilteredEnvironment { size: texture.width(), levels, irradiance_sh }))
    }

    /// Reads back the split-sum table: `(A, B)` for n·v = i / (N − 1)
    /// (column i) and roughness j / (N − 1) (row j), N =
    /// [`oxygen_passes::SPLIT_SUM_LUT_SIZE`], row by row. Waits for the GPU.
    pub fn read_split_sum_lut(&self) -> Result<Vec<glam::Vec2>, RenderError> {
        let image = self.gpu.read_rgba16_float(self.lighting.split_sum_lut())?;
        Ok(image.pixels.iter().map(|p| glam::Vec2::new(p[0], p[1])).collect())
    }

    /// Reads back level `level` of face `face` of a reflection probe's cube
    /// (linear radiance, row by row), or `None` for an unknown probe or a
    /// level or face it does not have. Waits for the GPU.
    pub fn read_probe_face(
        &self,
        probe: ProbeId,
        face: u32,
        level: u32,
    ) -> Result<Option<Vec<glam::Vec3>>, RenderError> {
        let Some(resources) = self.probes.get(&probe) else { return Ok(None) };
        let texture = &resources.texture;
        if face >= oxygen_passes::PROBE_FACES as u32 || level >= texture.mip_level_count() {
            return Ok(None);
        }
        let image = self.gpu.read_rgba16_float_layer(texture, level, face)?;
        Ok(Some(image.pixels.iter().map(|p| glam::Vec3::new(p[0], p[1], p[2])).collect()))
    }

    /// GGX samples per texel when a reflection probe's levels are
    /// prefiltered after its faces render (default
    /// [`oxygen_passes::PROBE_FILTER_SAMPLES`]; 1 to
    /// [`oxygen_passes::MAX_FILTER_SAMPLES`]): fewer cost
    /// less GPU time per probe update and leave rough reflections noisier
    /// (`environment_bench` measures both).
    pub fn set_probe_filter_samples(&mut self, samples: u32) {
        self.probe_filter_samples = samples.clamp(1, oxygen_passes::MAX_FILTER_SAMPLES);
    }

    /// Turns shadow maps of spot and point lights on (`Some`) or off.
    pub fn set_local_shadows(&mut self, settings: Option<LocalShadowSettings>) {
        self.shadows.local_settings = settings;
    }

    /// Registered views, in id order (not the views the renderer creates
    /// itself for shadows).
    pub fn views(&self) -> impl Iterator<Item = ViewId> + '_ {
        self.views.ids()
    }

    /// The registry of views.
    pub fn view_registry(&mut self) -> &mut Views {
        &mut self.views
    }

    /// The shadow cascades `view` owns now, nearest first.
    pub fn sun_cascades(&self, view: impl Into<ViewId>) -> Vec<ViewId> {
        self.shadows.cascades_of(view.into()).collect()
    }

    /// Every shadow view the renderer created itself (cascades and local).
    pub fn shadow_views(&self) -> Vec<ViewId> {
        self.shadows.all().collect()
    }

    /// What the views of the last frame were for, in submission order.
    pub fn last_frame_views(&self) -> &[(ViewId, ViewRole)] {
        &self.last_frame
    }

    /// Registers a probe's face view under an id of the renderer's own
    /// range ([`ViewIdRange::ProbeFace`](oxygen_core::ViewIdRange)).
    pub(crate) fn register_probe_face(&mut self, desc: ViewDesc) -> ViewId {
        let id = self.probe_face_ids.allocate();
        self.views.register_owned(id, desc, crate::ProbeFaceGraph);
        id
    }

    pub(crate) fn add_probe(
        &mut self,
        id: ProbeId,
        faces: [ViewId; oxygen_passes::PROBE_FACES],
        texture: wgpu::Texture,
        position: glam::Vec3,
    ) {
        self.views.probes.insert(id, faces);
        self.probes.insert(id, ProbeResources { texture, position });
    }

    /// What the targets of a `viewport`-sized view take, bytes (colour and
    /// depth, or depth only), with the default HDR format.
    pub fn target_bytes(viewport: glam::UVec2, depth_only: bool) -> u64 {
        ViewTargets::bytes_for(viewport.x, viewport.y, !depth_only)
    }

    /// Bytes the views' targets take now.
    pub fn target_memory(&self) -> u64 {
        self.gpu_views.values().filter_map(|v| v.targets.as_ref()).map(ViewTargets::bytes).sum()
    }

    /// The target budget ([`RendererOptions::target_budget_bytes`]).
    pub fn target_budget(&self) -> u64 {
        self.target_budget_bytes
    }

    /// Checks, before anything is allocated, that views of these sizes
    /// (`(viewport, depth_only)`) fit the target budget together; returns
    /// their total. The error ([`RenderError::TargetBudgetEntry`]) names
    /// the first entry that does not fit by its position.
    pub fn check_target_budget(&self, views: &[(glam::UVec2, bool)]) -> Result<u64, RenderError> {
        let mut taken = 0u64;
        for (index, (viewport, depth_only)) in views.iter().enumerate() {
            self.admit_targets(*viewport, !depth_only, 1, &mut taken).map_err(|e| RenderError::TargetBudgetEntry {
                index,
                width: e.width,
                height: e.height,
                bytes: e.bytes,
                budget: e.budget,
                taken: e.taken,
            })?;
        }
        Ok(taken)
    }

    /// Adds a `viewport`-sized view's targets to `taken`, or says they would
    /// pass the target budget (leaving `taken` as it was).
    fn admit_targets(
        &self,
        viewport: glam::UVec2,
        with_color: bool,
        samples: u32,
        taken: &mut u64,
    ) -> Result<(), OverBudget> {
        let bytes = ViewTargets::bytes_for_msaa(viewport.x, viewport.y, with_color.then_some(self.hdr_format), samples);
        if taken.saturating_add(bytes) > self.target_budget_bytes {
            let (width, height, budget) = (viewport.x, viewport.y, self.target_budget_bytes);
            return Err(OverBudget { width, height, bytes, budget, taken: *taken });
        }
        *taken += bytes;
        Ok(())
    }

    /// Renders one frame of `scene` through every active view: resolve,
    /// prepare, allocate targets, record every view's graph concurrently,
    /// submit in link order.
    pub fn render_frame(&mut self, scene: &Scene) -> Result<FrameReport, RenderError> {
        self.frame_index += 1;
        let frame_index = self.frame_index;
        let time_seconds = self.started.elapsed().as_secs_f32();
        let _span = info_span!("render_frame", frame = frame_index).entered();
        let prepare_start = Instant::now();
        // Lets finished readbacks (frame times, GPU overdraw estimates)
        // report in; never waits.
        let _ = self.gpu.device.poll(wgpu::PollType::Poll);
        let gpu_seconds = self.gpu_timer.as_mut().and_then(gpu_timer::GpuTimer::collect);
        let heap_bytes_before = self.heap.bytes_written();
        let (mut plan, mut warnings) = self.resolve_views(scene, frame_index, time_seconds);
        self.prepare(scene, &mut plan, &mut warnings, frame_index, time_seconds)?;
        let prepare_seconds = prepare_start.elapsed().as_secs_f64();
        let constants_bytes = self.allocate_targets(&plan, time_seconds);
        self.prepare_gpu_visibility(&plan);
        self.prepare_reference(&plan)?;
        let uploaded_bytes = self.heap.bytes_written() - heap_bytes_before
            + constants_bytes
            + self.visibility.as_ref().map_or(0, GpuVisibility::uploaded_last_frame);
        // What the shading pipelines must carry, as ScenePrep's material
        // table found it: texture sampling, the second UV set or transforms.
        let materials = self.prep.material_features();
        (self.textured_materials, self.uv_transforms) = (materials.textures, materials.uv_transforms);
        let record_start = Instant::now();
        let created_before = self.pipelines.pipelines_created();
        self.pipelines.begin_frame();
        let (reports, record_threads) = self.record(&plan)?;
        let rendered: Vec<ViewId> = reports.iter().map(|r| r.view).collect();
        let windows_presented = self.present_windows(&rendered, &mut warnings);
        let pipelines_used = self.pipelines.used_this_frame().len();
        let pipelines_created = self.pipelines.pipelines_created() - created_before;
        for report in &reports {
            if let Some(gpu) = self.gpu_views.get_mut(&report.view) {
                gpu.hdr_written = !report.recorded.tone_mapped_in_pass;
            }
        }
        let record_seconds = record_start.elapsed().as_secs_f64();
        warnings.extend(self.prep.frame_collection().skipped.iter().map(|s| FrameWarning::NodeSkipped {
            node: s.node,
            name: s.name.clone(),
            reason: s.reason,
        }));
        self.last_frame = reports.iter().map(|r| (r.view, r.role)).collect();
        Ok(FrameReport {
            frame_index,
            views: reports,
            prepare_seconds,
            record_seconds,
            record_threads,
            warnings,
            pipelines_used,
            pipelines_created,
            uploaded_bytes,
            windows_presented,
            gpu_seconds,
        })
    }

    /// Every draw `id` drew last frame, per partition mask in canonical order
    /// ([`oxygen_sceneprep::canonical_draws`]), whichever path produced
    /// them: on a GPU visibility path the GPU's draws are read back (waits
    /// for the GPU) and joined with the CPU's transparent ones. How tests
    /// compare the GPU paths with the CPU reference.
    pub fn view_draws(&self, id: impl Into<ViewId>) -> Result<Vec<(PassMask, Vec<DrawMetadata>)>, RenderError> {
        let id = id.into();
        let frame = self.prepared_frame(id).ok_or(RenderError::NoSuchView(id))?;
        let mut all = frame.canonical_draws();
        if let Some(visibility) = &self.visibility {
            all.extend(visibility.read_draws(&self.gpu, &self.heap, frame)?);
        }
        Ok(oxygen_sceneprep::canonical_draws(all))
    }

    /// The view's colour target as an image (waits for the GPU).
    pub fn read_color(&self, id: impl Into<ViewId>) -> Result<image::RgbaImage, RenderError> {
        let id = id.into();
        let color = self.color_targets(id)?;
        let display = color.color.as_ref().ok_or(RenderError::NoDisplayTarget(id))?;
        Ok(self.gpu.read_rgba8(display)?)
    }

    /// Reads back a rendered view's linear HDR target (what shading wrote,
    /// before the tone map), NaN and infinities included. Fails with
    /// [`RenderError::HdrNotWritten`] when the view's last frame tone-mapped
    /// in the shading pass (see [`RendererOptions::keep_hdr`]).
    pub fn read_hdr(&self, id: impl Into<ViewId>) -> Result<oxygen_gpu::HdrImage, RenderError> {
        let id = id.into();
        let color = self.color_targets(id)?;
        if color.hdr_layer != 0 {
            return Err(RenderError::NoDisplayTarget(id));
        }
        if !self.gpu_views.get(&id).is_some_and(|v| v.hdr_written) {
            return Err(RenderError::HdrNotWritten(id));
        }
        Ok(self.gpu.read_hdr_texels(&color.hdr)?)
    }

    fn color_targets(&self, id: ViewId) -> Result<&oxygen_gpu::ColorTargets, RenderError> {
        let known = self.views.entries.contains_key(&id) || self.shadows.all().any(|v| v == id);
        if !known {
            return Err(RenderError::NoSuchView(id));
        }
        let targets = self.gpu_views.get(&id).and_then(|v| v.targets.as_ref()).ok_or(RenderError::NotRendered(id))?;
        targets.color.as_ref().ok_or(RenderError::DepthOnly(id))
    }

    /// The view's prepared frame from the last `render_frame`.
    pub fn prepared_frame(&self, id: impl Into<ViewId>) -> Option<&PreparedSceneFrame> {
        let id = id.into();
        self.prep.frames().iter().find(|f| f.view_id() == id)
    }

    /// The GPU context.
    pub fn gpu(&self) -> &GpuContext {
        &self.gpu
    }

    /// The shared pipelines (e.g. to check how many exist).
    pub fn pipelines(&self) -> &Pipelines {
        &self.pipelines
    }

    /// The shared lighting resources.
    pub fn lighting(&self) -> &LightingResources {
        &self.lighting
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
