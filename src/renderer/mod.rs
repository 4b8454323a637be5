//! The `Renderer`: views in, images out.
//!
//! A frame is a chain of four steps, each a function from the output of
//! the one before to a value of its own, complete when made:
//!
//! ```text
//! render_frame(scene)
//!   resolve  (resolve.rs)  FrameClock          -> ResolvedFrame   registered views, world space
//!   prepare  (prepare.rs)  ResolvedFrame       -> PreparedFrame   + shadow views, ScenePrep, upload,
//!                                                                   targets, constants, GPU visibility
//!   record   (record.rs)   &PreparedFrame      -> RecordedFrame   every graph recorded, submitted
//!   present  (present.rs)  &RecordedFrame      -> PresentedFrame  windows composed and presented
//!   FrameReport::new(prepared, recorded, presented)
//! ```
//!
//! No step changes an earlier step's output. What outlives a frame lives in
//! the renderer's subsystems, each owning its state and the `Renderer`
//! methods of its subject: the views' targets and constants
//! (`targets.rs`), shadows (`shadows.rs`), reflection probes
//! (`probes.rs`), visibility (`visibility.rs`), the path-traced reference
//! (`reference.rs`), windows (`windows.rs`), the environment
//! (`environment.rs`, state in the shared lighting resources), plus
//! registration (`registration.rs`) and readbacks (`readback.rs`). The one
//! thing a frame writes back is what the views' targets hold afterwards
//! (`Targets::hold`), taken from the record step's output. Prepared frames
//! of the last frame stay in ScenePrep for inspection until the next frame
//! replaces them.

mod environment;
mod error;
mod gpu_timer;
mod options;
mod prepare;
mod present;
mod probes;
mod readback;
mod record;
mod reference;
mod registration;
mod report;
mod resolve;
mod schedules;
mod shadows;
mod streams;
mod targets;
mod visibility;
mod windows;

use std::time::Instant;

use oxygen_bindless::{BindlessHeap, TexturePath};
use oxygen_core::{Scene, ViewId};
use oxygen_gpu::{GpuContext, GpuOptions, HdrFormat};
use oxygen_passes::{DrawPath, GPU_VISIBILITY_FEATURES, LightingResources, Pipelines};
use oxygen_sceneprep::{RenderOrigin, ScenePrep};
use tracing::{info, info_span, warn};

pub use error::RenderError;
pub use options::RendererOptions;
pub use readback::{DepthImage, LabelImage};
pub use report::{FrameReport, FrameWarning, ViewReport, ViewRole};
pub use streams::{StreamOptions, StreamedCamera, StreamedFrame};

use crate::views::Views;
use probes::Probes;
use reference::Reference;
use resolve::FrameClock;
use shadows::Shadows;
use targets::Targets;
use visibility::Visibilities;
use windows::Windows;

/// How every frame is drawn, fixed when the renderer is made.
struct FrameSettings {
    draw_path: DrawPath,
    /// Where the GPU's coordinates are centred.
    origin: RenderOrigin,
    /// Write every HDR target, read or not.
    keep_hdr: bool,
    /// Specialise shading pipelines to what each view has.
    specialize_shaders: bool,
}

/// The renderer: views in, images out.
pub struct Renderer {
    gpu: GpuContext,
    heap: BindlessHeap,
    prep: ScenePrep,
    pipelines: Pipelines,
    /// The shared lighting resources, the environment's among them.
    lighting: LightingResources,
    pub(crate) views: Views,
    targets: Targets,
    shadows: Shadows,
    probes: Probes,
    visibility: Visibilities,
    reference: Reference,
    windows: Windows,
    streams: streams::Streams,
    schedules: schedules::Schedules,
    /// What the application draws over each view ([`Renderer::overlay`]).
    overlays: oxygen_core::ViewIdMap<std::sync::Mutex<oxygen_overlay::Overlay>>,
    settings: FrameSettings,
    frames: Frames,
}

/// The frames so far: how many, the clock they are timed by, their GPU
/// timestamps and what the last one rendered. Only `render_frame` moves it
/// on; the steps read the `FrameClock` it hands out.
struct Frames {
    count: u64,
    started: Instant,
    /// Frame timestamps, where the device has them.
    gpu_timer: Option<gpu_timer::GpuTimer>,
    /// The last frame's views in submission order, with their roles.
    last: Vec<(ViewId, ViewRole)>,
    /// Why each view the last frame skipped was skipped, kept until it
    /// renders again: a readback of it says so.
    skipped: oxygen_core::ViewIdMap<String>,
    /// How the last frame drew (its render origin, what its pipelines
    /// carry): what an ID render between frames draws the last frame's
    /// draws with ([`Renderer::pick`]).
    drawing: Option<(glam::DVec3, oxygen_passes::Shading)>,
}

impl Frames {
    /// The next frame's clock: at `time` seconds, or the wall-clock time
    /// since the renderer started.
    fn next(&mut self, time: Option<f64>) -> FrameClock {
        self.count += 1;
        let time_seconds = time.map_or_else(|| self.started.elapsed().as_secs_f32(), |t| t as f32);
        FrameClock { index: self.count, time_seconds }
    }
}

/// The renderer's parts ([`Renderer::internals`]): for tests, benchmarks
/// and tools that count what frames did. Not the way to render: every
/// frame goes through [`Renderer::render_frame`].
#[derive(Clone, Copy)]
pub struct RendererInternals<'a> {
    /// The shared pipelines (how many exist, how many a frame created).
    pub pipelines: &'a Pipelines,
    /// The shared lighting resources (the environment, the probes' filter).
    pub lighting: &'a LightingResources,
    /// ScenePrep (its counters, the last frame collection, the ray scene).
    pub scene_prep: &'a ScenePrep,
    /// The bindless heap (its GPU bytes and slot allocators).
    pub heap: &'a BindlessHeap,
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
        let visibility = Visibilities::new(&gpu, draw_path, options.visibility);
        info!(?draw_path, ?texture_path, ?hdr_format, default_visibility = ?visibility.default, "draw, texture and visibility paths chosen");
        let heap = BindlessHeap::new(&gpu.device, &gpu.queue, texture_path);
        let lighting = LightingResources::new(&gpu.device, &gpu.queue);
        let gpu_timer = gpu_timer::GpuTimer::new(&gpu.device, &gpu.queue, gpu.features);
        let pipelines = Pipelines::new(&gpu.device, &heap, &lighting);
        let mut prep = match options.prep_threads {
            Some(threads) => ScenePrep::with_threads(threads),
            None => ScenePrep::new(),
        };
        prep.set_debug_generations(options.debug_generations);
        prep.set_deterministic(options.deterministic);
        Ok(Renderer {
            heap,
            prep,
            pipelines,
            lighting,
            views,
            targets: Targets::new(hdr_format, options.target_budget_bytes),
            shadows: Shadows::new(options.local_shadows, options.shadow_bias),
            probes: Probes::new(),
            visibility,
            reference: Reference::default(),
            windows: Windows::new(&gpu.device),
            streams: streams::Streams::new(&downlevel),
            schedules: schedules::Schedules::default(),
            overlays: Default::default(),
            settings: FrameSettings {
                draw_path,
                origin: options.origin,
                keep_hdr: options.keep_hdr,
                specialize_shaders: options.specialize_shaders,
            },
            frames: Frames {
                count: 0,
                started: Instant::now(),
                gpu_timer,
                last: Vec::new(),
                skipped: Default::default(),
                drawing: None,
            },
            gpu,
        })
    }

    /// Renders one frame of `scene` through every active view: resolve,
    /// prepare (ScenePrep, upload, targets), record every view's graph
    /// concurrently and submit in link order, present the windows.
    pub fn render_frame(&mut self, scene: &Scene) -> Result<FrameReport, RenderError> {
        self.render_frame_timed(scene, None)
    }

    /// [`Renderer::render_frame`] at frame time `time_seconds` instead of
    /// the wall clock: what resolvers are told and what
    /// [`Schedule::Rate`](crate::schedule::Schedule::Rate) counts in (a
    /// simulation's time, so that sensor rates and animations follow it,
    /// not the machine's speed). Fails, rendering nothing, for a time that
    /// is not finite.
    pub fn render_frame_at(&mut self, scene: &Scene, time_seconds: f64) -> Result<FrameReport, RenderError> {
        if !time_seconds.is_finite() {
            return Err(RenderError::Unsupported(format!(
                "a frame at {time_seconds} seconds: the time must be finite"
            )));
        }
        self.render_frame_timed(scene, Some(time_seconds))
    }

    fn render_frame_timed(&mut self, scene: &Scene, time: Option<f64>) -> Result<FrameReport, RenderError> {
        let clock = self.frames.next(time);
        // Set again when this frame's draws are all recorded and submitted.
        self.frames.drawing = None;
        let _span = info_span!("render_frame", frame = clock.index).entered();
        let started = Instant::now();
        // Lets finished readbacks (frame times, GPU overdraw estimates)
        // report in; never waits.
        let _ = self.gpu.device.poll(wgpu::PollType::Poll);
        let gpu_seconds = self.frames.gpu_timer.as_mut().and_then(gpu_timer::GpuTimer::collect);
        let resolved = self.resolve(scene, clock);
        let mut prepared = self.prepare(scene, resolved, started)?;
        if let Some(timer) = &mut self.frames.gpu_timer {
            timer.reserve_jobs(&self.gpu.device, prepared.views.len());
        }
        let recorded = self.record(&prepared);
        // Back to ScenePrep, which reuses their buffers next frame and
        // answers `prepared_frame` until then; a failed recording too.
        self.prep.return_frames(std::mem::take(&mut prepared.frames));
        let recorded = recorded?;
        if let (Some(timer), Some(jobs)) = (&mut self.frames.gpu_timer, recorded.timed_jobs.clone()) {
            timer.time_jobs(jobs);
        }
        self.stream(&recorded, &prepared.views, clock)?;
        self.targets.hold(&recorded.rendered, &prepared.views);
        // The immediate shapes of the views that drew them are done.
        for view in &recorded.rendered {
            if let Some(overlay) = self.overlays.get_mut(&view.id) {
                overlay.get_mut().unwrap_or_else(std::sync::PoisonError::into_inner).end_frame();
            }
        }
        for view in &prepared.views {
            // An every-frame view has no schedule state to keep.
            if prepared.why.get(&view.id).is_some_and(|why| *why != crate::schedule::RenderReason::EveryFrame) {
                self.schedules.rendered(view.id, clock, &view.world);
            }
        }
        let presented = self.present(&recorded);
        let shading = oxygen_passes::Shading {
            materials: prepared.materials,
            vertex_attributes: prepared.vertex_attributes,
            specialize: self.settings.specialize_shaders,
        };
        self.frames.drawing = Some((prepared.origin, shading));
        let mut report = FrameReport::new(prepared, recorded, presented, gpu_seconds);
        if let Some(timer) = &self.frames.gpu_timer {
            for view in &mut report.views {
                view.gpu_seconds = timer.job_seconds(view.view);
            }
        }
        // What each view holds and streams back.
        let mut atlases_counted = std::collections::HashSet::new();
        for view in &mut report.views {
            let targets = self.targets.get(view.view).and_then(|g| g.targets.as_ref());
            view.target_bytes = targets.map_or(0, oxygen_gpu::ViewTargets::bytes);
            view.uploaded_bytes += self.targets.get(view.view).map_or(0, |g| g.constants_written);
            if let ViewRole::BatchCamera { batch } = view.role {
                if atlases_counted.insert(batch) {
                    view.target_bytes += self.targets.atlas(batch).map_or(0, oxygen_gpu::TileAtlas::bytes);
                }
                let labels = targets.and_then(|t| t.labels.as_ref()).map_or(oxygen_gpu::LabelSet::NONE, |l| l.set());
                let size = targets.map_or((0, 0), |t| (t.width, t.height));
                view.streamed_bytes = self.streams.camera_bytes(batch, size, labels);
            }
        }
        // What each registered view cost, for the frame budget's estimates.
        let budgeted = self.schedules.budgeted();
        for view in report.views.iter().filter(|v| v.why.is_some() && budgeted) {
            let seconds = view.prep_seconds + view.record_seconds + view.gpu_seconds.unwrap_or(0.0);
            self.schedules.measured(view.view, seconds);
        }
        // The costs as tracing data too: one event per view and one for
        // the frame, under the `oxygen::cost` target.
        for view in &report.views {
            tracing::info!(
                target: "oxygen::cost",
                view = %view.view,
                prep_ms = view.prep_seconds * 1e3,
                record_ms = view.record_seconds * 1e3,
                gpu_ms = view.gpu_seconds.map_or(f64::NAN, |s| s * 1e3),
                draws = view.draws as u64,
                triangles = view.triangles.unwrap_or(0),
                uploaded_bytes = view.uploaded_bytes,
                streamed_bytes = view.streamed_bytes,
                target_bytes = view.target_bytes,
                "view cost"
            );
        }
        tracing::info!(
            target: "oxygen::cost",
            frame = report.frame_index,
            prepare_ms = report.prepare_seconds * 1e3,
            record_ms = report.record_seconds * 1e3,
            gpu_ms = report.gpu_seconds.map_or(f64::NAN, |s| s * 1e3),
            uploaded_bytes = report.uploaded_bytes,
            views = report.views.len() as u64,
            "frame cost"
        );
        self.frames.last = report.views.iter().map(|r| (r.view, r.role)).collect();
        for view in &report.views {
            self.frames.skipped.remove(&view.view);
        }
        for warning in &report.warnings {
            if let FrameWarning::ViewSkipped { view, reason, .. } = warning {
                self.frames.skipped.insert(*view, reason.clone());
            }
        }
        Ok(report)
    }

    /// Starts copying the streaming batches' images of the frame just
    /// submitted (see `streams.rs`); `views` are the frame's, which the
    /// recorded views index.
    fn stream(
        &mut self,
        recorded: &record::RecordedFrame,
        views: &[prepare::FrameView],
        clock: FrameClock,
    ) -> Result<(), RenderError> {
        let mut rendered = streams::RenderedBatches::default();
        for view in &recorded.rendered {
            let Some(ViewRole::BatchCamera { batch }) = views.get(view.index).map(|v| v.role) else { continue };
            let (Some(atlas), Some(tile)) = (
                self.targets.atlas(batch),
                self.targets.get(view.id).and_then(|g| g.targets.as_ref()).and_then(|t| t.tile),
            ) else {
                continue;
            };
            rendered.entry(batch).or_insert_with(|| (atlas, Vec::new())).1.push((view.id, tile));
        }
        for (_, cameras) in rendered.values_mut() {
            cameras.sort_by_key(|(_, tile)| tile.index);
        }
        self.streams.after_submit(&self.gpu, &rendered, clock)
    }

    /// How textures are bound on this device.
    pub fn texture_path(&self) -> TexturePath {
        self.heap.texture_path()
    }

    /// How partitions are drawn on this device.
    pub fn draw_path(&self) -> DrawPath {
        self.settings.draw_path
    }

    /// The GPU context.
    pub fn gpu(&self) -> &GpuContext {
        &self.gpu
    }

    /// The renderer's parts, for tests, benchmarks and tools that count
    /// what frames did (pipelines created, ScenePrep's counters, heap
    /// bytes); what they expose may change with the renderer's design.
    pub fn internals(&self) -> RendererInternals<'_> {
        RendererInternals {
            pipelines: &self.pipelines,
            lighting: &self.lighting,
            scene_prep: &self.prep,
            heap: &self.heap,
        }
    }
}
