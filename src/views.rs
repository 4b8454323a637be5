//! The registry of views: who looks at the scene, what each reads from the
//! others, and in which order they must record. It needs no GPU, so a test
//! can register views and prepare their [`PreparedSceneFrame`]s without one
//! ([`Views::prepare`]); a [`crate::Renderer`] owns one and renders it.
//!
//! The view vocabulary of `oxygen-core` is re-exported here, so that one
//! module names all of it: [`ViewId`], the [`ViewResolver`] contract and its
//! [`ViewContext`] and [`ResolvedView`], the look-at resolvers and the
//! [`Camera`].

use std::collections::BTreeMap;
use std::sync::Arc;

use oxygen_bindless::SlotAllocators;
use oxygen_core::{CascadeSettings, Scene};
use oxygen_core::{Output, OutputSource, ProbeId, ProbeIds};
use oxygen_gpu::LabelSet;

use crate::schedule::Schedule;
use oxygen_sceneprep::{PreparedSceneFrame, ScenePrep, ViewPrepOptions, ViewRequest, Visibility};

use crate::RenderError;
use crate::batch::{BatchDesc, BatchEntry, BatchId, BatchIds};
use crate::graph::{ErasedGraph, RenderGraph};

pub use oxygen_core::{
    Camera, CameraError, DLookAtResolver, LookAtResolver, Projection, ResolvedView, ViewContext, ViewError, ViewId,
    ViewIds, ViewResolver,
};

/// How a view is registered: its resolver, its ScenePrep options, the
/// outputs of other views it reads, and the shadows it owns.
pub struct ViewDesc {
    pub(crate) resolver: Box<dyn ViewResolver>,
    pub(crate) options: ViewPrepOptions,
    pub(crate) links: Vec<OutputSource>,
    pub(crate) sun_shadows: Option<CascadeSettings>,
    pub(crate) target: TargetKind,
    pub(crate) visibility: Option<Visibility>,
    pub(crate) shown: Option<(crate::WindowId, crate::WindowRect)>,
    pub(crate) msaa: oxygen_gpu::Msaa,
    pub(crate) name: Option<String>,
    pub(crate) labels: LabelSet,
    pub(crate) schedule: Schedule,
    pub(crate) priority: u32,
}

/// Where a view renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum TargetKind {
    /// Targets of its own (colour unless depth-only).
    Own,
    /// Face `face` of probe `probe`: that layer of the probe's cube.
    ProbeFace { probe: ProbeId, face: u32 },
    /// Tile `slot` of batch `batch`'s atlas.
    Tile { batch: BatchId, slot: u32 },
}

impl ViewDesc {
    /// A view resolved by `resolver`, with default ScenePrep options.
    pub fn new(resolver: impl ViewResolver + 'static) -> Self {
        ViewDesc {
            resolver: Box::new(resolver),
            options: ViewPrepOptions::default(),
            links: Vec::new(),
            sun_shadows: None,
            target: TargetKind::Own,
            visibility: None,
            shown: None,
            msaa: oxygen_gpu::Msaa::Off,
            name: None,
            labels: LabelSet::NONE,
            schedule: Schedule::EveryFrame,
            priority: 0,
        }
    }

    /// Draws every per-pixel label plane with the colour: the node that
    /// drew each pixel (its instance id), the surface's world-space normal,
    /// the node's semantic class and the surface's linear depth, readable
    /// with [`crate::Renderer::read_labels`] and linkable
    /// ([`ViewId::instance_ids`], [`ViewId::normals`],
    /// [`ViewId::semantic_classes`], [`ViewId::linear_depth`]). The standard
    /// graphs' shading pass writes them (no geometry pass of their own);
    /// they cost 20 bytes a pixel of targets. Single-sampled colour views
    /// only: with MSAA, or on a depth-only view, registration refuses it.
    pub fn with_labels(self) -> Self {
        self.with_label_planes(LabelSet::ALL)
    }

    /// Draws the label planes of `planes` only (see
    /// [`ViewDesc::with_labels`]): a view pays only for what it reads.
    pub fn with_label_planes(mut self, planes: LabelSet) -> Self {
        self.labels = planes;
        self
    }

    /// When the view renders ([`Schedule`]; every frame by default). A
    /// view that does not render in a frame keeps its last images, and the
    /// views linked to it read them. Registration refuses a schedule that
    /// cannot be kept (every 0th frame, a rate that is not a positive
    /// number). A batch camera that does not render keeps its tile: its
    /// page is then loaded and each rendering camera's tile cleared alone.
    pub fn with_schedule(mut self, schedule: Schedule) -> Self {
        self.schedule = schedule;
        self
    }

    /// The view's priority under a frame budget
    /// ([`crate::Renderer::set_frame_budget`]): when the views due in a
    /// frame would pass the budget, those of lower priority are deferred
    /// first (0, the default, is the lowest).
    pub fn with_priority(mut self, priority: u32) -> Self {
        self.priority = priority;
        self
    }

    /// Names the view: reports ([`crate::ViewReport::name`]), warnings and
    /// logs use the name beside its id, and tools name its files after it.
    pub fn named(mut self, name: impl Into<String>) -> Self {
        self.name = Some(name.into());
        self
    }

    /// Anti-aliases the view's mesh passes with `msaa` samples per pixel
    /// (depth pre-pass, shading and transparent passes, all four variants;
    /// the colour resolves before the tone map). Costs: the multisampled
    /// targets' memory (counted against the target budget) and time
    /// (docs/performance.md); a multisampled view has no depth output for
    /// other views to read, and GPU occlusion culling falls back to GPU
    /// frustum culling for it (its depth pyramid needs a single-sample
    /// depth). Where the adapter cannot multisample the HDR format at that
    /// count, the renderer uses the largest count it can, with a warning.
    pub fn with_msaa(mut self, msaa: oxygen_gpu::Msaa) -> Self {
        self.msaa = msaa;
        self
    }

    /// Shows the view in `rect` of `window` ([`crate::Renderer::add_window`]):
    /// each frame its image is composed there and presented. The view
    /// follows the window: its size (targets, aspect ratio) is the
    /// rectangle's size in pixels, whatever its resolver's viewport says,
    /// and it is not rendered while the window is minimised.
    pub fn shown_in(mut self, window: crate::WindowId, rect: crate::WindowRect) -> Self {
        self.shown = Some((window, rect));
        self
    }

    /// Where the view's visibility is decided ([`Visibility`]); without it
    /// the renderer's default for the adapter ([`Renderer::visibility`]).
    /// A GPU path the device cannot run falls back to the CPU path with a
    /// warning; a depth-only view asking for occlusion culling gets frustum
    /// culling (it has no depth pre-pass to build a pyramid from).
    ///
    /// [`Renderer::visibility`]: crate::Renderer::visibility
    pub fn with_visibility(mut self, visibility: Visibility) -> Self {
        self.visibility = Some(visibility);
        self
    }

    /// Makes the view a path-traced reference: ScenePrep keeps the
    /// ray-tracing scene for it and the renderer's tracer accumulates its
    /// samples. Register it with a [`ReferenceGraph`](crate::graph::ReferenceGraph)
    /// (e.g. [`reference_render_graph`](crate::graph::reference_render_graph)); its
    /// raster draws are still prepared on the CPU path, unused.
    pub fn path_traced(mut self) -> Self {
        self.options.ray_scene = true;
        self.visibility = Some(Visibility::Cpu);
        self
    }

    /// ScenePrep options (filter, cull bound, depth only).
    pub fn with_options(mut self, options: ViewPrepOptions) -> Self {
        self.options = options;
        self
    }

    /// Links the view to `output`: the view records after whoever produces
    /// it, and its graph may read it (`RenderContext::input`). A probe cube
    /// linked this way is also reflected by the forward lit pass.
    pub fn reads<K>(mut self, output: Output<K>) -> Self {
        if !self.links.contains(&output.source) {
            self.links.push(output.source);
        }
        self
    }

    /// The view owns sun-shadow cascades: each frame in which a directional
    /// light casts shadows, the renderer renders `settings.count` cascade
    /// views fitted to this view's frustum before it (created, resized and
    /// removed with it, following the lights that exist that frame), and its
    /// forward lit pass samples them.
    pub fn with_sun_shadows(mut self, settings: CascadeSettings) -> Self {
        self.sun_shadows = Some(settings);
        self
    }
}

/// The name of a registered batch (empty when it is not).
fn entry_name(batches: &BTreeMap<BatchId, BatchEntry>, batch: BatchId) -> &str {
    batches.get(&batch).map_or("", |b| b.name.as_str())
}

impl<R: ViewResolver + 'static> From<R> for ViewDesc {
    fn from(resolver: R) -> Self {
        ViewDesc::new(resolver)
    }
}

pub(crate) struct ViewEntry {
    pub(crate) resolver: Box<dyn ViewResolver>,
    pub(crate) graph: Arc<dyn ErasedGraph>,
    pub(crate) options: ViewPrepOptions,
    pub(crate) links: Vec<OutputSource>,
    pub(crate) sun_shadows: Option<CascadeSettings>,
    pub(crate) target: TargetKind,
    pub(crate) active: bool,
    pub(crate) visibility: Option<Visibility>,
    pub(crate) shown: Option<(crate::WindowId, crate::WindowRect)>,
    pub(crate) msaa: oxygen_gpu::Msaa,
    pub(crate) name: Option<Arc<str>>,
    pub(crate) labels: LabelSet,
    pub(crate) schedule: Schedule,
    pub(crate) priority: u32,
}

/// The registered views and the links between them; no GPU needed.
pub struct Views {
    pub(crate) entries: BTreeMap<ViewId, ViewEntry>,
    /// Registered batches and their cameras' tiles.
    pub(crate) batches: BTreeMap<BatchId, BatchEntry>,
    batch_ids: BatchIds,
    /// Face views of each registered probe.
    pub(crate) probes: BTreeMap<ProbeId, [ViewId; oxygen_passes::PROBE_FACES]>,
    /// The application's ids; the renderer's own views take theirs from
    /// ranges of its own.
    ids: ViewIds,
    probe_ids: ProbeIds,
    cpu: Option<CpuPrep>,
}

/// ScenePrep for [`Views::prepare`], with slot allocators of its own.
struct CpuPrep {
    prep: ScenePrep,
    slots: SlotAllocators,
    frame_index: u64,
}

impl Default for Views {
    fn default() -> Self {
        Self::new()
    }
}

impl Views {
    /// No views.
    pub fn new() -> Self {
        Views {
            entries: BTreeMap::new(),
            batches: BTreeMap::new(),
            batch_ids: BatchIds::default(),
            probes: BTreeMap::new(),
            ids: ViewIds::default(),
            probe_ids: ProbeIds::default(),
            cpu: None,
        }
    }

    /// Registers a view (a resolver, or a [`ViewDesc`] with links and
    /// options) with the graph it records each frame. Fails when a link
    /// names a view or probe that is not registered.
    pub fn register(&mut self, desc: impl Into<ViewDesc>, graph: impl RenderGraph) -> Result<ViewId, RenderError> {
        let desc = desc.into();
        if let Some(reason) = desc.schedule.problem() {
            return Err(RenderError::InvalidSchedule { view: None, reason });
        }
        if !desc.labels.is_empty() && (desc.msaa != oxygen_gpu::Msaa::Off || desc.options.depth_only) {
            return Err(RenderError::Unsupported(
                "labels (ViewDesc::with_labels) on a multisampled or depth-only view".into(),
            ));
        }
        for link in &desc.links {
            self.check_source(*link)?;
        }
        let id = self.ids.allocate();
        self.insert(id, desc, graph);
        Ok(id)
    }

    /// Registers a view under an id the renderer allocated from a range of
    /// its own (a reflection probe's face), so that it is resolved,
    /// prepared and recorded like the application's views.
    pub(crate) fn register_owned(&mut self, id: ViewId, desc: ViewDesc, graph: impl RenderGraph) {
        self.insert(id, desc, graph);
    }

    fn insert(&mut self, id: ViewId, desc: ViewDesc, graph: impl RenderGraph) {
        self.insert_erased(id, desc, Arc::new(graph));
    }

    fn insert_erased(&mut self, id: ViewId, desc: ViewDesc, graph: Arc<dyn ErasedGraph>) {
        self.entries.insert(
            id,
            ViewEntry {
                resolver: desc.resolver,
                graph,
                options: desc.options,
                links: desc.links,
                sun_shadows: desc.sun_shadows,
                target: desc.target,
                active: true,
                visibility: desc.visibility,
                shown: desc.shown,
                msaa: desc.msaa,
                name: desc.name.map(Arc::from),
                labels: desc.labels,
                schedule: desc.schedule,
                priority: desc.priority,
            },
        );
        tracing::info!(view = %id, name = ?self.name(id), "view registered");
    }

    pub(crate) fn allocate_probe(&mut self) -> ProbeId {
        self.probe_ids.allocate()
    }

    fn check_source(&self, source: OutputSource) -> Result<(), RenderError> {
        match source {
            OutputSource::View(v) if !self.entries.contains_key(&v) => Err(RenderError::NoSuchView(v)),
            OutputSource::Probe(p) if !self.probes.contains_key(&p) => Err(RenderError::NoSuchProbe(p)),
            _ => Ok(()),
        }
    }

    /// Links `view` to `output` after registration (for a view registered
    /// before what it reads). Fails when either is not registered, or when
    /// the link would close a cycle (the view would have to record before
    /// itself).
    pub fn link<K>(&mut self, view: impl Into<ViewId>, output: Output<K>) -> Result<(), RenderError> {
        let view = view.into();
        self.check_source(output.source)?;
        if !self.entries.contains_key(&view) {
            return Err(RenderError::NoSuchView(view));
        }
        // A cycle exists when the producer already depends, through links,
        // on `view`.
        if self.producers(output.source).iter().any(|p| *p == view || self.depends_on(*p, view)) {
            return Err(RenderError::LinkCycle { view, output: output.source.to_string() });
        }
        let links = &mut self.entries.get_mut(&view).ok_or(RenderError::NoSuchView(view))?.links;
        if !links.contains(&output.source) {
            links.push(output.source);
        }
        Ok(())
    }

    /// The views that produce `source`.
    pub(crate) fn producers(&self, source: OutputSource) -> Vec<ViewId> {
        match source {
            OutputSource::View(v) => vec![v],
            OutputSource::Probe(p) => self.probes.get(&p).map(|faces| faces.to_vec()).unwrap_or_default(),
        }
    }

    /// Whether `from` reads, directly or through other links, what `to` produces.
    fn depends_on(&self, from: ViewId, to: ViewId) -> bool {
        let mut stack = vec![from];
        let mut seen = std::collections::BTreeSet::new();
        while let Some(v) = stack.pop() {
            if !seen.insert(v) {
                continue;
            }
            let Some(entry) = self.entries.get(&v) else { continue };
            for source in &entry.links {
                for p in self.producers(*source) {
                    if p == to {
                        return true;
                    }
                    stack.push(p);
                }
            }
        }
        false
    }

    /// Registers a batch of cameras ([`crate::batch`]); it has no camera
    /// until [`Views::add_camera`] adds one. Fails when the cameras' size
    /// is empty.
    pub fn register_batch(&mut self, desc: BatchDesc) -> Result<BatchId, RenderError> {
        let BatchDesc { name, size, graph, max_page_side, labels } = desc;
        if size.x == 0 || size.y == 0 {
            return Err(RenderError::InvalidBatch { name, reason: format!("its cameras' size {size} is empty") });
        }
        if max_page_side.is_some_and(|side| side < size.x.max(size.y)) {
            let reason = format!("its pages ({max_page_side:?} pixels a side) cannot hold one {size} camera");
            return Err(RenderError::InvalidBatch { name, reason });
        }
        let id = self.batch_ids.allocate();
        let graph = Arc::new(graph);
        self.batches.insert(id, BatchEntry { name, size, graph, max_page_side, labels, slots: Vec::new() });
        tracing::info!(batch = %id, "batch registered");
        Ok(id)
    }

    /// Adds a camera to `batch`: a view (its own id, resolver, prepared
    /// frame and outputs) that renders into a tile of the batch's atlas
    /// at the batch's size, with the batch's graph, its visibility decided
    /// as the view asks (`ViewDesc::with_visibility`; by default the
    /// renderer's default for the adapter; occlusion culling falls back to
    /// frustum culling, the batch graph having no depth pre-pass phases).
    /// Links (`ViewDesc::reads`) are kept; what a batch camera cannot have
    /// is refused: anti-aliasing, sun cascades of its own, a window
    /// rectangle, a path-traced reference, a visibility path other than
    /// the batch's other cameras' (the same `with_visibility`, or none for
    /// all). Remove it with
    /// [`Views::unregister`].
    pub fn add_camera(&mut self, batch: BatchId, desc: impl Into<ViewDesc>) -> Result<ViewId, RenderError> {
        let desc = desc.into();
        let entry = self.batches.get(&batch).ok_or(RenderError::NoSuchBatch(batch))?;
        let refused = if desc.msaa != oxygen_gpu::Msaa::Off {
            Some("anti-aliasing (MSAA)")
        } else if desc.sun_shadows.is_some() {
            Some("sun cascades of its own")
        } else if desc.shown.is_some() {
            Some("a window rectangle")
        } else if desc.options.ray_scene {
            Some("a path-traced reference")
        } else {
            None
        };
        if let Some(what) = refused {
            return Err(RenderError::InvalidBatch {
                name: entry.name.clone(),
                reason: format!("a batch camera cannot have {what}"),
            });
        }
        // One visibility path for the whole batch: its cameras are culled
        // and drawn together (a camera culled on the CPU among cameras
        // culled on the GPU drew the wrong draws).
        if let Some(first) = entry.cameras().next().and_then(|c| self.entries.get(&c))
            && first.visibility != desc.visibility
        {
            let path = |v: Option<Visibility>| v.map_or("the renderer's default".to_owned(), |v| format!("{v:?}"));
            return Err(RenderError::InvalidBatch {
                name: entry.name.clone(),
                reason: format!(
                    "a batch's cameras share one visibility path: its cameras use {}, this camera asks for {}",
                    path(first.visibility),
                    path(desc.visibility)
                ),
            });
        }
        for link in &desc.links {
            self.check_source(*link)?;
        }
        let graph = Arc::clone(&entry.graph);
        let labels = desc.labels.union(entry.labels);
        let id = self.ids.allocate();
        let slot = self.batches.get_mut(&batch).ok_or(RenderError::NoSuchBatch(batch))?.take_slot(id);
        // A camera without a name of its own is named after its batch and tile.
        let name = desc.name.clone().or_else(|| Some(format!("{}[{slot}]", entry_name(&self.batches, batch))));
        let target = TargetKind::Tile { batch, slot };
        let desc = ViewDesc { target, name, labels, ..desc };
        self.insert_erased(id, desc, graph);
        Ok(id)
    }

    /// Removes a batch and its cameras.
    pub fn unregister_batch(&mut self, batch: BatchId) -> Result<(), RenderError> {
        let entry = self.batches.get(&batch).ok_or(RenderError::NoSuchBatch(batch))?;
        let cameras: Vec<ViewId> = entry.cameras().collect();
        for camera in cameras {
            self.unregister(camera)?;
        }
        self.batches.remove(&batch);
        Ok(())
    }

    /// The cameras of `batch`, in tile order.
    pub fn batch_cameras(&self, batch: BatchId) -> Result<Vec<ViewId>, RenderError> {
        Ok(self.batches.get(&batch).ok_or(RenderError::NoSuchBatch(batch))?.cameras().collect())
    }

    /// The batch `view` is a camera of, if any.
    pub fn batch_of(&self, view: ViewId) -> Option<BatchId> {
        match self.entries.get(&view)?.target {
            TargetKind::Tile { batch, .. } => Some(batch),
            _ => None,
        }
    }

    /// The name a view was registered with ([`ViewDesc::named`]), if any.
    pub fn name(&self, view: ViewId) -> Option<&str> {
        self.entries.get(&view)?.name.as_deref()
    }

    /// The view called `name`, if one is (the first registered, when
    /// several share it).
    pub fn find(&self, name: &str) -> Option<ViewId> {
        self.entries.iter().find(|(_, e)| e.name.as_deref() == Some(name)).map(|(id, _)| *id)
    }

    /// The name of `batch`.
    pub fn batch_name(&self, batch: BatchId) -> Option<&str> {
        self.batches.get(&batch).map(|b| b.name.as_str())
    }

    /// Removes a view (a batch camera frees its tile); links to it from
    /// other views are dropped.
    pub fn unregister(&mut self, id: impl Into<ViewId>) -> Result<(), RenderError> {
        let id = id.into();
        let entry = self.entries.remove(&id).ok_or(RenderError::NoSuchView(id))?;
        if let TargetKind::Tile { batch, .. } = entry.target
            && let Some(batch) = self.batches.get_mut(&batch)
        {
            batch.free_slot(id);
        }
        for entry in self.entries.values_mut() {
            entry.links.retain(|l| *l != OutputSource::View(id));
        }
        Ok(())
    }

    /// Changes when a view renders ([`ViewDesc::with_schedule`]); refuses
    /// what registration would refuse.
    pub fn set_schedule(&mut self, id: impl Into<ViewId>, schedule: Schedule) -> Result<(), RenderError> {
        let id = id.into();
        if let Some(reason) = schedule.problem() {
            return Err(RenderError::InvalidSchedule { view: Some(id), reason });
        }
        self.entries.get_mut(&id).ok_or(RenderError::NoSuchView(id))?.schedule = schedule;
        Ok(())
    }

    /// Whether `id` is a registered view (a batch's cameras included).
    pub(crate) fn contains(&self, id: ViewId) -> bool {
        self.entries.contains_key(&id)
    }

    /// Pauses (`false`) or resumes a view.
    pub fn set_active(&mut self, id: impl Into<ViewId>, active: bool) -> Result<(), RenderError> {
        let id = id.into();
        self.entries.get_mut(&id).ok_or(RenderError::NoSuchView(id))?.active = active;
        Ok(())
    }

    /// Registered views, in id order.
    pub fn ids(&self) -> impl Iterator<Item = ViewId> + '_ {
        self.entries.keys().copied()
    }

    /// Prepares one registered view's [`PreparedSceneFrame`] of `scene`
    /// without a GPU: its resolver, its ScenePrep options, the default render
    /// origin (centred on this view's camera, as a renderer with only this
    /// view would), on one thread. Slots come from allocators of this
    /// registry's own, so the ranges in the frame are what a fresh renderer
    /// would use. For snapshot tests of what a view would draw.
    pub fn prepare(&mut self, scene: &Scene, id: impl Into<ViewId>) -> Result<&PreparedSceneFrame, RenderError> {
        let id = id.into();
        let entry = self.entries.get(&id).ok_or(RenderError::NoSuchView(id))?;
        let cpu = self.cpu.get_or_insert_with(|| CpuPrep {
            prep: ScenePrep::with_threads(1),
            // The binding limit of a typical device; only ranges' positions depend on it.
            slots: SlotAllocators::new(128 << 20),
            frame_index: 0,
        });
        cpu.frame_index += 1;
        let ctx = ViewContext { view_id: id, frame_index: cpu.frame_index, time_seconds: 0.0 };
        let mut resolved = entry.resolver.resolve(&ctx, scene)?;
        resolved.view_id = id;
        // A batch camera renders at its batch's size, as the renderer resolves it.
        if let TargetKind::Tile { batch, .. } = entry.target
            && let Some(size) = self.batches.get(&batch).map(|b| b.size)
            && size != resolved.viewport
        {
            resolved = resolved.with_viewport(size)?;
        }
        let origin = crate::RenderOrigin::default().resolve(Some(&resolved));
        cpu.prep.set_render_origin(origin);
        let request = ViewRequest { view: &resolved, options: entry.options };
        let frames = cpu.prep.prepare(scene, &[request], &mut cpu.slots)?;
        // One request, so one frame.
        Ok(&frames[0])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::standard_render_graph;
    use glam::{UVec2, Vec3, Vec4};
    use oxygen_core::{Geometry, Light, Material, Renderable, Transform, ViewIdRange};
    use oxygen_gpu::{Label, Msaa};

    fn camera() -> LookAtResolver {
        LookAtResolver::new(
            Camera::perspective(50f32.to_radians(), 0.1, Some(60.0)),
            Vec3::new(0.0, 2.0, 8.0),
            Vec3::ZERO,
            UVec2::new(64, 48),
        )
        .unwrap()
    }

    fn register(views: &mut Views, desc: impl Into<ViewDesc>) -> ViewId {
        views.register(desc, standard_render_graph).unwrap()
    }

    fn links(views: &Views, view: ViewId) -> Vec<OutputSource> {
        views.entries[&view].links.clone()
    }

    /// An id that was registered and is not any more.
    fn gone(views: &mut Views) -> ViewId {
        let id = register(views, camera());
        views.unregister(id).unwrap();
        id
    }

    /// A probe as the renderer registers one: its six faces under ids of the
    /// probe-face range, then the probe.
    fn add_probe(views: &mut Views, face_ids: &mut ViewIds) -> (ProbeId, [ViewId; oxygen_passes::PROBE_FACES]) {
        let probe = views.allocate_probe();
        let faces = std::array::from_fn(|face| {
            let id = face_ids.allocate();
            let mut desc = ViewDesc::new(camera());
            desc.target = TargetKind::ProbeFace { probe, face: face as u32 };
            views.register_owned(id, desc, standard_render_graph);
            id
        });
        views.probes.insert(probe, faces);
        (probe, faces)
    }

    fn rig(size: UVec2) -> BatchDesc {
        BatchDesc::new("rig", size)
    }

    fn looking_down(size: UVec2) -> LookAtResolver {
        LookAtResolver::new(
            Camera::perspective(60f32.to_radians(), 0.1, None),
            Vec3::new(0.0, 9.0, 0.0),
            Vec3::ZERO,
            size,
        )
        .unwrap()
        .with_up(Vec3::NEG_Z)
        .unwrap()
    }

    /// Nine unit boxes on a 3 × 3 grid, two units apart, under a sun.
    fn boxes() -> Scene {
        let mut scene = Scene::new();
        let grey = scene.add_material(Material::opaque("grey", Vec4::splat(0.6)));
        let cube = scene.add_geometry(Geometry::cube(1.0));
        for row in 0..3 {
            for column in 0..3 {
                let at = Vec3::new(column as f32 * 2.0 - 2.0, 0.5, row as f32 * 2.0 - 2.0);
                let node = scene.add_node("box", Transform::from_translation(at));
                scene.set_renderable(node, Renderable { geometry: cube, materials: vec![grey] }).unwrap();
            }
        }
        let sun = scene.add_node("sun", Transform::IDENTITY);
        scene.set_light(sun, Some(Light::directional(1.0))).unwrap();
        scene
    }

    #[test]
    fn a_description_keeps_what_its_builders_ask_for() {
        let cascades = CascadeSettings { count: 2, ..Default::default() };
        let options = ViewPrepOptions { lod_bias: 2.0, ..Default::default() };
        let rect = crate::WindowRect::grid(2, 1, 1, 0);
        let desc = ViewDesc::new(camera())
            .with_options(options)
            .with_label_planes(LabelSet::of(&[Label::Normal]))
            .with_schedule(Schedule::EveryNth(4))
            .with_priority(7)
            .named("main")
            .with_msaa(Msaa::X4)
            .shown_in(crate::WindowId(3), rect)
            .with_visibility(Visibility::GpuFrustum)
            .with_sun_shadows(cascades);
        assert_eq!(desc.options, options);
        assert_eq!(desc.labels, LabelSet::of(&[Label::Normal]));
        assert_eq!(desc.schedule, Schedule::EveryNth(4));
        assert_eq!(desc.priority, 7);
        assert_eq!(desc.name.as_deref(), Some("main"));
        assert_eq!(desc.msaa, Msaa::X4);
        assert_eq!(desc.shown, Some((crate::WindowId(3), rect)));
        assert_eq!(desc.visibility, Some(Visibility::GpuFrustum));
        assert_eq!(desc.sun_shadows, Some(cascades));
        assert_eq!(desc.target, TargetKind::Own);
        assert_eq!(ViewDesc::new(camera()).with_labels().labels, LabelSet::ALL);
    }

    /// A path-traced reference is prepared on the CPU path whatever else it
    /// was told, and keeps the ray-tracing scene.
    #[test]
    fn a_path_traced_view_keeps_the_ray_scene_and_is_culled_on_the_cpu() {
        let desc = ViewDesc::new(camera()).with_visibility(Visibility::GpuOcclusion).path_traced();
        assert!(desc.options.ray_scene);
        assert_eq!(desc.visibility, Some(Visibility::Cpu));
    }

    #[test]
    fn reading_two_outputs_of_one_view_links_it_once() {
        let mut views = Views::new();
        let [a, b] = std::array::from_fn(|_| register(&mut views, camera()));
        let desc = ViewDesc::new(camera()).reads(a.hdr()).reads(a.depth()).reads(b.depth());
        assert_eq!(desc.links, [OutputSource::View(a), OutputSource::View(b)]);
    }

    #[test]
    fn a_registered_view_keeps_its_description_and_starts_active() {
        let mut views = Views::new();
        let source = register(&mut views, camera());
        let desc = ViewDesc::from(camera())
            .named("main")
            .with_schedule(Schedule::Once)
            .with_priority(3)
            .with_msaa(Msaa::X2)
            .reads(source.depth());
        let id = register(&mut views, desc);
        let entry = &views.entries[&id];
        assert!(entry.active);
        assert_eq!(entry.name.as_deref(), Some("main"));
        assert_eq!(entry.schedule, Schedule::Once);
        assert_eq!(entry.priority, 3);
        assert_eq!(entry.msaa, Msaa::X2);
        assert_eq!(entry.links, [OutputSource::View(source)]);
        assert_eq!(entry.target, TargetKind::Own);
    }

    #[test]
    fn registered_views_get_fresh_application_ids_listed_in_order() {
        let mut views = Views::default();
        let ids: Vec<ViewId> = (0..3).map(|_| register(&mut views, camera())).collect();
        assert_eq!(views.ids().collect::<Vec<_>>(), ids);
        assert!(ids.windows(2).all(|w| w[0] < w[1]));
        assert!(ids.iter().all(|id| id.range() == ViewIdRange::Application));
    }

    #[test]
    fn labels_are_refused_on_a_multisampled_or_depth_only_view_only() {
        let mut views = Views::new();
        let depth_only = ViewPrepOptions { depth_only: true, ..Default::default() };
        for refused in [
            ViewDesc::new(camera()).with_labels().with_msaa(Msaa::X2),
            ViewDesc::new(camera()).with_labels().with_options(depth_only),
        ] {
            let result = views.register(refused, standard_render_graph);
            assert!(matches!(result, Err(RenderError::Unsupported(_))), "{result:?}");
        }
        assert_eq!(views.ids().count(), 0);
        register(&mut views, ViewDesc::new(camera()).with_labels());
        register(&mut views, ViewDesc::new(camera()).with_msaa(Msaa::X4));
        register(&mut views, ViewDesc::new(camera()).with_options(depth_only));
        assert_eq!(views.ids().count(), 3);
    }

    #[test]
    fn a_schedule_that_cannot_be_kept_is_refused_at_registration() {
        let mut views = Views::new();
        for schedule in [Schedule::EveryNth(0), Schedule::Rate(0.0), Schedule::Rate(f64::NAN)] {
            let result = views.register(ViewDesc::new(camera()).with_schedule(schedule), standard_render_graph);
            assert!(matches!(result, Err(RenderError::InvalidSchedule { view: None, .. })), "{result:?}");
        }
        assert_eq!(views.ids().count(), 0);
    }

    #[test]
    fn a_view_reading_a_missing_view_or_probe_is_refused() {
        let mut views = Views::new();
        let gone = gone(&mut views);
        let result = views.register(ViewDesc::new(camera()).reads(gone.hdr()), standard_render_graph);
        assert!(matches!(result, Err(RenderError::NoSuchView(v)) if v == gone), "{result:?}");
        let unregistered = views.allocate_probe();
        let result = views.register(ViewDesc::new(camera()).reads(unregistered.cube()), standard_render_graph);
        assert!(matches!(result, Err(RenderError::NoSuchProbe(p)) if p == unregistered), "{result:?}");
        assert_eq!(views.ids().count(), 0);
    }

    #[test]
    fn a_view_may_read_registered_views_and_probes() {
        let mut views = Views::new();
        let (probe, _) = add_probe(&mut views, &mut ViewIds::new(ViewIdRange::ProbeFace));
        let a = register(&mut views, camera());
        let reader = register(&mut views, ViewDesc::new(camera()).reads(a.hdr()).reads(probe.cube()));
        assert_eq!(links(&views, reader), [OutputSource::View(a), OutputSource::Probe(probe)]);
    }

    #[test]
    fn a_probe_face_is_a_view_under_the_id_the_renderer_gave_it() {
        let mut views = Views::new();
        let (probe, faces) = add_probe(&mut views, &mut ViewIds::new(ViewIdRange::ProbeFace));
        assert_eq!(views.ids().collect::<Vec<_>>(), faces);
        assert_eq!(views.entries[&faces[4]].target, TargetKind::ProbeFace { probe, face: 4 });
        // The application's ids are not taken by the faces.
        assert_eq!(register(&mut views, camera()).to_string(), "view#0");
    }

    #[test]
    fn linking_adds_a_producer_once() {
        let mut views = Views::new();
        let [a, b] = std::array::from_fn(|_| register(&mut views, camera()));
        views.link(b, a.hdr()).unwrap();
        views.link(b, a.depth()).unwrap();
        assert_eq!(links(&views, b), [OutputSource::View(a)]);
        assert!(links(&views, a).is_empty());
    }

    #[test]
    fn linking_from_or_to_what_is_not_registered_fails() {
        let mut views = Views::new();
        let a = register(&mut views, camera());
        let gone = gone(&mut views);
        let result = views.link(gone, a.hdr());
        assert!(matches!(result, Err(RenderError::NoSuchView(v)) if v == gone), "{result:?}");
        let result = views.link(a, gone.hdr());
        assert!(matches!(result, Err(RenderError::NoSuchView(v)) if v == gone), "{result:?}");
        let unregistered = views.allocate_probe();
        let result = views.link(a, unregistered.cube());
        assert!(matches!(result, Err(RenderError::NoSuchProbe(p)) if p == unregistered), "{result:?}");
        assert!(links(&views, a).is_empty());
    }

    #[test]
    fn a_link_to_itself_or_back_through_other_views_closes_a_cycle() {
        let mut views = Views::new();
        let a = register(&mut views, camera());
        let b = register(&mut views, ViewDesc::new(camera()).reads(a.hdr()));
        let c = register(&mut views, ViewDesc::new(camera()).reads(b.depth()));
        let result = views.link(a, a.depth());
        assert!(matches!(&result, Err(RenderError::LinkCycle { view, output }) if *view == a && output == "view#0"));
        let result = views.link(a, c.hdr());
        assert!(matches!(&result, Err(RenderError::LinkCycle { view, output }) if *view == a && output == "view#2"));
        assert!(links(&views, a).is_empty(), "a refused link is not added");
    }

    /// Reading a view that reads others is no cycle: only a path back to
    /// the reader is.
    #[test]
    fn a_view_may_link_to_a_view_that_reads_others() {
        let mut views = Views::new();
        let a = register(&mut views, camera());
        let b = register(&mut views, ViewDesc::new(camera()).reads(a.hdr()));
        let d = register(&mut views, camera());
        views.link(d, b.hdr()).unwrap();
        views.link(d, a.hdr()).unwrap();
        assert_eq!(links(&views, d), [OutputSource::View(b), OutputSource::View(a)]);
    }

    /// A probe's cube is produced by its six faces: a face cannot read a
    /// view that reads the cube, nor a view the cube of a probe whose faces
    /// read that view.
    #[test]
    fn a_probes_faces_and_the_views_reading_its_cube_cannot_wait_for_each_other() {
        let mut views = Views::new();
        let mut face_ids = ViewIds::new(ViewIdRange::ProbeFace);
        let (probe, faces) = add_probe(&mut views, &mut face_ids);
        let reader = register(&mut views, ViewDesc::new(camera()).reads(probe.cube()));
        let result = views.link(faces[2], reader.hdr());
        assert!(matches!(result, Err(RenderError::LinkCycle { view, .. }) if view == faces[2]), "{result:?}");

        let (other, other_faces) = add_probe(&mut views, &mut face_ids);
        let source = register(&mut views, camera());
        views.link(other_faces[5], source.hdr()).unwrap();
        let result = views.link(source, other.cube());
        assert!(matches!(&result, Err(RenderError::LinkCycle { output, .. }) if output == "probe#1"), "{result:?}");
    }

    #[test]
    fn a_batch_needs_cameras_of_some_size() {
        let mut views = Views::new();
        for size in [UVec2::new(0, 8), UVec2::new(8, 0)] {
            let result = views.register_batch(rig(size));
            assert!(matches!(&result, Err(RenderError::InvalidBatch { name, .. }) if name == "rig"), "{result:?}");
        }
        let batch = views.register_batch(rig(UVec2::new(8, 8))).unwrap();
        assert_eq!(views.batch_name(batch), Some("rig"));
    }

    #[test]
    fn a_batchs_pages_must_hold_one_camera_on_its_longer_side() {
        let mut views = Views::new();
        let size = UVec2::new(8, 16);
        let result = views.register_batch(rig(size).with_max_page_side(15));
        assert!(matches!(result, Err(RenderError::InvalidBatch { .. })), "{result:?}");
        for side in [16, 32] {
            let batch = views.register_batch(rig(size).with_max_page_side(side)).unwrap();
            assert_eq!(views.batches[&batch].max_page_side, Some(side));
        }
    }

    #[test]
    fn batch_cameras_take_tiles_in_order_and_are_named_after_their_batch_and_tile() {
        let mut views = Views::new();
        let lone = register(&mut views, camera());
        let batch = views.register_batch(rig(UVec2::new(8, 8))).unwrap();
        let x = views.add_camera(batch, camera()).unwrap();
        let y = views.add_camera(batch, ViewDesc::new(camera()).named("left eye")).unwrap();
        let z = views.add_camera(batch, camera()).unwrap();
        assert_eq!(views.batch_cameras(batch).unwrap(), [x, y, z]);
        assert_eq!([views.name(x), views.name(y), views.name(z)], [Some("rig[0]"), Some("left eye"), Some("rig[2]")]);
        assert_eq!(views.entries[&z].target, TargetKind::Tile { batch, slot: 2 });
        assert_eq!([views.batch_of(x), views.batch_of(lone)], [Some(batch), None]);
        assert_eq!(views.ids().collect::<Vec<_>>(), [lone, x, y, z]);
    }

    #[test]
    fn a_batch_camera_draws_the_label_planes_of_its_own_and_its_batchs() {
        let mut views = Views::new();
        let batch =
            views.register_batch(rig(UVec2::new(8, 8)).with_label_planes(LabelSet::of(&[Label::Instance]))).unwrap();
        let id = views.add_camera(batch, ViewDesc::new(camera()).with_label_planes(LabelSet::of(&[Label::Normal])));
        let labels = views.entries[&id.unwrap()].labels;
        assert_eq!(labels, LabelSet::of(&[Label::Instance, Label::Normal]));
    }

    #[test]
    fn a_batch_camera_cannot_have_msaa_sun_cascades_a_window_or_a_path_traced_reference() {
        let mut views = Views::new();
        let batch = views.register_batch(rig(UVec2::new(8, 8))).unwrap();
        for (desc, what) in [
            (ViewDesc::new(camera()).with_msaa(Msaa::X4), "anti-aliasing"),
            (ViewDesc::new(camera()).with_sun_shadows(CascadeSettings::default()), "sun cascades"),
            (ViewDesc::new(camera()).shown_in(crate::WindowId(0), crate::WindowRect::FULL), "a window rectangle"),
            (ViewDesc::new(camera()).path_traced(), "a path-traced reference"),
        ] {
            let reason = match views.add_camera(batch, desc) {
                Err(RenderError::InvalidBatch { name, reason }) if name == "rig" => reason,
                other => panic!("{what}: {other:?}"),
            };
            assert!(reason.contains(what), "{what}: {reason}");
        }
        assert!(views.batch_cameras(batch).unwrap().is_empty());
        assert_eq!(views.ids().count(), 0);
    }

    #[test]
    fn a_batchs_cameras_share_one_visibility_path() {
        let mut views = Views::new();
        let batch = views.register_batch(rig(UVec2::new(8, 8))).unwrap();
        let gpu = || ViewDesc::new(camera()).with_visibility(Visibility::GpuFrustum);
        views.add_camera(batch, gpu()).unwrap();
        views.add_camera(batch, gpu()).unwrap();
        for other in [ViewDesc::new(camera()).with_visibility(Visibility::Cpu), ViewDesc::new(camera())] {
            let result = views.add_camera(batch, other);
            assert!(matches!(&result, Err(RenderError::InvalidBatch { reason, .. }) if reason.contains("share")));
        }
        assert_eq!(views.batch_cameras(batch).unwrap().len(), 2);
    }

    #[test]
    fn a_camera_of_a_missing_batch_or_reading_a_missing_view_is_refused() {
        let mut views = Views::new();
        let batch = views.register_batch(rig(UVec2::new(8, 8))).unwrap();
        let gone = gone(&mut views);
        let result = views.add_camera(batch, ViewDesc::new(camera()).reads(gone.depth()));
        assert!(matches!(result, Err(RenderError::NoSuchView(v)) if v == gone), "{result:?}");
        views.unregister_batch(batch).unwrap();
        let result = views.add_camera(batch, camera());
        assert!(matches!(result, Err(RenderError::NoSuchBatch(b)) if b == batch), "{result:?}");
        assert_eq!(views.ids().count(), 0);
    }

    #[test]
    fn an_unregistered_camera_frees_its_tile_for_the_next_and_the_others_keep_theirs() {
        let mut views = Views::new();
        let batch = views.register_batch(rig(UVec2::new(8, 8))).unwrap();
        let [x, y] = std::array::from_fn(|_| views.add_camera(batch, camera()).unwrap());
        views.unregister(x).unwrap();
        assert_eq!(views.batch_cameras(batch).unwrap(), [y]);
        let z = views.add_camera(batch, camera()).unwrap();
        assert_eq!(views.batch_cameras(batch).unwrap(), [z, y]);
        assert_eq!(views.name(z), Some("rig[0]"));
        assert_eq!(views.entries[&y].target, TargetKind::Tile { batch, slot: 1 });
    }

    #[test]
    fn unregistering_a_batch_removes_it_and_its_cameras_only() {
        let mut views = Views::new();
        let lone = register(&mut views, camera());
        let batch = views.register_batch(rig(UVec2::new(8, 8))).unwrap();
        views.add_camera(batch, camera()).unwrap();
        views.add_camera(batch, camera()).unwrap();
        views.unregister_batch(batch).unwrap();
        assert_eq!(views.ids().collect::<Vec<_>>(), [lone]);
        assert_eq!(views.batch_name(batch), None);
        assert!(matches!(views.batch_cameras(batch), Err(RenderError::NoSuchBatch(b)) if b == batch));
        assert!(matches!(views.unregister_batch(batch), Err(RenderError::NoSuchBatch(b)) if b == batch));
    }

    #[test]
    fn a_name_finds_the_first_view_registered_under_it() {
        let mut views = Views::new();
        let main = register(&mut views, ViewDesc::new(camera()).named("main"));
        let unnamed = register(&mut views, camera());
        let inset = register(&mut views, ViewDesc::new(camera()).named("inset"));
        let again = register(&mut views, ViewDesc::new(camera()).named("main"));
        assert_eq!([views.name(main), views.name(unnamed), views.name(again)], [Some("main"), None, Some("main")]);
        assert_eq!([views.find("inset"), views.find("main"), views.find("side")], [Some(inset), Some(main), None]);
        views.unregister(inset).unwrap();
        assert_eq!((views.name(inset), views.find("inset")), (None, None));
    }

    #[test]
    fn unregistering_a_view_drops_the_links_to_it_and_no_others() {
        let mut views = Views::new();
        let [a, b] = std::array::from_fn(|_| register(&mut views, camera()));
        let c = register(&mut views, ViewDesc::new(camera()).reads(a.hdr()).reads(b.depth()));
        views.unregister(a).unwrap();
        assert_eq!(links(&views, c), [OutputSource::View(b)]);
        assert_eq!(views.ids().collect::<Vec<_>>(), [b, c]);
        assert!(matches!(views.unregister(a), Err(RenderError::NoSuchView(v)) if v == a));
    }

    #[test]
    fn a_schedule_set_later_is_kept_unless_registration_would_refuse_it() {
        let mut views = Views::new();
        let a = register(&mut views, camera());
        views.set_schedule(a, Schedule::EveryNth(3)).unwrap();
        assert_eq!(views.entries[&a].schedule, Schedule::EveryNth(3));
        let result = views.set_schedule(a, Schedule::Rate(-1.0));
        assert!(matches!(result, Err(RenderError::InvalidSchedule { view: Some(v), .. }) if v == a), "{result:?}");
        assert_eq!(views.entries[&a].schedule, Schedule::EveryNth(3));
        let gone = gone(&mut views);
        let result = views.set_schedule(gone, Schedule::Once);
        assert!(matches!(result, Err(RenderError::NoSuchView(v)) if v == gone), "{result:?}");
    }

    #[test]
    fn a_view_is_paused_and_resumed() {
        let mut views = Views::new();
        let a = register(&mut views, camera());
        views.set_active(a, false).unwrap();
        assert!(!views.entries[&a].active);
        views.set_active(a, true).unwrap();
        assert!(views.entries[&a].active);
        let gone = gone(&mut views);
        assert!(matches!(views.set_active(gone, false), Err(RenderError::NoSuchView(v)) if v == gone));
    }

    /// Each call is a frame of its own, numbered from 1 as a renderer's are.
    #[test]
    fn preparing_hands_the_resolver_the_view_and_frames_numbered_from_one() {
        let mut views = Views::new();
        let failing = |ctx: &ViewContext, _: &Scene| -> Result<ResolvedView, ViewError> {
            Err(ViewError::Other { view: ctx.view_id, message: format!("frame {}", ctx.frame_index) })
        };
        let id = register(&mut views, failing);
        for frame in 1..=2 {
            let message = match views.prepare(&Scene::new(), id).map(|_| ()) {
                Err(RenderError::View(ViewError::Other { view, message })) if view == id => message,
                other => panic!("{other:?}"),
            };
            assert_eq!(message, format!("frame {frame}"));
        }
    }

    #[test]
    fn preparing_a_view_draws_what_it_sees() {
        let mut views = Views::new();
        let id = register(&mut views, looking_down(UVec2::new(64, 64)));
        let frame = views.prepare(&boxes(), id).unwrap();
        assert_eq!(frame.view_id(), id);
        assert_eq!(frame.draws().len(), 9);
        let gone = gone(&mut views);
        assert!(matches!(views.prepare(&boxes(), gone), Err(RenderError::NoSuchView(v)) if v == gone));
    }

    /// The resolver asks for a wide image; the batch's narrow size wins, as
    /// it does when the renderer resolves the camera.
    #[test]
    fn a_batch_camera_is_prepared_at_its_batchs_size() {
        let scene = boxes();
        let narrow = UVec2::new(16, 64);
        let draws = |desc: &mut dyn FnMut(&mut Views) -> ViewId| {
            let mut views = Views::new();
            let id = desc(&mut views);
            views.prepare(&scene, id).unwrap().canonical_draws()
        };
        let batched = draws(&mut |views| {
            let batch = views.register_batch(rig(narrow)).unwrap();
            views.add_camera(batch, looking_down(UVec2::new(480, 100))).unwrap()
        });
        let lone_narrow = draws(&mut |views| register(views, looking_down(narrow)));
        let lone_wide = draws(&mut |views| register(views, looking_down(UVec2::new(480, 100))));
        assert_eq!(batched, lone_narrow);
        assert_ne!(batched, lone_wide, "the sizes must frame different boxes for this test to tell");
    }
}
