//! `RenderContext`: everything a pass may read for one view this frame.

use oxygen_bindless::{BindlessHeap, SceneConstantsBuffer};
use oxygen_core::{Output, ResolvedView};
use oxygen_gpu::{ColorTargets, GpuContext, ViewTargets};
use oxygen_sceneprep::{MaterialFeatures, PassMask, PreparedSceneFrame};

use super::{CommandRecorder, DrawPath, FrameProgress, OutputKind, PassError, ViewInputs};
use crate::{LightingResources, Pipelines};

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
    /// This view's uniform block (bind group 3).
    pub scene_constants: &'a SceneConstantsBuffer,
    /// The bindless heap (bind group 0, shared index buffer).
    pub heap: &'a BindlessHeap,
    /// Colour and depth targets of the view.
    pub targets: &'a ViewTargets,
    /// Shared pipelines.
    pub pipelines: &'a Pipelines,
    /// Shared lighting resources (group 1 layout, shadow atlas, probe mips).
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
    /// What the frame's shading pipelines carry.
    pub shading: Shading,
    /// The frame's time in seconds (the renderer's clock, or the time the
    /// frame was rendered at): for passes that change over time
    /// (automatic exposure's adaptation).
    pub time_seconds: f32,
    /// What the application draws over this view's final image
    /// ([`crate::OverlayPass`]); `None` for a view without an overlay.
    pub overlay: Option<&'a std::sync::Mutex<oxygen_overlay::Overlay>>,
}

/// What the frame's shading pipelines carry, the same for every view of the
/// frame ([`crate::ShaderFeatures`] adds what each view has).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shading {
    /// What the scene's materials need, as ScenePrep's material table found
    /// it: pipelines leave texture sampling and the UV-transform path out
    /// when no material needs them.
    pub materials: MaterialFeatures,
    /// Some mesh the frame draws has vertex colours or a second UV set
    /// (ScenePrep's geometry cache: [`oxygen_sceneprep::ScenePrep::vertex_attributes`]);
    /// without, every mesh pipeline's vertex stage leaves them out.
    pub vertex_attributes: bool,
    /// Specialise the shading pipelines to what the view has this frame;
    /// `false` runs the fully featured shader everywhere (for comparisons).
    pub specialize: bool,
}

impl Shading {
    /// Every feature in every pipeline: what a context made without a scene
    /// in view uses.
    pub const ALL: Shading = Shading { materials: MaterialFeatures::ALL, vertex_attributes: true, specialize: true };
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
        match (self.prepared.gpu_plan(), self.inputs.visibility) {
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
        let indices = match (self.prepared.gpu_plan(), self.inputs.visibility) {
            (Some(_), Some(visibility)) => visibility.depth_pass_indices(self.view.view_id).unwrap_or(0),
            _ => 0,
        } + self.prepared.depth_pass_indices();
        PrePassEstimate {
            overdraw: self.estimated_overdraw(),
            indices,
            pixels: u64::from(self.view.viewport.x) * u64::from(self.view.viewport.y),
        }
    }

    /// Whether the view was prepared in the deterministic mode
    /// ([`PreparedSceneFrame::deterministic`]): its shading pass lets the
    /// last of two surfaces at one depth show, with or without a pre-pass,
    /// and a graph must not choose passes that change pixels from estimates
    /// (they differ between visibility paths and depend on earlier frames).
    pub fn deterministic(&self) -> bool {
        self.prepared.deterministic()
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
        if let (true, Some(visibility)) = (self.occlusion_culling(), self.inputs.visibility) {
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

    /// The same view's draws aimed at other targets through other scene
    /// constants (an ID render: [`crate::record_id_render`]). It reads
    /// nothing from other views (no inputs but GPU visibility's counts,
    /// which say how many of the view's commands the GPU kept) and has no
    /// overlay.
    pub fn drawing_into<'b>(
        &'b self,
        targets: &'b ViewTargets,
        scene_constants: &'b SceneConstantsBuffer,
    ) -> RenderContext<'b> {
        RenderContext {
            targets,
            scene_constants,
            inputs: ViewInputs { visibility: self.inputs.visibility, ..Default::default() },
            overlay: None,
            hdr_read_by_others: false,
            ..*self
        }
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
