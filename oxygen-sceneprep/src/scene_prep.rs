//! `ScenePrep`: the orchestrator. One call per frame prepares every view
//! ([`ScenePrep::prepare`]), or two when the views depend on the frame
//! phase's output ([`ScenePrep::begin_frame`], then
//! [`ScenePrep::prepare_views`]); a last call uploads what they need.
//!
//! ```text
//! begin_frame:   frame phase (serial, once): collect, materials, frame-global slots
//!                  ─► FrameCollection (the caller may read it to pick shadow views)
//! prepare_views: phase 1 (parallel per view): cull, items, keys, radix sort
//!                  ─► serial: new geometry slots, per-view draw slots
//!                  ─► phase 2 (parallel per view): emit (finalize/emit.rs)
//! ```
//!
//! Views run on a persistent [`WorkerPool`] (see its module for why not
//! scoped threads or rayon). Every buffer — items, keys, draws, partitions,
//! the prepared frames themselves — is kept and reused, so a steady-state
//! frame allocates nothing (a counting-allocator test proves it).
//!
//! Ownership and lifetime of slots:
//! * per frame, shared: world/normal matrices and light arrays — freed and
//!   re-allocated each frame (same sizes get the same slots back);
//! * per view, per frame: draw metadata — likewise, keyed by view;
//! * persistent: geometry (allocated on first draw) and the material table.

use std::sync::{Arc, Mutex};

use glam::DVec3;
use oxygen_bindless::{Allocation, BindlessError, BindlessHeap, DomainKind, SlotAllocators, SlotError, TextureUpload};
use oxygen_core::{Geometry, GeometryHandle, ResolvedView, Scene, TextureImage, ViewId};
use thiserror::Error;
use tracing::info_span;

use crate::collect::view_phase::collect_view_subset;
use crate::collect::view_phase::projected_screen_fraction;
use crate::finalize::emit::{FrameEmit, ViewEmit, emit_view};
use crate::finalize::geometry_cache::{GeometryCache, GeometrySlots};
use crate::finalize::materials::MaterialTable;
use crate::finalize::radix_sort::radix_sort_by_key;
use crate::finalize::sort_key::{sort_key, sort_key_grouped};
use crate::finalize::texture_cache::TextureCache;
use crate::finalize::triangle_table::TriangleLayout;
use crate::gpu_scene::GpuScene;
use crate::prepared_frame::FrameTransforms;
use crate::worker_pool::WorkerPool;
use crate::{
    FrameCollection, Instancing, PassMask, PreparedSceneFrame, PreparedSlots, RenderItem, ViewPrepOptions, Visibility,
};

/// Why a frame could not be prepared or uploaded.
#[derive(Debug, Error, PartialEq)]
pub enum PrepError {
    /// Slot allocation failed (a domain is full) or a handle was stale.
    #[error("scene prep: {0}")]
    Slot(#[from] SlotError),
    /// Writing to the heap failed.
    #[error("scene prep upload: {0}")]
    Bindless(#[from] BindlessError),
    /// The same view was requested twice in one frame.
    #[error("{0} was requested twice in one frame")]
    DuplicateView(ViewId),
    /// [`ScenePrep::prepare_views`] was called with no frame begun: without
    /// [`ScenePrep::begin_frame`] before it, or a second time for one begun
    /// frame.
    #[error("prepare_views needs a frame begun by begin_frame (each begun frame is prepared once)")]
    FrameNotBegun,
}

/// A view's draw-metadata and indirect-argument ranges before it has any.
const UNALLOCATED_VIEW: [Allocation; 2] =
    [Allocation::empty(DomainKind::DrawMetadata), Allocation::empty(DomainKind::IndirectArgs)];

/// Rejects a request list that names one view twice: `Err` naming it. Sorts the ids into `scratch`
/// (kept by the caller, so a steady frame allocates nothing): a scan of
/// the earlier requests for each one cost a 1 024-camera batch half a
/// million comparisons a frame.
fn check_distinct(views: &[ViewRequest<'_>], scratch: &mut Vec<ViewId>) -> Result<(), PrepError> {
    scratch.clear();
    scratch.extend(views.iter().map(|v| v.view.view_id));
    scratch.sort_unstable();
    match scratch.windows(2).find(|pair| pair[0] == pair[1]) {
        Some(pair) => Err(PrepError::DuplicateView(pair[0])),
        None => Ok(()),
    }
}

/// One view to prepare.
#[derive(Clone, Copy, Debug)]
pub struct ViewRequest<'a> {
    /// Its resolved matrices and frustum.
    pub view: &'a ResolvedView,
    /// Filter and cull choices.
    pub options: ViewPrepOptions,
}

/// Counters for tests and reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PrepStats {
    /// Frame phases run (one per `begin_frame`, which `prepare` calls).
    pub frame_phase_runs: u64,
    /// Frame phases that found the scene unchanged and reused last frame's collection.
    pub frame_phase_reuses: u64,
    /// View phases run.
    pub views_prepared: u64,
    /// Draws emitted in the last frame, all views.
    pub draws_last_frame: u64,
    /// Renderables of the last frame phase.
    pub renderables_last_frame: u64,
    /// Meshes uploaded so far.
    pub geometry_uploads: u64,
    /// Material table uploads so far.
    pub material_uploads: u64,
    /// Rebuilds of the GPU scene (GPU visibility paths) so far.
    pub gpu_scene_rebuilds: u64,
    /// Frames whose world and normal matrices were not uploaded at all,
    /// because the scene had not changed since the last upload.
    pub transform_uploads_skipped: u64,
}

/// Per-view scratch state, reused frame to frame.
struct ViewWork {
    items: Vec<RenderItem>,
    keyed: Vec<(u64, u32)>,
    scratch: Vec<(u64, u32)>,
    /// Geometries this view draws that had no slots when it looked.
    missing_geometry: Vec<GeometryHandle>,
    /// Seconds spent on this view in phases 1 and 2.
    seconds: f32,
    /// Per item: the fraction of the viewport it covers (0 for transparent).
    coverage: Vec<f32>,
    draw_allocation: Allocation,
    indirect_allocation: Allocation,
    frame: PreparedSceneFrame,
}

impl ViewWork {
    fn new(view_id: ViewId, transforms: Arc<FrameTransforms>) -> Self {
        ViewWork {
            items: Vec::new(),
            keyed: Vec::new(),
            scratch: Vec::new(),
            missing_geometry: Vec::new(),
            seconds: 0.0,
            coverage: Vec::new(),
            draw_allocation: Allocation::empty(DomainKind::DrawMetadata),
            indirect_allocation: Allocation::empty(DomainKind::IndirectArgs),
            frame: PreparedSceneFrame::empty(view_id, transforms),
        }
    }
}

/// The ScenePrep pipeline with its caches.
pub struct ScenePrep {
    frame: FrameCollection,
    geometry: GeometryCache,
    textures: TextureCache,
    pending_textures: Vec<(Allocation, Arc<TextureImage>)>,
    materials: MaterialTable,
    frame_allocations: Vec<Allocation>,
    /// Each view's draw-metadata and indirect-argument ranges.
    view_allocations: oxygen_core::ViewIdMap<[Allocation; 2]>,
    /// The requested views' ids, sorted to find one asked for twice.
    distinct_scratch: Vec<ViewId>,
    /// Placeholder the pooled frames point at between frames, so the frame
    /// phase can update the shared matrices in place.
    released_transforms: Arc<FrameTransforms>,
    work: Vec<Mutex<ViewWork>>,
    frames: Vec<PreparedSceneFrame>,
    active_frames: usize,
    pending_geometry: Vec<(GeometrySlots, Arc<Geometry>)>,
    pool: WorkerPool,
    frame_index: u64,
    stats: PrepStats,
    debug_generations: bool,
    /// The deterministic mode ([`ScenePrep::set_deterministic`]).
    deterministic: bool,
    /// Meshes get triangle tables from the next frame on
    /// ([`ScenePrep::set_triangle_tables`]).
    triangle_tables: bool,
    render_origin: DVec3,
    /// Frame-global slots of the frame begun (materials filled in at emit).
    frame_slots: PreparedSlots,
    /// A frame was begun and its views are not prepared yet.
    frame_begun: bool,
    /// The opaque and masked scene as GPU records, for GPU visibility.
    gpu_scene: GpuScene,
    /// Collections the frame phase has made (not counting reuses): the GPU
    /// scene and the uploaded matrices remember which one they reflect.
    collection_generation: u64,
    gpu_scene_generation: Option<u64>,
    ray_scene: crate::RayScene,
    /// The scene whose meshes and textures the caches hold.
    cached_scene: Option<u64>,
    /// The collection the ray scene was built from.
    ray_scene_generation: Option<u64>,
    /// What the heap holds of the frame-global data: the slots and the
    /// collection it came from, with the matrices, so that an unchanged
    /// frame uploads nothing and a changed one only what differs.
    uploaded: Option<(PreparedSlots, u64)>,
    uploaded_world: Vec<glam::Mat4>,
    uploaded_normal: Vec<crate::NormalMatrix>,
}

impl Default for ScenePrep {
    fn default() -> Self {
        Self::new()
    }
}

/// The depth complexity a forward pass without a depth pre-pass would shade,
/// estimated from the sorted draws: within one run of a material the draws go
/// front to back, so early depth testing shades each covered pixel about
/// once. So each run counts its coverage (the viewport fractions its draws'
/// bounding spheres cover), capped at 1; the runs add up to the layers of
/// runs over a pixel, never more than all draws' coverage together; and
/// [`expected_shaded_layers`](crate::expected_shaded_layers) turns those
/// layers into the times a pixel is shaded when the runs come in no
/// particular depth order.
fn overdraw_in_draw_order(keyed: &[(u64, u32)], items: &[RenderItem], coverage: &[f32]) -> f32 {
    let (mut runs, mut run, mut material) = (0.0f32, 0.0f32, None);
    for &(_, index) in keyed {
        let item = &items[index as usize];
        if material != Some(item.material) {
            runs += run.min(1.0);
            run = 0.0;
            material = Some(item.material);
        }
        run += coverage[index as usize];
    }
    // Runs spread side by side over the view (a grid of objects in several
    // materials) each cover much of it without covering each other: the
    // whole frame's depth complexity bounds the layers too.
    let total: f32 = coverage.iter().sum();
    crate::expected_shaded_layers((runs + run.min(1.0)).min(total))
}

/// The deterministic mode's key for an opaque or masked item
/// ([`GpuScene::canonical_key`]): its group and instance, below every
/// transparent key (whose class bits are set). An item the GPU scene does
/// not hold (its mesh had no slots when the scene was built) goes after the
/// others, in item order.
fn canonical_key(scene: &GpuScene, frame: &FrameCollection, item: &RenderItem) -> u64 {
    const UNHELD: u64 = 0x3FFF_FFFF << 32;
    let Some(entry) = frame.renderables.get(item.renderable as usize) else { return UNHELD };
    let (start, count) = entry.lods;
    let lod = if item.geometry == entry.geometry {
        None
    } else {
        frame.lod_levels[start as usize..(start + count) as usize].iter().position(|l| l.geometry == item.geometry)
    };
    let submesh = entry.submeshes.0 as usize + item.submesh as usize;
    scene.canonical_key(submesh, lod).map_or(UNHELD, |key| key.min(UNHELD - 1))
}

/// Whether two frames' frame-global ranges are the same slots (handles
/// differ, since each frame allocates anew).
fn same_frame_ranges(a: &PreparedSlots, b: &PreparedSlots) -> bool {
    let same = |x: &Allocation, y: &Allocation| (x.start, x.count) == (y.start, y.count);
    same(&a.world_transforms, &b.world_transforms)
        && same(&a.normal_transforms, &b.normal_transforms)
        && same(&a.directional_lights, &b.directional_lights)
        && same(&a.positional_lights, &b.positional_lights)
}

/// Locks a view's scratch; a poisoned lock (a panic in an earlier frame) is
/// recovered because every buffer is cleared before use.
fn lock(work: &Mutex<ViewWork>) -> std::sync::MutexGuard<'_, ViewWork> {
    work.lock().unwrap_or_else(|e| e.into_inner())
}

impl ScenePrep {
    /// A pipeline preparing views on all available cores.
    pub fn new() -> Self {
        Self::with_threads(std::thread::available_parallelism().map_or(1, |n| n.get()))
    }

    /// A pipeline preparing views on `threads` threads (the caller's
    /// included; 1 means everything runs on the caller's thread).
    pub fn with_threads(threads: usize) -> Self {
        ScenePrep {
            frame: FrameCollection::default(),
            geometry: GeometryCache::default(),
            textures: TextureCache::default(),
            pending_textures: Vec::new(),
            materials: MaterialTable::default(),
            frame_allocations: Vec::new(),
            view_allocations: oxygen_core::ViewIdMap::default(),
            distinct_scratch: Vec::new(),
            released_transforms: Arc::new(FrameTransforms::default()),
            work: Vec::new(),
            frames: Vec::new(),
            active_frames: 0,
            pending_geometry: Vec::new(),
            pool: WorkerPool::new(threads),
            frame_index: 0,
            stats: PrepStats::default(),
            debug_generations: false,
            deterministic: false,
            triangle_tables: false,
            render_origin: DVec3::ZERO,
            frame_slots: PreparedSlots::unallocated(),
            frame_begun: false,
            gpu_scene: GpuScene::default(),
            collection_generation: 0,
            gpu_scene_generation: None,
            ray_scene: crate::RayScene::default(),
            cached_scene: None,
            ray_scene_generation: None,
            uploaded: None,
            uploaded_world: Vec::new(),
            uploaded_normal: Vec::new(),
        }
    }

    /// The world position the GPU's coordinates are centred on (camera-relative
    /// rendering): world matrices and light positions are uploaded relative
    /// to it, and views must be given to the passes through
    /// [`oxygen_core::ResolvedView::relative_to`] with the same origin.
    /// Culling and sorting stay in world space. Changing it re-runs the
    /// frame phase, as a moved scene would. Default: the world origin.
    pub fn set_render_origin(&mut self, origin: DVec3) {
        self.render_origin = origin;
    }

    /// The origin set by [`ScenePrep::set_render_origin`].
    pub fn render_origin(&self) -> DVec3 {
        self.render_origin
    }

    /// Debug mode: every `DrawMetadata` carries its range's generation in
    /// `generation`, and the view's constants ask the shader to check it.
    pub fn set_debug_generations(&mut self, enabled: bool) {
        self.debug_generations = enabled;
    }

    /// The deterministic mode: every view's opaque and masked draws come
    /// in one canonical order whatever the visibility path, the frame
    /// history, the number of threads or the order views were registered
    /// in — group by group of the GPU scene (partition, material, mesh),
    /// then instance by instance (renderable, then submesh) — instead of
    /// front to back. The GPU paths restore that order after culling
    /// ([`crate::GpuViewPlan::deterministic`]); the CPU path sorts by it, so it
    /// builds the GPU scene even when no view is on a GPU path. Costs the
    /// front-to-back order (more shading without a depth pre-pass) and, on
    /// the GPU paths, a compaction pass per view. Transparent draws keep
    /// their back-to-front order, which is already a function of the scene
    /// and the camera.
    pub fn set_deterministic(&mut self, enabled: bool) {
        self.deterministic = enabled;
    }

    /// Whether the deterministic mode is on.
    pub fn deterministic(&self) -> bool {
        self.deterministic
    }

    /// Whether meshes are uploaded with their triangle tables, which
    /// deferred shading reads to find a pixel's triangle from its first
    /// corner (`finalize/triangle_table.rs`): about half as much again of
    /// index memory and the table's build at upload, so off until asked
    /// for (the renderer asks when a batch shades deferred). A change
    /// takes effect at the next frame, which uploads every mesh anew.
    pub fn set_triangle_tables(&mut self, enabled: bool) {
        self.triangle_tables = enabled;
    }

    /// Whether meshes are uploaded with their triangle tables.
    pub fn triangle_tables(&self) -> bool {
        self.triangle_tables
    }

    /// Threads views are prepared on.
    pub fn threads(&self) -> usize {
        self.pool.threads()
    }

    /// The persistent worker threads, for other per-view work of the frame
    /// (the renderer records the views' graphs on them).
    pub fn worker_pool(&self) -> &WorkerPool {
        &self.pool
    }

    /// The last frame phase's output.
    pub fn frame_collection(&self) -> &FrameCollection {
        &self.frame
    }

    /// Counters.
    pub fn stats(&self) -> PrepStats {
        self.stats
    }

    /// What the materials of the frame begun last need of a shading
    /// pipeline (textures, UV transforms), found by the frame phase's sync
    /// of the material table.
    pub fn material_features(&self) -> crate::finalize::materials::MaterialFeatures {
        self.materials.features()
    }

    /// Whether some mesh resident for the frames prepared so far has vertex
    /// colours or a second UV set: shaders pass those on only then. A mesh
    /// stays resident once some view drew it, so this answers for every
    /// mesh the frame's draws can name.
    pub fn vertex_attributes(&self) -> bool {
        self.geometry.any_attributes()
    }

    /// The prepared frames of the last `prepare` or `prepare_views`, in
    /// request order; empty between `begin_frame` and `prepare_views`.
    pub fn frames(&self) -> &[PreparedSceneFrame] {
        &self.frames[..self.active_frames]
    }

    /// Moves the prepared frames of the last `prepare` or `prepare_views`
    /// out, in request order, for a caller whose later steps take them as
    /// their input (the renderer's record step); [`ScenePrep::frames`] is
    /// empty until they come back through [`ScenePrep::return_frames`].
    /// Frames not returned are only a lost reuse of their buffers: the
    /// next `prepare_views` makes new ones.
    pub fn take_frames(&mut self) -> Vec<PreparedSceneFrame> {
        let rest = self.frames.split_off(self.active_frames);
        self.active_frames = 0;
        std::mem::replace(&mut self.frames, rest)
    }

    /// Gives back frames taken by [`ScenePrep::take_frames`]: they are
    /// [`ScenePrep::frames`] again until the next frame begins, and their
    /// buffers are reused by the next `prepare_views`.
    pub fn return_frames(&mut self, mut frames: Vec<PreparedSceneFrame>) {
        self.active_frames = frames.len();
        frames.append(&mut self.frames);
        self.frames = frames;
    }

    /// Forgets the cached frame phase (world transforms, renderables,
    /// lights), so the next frame phase collects the scene from scratch, as
    /// for a scene where everything moved. For benchmarks and tests.
    pub fn invalidate_frame_cache(&mut self) {
        self.frame.invalidate();
    }

    /// The GPU scene of the last frame that had a view on a GPU visibility
    /// path (empty before).
    pub fn gpu_scene(&self) -> &GpuScene {
        &self.gpu_scene
    }

    /// The ray-tracing scene, as of the last frame a view asked for it
    /// ([`crate::ViewPrepOptions::ray_scene`]).
    pub fn ray_scene(&self) -> &crate::RayScene {
        &self.ray_scene
    }

    /// The GPU scene, for the uploader that takes its changes.
    pub fn gpu_scene_mut(&mut self) -> &mut GpuScene {
        &mut self.gpu_scene
    }

    /// Meshes that have slots (drawn by some view at least once).
    pub fn resident_geometry(&self) -> usize {
        self.geometry.resident()
    }

    /// Runs the frame phase once, then the view phase and finalization for
    /// every view (in parallel), and returns one prepared frame per request,
    /// in request order. CPU only: slots come from `slots`.
    ///
    /// The one-call form of [`ScenePrep::begin_frame`] followed by
    /// [`ScenePrep::prepare_views`], for callers that know every view before
    /// the frame phase runs.
    pub fn prepare(
        &mut self,
        scene: &Scene,
        views: &[ViewRequest<'_>],
        slots: &mut SlotAllocators,
    ) -> Result<&[PreparedSceneFrame], PrepError> {
        let _span = info_span!("scene_prep", views = views.len()).entered();
        // Rejected before the frame begins, so a bad request changes nothing.
        check_distinct(views, &mut self.distinct_scratch)?;
        self.begin_frame(scene, slots)?;
        self.prepare_views(scene, views, slots)
    }

    /// The frame phase: begins a frame of `scene` and returns its collection
    /// (renderables, lights, the frame's shadow casters), before any view is
    /// prepared. Collects the scene (or reuses last frame's collection when
    /// nothing changed), syncs the material table and allocates the
    /// frame-global slots (world and normal matrices, light arrays).
    ///
    /// Set the render origin ([`ScenePrep::set_render_origin`]) first: the
    /// collection is rebased on it. A renderer reads the returned collection
    /// to decide which shadow views this frame needs, resolves them, then
    /// calls [`ScenePrep::prepare_views`] once with every view. Calling it
    /// again before `prepare_views` begins the frame over.
    pub fn begin_frame(&mut self, scene: &Scene, slots: &mut SlotAllocators) -> Result<&FrameCollection, PrepError> {
        let _span = info_span!("begin_frame").entered();
        self.frame_begun = false;
        self.frame_index += 1;
        self.active_frames = 0;

        // Release last frame's hold on the shared matrices so the frame phase
        // can rewrite them in place.
        for f in &mut self.frames {
            f.transforms = Arc::clone(&self.released_transforms);
        }
        for w in &mut self.work {
            let w = w.get_mut().unwrap_or_else(|e| e.into_inner());
            w.frame.transforms = Arc::clone(&self.released_transforms);
        }
        // Asset handles are slot indices, alike in every scene: a frame of
        // another scene must not find its meshes and textures in the cache.
        if self.cached_scene != Some(scene.id()) {
            if self.cached_scene.is_some() {
                let _span = info_span!("evict_other_scene").entered();
                self.geometry.clear(slots)?;
                self.textures.clear(slots)?;
                self.ray_scene.forget_meshes();
            }
            self.cached_scene = Some(scene.id());
        }
        if self.geometry.triangle_tables() != self.triangle_tables {
            // Every mesh is allocated and uploaded anew, in the other
            // layout: what holds their slots forgets them.
            let _span = info_span!("triangle_tables", enabled = self.triangle_tables).entered();
            self.geometry.set_triangle_tables(self.triangle_tables, slots)?;
            self.ray_scene.forget_meshes();
            self.gpu_scene_generation = None;
        }
        self.frame.collect(scene, self.render_origin);
        if !self.frame.reused_last() {
            self.collection_generation += 1;
        }
        self.stats.frame_phase_runs += 1;
        self.stats.frame_phase_reuses += u64::from(self.frame.reused_last());
        self.stats.renderables_last_frame = self.frame.renderables.len() as u64;
        self.materials.sync(scene, slots, &mut self.textures)?;
        self.frame_slots = self.allocate_frame_slots(slots)?;
        self.frame_begun = true;
        Ok(&self.frame)
    }

    /// The view phase and finalization of every view of the frame begun by
    /// [`ScenePrep::begin_frame`]: cull, key and sort each view (in
    /// parallel), allocate new geometry and per-view draw slots (serial),
    /// then emit each view's draws and partitions (in parallel). Returns one
    /// prepared frame per request, in request order.
    ///
    /// `scene` must be the scene the frame was begun with. Each begun frame
    /// is prepared once: a second call, or a call with no frame begun, is
    /// [`PrepError::FrameNotBegun`]. A [`PrepError::DuplicateView`] leaves
    /// the frame begun, so the caller may retry with corrected requests.
    pub fn prepare_views(
        &mut self,
        scene: &Scene,
        views: &[ViewRequest<'_>],
        slots: &mut SlotAllocators,
    ) -> Result<&[PreparedSceneFrame], PrepError> {
        let _span = info_span!("prepare_views", views = views.len()).entered();
        if !self.frame_begun {
            return Err(PrepError::FrameNotBegun);
        }
        check_distinct(views, &mut self.distinct_scratch)?;
        self.frame_begun = false;

        while self.work.len() < views.len() {
            let view_id = views[self.work.len()].view.view_id;
            self.work.push(Mutex::new(ViewWork::new(view_id, Arc::clone(&self.released_transforms))));
        }
        // A pooled frame per view; frames taken and never returned
        // (`take_frames`) are made anew.
        while self.frames.len() < views.len() {
            let view_id = views[self.frames.len()].view.view_id;
            self.frames.push(PreparedSceneFrame::empty(view_id, Arc::clone(&self.released_transforms)));
        }

        if self.deterministic || views.iter().any(|v| v.options.visibility.on_gpu()) {
            self.sync_gpu_scene(scene, slots)?;
        }
        if views.iter().any(|v| v.options.ray_scene) && self.ray_scene_generation != Some(self.collection_generation) {
            // The GPU scene's sync gives every mesh its slots (LODs too).
            self.resolve_all_geometry(scene, slots)?;
            self.ray_scene.rebuild(scene, &self.frame, &self.geometry);
            self.ray_scene_generation = Some(self.collection_generation);
        }

        // Phase 1: cull, produce items, key and sort them.
        {
            let _span = info_span!("view_phases").entered();
            let (frame, geometry, work) = (&self.frame, &self.geometry, &self.work);
            let transparent = self.gpu_scene.transparent_renderables();
            let canonical = self.deterministic.then_some(&self.gpu_scene);
            // In runs of views: a camera of a batch culled on the GPU has
            // next to nothing to do here, and one clock read between views
            // times each.
            self.pool.run_ranges(views.len(), &|run| {
                let mut started = std::time::Instant::now();
                for i in run {
                    let mut w = lock(&work[i]);
                    let w = &mut *w;
                    // On a GPU path the CPU handles the transparent draws only,
                    // so it visits only the renderables that have some.
                    let on_gpu = views[i].options.visibility.on_gpu();
                    let subset = on_gpu.then_some(transparent);
                    collect_view_subset(scene, frame, views[i].view, &views[i].options, subset, &mut w.items);
                    w.keyed.clear();
                    w.missing_geometry.clear();
                    let depth_only = views[i].options.depth_only;
                    let grouped = views[i].options.instancing == Instancing::ByGeometry;
                    let view = views[i].view;
                    // Disc area per unit of projected diameter², as a fraction of
                    // the viewport (the diameter is in viewport heights).
                    let disc = std::f32::consts::FRAC_PI_4 / view.aspect().max(f32::MIN_POSITIVE);
                    w.coverage.clear();
                    for (index, item) in w.items.iter().enumerate() {
                        let coverage = match frame.renderables.get(item.renderable as usize) {
                            Some(r) if !item.pass_mask.contains(PassMask::TRANSPARENT) => {
                                let diameter =
                                    2.0 * projected_screen_fraction(view, r.world_sphere.radius, item.view_depth);
                                // One draw covers the viewport at most once.
                                (disc * diameter * diameter).min(1.0)
                            }
                            _ => 0.0,
                        };
                        w.coverage.push(if coverage.is_finite() { coverage } else { 0.0 });
                        let material_key = if depth_only { 0 } else { item.material };
                        let key = if let Some(scene) = canonical
                            && !item.pass_mask.contains(PassMask::TRANSPARENT)
                        {
                            canonical_key(scene, frame, item)
                        } else if grouped {
                            let geometry = frame.renderables.get(item.renderable as usize).map_or(0, |r| r.geometry_id);
                            sort_key_grouped(item.pass_mask, material_key, geometry, item.view_depth)
                        } else {
                            sort_key(item.pass_mask, material_key, item.view_depth)
                        };
                        w.keyed.push((key, index as u32));
                        let handle = item.geometry;
                        if geometry.get(handle).is_none() && !w.missing_geometry.contains(&handle) {
                            w.missing_geometry.push(handle);
                        }
                    }
                    // Items are in (node id, submesh) order, so a stable sort by
                    // key alone gives the deterministic tie-break.
                    radix_sort_by_key(&mut w.keyed, &mut w.scratch);
                    // The GPU's draws are neither known here nor front to back:
                    // the estimate says "unknown", which turns an automatic
                    // pre-pass on.
                    w.frame.estimated_overdraw =
                        if on_gpu { f32::INFINITY } else { overdraw_in_draw_order(&w.keyed, &w.items, &w.coverage) };
                    let now = std::time::Instant::now();
                    w.seconds = (now - started).as_secs_f32();
                    started = now;
                }
            });
        }
        self.stats.views_prepared += views.len() as u64;

        self.allocate_view_slots(scene, views, slots)?;

        // Phase 2: emit DrawMetadata and partitions.
        {
            let _span = info_span!("finalize").entered();
            let frame = FrameEmit {
                geometry: &self.geometry,
                transforms: &self.frame.transforms,
                frame_slots: PreparedSlots { materials: self.materials.allocation(), ..self.frame_slots },
                frame_index: self.frame_index,
                debug_generations: self.debug_generations,
            };
            let (work, gpu_scene, deterministic) = (&self.work, &self.gpu_scene, self.deterministic);
            self.pool.run_ranges(views.len(), &|run| {
                let mut started = std::time::Instant::now();
                for i in run {
                    let mut w = lock(&work[i]);
                    let w = &mut *w;
                    let view = ViewEmit {
                        view_id: views[i].view.view_id,
                        items: &w.items,
                        keyed: &w.keyed,
                        draw_allocation: w.draw_allocation,
                        indirect_allocation: w.indirect_allocation,
                        instancing: views[i].options.instancing,
                        gpu: Some((gpu_scene, views[i].options.visibility)).filter(|(_, v)| v.on_gpu()),
                        deterministic,
                    };
                    emit_view(&frame, &view, &mut w.frame);
                    let now = std::time::Instant::now();
                    w.frame.prep_seconds = w.seconds + (now - started).as_secs_f32();
                    started = now;
                }
            });
        }

        for (frame, work) in self.frames.iter_mut().zip(&mut self.work).take(views.len()) {
            std::mem::swap(frame, &mut work.get_mut().unwrap_or_else(|e| e.into_inner()).frame);
        }
        self.active_frames = views.len();
        Ok(&self.frames[..views.len()])
    }

    /// The serial step between the parallel phases: slots for geometry some
    /// view draws for the first time, and each view's draw ranges (last
    /// frame's ranges of the same view freed first).
    fn allocate_view_slots(
        &mut self,
        scene: &Scene,
        views: &[ViewRequest<'_>],
        slots: &mut SlotAllocators,
    ) -> Result<(), PrepError> {
        let _span = info_span!("allocate_view_slots").entered();
        let mut total_draws = 0;
        for (request, work) in views.iter().zip(&mut self.work) {
            let w = work.get_mut().unwrap_or_else(|e| e.into_inner());
            for handle in &w.missing_geometry {
                if let Some(geometry) = scene.geometry(*handle) {
                    self.geometry.resolve(*handle, geometry, slots)?;
                }
            }
            // One lookup a view, its ranges replaced in place: a removal and
            // an insertion a view a frame left the table to probe past
            // deleted entries.
            let held = self.view_allocations.entry(request.view.view_id).or_insert(UNALLOCATED_VIEW);
            std::mem::replace(held, UNALLOCATED_VIEW).into_iter().try_for_each(|a| slots.free(a))?;
            // A GPU path's room comes first (see `gpu_scene`'s layout).
            let (gpu_draws, gpu_commands) = match request.options.visibility {
                Visibility::Cpu => (0, 0),
                v => (
                    self.gpu_scene.capacity()
                        + crate::finalize::emit::shading_offset(&self.gpu_scene, v, self.deterministic),
                    v.command_lists() * self.gpu_scene.groups().len() as u32,
                ),
            };
            w.draw_allocation = slots.allocate(DomainKind::DrawMetadata, gpu_draws + w.keyed.len() as u32)?;
            w.indirect_allocation = match slots.allocate(DomainKind::IndirectArgs, gpu_commands + w.keyed.len() as u32)
            {
                Ok(a) => a,
                Err(e) => {
                    slots.free(std::mem::replace(&mut w.draw_allocation, UNALLOCATED_VIEW[0]))?;
                    return Err(e.into());
                }
            };
            *held = [w.draw_allocation, w.indirect_allocation];
            total_draws += w.keyed.len() as u64;
        }
        self.stats.draws_last_frame = total_draws;
        Ok(())
    }

    /// Rebuilds the GPU scene when the frame phase recollected the scene
    /// since it was built: every mesh it names (LODs included) gets slots
    /// first, since the GPU may draw any of them.
    fn sync_gpu_scene(&mut self, scene: &Scene, slots: &mut SlotAllocators) -> Result<(), PrepError> {
        if self.gpu_scene_generation == Some(self.collection_generation) {
            return Ok(());
        }
        let _span = info_span!("sync_gpu_scene").entered();
        self.resolve_all_geometry(scene, slots)?;
        self.gpu_scene.rebuild(scene, &self.frame, &self.geometry);
        self.gpu_scene_generation = Some(self.collection_generation);
        self.stats.gpu_scene_rebuilds += 1;
        Ok(())
    }

    /// Gives every mesh the collection names (LODs included) its slots.
    fn resolve_all_geometry(&mut self, scene: &Scene, slots: &mut SlotAllocators) -> Result<(), PrepError> {
        for entry in &self.frame.renderables {
            let (start, count) = entry.lods;
            let lods = &self.frame.lod_levels[start as usize..(start + count) as usize];
            for handle in std::iter::once(entry.geometry).chain(lods.iter().map(|l| l.geometry)) {
                if self.geometry.get(handle).is_none()
                    && let Some(geometry) = scene.geometry(handle)
                {
                    self.geometry.resolve(handle, geometry, slots)?;
                }
            }
        }
        Ok(())
    }

    /// Frees last frame's frame-global ranges and allocates this frame's.
    fn allocate_frame_slots(&mut self, slots: &mut SlotAllocators) -> Result<PreparedSlots, PrepError> {
        for a in self.frame_allocations.drain(..) {
            slots.free(a)?;
        }
        let n = self.frame.transforms.world.len() as u32;
        let mut allocate = |kind, count: usize| -> Result<Allocation, PrepError> {
            let a = slots.allocate(kind, count as u32)?;
            self.frame_allocations.push(a);
            Ok(a)
        };
        Ok(PreparedSlots {
            world_transforms: allocate(DomainKind::WorldTransforms, n as usize)?,
            normal_transforms: allocate(DomainKind::NormalTransforms, n as usize)?,
            directional_lights: allocate(DomainKind::DirectionalLights, self.frame.directional_lights.len())?,
            positional_lights: allocate(DomainKind::PositionalLights, self.frame.positional_lights.len())?,
            ..PreparedSlots::unallocated()
        })
    }

    /// Frees the per-view slots of a view that is gone.
    pub fn forget_view(&mut self, view_id: ViewId, slots: &mut SlotAllocators) -> Result<(), PrepError> {
        if let Some(old) = self.view_allocations.remove(&view_id) {
            old.into_iter().try_for_each(|a| slots.free(a))?;
        }
        Ok(())
    }

    /// Writes what the last prepared frames need into the heap: grows
    /// domains first, then transforms and lights (once for all views),
    /// materials if they changed, geometry not yet uploaded, and each view's
    /// draws.
    pub fn upload(
        &mut self,
        heap: &mut BindlessHeap,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<(), PrepError> {
        let _span = info_span!("upload", views = self.active_frames).entered();
        heap.ensure_capacity(device, queue);
        let frames = &self.frames[..self.active_frames];
        if let Some(first) = frames.first() {
            let s = first.slots;
            // A heap that grew was copied whole, so what it held is still there.
            let same_slots = self.uploaded.is_some_and(|(u, _)| same_frame_ranges(&u, &s));
            let same_collection = self.uploaded.is_some_and(|(_, g)| g == self.collection_generation);
            if same_slots && same_collection {
                self.stats.transform_uploads_skipped += 1;
            } else {
                let transforms = &self.frame.transforms;
                if same_slots {
                    // Only what moved.
                    for r in crate::gpu_scene::changed_ranges(&self.uploaded_world, &transforms.world) {
                        heap.write(
                            queue,
                            &s.world_transforms,
                            r.start,
                            &transforms.world[r.start as usize..r.end as usize],
                        )?;
                    }
                    for r in crate::gpu_scene::changed_ranges(&self.uploaded_normal, &transforms.normal) {
                        let normals = &transforms.normal[r.start as usize..r.end as usize];
                        heap.write(queue, &s.normal_transforms, r.start, normals)?;
                    }
                } else {
                    heap.write(queue, &s.world_transforms, 0, &transforms.world)?;
                    heap.write(queue, &s.normal_transforms, 0, &transforms.normal)?;
                }
                heap.write(queue, &s.directional_lights, 0, &self.frame.directional_lights)?;
                heap.write(queue, &s.positional_lights, 0, &self.frame.positional_lights)?;
                self.uploaded_world.clone_from(&transforms.world);
                self.uploaded_normal.clone_from(&transforms.normal);
                self.uploaded = Some((s, self.collection_generation));
            }
        }
        self.textures.take_pending(&mut self.pending_textures);
        for (slot, image) in self.pending_textures.drain(..) {
            let srgb = image.color_space() == oxygen_core::ColorSpace::Srgb;
            let sampling = image.sampling();
            let upload = TextureUpload {
                width: image.width(),
                height: image.height(),
                srgb,
                sampler: sampling.table_index(),
                wrap_v: sampling.wrap_v.index(),
                pixels: image.pixels(),
            };
            heap.upload_texture(device, queue, &slot, &upload)?;
        }
        if self.materials.is_dirty() {
            heap.write(queue, &self.materials.allocation(), 0, self.materials.records())?;
            self.materials.mark_uploaded();
            self.stats.material_uploads += 1;
        }
        self.geometry.take_pending(&mut self.pending_geometry);
        for (slots, geometry) in self.pending_geometry.drain(..) {
            heap.write(queue, &slots.vertices, 0, geometry.vertices())?;
            if !geometry.morph_targets().is_empty() {
                heap.write(queue, &slots.vertices, geometry.vertices().len() as u32, &geometry.morph_records())?;
            }
            if let Some(attributes) = geometry.attributes() {
                heap.write(queue, &slots.vertices, slots.attributes - slots.vertices.start, attributes)?;
            }
            if let Some(skin) = geometry.skin_weights() {
                heap.write(queue, &slots.vertices, slots.skin - slots.vertices.start, skin)?;
            }
            // With a table: the table, its length and the turned indices
            // (finalize/triangle_table.rs), `index_slot` past the first
            // two; without, the turned indices alone.
            if slots.triangle_table() {
                let layout = TriangleLayout::new(geometry.indices(), slots.vertex_count);
                heap.write(queue, &slots.indices, 0, &layout.words)?;
            } else {
                let (turned, _) = crate::finalize::triangle_table::turn(geometry.indices(), slots.vertex_count);
                heap.write(queue, &slots.indices, 0, &turned)?;
            }
            self.stats.geometry_uploads += 1;
        }
        // Every view's draws, then every view's commands, as few writes as
        // their slots allow (adjacent views' ranges are one write).
        let draws: Vec<_> =
            frames.iter().map(|f| (&f.slots.draw_metadata, f.cpu_offsets().0, f.draws.as_slice())).collect();
        heap.write_runs(queue, &draws)?;
        let commands: Vec<_> =
            frames.iter().map(|f| (&f.slots.indirect_args, f.cpu_offsets().1, f.indirect_args.as_slice())).collect();
        heap.write_runs(queue, &commands)?;
        Ok(())
    }
}
