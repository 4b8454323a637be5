//! `ScenePrep`: the orchestrator. One call per frame prepares every view;
//! a second call uploads what they need.
//!
//! Ownership and lifetime of slots:
//! * per frame, shared: world/normal matrices and light arrays — freed and
//!   re-allocated each frame (same sizes get the same slots back);
//! * per view, per frame: draw metadata — likewise, keyed by view;
//! * persistent: geometry (allocated on first draw) and the material table.

use std::collections::HashMap;
use std::sync::Arc;

use oxygen_bindless::{Allocation, BindlessError, BindlessHeap, DomainKind, SlotAllocators, SlotError};
use oxygen_core::{ResolvedView, Scene, ViewId};
use thiserror::Error;
use tracing::info_span;

use crate::collect::view_phase::collect_view;
use crate::finalize::geometry_cache::GeometryCache;
use crate::finalize::materials::MaterialTable;
use crate::finalize::partition::build_partitions;
use crate::finalize::radix_sort::radix_sort_by_key;
use crate::finalize::sort_key::sort_key;
use crate::prepared_frame::FrameTransforms;
use crate::{DrawMetadata, FrameCollection, PreparedSceneFrame, PreparedSlots, RenderItem, ViewPrepOptions};

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
    /// Frame phases run (one per `prepare`).
    pub frame_phase_runs: u64,
    /// View phases run.
    pub views_prepared: u64,
    /// Draws emitted in the last frame, all views.
    pub draws_last_frame: u64,
    /// Renderables of the last frame phase.
    pub renderables_last_frame: u64,
    /// Meshes uploaded so far.
    pub geometry_uploads: u64,
}

/// The ScenePrep pipeline with its caches.
#[derive(Default)]
pub struct ScenePrep {
    frame: FrameCollection,
    geometry: GeometryCache,
    materials: MaterialTable,
    frame_allocations: Vec<Allocation>,
    view_allocations: HashMap<ViewId, Allocation>,
    items: Vec<RenderItem>,
    keyed: Vec<(u64, u32)>,
    sort_scratch: Vec<(u64, u32)>,
    frame_index: u64,
    stats: PrepStats,
}

impl ScenePrep {
    /// An empty pipeline.
    pub fn new() -> Self {
        Self::default()
    }

    /// The last frame phase's output.
    pub fn frame_collection(&self) -> &FrameCollection {
        &self.frame
    }

    /// Counters.
    pub fn stats(&self) -> PrepStats {
        self.stats
    }

    /// Runs the frame phase once, then the view phase and finalization for
    /// each view, in order. CPU only: slots come from `slots`.
    pub fn prepare(
        &mut self,
        scene: &Scene,
        views: &[ViewRequest<'_>],
        slots: &mut SlotAllocators,
    ) -> Result<Vec<PreparedSceneFrame>, PrepError> {
        let _span = info_span!("scene_prep", views = views.len()).entered();
        for (i, v) in views.iter().enumerate() {
            if views[..i].iter().any(|o| o.view.view_id == v.view.view_id) {
                return Err(PrepError::DuplicateView(v.view.view_id));
            }
        }
        self.frame_index += 1;
        self.frame.collect(scene);
        self.stats.frame_phase_runs += 1;
        self.stats.renderables_last_frame = self.frame.renderables.len() as u64;
        self.materials.sync(scene, slots)?;

        // Frame-global ranges: free last frame's, allocate this frame's.
        for a in self.frame_allocations.drain(..) {
            slots.free(a)?;
        }
        let n = self.frame.world_matrices.len() as u32;
        let world = slots.allocate(DomainKind::WorldTransforms, n)?;
        self.frame_allocations.push(world);
        let normal = slots.allocate(DomainKind::NormalTransforms, n)?;
        self.frame_allocations.push(normal);
        let directional = slots.allocate(DomainKind::DirectionalLights, self.frame.directional_lights.len() as u32)?;
        self.frame_allocations.push(directional);
        let positional = slots.allocate(DomainKind::PositionalLights, self.frame.positional_lights.len() as u32)?;
        self.frame_allocations.push(positional);
        let transforms = Arc::new(FrameTransforms {
            world: self.frame.world_matrices.clone(),
            normal: self.frame.normal_matrices.clone(),
        });

        let mut frames = Vec::with_capacity(views.len());
        let mut total_draws = 0;
        for request in views {
            collect_view(scene, &self.frame, request.view, &request.options, &mut self.items);
            self.stats.views_prepared += 1;
            let _span = info_span!("finalize", view = %request.view.view_id, items = self.items.len()).entered();

            self.keyed.clear();
            for (i, item) in self.items.iter().enumerate() {
                self.keyed.push((sort_key(item.pass_mask, item.material, item.view_depth), i as u32));
            }
            // Items are in (node id, submesh) order, so a stable sort by key
            // alone gives the deterministic tie-break.
            radix_sort_by_key(&mut self.keyed, &mut self.sort_scratch);

            let mut draws = Vec::with_capacity(self.keyed.len());
            let mut sort_keys = Vec::with_capacity(self.keyed.len());
            for &(key, item_index) in &self.keyed {
                let item = self.items[item_index as usize];
                let entry = &self.frame.renderables[item.renderable as usize];
                let (node_id, submesh) = (entry.node_id, item.submesh);
                let Some(geometry) = scene.geometry(entry.geometry) else { continue };
                let g = self.geometry.resolve(entry.geometry, geometry, slots)?;
                let sub = geometry.submeshes()[submesh as usize];
                draws.push(DrawMetadata {
                    vertex_slot: g.vertices.start,
                    index_slot: g.indices.start,
                    first_index: sub.first_index,
                    index_count: sub.index_count,
                    base_vertex: 0,
                    instance_count: 1,
                    transform_index: entry.transform_index,
                    material_handle: item.material,
                    pass_mask: item.pass_mask.bits(),
                    node_id,
                    submesh,
                    reserved: [0; 5],
                });
                sort_keys.push(key);
            }
            let mut partitions = Vec::new();
            build_partitions(&draws, &mut partitions);

            let view_id = request.view.view_id;
            if let Some(old) = self.view_allocations.remove(&view_id) {
                slots.free(old)?;
            }
            let draw_allocation = slots.allocate(DomainKind::DrawMetadata, draws.len() as u32)?;
            self.view_allocations.insert(view_id, draw_allocation);
            total_draws += draws.len() as u64;
            frames.push(PreparedSceneFrame {
                view_id,
                frame_index: self.frame_index,
                draws,
                sort_keys,
                partitions,
                transforms: Arc::clone(&transforms),
                slots: PreparedSlots {
                    draw_metadata: draw_allocation,
                    world_transforms: world,
                    normal_transforms: normal,
                    materials: self.materials.allocation(),
                    directional_lights: directional,
                    positional_lights: positional,
                },
            });
        }
        self.stats.draws_last_frame = total_draws;
        Ok(frames)
    }

    /// Frees the per-view slots of a view that is gone.
    pub fn forget_view(&mut self, view_id: ViewId, slots: &mut SlotAllocators) -> Result<(), PrepError> {
        if let Some(a) = self.view_allocations.remove(&view_id) {
            slots.free(a)?;
        }
        Ok(())
    }

    /// Writes what `frames` need into the heap: grows domains first, then
    /// transforms and lights (once for all views), materials if they changed,
    /// geometry not yet uploaded, and each view's draws.
    pub fn upload(
        &mut self,
        frames: &[PreparedSceneFrame],
        heap: &mut BindlessHeap,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<(), PrepError> {
        let _span = info_span!("upload", views = frames.len()).entered();
        heap.ensure_capacity(device, queue);
        if let Some(first) = frames.first() {
            let s = first.slots;
            heap.write(
                queue,
                &s.world_transforms,
                0,
                &first.transforms.world.iter().map(|m| m.to_cols_array_2d()).collect::<Vec<_>>(),
            )?;
            heap.write(queue, &s.normal_transforms, 0, &first.transforms.normal)?;
            heap.write(queue, &s.directional_lights, 0, &self.frame.directional_lights)?;
            heap.write(queue, &s.positional_lights, 0, &self.frame.positional_lights)?;
        }
        if self.materials.is_dirty() {
            heap.write(queue, &self.materials.allocation(), 0, self.materials.records())?;
            self.materials.mark_uploaded();
        }
        for (slots, geometry) in self.geometry.take_pending() {
            heap.write(queue, &slots.vertices, 0, geometry.vertices())?;
            heap.write(queue, &slots.indices, 0, geometry.indices())?;
            self.stats.geometry_uploads += 1;
        }
        for frame in frames {
            heap.write(queue, &frame.slots.draw_metadata, 0, &frame.draws)?;
        }
        Ok(())
    }
}
