//! Geometry slots, allocated lazily the first time some view draws a mesh.
//!
//! A mesh no view sees costs nothing: no slots, no upload. Once allocated, a
//! mesh keeps its slots (and its GPU copy) until [`GeometryCache::evict`].
//! The table is dense, indexed by the geometry's stable id, so the parallel
//! emission phase reads it with one bounds-checked load per draw.

use std::sync::Arc;

use oxygen_bindless::{Allocation, DomainKind, SlotAllocators, SlotError};
use oxygen_core::scene::geometry_index;
use oxygen_core::{Geometry, GeometryHandle};

/// Where a mesh lives in the vertex and index domains.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GeometrySlots {
    /// Vertex range: the vertices, then the attribute records when the
    /// mesh has them.
    pub vertices: Allocation,
    /// Index range.
    pub indices: Allocation,
    /// First attribute record, [`oxygen_bindless::INVALID_SLOT`] when none.
    pub attributes: u32,
    /// First skin record, [`oxygen_bindless::INVALID_SLOT`] when none.
    pub skin: u32,
}

/// Lazily allocated geometry slots plus the uploads still owed.
#[derive(Default)]
pub struct GeometryCache {
    entries: Vec<Option<(GeometryHandle, GeometrySlots)>>,
    pending: Vec<(GeometrySlots, Arc<Geometry>)>,
    resident: usize,
}

impl GeometryCache {
    /// Slots of a resident mesh by geometry id (checking the handle's generation).
    pub fn get(&self, handle: GeometryHandle) -> Option<GeometrySlots> {
        match self.entries.get(geometry_index(handle) as usize) {
            Some(Some((h, s))) if *h == handle => Some(*s),
            _ => None,
        }
    }

    /// Slots for `handle`, allocating (and queueing an upload) on first use.
    pub fn resolve(
        &mut self,
        handle: GeometryHandle,
        geometry: &Arc<Geometry>,
        slots: &mut SlotAllocators,
    ) -> Result<GeometrySlots, SlotError> {
        if let Some(s) = self.get(handle) {
            return Ok(s);
        }
        let index = geometry_index(handle) as usize;
        // A different generation in the same slot: the old asset is gone.
        if let Some(Some((_, old))) = self.entries.get(index).copied() {
            self.free_slots(old, slots)?;
        }
        // Fits in u32: `Geometry` refuses more records than that.
        let vertices = slots.allocate(DomainKind::Vertices, geometry.vertex_domain_records() as u32)?;
        let indices = match slots.allocate(DomainKind::Indices, geometry.indices().len() as u32) {
            Ok(i) => i,
            Err(e) => {
                slots.free(vertices)?;
                return Err(e);
            }
        };
        // Vertices, then one block per morph target, then attribute
        // records, then skin records.
        let n = geometry.vertices().len() as u32;
        let after_morphs = vertices.start + n * (1 + geometry.morph_targets().len() as u32);
        let attributes = match geometry.attributes() {
            Some(_) => after_morphs,
            None => oxygen_bindless::INVALID_SLOT,
        };
        let skin = match geometry.skin_weights() {
            Some(_) => after_morphs + n * u32::from(geometry.attributes().is_some()),
            None => oxygen_bindless::INVALID_SLOT,
        };
        let s = GeometrySlots { vertices, indices, attributes, skin };
        if self.entries.len() <= index {
            self.entries.resize(index + 1, None);
        }
        self.entries[index] = Some((handle, s));
        self.resident += 1;
        self.pending.push((s, Arc::clone(geometry)));
        Ok(s)
    }

    /// Takes the uploads owed since the last call (into `out`, cleared first).
    pub fn take_pending(&mut self, out: &mut Vec<(GeometrySlots, Arc<Geometry>)>) {
        out.clear();
        out.append(&mut self.pending);
    }

    /// Number of meshes resident.
    pub fn resident(&self) -> usize {
        self.resident
    }

    fn free_slots(&mut self, s: GeometrySlots, slots: &mut SlotAllocators) -> Result<(), SlotError> {
        self.pending.retain(|(p, _)| *p != s);
        self.resident -= 1;
        slots.free(s.vertices)?;
        slots.free(s.indices)
    }

    /// Frees every mesh's slots: the handles of another scene name other
    /// meshes (handles are slot indices, the same in every scene).
    pub fn clear(&mut self, slots: &mut SlotAllocators) -> Result<(), SlotError> {
        for (_, s) in self.entries.drain(..).flatten() {
            slots.free(s.vertices)?;
            slots.free(s.indices)?;
        }
        self.pending.clear();
        self.resident = 0;
        Ok(())
    }
}
