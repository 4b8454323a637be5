//! Step 1 of a frame: resolve every active registered view (its camera →
//! matrices, frustum, viewport) and admit its targets to the budget. A view
//! that cannot be rendered this frame is left out with a warning; the others
//! go on.

use std::sync::Arc;

use oxygen_core::{ResolvedView, Scene, ViewContext, ViewId};
use oxygen_passes::{OutputSource, ProbeId};
use oxygen_sceneprep::ViewPrepOptions;
use tracing::{info_span, warn};

use super::{FrameWarning, RenderError, Renderer, ViewRole};
use crate::graph::ErasedGraph;
use crate::views::TargetKind;

/// Where a view of this frame renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum TargetPlan {
    /// Targets of its own, with colour or depth only, and samples per pixel.
    Own { with_color: bool, samples: u32 },
    /// Layer `tile` of the local shadow atlas.
    AtlasLayer { tile: u32 },
    /// Layer `face` of probe `probe`'s cube.
    ProbeFace { probe: ProbeId, face: u32 },
}

/// One view of this frame.
pub(crate) struct FrameView {
    pub(crate) id: ViewId,
    pub(crate) role: ViewRole,
    /// The view in world space (what ScenePrep culls against).
    pub(crate) world: ResolvedView,
    /// The view relative to the render origin (what the GPU sees); set by
    /// the prepare step.
    pub(crate) gpu: ResolvedView,
    pub(crate) options: ViewPrepOptions,
    pub(crate) graph: Arc<dyn ErasedGraph>,
    pub(crate) links: Vec<OutputSource>,
    pub(crate) target: TargetPlan,
}

/// The views of this frame, in id order until the record step orders them
/// by their links.
pub(crate) struct FramePlan {
    pub(crate) views: Vec<FrameView>,
    pub(crate) origin: glam::DVec3,
}

impl Renderer {
    /// Resolves every active registered view.
    pub(super) fn resolve_views(
        &self,
        scene: &Scene,
        frame_index: u64,
        time_seconds: f32,
    ) -> (FramePlan, Vec<FrameWarning>) {
        let _span = info_span!("resolve_views").entered();
        let limit = self.gpu.device.limits().max_texture_dimension_2d;
        // Paused views keep their targets: their memory stays taken.
        let mut taken = self.paused_target_bytes();
        let mut views = Vec::with_capacity(self.views.entries.len());
        let mut warnings = Vec::new();
        for (id, entry) in self.views.entries.iter().filter(|(_, entry)| entry.active) {
            let ctx = ViewContext { view_id: *id, frame_index, time_seconds };
            let (role, target) = match entry.target {
                TargetKind::Own => {
                    let with_color = !entry.options.depth_only;
                    let samples = if with_color { self.msaa_samples(entry.msaa) } else { 1 };
                    (ViewRole::Registered, TargetPlan::Own { with_color, samples })
                }
                TargetKind::ProbeFace { probe, face } => {
                    (ViewRole::ProbeFace { probe, face }, TargetPlan::ProbeFace { probe, face })
                }
            };
            // A view shown in a minimised window is not rendered.
            let shown_size = self.shown_size(entry.shown);
            if shown_size == Some(None) {
                continue;
            }
            let attempt = entry.resolver.resolve(&ctx, scene).map_err(RenderError::from).and_then(|mut view| {
                // The id is the renderer's, whatever the resolver wrote.
                view.view_id = *id;
                // A view shown in a window takes its rectangle's size.
                if let Some(Some(size)) = shown_size
                    && size != view.viewport
                {
                    view = view.with_viewport(size)?;
                }
                let (width, height) = (view.viewport.x, view.viewport.y);
                if width > limit || height > limit {
                    return Err(RenderError::ViewportTooLarge { view: *id, width, height, limit });
                }
                if let TargetPlan::Own { with_color, samples } = target {
                    self.admit_targets(view.viewport, with_color, samples, &mut taken).map_err(|e| e.for_view(*id))?;
                }
                Ok(view)
            });
            match attempt {
                Ok(view) => views.push(FrameView {
                    id: *id,
                    role,
                    world: view,
                    gpu: view,
                    options: ViewPrepOptions {
                        visibility: self.view_visibility(
                            entry.visibility,
                            entry.options.depth_only,
                            // A multisampled view has no single-sample depth
                            // for the occlusion test's pyramid.
                            entry.graph.two_phase() && !matches!(target, TargetPlan::Own { samples: 2.., .. }),
                        ),
                        ..entry.options
                    },
                    graph: Arc::clone(&entry.graph),
                    links: entry.links.clone(),
                    target,
                }),
                Err(e) => {
                    warn!(view = %id, "view skipped this frame: {e}");
                    warnings.push(FrameWarning::ViewSkipped { view: *id, reason: e.to_string() });
                }
            }
        }
        (FramePlan { views, origin: glam::DVec3::ZERO }, warnings)
    }

    /// Target bytes of paused views: they keep their targets.
    fn paused_target_bytes(&self) -> u64 {
        self.views
            .entries
            .iter()
            .filter(|(_, v)| !v.active)
            .filter_map(|(id, _)| self.gpu_views.get(id)?.targets.as_ref())
            .map(oxygen_gpu::ViewTargets::bytes)
            .sum()
    }

    /// Target bytes the frame's own targets take (for admitting the shadow
    /// cascades the prepare step adds).
    pub(super) fn planned_target_bytes(&self, plan: &FramePlan) -> u64 {
        let paused = self.paused_target_bytes();
        paused
            + plan
                .views
                .iter()
                .filter_map(|v| match v.target {
                    TargetPlan::Own { with_color, samples } => Some(oxygen_gpu::ViewTargets::bytes_for_msaa(
                        v.world.viewport.x,
                        v.world.viewport.y,
                        with_color.then_some(self.hdr_format),
                        samples,
                    )),
                    _ => None,
                })
                .sum::<u64>()
    }
}
