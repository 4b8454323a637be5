//! Step 1 of a frame, resolve: every active registered view's camera
//! becomes matrices, frustum and viewport (in world space), and its targets
//! are admitted to the budget. A view that cannot be rendered this frame is
//! left out with a warning; the others go on. Its output is
//! [`ResolvedFrame`]; the views the renderer makes itself (shadows) are
//! planned by the prepare step, from the lights the frame phase finds.

use std::sync::Arc;

use oxygen_core::{ResolvedView, Scene, ViewContext, ViewId};
use oxygen_gpu::LabelSet;
use oxygen_passes::OutputSource;
use oxygen_sceneprep::ViewPrepOptions;
use tracing::{info_span, warn};

use super::prepare::TargetPlan;
use super::{FrameWarning, RenderError, Renderer, ViewRole};
use crate::graph::ErasedGraph;
use crate::views::TargetKind;

/// Which frame this is and when: what every resolver of the frame is told.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FrameClock {
    /// Frame sequence number, from 1.
    pub(crate) index: u64,
    /// Seconds since the renderer started.
    pub(crate) time_seconds: f32,
}

impl FrameClock {
    /// What `view`'s resolver is told.
    pub(crate) fn context(self, view: ViewId) -> ViewContext {
        ViewContext { view_id: view, frame_index: self.index, time_seconds: self.time_seconds }
    }
}

/// A registered view resolved for this frame, in world space.
pub(crate) struct ResolvedFrameView {
    pub(crate) id: ViewId,
    /// Its registered name, if any.
    pub(crate) name: Option<Arc<str>>,
    pub(crate) role: ViewRole,
    pub(crate) world: ResolvedView,
    pub(crate) options: ViewPrepOptions,
    pub(crate) graph: Arc<dyn ErasedGraph>,
    pub(crate) links: Vec<OutputSource>,
    pub(crate) target: TargetPlan,
}

/// The output of the resolve step.
pub(crate) struct ResolvedFrame {
    pub(crate) clock: FrameClock,
    /// The active registered views that can render this frame, in id order.
    pub(crate) views: Vec<ResolvedFrameView>,
    /// The views left out, and why.
    pub(crate) warnings: Vec<FrameWarning>,
    /// Target bytes admitted to the budget: paused views', the views' own
    /// and the batches' atlases (the prepare step admits shadow cascades
    /// after them).
    pub(crate) taken: u64,
}

impl Renderer {
    /// Step 1: resolves every active registered view of `scene` at `clock`.
    pub(super) fn resolve(&self, scene: &Scene, clock: FrameClock) -> ResolvedFrame {
        let _span = info_span!("resolve", frame = clock.index).entered();
        let limit = self.gpu.device.limits().max_texture_dimension_2d;
        // Paused views keep their targets: their memory stays taken.
        let mut taken = self.targets.paused_bytes(&self.views);
        let mut views = Vec::with_capacity(self.views.entries.len());
        let mut warnings = Vec::new();
        for (id, entry) in self.views.entries.iter().filter(|(_, entry)| entry.active) {
            let (role, target) = match entry.target {
                TargetKind::Own => {
                    let with_color = !entry.options.depth_only;
                    let samples = if with_color { self.msaa_samples(entry.msaa) } else { 1 };
                    let labels = if with_color { entry.labels } else { LabelSet::NONE };
                    (ViewRole::Registered, TargetPlan::Own { with_color, samples, labels })
                }
                TargetKind::ProbeFace { probe, face } => {
                    (ViewRole::ProbeFace { probe, face }, TargetPlan::ProbeFace { probe, face })
                }
                TargetKind::Tile { batch, slot } => (ViewRole::BatchCamera { batch }, TargetPlan::Tile { batch, slot }),
            };
            // A batch camera renders at its batch's size.
            let batch_size = match entry.target {
                TargetKind::Tile { batch, .. } => self.views.batches.get(&batch).map(|b| b.size),
                _ => None,
            };
            // A view shown in a minimised window is not rendered.
            let shown_size = self.windows.shown_size(entry.shown);
            if shown_size == Some(None) {
                continue;
            }
            let attempt =
                entry.resolver.resolve(&clock.context(*id), scene).map_err(RenderError::from).and_then(|mut view| {
                    // The id is the renderer's, whatever the resolver wrote.
                    view.view_id = *id;
                    // A view shown in a window takes its rectangle's size.
                    if let Some(size) = shown_size.flatten().or(batch_size)
                        && size != view.viewport
                    {
                        view = view.with_viewport(size)?;
                    }
                    let (width, height) = (view.viewport.x, view.viewport.y);
                    if width > limit || height > limit {
                        return Err(RenderError::ViewportTooLarge { view: *id, width, height, limit });
                    }
                    if let TargetPlan::Own { with_color, samples, labels } = target {
                        self.targets
                            .admit(view.viewport, with_color, samples, labels, &mut taken)
                            .map_err(|e| e.for_view(*id))?;
                    }
                    Ok(view)
                });
            match attempt {
                Ok(view) => views.push(ResolvedFrameView {
                    id: *id,
                    name: entry.name.clone(),
                    role,
                    world: view,
                    options: ViewPrepOptions {
                        visibility: self.visibility.for_view(
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
                    let name = entry.name.as_deref().map(str::to_owned);
                    warnings.push(FrameWarning::ViewSkipped { view: *id, name, reason: e.to_string() });
                }
            }
        }
        self.admit_batches(&mut views, &mut warnings, &mut taken);
        ResolvedFrame { clock, views, warnings, taken }
    }

    /// Admits each batch's atlas (counted with an HDR layer, the most it
    /// can take) to the target budget after the other views' targets; the
    /// cameras of a batch that does not fit, or whose atlas the device
    /// cannot hold, are left out with a warning naming the reason.
    fn admit_batches(&self, views: &mut Vec<ResolvedFrameView>, warnings: &mut Vec<FrameWarning>, taken: &mut u64) {
        let limits = self.gpu.device.limits();
        let mut refused: Vec<(crate::batch::BatchId, RenderError)> = Vec::new();
        for (batch, entry) in &self.views.batches {
            if !views.iter().any(|v| matches!(v.target, TargetPlan::Tile { batch: b, .. } if b == *batch)) {
                continue;
            }
            let size = (entry.size.x, entry.size.y);
            let tiles = entry.slots.len() as u32;
            let layout = oxygen_gpu::TileAtlas::layout(size, tiles, entry.page_side(limits.max_texture_dimension_2d))
                .filter(|(_, _, pages)| *pages <= limits.max_texture_array_layers);
            let Some(layout) = layout else {
                let reason = format!(
                    "{tiles} cameras of {}x{} do not fit the device's {} pixels and {} layers",
                    size.0, size.1, limits.max_texture_dimension_2d, limits.max_texture_array_layers
                );
                refused.push((*batch, RenderError::InvalidBatch { name: entry.name.clone(), reason }));
                continue;
            };
            let hdr = Some(self.targets.hdr_format.bytes_per_pixel());
            let labels = entry
                .cameras()
                .filter_map(|c| self.views.entries.get(&c))
                .fold(entry.labels, |set, camera| set.union(camera.labels));
            let deferred = entry.graph.shading == crate::batch::BatchShading::Deferred;
            let bytes = oxygen_gpu::TileAtlas::bytes_for(size, layout, hdr, labels, deferred);
            if taken.saturating_add(bytes) > self.targets.budget {
                refused.push((
                    *batch,
                    RenderError::BatchBudget {
                        name: entry.name.clone(),
                        cameras: tiles,
                        bytes,
                        budget: self.targets.budget,
                        taken: *taken,
                    },
                ));
                continue;
            }
            *taken += bytes;
        }
        for (batch, error) in refused {
            views.retain(|v| {
                let keep = !matches!(v.target, TargetPlan::Tile { batch: b, .. } if b == batch);
                if !keep {
                    warn!(view = %v.id, "view skipped this frame: {error}");
                    let name = self.views.name(v.id).map(str::to_owned);
                    warnings.push(FrameWarning::ViewSkipped { view: v.id, name, reason: error.to_string() });
                }
                keep
            });
        }
    }
}
