//! Why a frame, or a renderer, failed.

use oxygen_core::ViewId;
use oxygen_gpu::GpuError;
use oxygen_passes::{PassError, ProbeId};
use oxygen_sceneprep::PrepError;
use thiserror::Error;

use oxygen_core::ViewError;

#[cfg(doc)]
use crate::Renderer;

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
    #[error("{view}{}: {source}", name.as_ref().map(|n| format!(" ({n})")).unwrap_or_default())]
    Pass {
        /// The view whose graph failed.
        view: ViewId,
        /// Its name, if it has one.
        name: Option<String>,
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
    /// A reflection probe's parallax box cannot be used (not finite,
    /// empty, or not holding the probe).
    #[error("{probe:?}: parallax box {min:?}..{max:?}: {reason}")]
    InvalidProbeBox {
        /// The probe.
        probe: ProbeId,
        /// The box's smallest corner as given.
        min: glam::Vec3,
        /// The box's largest corner as given.
        max: glam::Vec3,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// The view has not been rendered yet, so it has no image.
    #[error("{0} has not been rendered yet")]
    NotRendered(ViewId),
    /// The view has no image: the frames so far skipped it, and this is
    /// why the last one did.
    #[error("{view} has no image: it was skipped ({reason})")]
    Skipped {
        /// The view.
        view: ViewId,
        /// The reason its last frame gave.
        reason: String,
    },
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
    /// A view's schedule cannot be kept ([`crate::schedule::Schedule::problem`]).
    #[error("the schedule of {}: {reason}", view.map_or_else(|| "a new view".to_string(), |v| v.to_string()))]
    InvalidSchedule {
        /// The view, when it was registered already.
        view: Option<ViewId>,
        /// What is wrong.
        reason: String,
    },
    /// A batch or one of its cameras cannot be registered as asked.
    #[error("batch {name:?}: {reason}")]
    InvalidBatch {
        /// The batch's name.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// A batch's atlas would pass the renderer's target memory budget.
    #[error(
        "batch {name:?}: the atlas of {cameras} cameras would take {} MiB; the target budget is {} MiB, of which {} MiB \
         are taken (RendererOptions::target_budget_bytes)",
        bytes >> 20, budget >> 20, taken >> 20
    )]
    BatchBudget {
        /// The batch's name.
        name: String,
        /// Its cameras (tiles).
        cameras: u32,
        /// What its atlas would take.
        bytes: u64,
        /// The budget.
        budget: u64,
        /// What other views' targets take already.
        taken: u64,
    },
    /// No batch with this id.
    #[error("{0} is not registered")]
    NoSuchBatch(crate::batch::BatchId),
    /// No window with this id.
    #[error("{0} does not exist")]
    NoSuchWindow(crate::WindowId),
    /// The window has not been composed yet (no frame since it was added
    /// or resized from zero).
    #[error("{0} has presented nothing yet")]
    NothingPresented(crate::WindowId),
}
