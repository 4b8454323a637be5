//! Step 2 of a frame, prepare: pick the render origin, run ScenePrep's
//! frame phase, plan this frame's shadow views from the lights it found
//! (the owners' sun cascades, one view per local shadow tile), prepare
//! every view and upload; then give every view its targets and constants,
//! and hand GPU visibility and the reference tracer what they need. Its
//! output, [`PreparedFrame`], is every view of the frame complete: nothing
//! after it changes a view.

use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};
use std::sync::Arc;
use std::time::Instant;

use oxygen_core::{ResolvedView, Scene, ViewId};
use oxygen_gpu::LabelSet;
use oxygen_passes::{OutputSource, ProbeId};
use oxygen_sceneprep::{MaterialFeatures, PassMask, PreparedSceneFrame};
use oxygen_sceneprep::{ViewPrepOptions, ViewRequest};
use tracing::{info_span, warn};

use super::resolve::{FrameClock, ResolvedFrame, ResolvedFrameView};
use super::targets::{BatchPlan, atlas_layers};
use super::{FrameWarning, RenderError, Renderer, ViewRole};
use crate::batch::BatchId;
use crate::graph::ErasedGraph;
use crate::schedule::{IdleView, RenderReason};
use crate::shadows::{ShadowRole, shadow_view_options};

/// Where a view of this frame renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum TargetPlan {
    /// Targets of its own, with colour or depth only, samples per pixel,
    /// and the label planes the view asked for.
    Own { with_color: bool, samples: u32, labels: LabelSet },
    /// Layer `tile` of the local shadow atlas.
    AtlasLayer { tile: u32 },
    /// Layer `face` of probe `probe`'s cube.
    ProbeFace { probe: ProbeId, face: u32 },
    /// Tile `slot` of batch `batch`'s atlas.
    Tile { batch: crate::batch::BatchId, slot: u32 },
}

/// One view of this frame, registered or the renderer's own.
pub(crate) struct FrameView {
    pub(crate) id: ViewId,
    /// Its registered name, shared with the registry (for its report).
    pub(crate) name: Option<Arc<str>>,
    pub(crate) role: ViewRole,
    /// The view in world space (what ScenePrep culls against).
    pub(crate) world: ResolvedView,
    /// The view relative to the render origin (what the GPU sees).
    pub(crate) gpu: ResolvedView,
    pub(crate) options: ViewPrepOptions,
    pub(crate) graph: Arc<dyn ErasedGraph>,
    pub(crate) links: Vec<OutputSource>,
    pub(crate) target: TargetPlan,
}

/// The output of the prepare step: every view of the frame with its
/// prepared scene frame. A view's targets and constants are the `Targets`
/// subsystem's, allocated here for the view's id (they outlive the frame:
/// a view keeps its image between frames).
pub(crate) struct PreparedFrame {
    pub(crate) clock: FrameClock,
    /// Where the GPU's coordinates are centred this frame.
    pub(crate) origin: glam::DVec3,
    /// The registered views in id order, then the shadow views.
    pub(crate) views: Vec<FrameView>,
    /// ScenePrep's result for `views[i]` is `frames[i]`; taken from
    /// ScenePrep for the frame and returned to it after recording
    /// (`ScenePrep::return_frames`), so their buffers are reused.
    pub(crate) frames: Vec<PreparedSceneFrame>,
    /// The local shadow atlas, when a view renders into it.
    pub(crate) atlas: Option<wgpu::Texture>,
    /// What the scene's materials need of the shading pipelines.
    pub(crate) materials: MaterialFeatures,
    /// Whether some mesh drawn has vertex colours or a second UV set.
    pub(crate) vertex_attributes: bool,
    /// The views left out, and why.
    pub(crate) warnings: Vec<FrameWarning>,
    /// The nodes ScenePrep left out, and why.
    pub(crate) skipped_nodes: Vec<FrameWarning>,
    /// Seconds from the start of the frame to the end of the upload.
    pub(crate) seconds: f64,
    /// Bytes written into GPU buffers.
    pub(crate) uploaded_bytes: u64,
    /// Why each registered view of the frame renders (its schedule).
    pub(crate) why: oxygen_core::ViewIdMap<RenderReason>,
    /// The registered views the schedules left idle, and why.
    pub(crate) idle: Vec<IdleView>,
}

impl FrameView {
    /// `view` as the frame renders it: the passes see every view relative
    /// to the render origin, as the world matrices and lights are uploaded.
    fn at_origin(view: ResolvedFrameView, origin: glam::DVec3) -> Self {
        let ResolvedFrameView { id, name, role, world, options, graph, links, target } = view;
        FrameView { id, name, role, world, gpu: world.relative_to(origin), options, graph, links, target }
    }
}

/// Views whose targets another view of the frame is linked to. A link
/// names the view, not which of its outputs, so any link counts as reading
/// the HDR image: the cautious answer keeps it written.
pub(crate) fn hdr_readers(views: &[FrameView]) -> BTreeSet<ViewId> {
    views
        .iter()
        .flat_map(|v| {
            v.links.iter().filter_map(move |l| match l {
                OutputSource::View(id) if *id != v.id => Some(*id),
                _ => None,
            })
        })
        .collect()
}

impl Renderer {
    /// What each batch's atlas must hold this frame: its cameras' size,
    /// its tiles, and HDR colour when some camera has blended draws, is
    /// read by another view, or the renderer keeps every HDR image.
    fn batch_plans(&self, views: &[FrameView], frames: &[PreparedSceneFrame]) -> BTreeMap<BatchId, BatchPlan> {
        let readers = hdr_readers(views);
        let mut plans: BTreeMap<BatchId, BatchPlan> = BTreeMap::new();
        for (view, frame) in views.iter().zip(frames) {
            let TargetPlan::Tile { batch, .. } = view.target else { continue };
            let Some(entry) = self.views.batches.get(&batch) else { continue };
            let plan = plans.entry(batch).or_insert(BatchPlan {
                size: entry.size,
                tiles: entry.slots.len() as u32,
                hdr: self.settings.keep_hdr,
                labels: entry.labels,
                max_page_side: entry.max_page_side,
                deferred: entry.graph.shading == crate::batch::BatchShading::Deferred,
            });
            if let Some(e) = self.views.entries.get(&view.id) {
                plan.labels = plan.labels.union(e.labels);
            }
            plan.hdr |= readers.contains(&view.id)
                || frame.partitions_matching(PassMask::TRANSPARENT, PassMask::empty()).next().is_some();
        }
        plans
    }

    /// Step 2: prepares the views `resolved` of `scene` (and the shadow views
    /// they need) and everything the GPU reads of them; `started` is when
    /// the frame began.
    pub(super) fn prepare(
        &mut self,
        scene: &Scene,
        resolved: ResolvedFrame,
        started: Instant,
    ) -> Result<PreparedFrame, RenderError> {
        let _span = info_span!("prepare", views = resolved.views.len()).entered();
        let ResolvedFrame { clock, views: registered, mut warnings, taken } = resolved;
        let heap_bytes_before = self.heap.bytes_written();
        // The origin follows the first colour view (shadow views are passed
        // over when there is another).
        let followed = registered.iter().find(|v| !v.options.depth_only).or(registered.first()).map(|v| &v.world);
        let origin = self.settings.origin.resolve(followed);
        self.prep.set_render_origin(origin);
        let frame = self.prep.begin_frame(scene, &mut self.heap.slots)?;
        // Which views render (their schedules), before any is culled.
        let (kept, idle) = self.schedules.decide(clock, scene, frame, registered, &self.views);
        let why: oxygen_core::ViewIdMap<RenderReason> = kept.iter().map(|(v, reason)| (v.id, *reason)).collect();
        let registered: Vec<ResolvedFrameView> = kept.into_iter().map(|(v, _)| v).collect();

        let owners: Vec<_> = registered
            .iter()
            .filter_map(|v| Some((v.id, v.world, self.views.entries.get(&v.id)?.sun_shadows?)))
            .collect();
        if frame.shadow_sun.is_none() {
            for (view, _, _) in &owners {
                tracing::debug!(view = %view, "sun shadows asked for, no shadow-casting sun");
                warnings.push(FrameWarning::NoSunForShadows { view: *view });
            }
        }
        let (planned, released) = self.shadows.views.plan(&owners, frame, scene, clock.index, clock.time_seconds);
        // Shadow views no light needs any more: their targets and slots go.
        for id in released {
            self.targets.release(id);
            self.prep.forget_view(id, &mut self.heap.slots)?;
        }
        // Shadow cascades are admitted after the registered views' targets
        // and the batches' atlases.
        let mut taken = taken;
        let mut views: Vec<FrameView> = Vec::with_capacity(registered.len() + planned.len());
        for v in registered {
            views.push(FrameView::at_origin(v, origin));
        }
        for shadow in planned {
            let resolved = shadow.resolved.map_err(RenderError::from).and_then(|view| {
                if let ShadowRole::Cascade { .. } = shadow.role {
                    self.targets
                        .admit(view.viewport, false, 1, LabelSet::NONE, &mut taken)
                        .map_err(|e| e.for_view(shadow.id))?;
                }
                Ok(view)
            });
            let world = match resolved {
                Ok(view) => view,
                Err(e) => {
                    warn!(view = %shadow.id, "shadow view skipped this frame: {e}");
                    warnings.push(FrameWarning::ViewSkipped { view: shadow.id, name: None, reason: e.to_string() });
                    continue;
                }
            };
            // A sun cascade culls the way its owner does (frustum culling
            // for an owner with occlusion culling: a shadow map has no
            // pre-pass to build a pyramid from); local shadows the default way.
            let owner_visibility = match shadow.role {
                ShadowRole::Cascade { owner, .. } => views.iter().find(|v| v.id == owner).map(|v| v.options.visibility),
                ShadowRole::Local { .. } => None,
            };
            let visibility = self.visibility.for_view(owner_visibility, true, false);
            let (role, target) = match shadow.role {
                ShadowRole::Cascade { owner, index } => (
                    ViewRole::SunCascade { owner, index },
                    TargetPlan::Own { with_color: false, samples: 1, labels: LabelSet::NONE },
                ),
                ShadowRole::Local { light, face, tile } => {
                    (ViewRole::LocalShadow { light, face, tile }, TargetPlan::AtlasLayer { tile })
                }
            };
            let options = ViewPrepOptions { visibility, ..shadow_view_options() };
            let graph = Arc::clone(&self.shadows.graph);
            let view =
                ResolvedFrameView { id: shadow.id, name: None, role, world, options, graph, links: Vec::new(), target };
            views.push(FrameView::at_origin(view, origin));
        }

        let requests: Vec<ViewRequest<'_>> =
            views.iter().map(|v| ViewRequest { view: &v.world, options: v.options }).collect();
        self.prep.prepare_views(scene, &requests, &mut self.heap.slots)?;
        self.prep.upload(&mut self.heap, &self.gpu.device, &self.gpu.queue)?;
        let seconds = started.elapsed().as_secs_f64();

        let layers = atlas_layers(&views);
        let atlas = (layers > 0).then(|| {
            let resolution = self.shadows.views.local_settings.map_or(1024, |s| s.resolution).max(1);
            self.lighting.local_shadow_atlas(&self.gpu.device, resolution, layers)
        });
        let _targets = info_span!("targets", views = views.len()).entered();
        let frames = self.prep.frames();
        let batches = self.batch_plans(&views, frames);
        let registry = &self.views;
        self.targets.allocate_atlases(
            &self.gpu.device,
            &batches,
            |b| registry.batches.contains_key(&b),
            |b| registry.batch_name(b).unwrap_or("batch").to_string(),
        );
        // Batches with a camera that does not render this frame (idle,
        // paused or skipped): their pages keep that camera's tile.
        let mut rendering: HashMap<BatchId, usize> = HashMap::new();
        for view in &views {
            if let TargetPlan::Tile { batch, .. } = view.target {
                *rendering.entry(batch).or_default() += 1;
            }
        }
        let kept_batches: HashSet<BatchId> = rendering
            .iter()
            .filter(|(batch, n)| registry.batches.get(batch).is_some_and(|b| b.cameras().count() > **n))
            .map(|(batch, _)| *batch)
            .collect();
        let constants_bytes = self.targets.allocate(
            &self.gpu,
            &self.heap,
            &self.probes,
            &views,
            frames,
            atlas.as_ref(),
            clock.time_seconds,
            &kept_batches,
        );
        drop(_targets);
        self.visibility.prepare(&self.gpu, &self.heap, &self.prep, &views, frames);
        self.reference.prepare(&self.gpu, &mut self.heap, &self.prep, &views)?;
        // A set: a scan of the frame's views per clustered view is quadratic
        // in a batch of a thousand cameras.
        let rendered: oxygen_core::ViewIdSet = views.iter().map(|v| v.id).collect();
        self.lighting.retain_views(|id| rendered.contains(&id));
        let uploaded_bytes =
            self.heap.bytes_written() - heap_bytes_before + constants_bytes + self.visibility.uploaded_last_frame();
        let skipped_nodes = self.prep.frame_collection().skipped.iter().map(|s| FrameWarning::NodeSkipped {
            node: s.node,
            name: s.name.clone(),
            reason: s.reason,
        });
        let skipped_nodes = skipped_nodes.collect();
        Ok(PreparedFrame {
            clock,
            origin,
            views,
            frames: self.prep.take_frames(),
            atlas,
            materials: self.prep.material_features(),
            vertex_attributes: self.prep.vertex_attributes(),
            warnings,
            skipped_nodes,
            seconds,
            uploaded_bytes,
            why,
            idle,
        })
    }
}
