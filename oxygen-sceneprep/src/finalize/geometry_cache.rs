//! Geometry slots, allocated lazily the first time some view draws a mesh.
//!
//! A mesh no view sees costs nothing: no slots, no upload. Once allocated, a
//! mesh keeps its slots (and its GPU copy) until [`GeometryCache::evict`].

use std::collections::HashMap;
use std::sync::Arc;

use oxygen_bindless::{Allocation, DomainKind, SlotAllocators, SlotError};
use oxygen_core::{Geometry, GeometryHandle};

/// Where a mesh lives in the vertex and index domains.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GeometrySlots {
    /// Vertex range.
    pub vertices: Allocation,
    /// Index range.
    pub indices: Allocation,
}

/// Lazily allocated geometry slots plus the uploads still owed.
#[derive(Default)]
pub struct GeometryCache {
    entries: HashMap<GeometryHandle, GeometrySlots>,
    pending: Vec<(GeometrySlots, Arc<Geometry>)>,
}

impl GeometryCache {
    /// Slots for `handle`, allocating (and queueing an upload) on first use.
    pub fn resolve(
        &mut self,
        handle: GeometryHandle,
        geometry: &Arc<Geometry>,
        slots: &mut SlotAllocators,
    ) -> Result<GeometrySlots, SlotError> {
        if let Some(s) = self.entries.get(&handle) {
            return Ok(*s);
        }
        let vertices = slots.allocate(DomainKind::Vertices, geometry.vertices().len() as u32)?;
        let indices = match slots.allocate(DomainKind::Indices, geometry.indices().len() as u32) {
            Ok(i) => i,
            Err(e) => {
                slots.free(vertices)?;
                return Err(e);
            }
        };
        let s = GeometrySlots { vertices, indices };
        self.entries.insert(handle, s);
        self.pending.push((s, Arc::clone(geometry)));
        Ok(s)
    }

    /// Takes the uploads owed since the last call.
    pub fn take_pending(&mut self) -> Vec<(GeometrySlots, Arc<Geometry>)> {
        std::mem::take(&mut self.pending)
    }

    /// Number of meshes resident.
    pub fn resident(&self) -> usize {
        self.entries.len()
    }

    /// Frees a mesh's slots (e.g. when the asset is removed).
    pub fn evict(&mut self, handle: GeometryHandle, slots: &mut SlotAllocators) -> Result<(), SlotError> {
        if let Some(s) = self.entries.remove(&handle) {
            self.pending.retain(|(p, _)| *p != s);
            slots.free(s.vertices)?;
            slots.free(s.indices)?;
        }
        Ok(())
    }
}
