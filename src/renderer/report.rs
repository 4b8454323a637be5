//! What a frame did: per view ([`ViewReport`], [`ViewRole`]), what it left
//! out ([`FrameWarning`]) and the whole ([`FrameReport`]), put together from
//! the outputs of the frame's steps.

use oxygen_core::{NodeKey, ViewId};
#[cfg(doc)]
use oxygen_passes::Pipelines;
use oxygen_passes::{ProbeId, RecordStats};
use oxygen_sceneprep::Visibility;

use super::prepare::PreparedFrame;
use super::present::PresentedFrame;
use super::record::RecordedFrame;

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
    /// A camera of batch `batch`, recorded with the rest of its batch.
    BatchCamera {
        /// The batch.
        batch: crate::batch::BatchId,
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
    /// Its name ([`crate::ViewDesc::named`]; a batch camera's defaults to
    /// its batch's name and tile), if it has one.
    pub name: Option<std::sync::Arc<str>>,
    /// What it is for.
    pub role: ViewRole,
    /// Draws after culling. On a GPU visibility path the GPU counts the
    /// draws it keeps and the count is read back without waiting: one or
    /// two frames old, plus this frame's CPU-written transparent draws
    /// (only those before the first readback).
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
    /// Why it rendered this frame (its [`crate::schedule::Schedule`]); `None`
    /// for the views the renderer makes itself (shadows, probe faces follow
    /// their owners).
    pub why: Option<crate::schedule::RenderReason>,
    /// GPU time of its recording job in a recent frame (one or two frames
    /// old, read back without waiting): its own command buffer's, from a
    /// timestamp at its start to one at its end; for a batch's first
    /// camera the whole batch's, `None` for its other cameras. `None` too
    /// before the first readback and on devices without timestamps inside
    /// encoders.
    pub gpu_seconds: Option<f64>,
    /// Triangles its draws drew (each draw's indices ÷ 3 × its instances).
    /// On a GPU visibility path the GPU counts the indices of the draws it
    /// keeps and the count is read back without waiting, so it is one or
    /// two frames old (plus this frame's CPU-written transparent draws);
    /// `None` there before the first readback.
    pub triangles: Option<u64>,
    /// Bytes written to the GPU for this view alone this frame: its draws
    /// and commands (ScenePrep's CPU-written ranges) and its constants.
    /// What views share — matrices, lights, materials, meshes, the GPU
    /// scene, cull parameters and a batch's constants block — is counted in
    /// [`FrameReport::uploaded_bytes`] only.
    pub uploaded_bytes: u64,
    /// Bytes of GPU targets it holds: its own targets' (colour, HDR, depth,
    /// multisampled and label targets); for a batch's first camera its
    /// batch's whole atlas, 0 for its other cameras.
    pub target_bytes: u64,
    /// Bytes of images its batch's stream copies back for it this frame
    /// ([`crate::Renderer::stream_batch`]); 0 for a view no stream reads.
    pub streamed_bytes: u64,
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
        /// Its name, if it has one.
        name: Option<String>,
        /// Why, as the error would have said it.
        reason: String,
    },
    /// A view asks for sun shadows ([`crate::ViewDesc::with_sun_shadows`])
    /// but the frame has no directional light that casts shadows: it is
    /// lit without them.
    NoSunForShadows {
        /// The view.
        view: ViewId,
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
            FrameWarning::ViewSkipped { view, name: Some(name), reason } => {
                write!(f, "{view} ({name}) skipped: {reason}")
            }
            FrameWarning::ViewSkipped { view, name: None, reason } => write!(f, "{view} skipped: {reason}"),
            FrameWarning::NoSunForShadows { view } => write!(
                f,
                "{view} asks for sun shadows, but no directional light of the scene casts shadows: it has no cascades"
            ),
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
    /// The registered views this frame left idle by their schedules, and
    /// why ([`crate::schedule::IdleReason`]); each keeps its last images.
    pub idle: Vec<crate::schedule::IdleView>,
    /// GPU time of a recent frame's views (from a timestamp before its
    /// first command buffer to one after its last), read back without
    /// waiting, so one or two frames old; `None` before the first readback
    /// and on devices without timestamps inside encoders.
    pub gpu_seconds: Option<f64>,
}

impl FrameReport {
    /// The report of a frame, from what its steps made: its views and
    /// nodes left out by resolve and prepare, then the windows present
    /// skipped, then the nodes ScenePrep skipped (`gpu_seconds`: a recent
    /// frame's GPU time, when read back).
    pub(crate) fn new(
        prepared: PreparedFrame,
        recorded: RecordedFrame,
        presented: PresentedFrame,
        gpu_seconds: Option<f64>,
    ) -> Self {
        let mut warnings = prepared.warnings;
        warnings.extend(presented.warnings);
        warnings.extend(prepared.skipped_nodes);
        let mut views = recorded.reports;
        for view in &mut views {
            view.why = prepared.why.get(&view.view).copied();
        }
        FrameReport {
            frame_index: prepared.clock.index,
            views,
            idle: prepared.idle,
            prepare_seconds: prepared.seconds,
            record_seconds: recorded.seconds,
            record_threads: recorded.threads,
            warnings,
            pipelines_used: recorded.pipelines_used,
            pipelines_created: recorded.pipelines_created,
            uploaded_bytes: prepared.uploaded_bytes,
            windows_presented: presented.windows_presented,
            gpu_seconds,
        }
    }
}
