//! `RenderContext` and `CommandRecorder`: what a pass reads and where it records.

use oxygen_bindless::{BindlessHeap, SceneConstantsBuffer};
use oxygen_core::{Depth, HdrColor, Output, OutputSource, ProbeCube, ProbeId, ResolvedView, ShadowMap, ViewId};
use oxygen_gpu::{ColorTargets, GpuContext, ViewTargets};
use oxygen_sceneprep::{PassMask, PreparedSceneFrame};
use thiserror::Error;

use crate::{LightingResources, Pipelines};

/// A pass that cannot record.
#[derive(Debug, Error)]
pub enum PassError {
    /// A graph read an output its view is not linked to.
    #[error("reads the {output} of {from}, which the view is not linked to (link it when registering the view)")]
    UndeclaredInput {
        /// The kind of output.
        output: &'static str,
        /// Whose output.
        from: String,
    },
    /// A pass needs what an earlier pass should have produced.
    #[error("{pass}: needs {input}, which no earlier pass of this view produced")]
    MissingInput {
        /// The pass.
        pass: &'static str,
        /// The missing output's type.
        input: &'static str,
    },
    /// A colour pass ran in a depth-only view.
    #[error("{pass}: the view is depth-only and has no colour target")]
    NoColorTarget {
        /// The pass.
        pass: &'static str,
    },
    /// An input the pass cannot use, e.g. local-light shadow maps of
    /// different sizes.
    #[error("{pass}: {what}")]
    BadInput {
        /// The pass.
        pass: &'static str,
        /// What is wrong.
        what: String,
    },
    /// An application-defined failure inside a render graph.
    #[error("render graph: {0}")]
    Graph(String),
}

/// How a partition's draws are submitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DrawPath {
    /// One `draw_indexed` per draw; works on every backend.
    Direct,
    /// One `multi_draw_indexed_indirect` per partition over the indirect
    /// arguments ScenePrep wrote; needs `DownlevelFlags::INDIRECT_EXECUTION`
    /// and `Features::INDIRECT_FIRST_INSTANCE`.
    MultiDrawIndirect,
}

impl DrawPath {
    /// The fastest path the device supports.
    pub fn best_for(features: wgpu::Features, downlevel: &wgpu::DownlevelCapabilities) -> Self {
        if Self::MultiDrawIndirect.is_supported(features, downlevel) {
            DrawPath::MultiDrawIndirect
        } else {
            DrawPath::Direct
        }
    }

    /// Whether the device can use this path.
    pub fn is_supported(self, features: wgpu::Features, downlevel: &wgpu::DownlevelCapabilities) -> bool {
        match self {
            DrawPath::Direct => true,
            DrawPath::MultiDrawIndirect => {
                features.contains(wgpu::Features::INDIRECT_FIRST_INSTANCE)
                    && downlevel.flags.contains(wgpu::DownlevelFlags::INDIRECT_EXECUTION)
            }
        }
    }
}

/// Everything a pass may read for one view in one frame. Immutable: passes
/// communicate through the textures they write, never by changing this.
pub struct RenderContext<'a> {
    /// Device and queue.
    pub gpu: &'a GpuContext,
    /// The resolved view, relative to [`RenderContext::origin`]
    /// ([`ResolvedView::relative_to`]).
    pub view: &'a ResolvedView,
    /// ScenePrep's result for this view.
    pub prepared: &'a PreparedSceneFrame,
    /// This view's uniform block (bind group 1).
    pub scene_constants: &'a SceneConstantsBuffer,
    /// The bindless heap (bind group 0, shared index buffer).
    pub heap: &'a BindlessHeap,
    /// Colour and depth targets of the view.
    pub targets: &'a ViewTargets,
    /// Shared pipelines.
    pub pipelines: &'a Pipelines,
    /// Shared lighting resources (group 3 layout, shadow atlas, probe mips).
    pub lighting: &'a LightingResources,
    /// How partitions are drawn.
    pub draw_path: DrawPath,
    /// What this view may read from other views: its own sun cascades, the
    /// frame's local shadow maps, and the outputs it is linked to.
    pub inputs: ViewInputs<'a>,
    /// Which views of the frame have finished recording; inputs are awaited
    /// through it.
    pub progress: &'a FrameProgress,
    /// The render origin: every matrix and position the GPU sees this frame
    /// (`view`, `inputs`, world matrices, lights) is relative to it. A pass
    /// that uploads a world position of its own subtracts it.
    pub origin: glam::DVec3,
    /// Whether another view of the frame reads this view's HDR image (it is
    /// linked to this view's output; links do not say which output, so a
    /// link counts as reading the HDR), or the renderer was asked to keep
    /// every HDR image (`RendererOptions::keep_hdr`). Not part of
    /// [`ViewInputs`], which says what this view reads, not who reads it.
    /// [`RenderContext::hdr_read_after_shading`] uses it.
    pub hdr_read_by_others: bool,
    /// Whether any material of the scene has a texture: shading pipelines
    /// leave texture sampling out otherwise ([`crate::ShaderFeatures`]).
    pub textured_materials: bool,
    /// Whether any material of the scene reads a second UV set or a
    /// texture transform: shading pipelines leave that path out otherwise.
    pub uv_transforms: bool,
    /// Specialise the shading pipelines to what the view has this frame
    /// ([`crate::ShaderFeatures`]); `false` runs the fully featured shader
    /// everywhere (for comparisons).
    pub specialize_shaders: bool,
    /// GPU visibility's per-view state, when the renderer has it: the count
    /// buffers of GPU-written partitions, and phase 2 of occlusion culling.
    pub visibility: Option<&'a crate::GpuVisibility>,
    /// The path-traced reference's scene and samples, when a view of the
    /// renderer is path traced ([`crate::ReferencePass`]).
    pub reference: Option<&'a crate::ReferenceTracer>,
}

/// What an automatic depth pre-pass decides from, for one view and frame
/// ([`RenderContext::pre_pass_estimate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrePassEstimate {
    /// The times a forward pass without a pre-pass is expected to shade a
    /// pixel; infinite when not known yet.
    pub overdraw: f32,
    /// The indices a pre-pass would draw (the opaque and masked draws').
    pub indices: u64,
    /// The view's pixels.
    pub pixels: u64,
}

impl<'a> RenderContext<'a> {
    /// The view's colour targets, or [`PassError::NoColorTarget`] naming
    /// `pass` when the view is depth-only.
    pub fn color_targets(&self, pass: &'static str) -> Result<&'a ColorTargets, PassError> {
        self.targets.color.as_ref().ok_or(PassError::NoColorTarget { pass })
    }

    /// The depth complexity a forward pass without a depth pre-pass is
    /// expected to shade, for an automatic pre-pass: on the CPU path
    /// ScenePrep's estimate from this frame's draws
    /// ([`oxygen_sceneprep::PreparedSceneFrame::estimated_overdraw`]); on a
    /// GPU path the coverage the GPU summed over the draws it kept, read
    /// back from an earlier frame, and infinite (so: pre-pass) until the
    /// first readback arrives.
    pub fn estimated_overdraw(&self) -> f32 {
        match (self.prepared.gpu_plan(), self.visibility) {
            (Some(_), Some(visibility)) => visibility.estimated_overdraw(self.view.view_id).unwrap_or(f32::INFINITY),
            _ => self.prepared.estimated_overdraw(),
        }
    }

    /// What an automatic depth pre-pass decides from: the expected
    /// overdraw ([`RenderContext::estimated_overdraw`]), the indices a
    /// pre-pass would draw (ScenePrep's count on the CPU path, the GPU's
    /// read back with the overdraw on a GPU path, 0 until it arrives) and
    /// the view's pixels.
    pub fn pre_pass_estimate(&self) -> PrePassEstimate {
        let indices = match (self.prepared.gpu_plan(), self.visibility) {
            (Some(_), Some(visibility)) => visibility.depth_pass_indices(self.view.view_id).unwrap_or(0),
            _ => 0,
        } + self.prepared.depth_pass_indices();
        PrePassEstimate {
            overdraw: self.estimated_overdraw(),
            indices,
            pixels: u64::from(self.view.viewport.x) * u64::from(self.view.viewport.y),
        }
    }

    /// Whether this view's visibility is GPU occlusion culling this frame:
    /// its depth pre-pass then runs in two phases around
    /// [`RenderContext::cull_occluded`].
    pub fn occlusion_culling(&self) -> bool {
        self.prepared.gpu_plan().is_some_and(|p| p.visibility == oxygen_sceneprep::Visibility::GpuOcclusion)
    }

    /// Occlusion culling's second phase, between the depth pre-pass's two
    /// phases ([`crate::DrawList`]): builds the depth pyramid from what the
    /// first phase drew and finds the draws it hid not. Does nothing for a
    /// view without occlusion culling.
    pub fn cull_occluded(&self, rec: &mut CommandRecorder) {
        if let (true, Some(visibility)) = (self.occlusion_culling(), self.visibility) {
            visibility.record_late(&self.gpu.device, rec.encoder(), self.view.view_id, &self.targets.depth_view);
        }
    }

    /// Whether anything after the opaque shading reads the view's HDR
    /// image this frame: its transparent partitions (blended over it) or
    /// another view ([`RenderContext::hdr_read_by_others`]). When nothing
    /// does, the standard graph tone-maps at the end of shading
    /// ([`crate::MeshPass::tone_mapped`]) and skips the tone-map pass.
    pub fn hdr_read_after_shading(&self) -> bool {
        // With MSAA the shading pass resolves into the HDR target, which the
        // tone-map pass then reads.
        self.hdr_read_by_others
            || self.targets.msaa.is_some()
            || self.prepared.partitions_matching(PassMask::TRANSPARENT, PassMask::empty()).next().is_some()
    }

    /// Another view's output this view is linked to, once the views that
    /// produce it have recorded their commands (their command buffers are
    /// submitted before this view's). Fails with
    /// [`PassError::UndeclaredInput`] for an output the view was not linked
    /// to at registration: the renderer orders views by their links, so an
    /// unlinked read could see last frame's image.
    pub async fn input<K: OutputKind>(&self, output: Output<K>) -> Result<K::Value<'a>, PassError> {
        let (value, producers) = K::find(&self.inputs, output.source)
            .ok_or(PassError::UndeclaredInput { output: K::NAME, from: output.source.to_string() })?;
        self.progress.recorded(&producers).await;
        Ok(value)
    }
}

/// What kinds of output exist and how a view's inputs find them.
pub trait OutputKind: 'static {
    /// What reading it gives.
    type Value<'a>;
    /// Name for errors.
    const NAME: &'static str;
    /// The value and the views that must have recorded first.
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)>;
}

fn linked_view<'i, 'a>(inputs: &'i ViewInputs<'a>, source: OutputSource) -> Option<&'i LinkedView<'a>> {
    let OutputSource::View(id) = source else { return None };
    inputs.views.iter().find(|v| v.id == id)
}

impl OutputKind for Depth {
    type Value<'a> = (&'a ResolvedView, &'a wgpu::TextureView);
    const NAME: &'static str = "depth";
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)> {
        let v = linked_view(inputs, source)?;
        // A multisampled view's single-sample depth is never written (depth
        // does not resolve): there is no depth output to read.
        if v.targets.msaa.is_some() {
            return None;
        }
        Some(((v.view, &v.targets.depth_view), vec![v.id]))
    }
}

impl OutputKind for HdrColor {
    type Value<'a> = (&'a ResolvedView, &'a wgpu::TextureView);
    const NAME: &'static str = "HDR colour";
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)> {
        let v = linked_view(inputs, source)?;
        Some(((v.view, &v.targets.color.as_ref()?.hdr_view), vec![v.id]))
    }
}

impl OutputKind for ShadowMap {
    type Value<'a> = ShadowMapInput<'a>;
    const NAME: &'static str = "shadow map";
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)> {
        let OutputSource::View(id) = source else { return None };
        let own = inputs.cascades.iter().chain(inputs.local_shadows.iter().flat_map(|l| l.tiles.iter().flatten()));
        if let Some(map) = own.into_iter().find(|m| m.producer == id) {
            return Some((map.clone(), vec![id]));
        }
        let v = linked_view(inputs, source)?;
        let map =
            ShadowMapInput { producer: v.id, view: v.view, depth: &v.targets.depth_view, resolution: v.targets.width };
        Some((map, vec![v.id]))
    }
}

impl OutputKind for ProbeCube {
    type Value<'a> = ProbeCubeInput<'a>;
    const NAME: &'static str = "probe cube";
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)> {
        let OutputSource::Probe(id) = source else { return None };
        let probe = inputs.probes.iter().find(|p| p.probe == id)?;
        Some((probe.clone(), probe.faces.to_vec()))
    }
}

/// A shadow map another view rendered.
#[derive(Clone, Debug)]
pub struct ShadowMapInput<'a> {
    /// The shadow view that rendered it.
    pub producer: ViewId,
    /// The light's view (relative to the render origin).
    pub view: &'a ResolvedView,
    /// Its depth (a whole target, or one layer of the local shadow atlas).
    pub depth: &'a wgpu::TextureView,
    /// Texels a side.
    pub resolution: u32,
}

/// The frame's local-light shadow maps: one atlas, one layer per tile.
#[derive(Clone, Debug)]
pub struct LocalShadowsInput<'a> {
    /// The atlas as a 2D array.
    pub atlas: &'a wgpu::TextureView,
    /// Per tile (atlas layer): the shadow view rendering it, if any this frame.
    pub tiles: Vec<Option<ShadowMapInput<'a>>>,
}

/// A reflection probe a view is linked to.
#[derive(Clone, Debug)]
pub struct ProbeCubeInput<'a> {
    /// The probe.
    pub probe: ProbeId,
    /// Its face views (+X, −X, +Y, −Y, +Z, −Z).
    pub faces: [ViewId; crate::PROBE_FACES],
    /// Six-layer HDR texture with its mip chain.
    pub texture: &'a wgpu::Texture,
    /// Its world position.
    pub position: glam::Vec3,
}

/// A view this view is linked to, with its targets.
#[derive(Clone, Copy)]
pub struct LinkedView<'a> {
    /// The view.
    pub id: ViewId,
    /// Its resolved view (relative to the render origin).
    pub view: &'a ResolvedView,
    /// Its targets.
    pub targets: &'a ViewTargets,
}

/// What one view may read from the others this frame.
#[derive(Clone, Default)]
pub struct ViewInputs<'a> {
    /// The view's own sun-shadow cascades, nearest first (empty when it
    /// asked for none or no directional light casts shadows this frame).
    pub cascades: Vec<ShadowMapInput<'a>>,
    /// The frame's local-light shadow maps, when any light casts them.
    pub local_shadows: Option<LocalShadowsInput<'a>>,
    /// The reflection probes the view is linked to, in link order.
    pub probes: Vec<ProbeCubeInput<'a>>,
    /// The views the view is linked to.
    pub views: Vec<LinkedView<'a>>,
}

/// Which views of a frame have finished recording. Awaiting an input waits
/// here; the renderer marks each view when its graph returns.
pub struct FrameProgress {
    state: std::sync::Mutex<ProgressState>,
}

struct ProgressState {
    pending: Vec<ViewId>,
    wakers: Vec<std::task::Waker>,
}

impl FrameProgress {
    /// Progress of a frame in which `recording` will record; any other view
    /// counts as recorded already (it keeps its last image).
    pub fn new(recording: impl IntoIterator<Item = ViewId>) -> Self {
        FrameProgress {
            state: std::sync::Mutex::new(ProgressState {
                pending: recording.into_iter().collect(),
                wakers: Vec::new(),
            }),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, ProgressState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Marks `view` recorded and wakes whoever awaits it.
    pub fn complete(&self, view: ViewId) {
        let wakers = {
            let mut state = self.lock();
            state.pending.retain(|v| *v != view);
            std::mem::take(&mut state.wakers)
        };
        wakers.into_iter().for_each(std::task::Waker::wake);
    }

    /// Whether every view of `views` has recorded (or is not recording).
    pub fn all_recorded(&self, views: &[ViewId]) -> bool {
        let state = self.lock();
        !views.iter().any(|v| state.pending.contains(v))
    }

    /// Whether `view` still has to record.
    pub fn is_pending(&self, view: ViewId) -> bool {
        self.lock().pending.contains(&view)
    }

    /// Resolves once every view of `views` has recorded.
    pub fn recorded<'p>(&'p self, views: &'p [ViewId]) -> impl std::future::Future<Output = ()> + 'p {
        std::future::poll_fn(move |cx| {
            let mut state = self.lock();
            if views.iter().any(|v| state.pending.contains(v)) {
                // Woken on every completion; re-checked then. One waker per
                // task, however often it is polled before that.
                if !state.wakers.iter().any(|w| w.will_wake(cx.waker())) {
                    state.wakers.push(cx.waker().clone());
                }
                std::task::Poll::Pending
            } else {
                std::task::Poll::Ready(())
            }
        })
    }
}

/// Counts of what a view's passes recorded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RecordStats {
    /// wgpu render passes begun.
    pub render_passes: u32,
    /// Pipelines set (one per partition drawn).
    pub pipeline_binds: u32,
    /// Draw calls recorded (a multi-draw counts once).
    pub draw_calls: u32,
    /// Draw commands the GPU executes (each command of a multi-draw counts;
    /// an instanced run counts once).
    pub draw_commands: u32,
    /// Shading tone-mapped in place and wrote the display colour: the HDR
    /// image was not written this frame.
    pub tone_mapped_in_pass: bool,
}

/// The command encoder of one view plus counters.
pub struct CommandRecorder {
    encoder: wgpu::CommandEncoder,
    /// What was recorded so far.
    pub stats: RecordStats,
}

impl CommandRecorder {
    /// A recorder with a fresh encoder.
    pub fn new(device: &wgpu::Device, label: &str) -> Self {
        CommandRecorder {
            encoder: device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) }),
            stats: RecordStats::default(),
        }
    }

    /// The encoder.
    pub fn encoder(&mut self) -> &mut wgpu::CommandEncoder {
        &mut self.encoder
    }

    /// Finishes recording.
    pub fn finish(self) -> (wgpu::CommandBuffer, RecordStats) {
        (self.encoder.finish(), self.stats)
    }
}
