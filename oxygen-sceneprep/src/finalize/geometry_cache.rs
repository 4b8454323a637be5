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

use super::triangle_table;

/// Where a mesh lives in the vertex and index domains.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GeometrySlots {
    /// Vertex range: the vertices, then the attribute records when the
    /// mesh has them.
    pub vertices: Allocation,
    /// Index-domain range: with triangle tables
    /// ([`GeometryCache::set_triangle_tables`]), the geometry's table, its
    /// length, then its indices turned (see `triangle_table`); without,
    /// its indices as given.
    pub indices: Allocation,
    /// First index of the geometry in the index domain (past its triangle
    /// table when it has one): a draw's `index_slot`.
    pub index_slot: u32,
    /// Vertices of the geometry (its vertex range holds more records:
    /// morph blocks, attributes, skin).
    pub vertex_count: u32,
    /// First attribute record, [`oxygen_bindless::INVALID_SLOT`] when none.
    pub attributes: u32,
    /// First skin record, [`oxygen_bindless::INVALID_SLOT`] when none.
    pub skin: u32,
}

impl GeometrySlots {
    /// Whether the index range holds a triangle table before the indices.
    pub fn triangle_table(&self) -> bool {
        self.index_slot != self.indices.start
    }
}

/// Lazily allocated geometry slots plus the uploads still owed.
#[derive(Default)]
pub struct GeometryCache {
    entries: Vec<Option<(GeometryHandle, GeometrySlots)>>,
    pending: Vec<(GeometrySlots, Arc<Geometry>)>,
    resident: usize,
    /// Resident meshes with attribute records.
    with_attributes: usize,
    /// The most vertices a resident mesh has.
    most_vertices: u32,
    /// Meshes are allocated and uploaded with their triangle tables.
    triangle_tables: bool,
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
        // The indices fit in u32 (`Geometry` refuses more records); with
        // the table beside them they may not, and asking for u32::MAX
        // records is refused as any range too large for the domain is.
        let n = geometry.vertices().len() as u32;
        let index_count = geometry.indices().len() as u32;
        let before = match self.triangle_tables {
            true => triangle_table::words_before_indices(n, index_count).unwrap_or(u32::MAX),
            false => 0,
        };
        let words = before.saturating_add(index_count);
        let indices = match slots.allocate(DomainKind::Indices, words) {
            Ok(i) => i,
            Err(e) => {
                slots.free(vertices)?;
                return Err(e);
            }
        };
        // Vertices, then one block per morph target, then attribute
        // records, then skin records.
        let after_morphs = vertices.start + n * (1 + geometry.morph_targets().len() as u32);
        let attributes = match geometry.attributes() {
            Some(_) => after_morphs,
            None => oxygen_bindless::INVALID_SLOT,
        };
        let skin = match geometry.skin_weights() {
            Some(_) => after_morphs + n * u32::from(geometry.attributes().is_some()),
            None => oxygen_bindless::INVALID_SLOT,
        };
        let s = GeometrySlots {
            vertices,
            indices,
            index_slot: indices.start.saturating_add(before),
            vertex_count: n,
            attributes,
            skin,
        };
        if self.entries.len() <= index {
            self.entries.resize(index + 1, None);
        }
        self.entries[index] = Some((handle, s));
        self.resident += 1;
        self.with_attributes += usize::from(attributes != oxygen_bindless::INVALID_SLOT);
        self.most_vertices = self.most_vertices.max(n);
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

    /// Whether some resident mesh has attribute records (vertex colours or
    /// a second UV set), which the mesh shaders then pass on.
    pub fn any_attributes(&self) -> bool {
        self.with_attributes > 0
    }

    /// Whether meshes get their triangle tables (deferred shading's: about
    /// half as much again of index memory, and the table's build at
    /// upload), off until some view needs them. Changing it frees every
    /// mesh's slots, which the next frame allocates and uploads anew.
    pub fn set_triangle_tables(&mut self, enabled: bool, slots: &mut SlotAllocators) -> Result<(), SlotError> {
        if self.triangle_tables != enabled {
            self.clear(slots)?;
            self.triangle_tables = enabled;
        }
        Ok(())
    }

    /// Whether meshes get their triangle tables.
    pub fn triangle_tables(&self) -> bool {
        self.triangle_tables
    }

    /// How many low bits of a visibility pass's surface id name the vertex
    /// (`RendererConstants::surface_vertex_bits`): enough for every index
    /// value of every resident mesh, at least one.
    pub fn surface_vertex_bits(&self) -> u32 {
        (32 - self.most_vertices.saturating_sub(1).leading_zeros()).max(1)
    }

    fn free_slots(&mut self, s: GeometrySlots, slots: &mut SlotAllocators) -> Result<(), SlotError> {
        self.pending.retain(|(p, _)| *p != s);
        self.resident -= 1;
        self.with_attributes -= usize::from(s.attributes != oxygen_bindless::INVALID_SLOT);
        slots.free(s.vertices)?;
        slots.free(s.indices)?;
        if s.vertex_count == self.most_vertices {
            // The caller replaces or drops the entry; the largest of the
            // others is recounted from the entries still holding other slots.
            self.most_vertices =
                self.entries.iter().flatten().filter(|(_, e)| *e != s).map(|(_, e)| e.vertex_count).max().unwrap_or(0);
        }
        Ok(())
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
        self.with_attributes = 0;
        self.most_vertices = 0;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use oxygen_core::{MorphTarget, SkinWeights, VertexAttributes};
    use slotmap::KeyData;

    use super::*;

    /// The handle of slot `index` at `version` (odd: occupied), as a scene
    /// whose geometry slot was reused would hand out.
    fn handle(index: u32, version: u32) -> GeometryHandle {
        GeometryHandle::from(KeyData::from_ffi((u64::from(version) << 32) | u64::from(index)))
    }

    fn mesh(name: &str, size: f32) -> Arc<Geometry> {
        let cube = Geometry::cube(size);
        let geometry =
            Geometry::new(name, cube.vertices().to_vec(), cube.indices().to_vec(), cube.submeshes().to_vec());
        Arc::new(geometry.expect("a cube's arrays make a geometry"))
    }

    /// The names of the meshes whose uploads are owed, in order.
    fn pending_names(cache: &mut GeometryCache) -> Vec<String> {
        let mut pending = Vec::new();
        cache.take_pending(&mut pending);
        pending.iter().map(|(_, g)| g.name().to_owned()).collect()
    }

    /// The vertex range holds the vertices, one block per morph target, the
    /// attribute records and the skin records, in that order and back to
    /// back: the first attribute and skin records the shaders are given are
    /// where the upload writes them.
    #[test]
    fn attribute_and_skin_records_follow_the_morph_blocks() -> Result<(), SlotError> {
        let quad = Geometry::quad(1.0);
        let n = quad.vertices().len() as u32;
        let target = || MorphTarget { positions: vec![Vec3::X; n as usize], normals: None };
        let full = quad
            .clone()
            .with_morph_targets(vec![target(), target()])
            .and_then(|g| g.with_attributes(vec![VertexAttributes::default(); n as usize]))
            .and_then(|g| g.with_skin_weights(vec![SkinWeights::new([0; 4], [1.0, 0.0, 0.0, 0.0]); n as usize]))
            .expect("a quad with two morph targets, attributes and skin");
        let skinned = quad
            .with_morph_targets(vec![target()])
            .and_then(|g| g.with_skin_weights(vec![SkinWeights::new([0; 4], [1.0, 0.0, 0.0, 0.0]); n as usize]))
            .expect("a quad with a morph target and skin");
        let mut slots = SlotAllocators::default();
        let mut cache = GeometryCache::default();
        // Something first, so the ranges do not start at slot 0.
        cache.resolve(handle(1, 1), &mesh("first", 1.0), &mut slots)?;

        let s = cache.resolve(handle(2, 1), &Arc::new(full), &mut slots)?;
        assert_eq!(s.vertices.count, 5 * n, "vertices, two morph blocks, attributes, skin");
        assert_eq!(s.attributes, s.vertices.start + 3 * n, "attributes after the vertices and two morph blocks");
        assert_eq!(s.skin, s.vertices.start + 4 * n, "skin after the attributes");
        assert_eq!(s.skin + n, s.vertices.end(), "the skin records end the range");

        let s = cache.resolve(handle(3, 1), &Arc::new(skinned), &mut slots)?;
        assert_eq!(s.attributes, oxygen_bindless::INVALID_SLOT, "no attributes");
        assert_eq!(s.skin, s.vertices.start + 2 * n, "skin right after the one morph block");
        assert_eq!(s.skin + n, s.vertices.end());
        Ok(())
    }

    /// Whether some resident mesh has attribute records follows the meshes
    /// resident: a mesh with them turns it on, its slot taken by a mesh
    /// without (another generation) and a cleared cache turn it off.
    #[test]
    fn any_attributes_follows_the_resident_meshes() -> Result<(), SlotError> {
        let quad = Geometry::quad(1.0);
        let n = quad.vertices().len();
        let coloured = Arc::new(quad.with_attributes(vec![VertexAttributes::default(); n]).expect("attributes"));
        let mut slots = SlotAllocators::default();
        let mut cache = GeometryCache::default();
        cache.resolve(handle(1, 1), &mesh("plain", 1.0), &mut slots)?;
        assert!(!cache.any_attributes(), "a mesh without attribute records");
        cache.resolve(handle(2, 1), &coloured, &mut slots)?;
        cache.resolve(handle(2, 1), &coloured, &mut slots)?;
        assert!(cache.any_attributes(), "a mesh with them");
        cache.resolve(handle(3, 1), &coloured, &mut slots)?;
        cache.resolve(handle(2, 3), &mesh("plain again", 1.0), &mut slots)?;
        assert!(cache.any_attributes(), "one of the two coloured meshes is still resident");
        cache.resolve(handle(3, 3), &mesh("plain too", 1.0), &mut slots)?;
        assert!(!cache.any_attributes(), "both replaced by meshes without");
        cache.resolve(handle(4, 1), &coloured, &mut slots)?;
        cache.clear(&mut slots)?;
        assert!(!cache.any_attributes(), "a cleared cache holds none");
        Ok(())
    }

    /// The surface id's vertex bits name every index value of the largest
    /// resident mesh: they grow with a larger mesh, shrink when it is
    /// replaced by a smaller one or the cache is cleared, and the index
    /// slot sits past the mesh's triangle table.
    #[test]
    fn surface_vertex_bits_follow_the_largest_resident_mesh() -> Result<(), SlotError> {
        let mut slots = SlotAllocators::default();
        let mut cache = GeometryCache::default();
        assert_eq!(cache.surface_vertex_bits(), 1, "at least one bit");
        let cube = mesh("cube", 1.0);
        // Without triangle tables (the default) the range is the indices.
        let s = cache.resolve(handle(1, 1), &cube, &mut slots)?;
        assert_eq!((s.index_slot, s.indices.count, s.triangle_table()), (s.indices.start, 36, false));
        // Turning them on frees every mesh; it comes back with its table.
        cache.set_triangle_tables(true, &mut slots)?;
        assert_eq!((cache.resident(), cache.get(handle(1, 1))), (0, None));
        assert_eq!(slots.get(DomainKind::Indices).live_allocations(), 0);
        let s = cache.resolve(handle(1, 1), &cube, &mut slots)?;
        assert!(s.triangle_table());
        assert_eq!(cache.surface_vertex_bits(), 5, "24 vertices: values 0..=23");
        assert_eq!((s.vertex_count, s.index_slot), (24, s.indices.start + 24 + 1 + 12 + 1));
        assert_eq!(s.indices.count, 24 + 1 + 12 + 1 + 36, "the table, its length, the indices");
        let sphere = Arc::new(Geometry::uv_sphere(1.0, 32, 16));
        let n = sphere.vertices().len() as u32;
        cache.resolve(handle(2, 1), &sphere, &mut slots)?;
        assert_eq!(cache.surface_vertex_bits(), 32 - (n - 1).leading_zeros());
        cache.resolve(handle(2, 3), &mesh("small again", 1.0), &mut slots)?;
        assert_eq!(cache.surface_vertex_bits(), 5, "the sphere's slot taken by a cube");
        cache.clear(&mut slots)?;
        assert_eq!(cache.surface_vertex_bits(), 1);
        Ok(())
    }

    /// A mesh drawn again keeps its slots and is uploaded once; the count of
    /// resident meshes grows by one per new mesh.
    #[test]
    fn a_mesh_is_allocated_and_uploaded_once() -> Result<(), SlotError> {
        let mut slots = SlotAllocators::default();
        let mut cache = GeometryCache::default();
        assert_eq!(cache.resident(), 0);
        let a = mesh("a", 1.0);
        let first = cache.resolve(handle(1, 1), &a, &mut slots)?;
        assert_eq!(cache.resolve(handle(1, 1), &a, &mut slots)?, first);
        assert_eq!(cache.get(handle(1, 1)), Some(first));
        cache.resolve(handle(2, 1), &mesh("b", 2.0), &mut slots)?;
        assert_eq!(cache.resident(), 2);
        assert_eq!(pending_names(&mut cache), ["a", "b"]);
        assert!(pending_names(&mut cache).is_empty(), "each upload is handed out once");
        cache.resolve(handle(1, 1), &a, &mut slots)?;
        assert!(pending_names(&mut cache).is_empty(), "a resident mesh is not uploaded again");
        Ok(())
    }

    /// A handle of another generation at a resident mesh's index names
    /// another mesh: it does not find the old one's slots, and resolving it
    /// frees them (and drops their upload, if still owed) before allocating
    /// its own, leaving the other meshes and their uploads alone.
    #[test]
    fn a_new_generation_at_the_same_index_replaces_the_old_mesh() -> Result<(), SlotError> {
        let mut slots = SlotAllocators::default();
        let mut cache = GeometryCache::default();
        cache.resolve(handle(1, 1), &mesh("old", 1.0), &mut slots)?;
        cache.resolve(handle(2, 1), &mesh("other", 1.0), &mut slots)?;
        let new = handle(1, 3);
        assert_eq!(cache.get(new), None, "the old mesh's slots are not the new one's");

        let replaced = cache.resolve(new, &mesh("new", 2.0), &mut slots)?;
        assert_eq!(cache.get(new), Some(replaced));
        assert_eq!(cache.get(handle(1, 1)), None, "the old handle is stale");
        assert_eq!(cache.resident(), 2);
        for domain in [DomainKind::Vertices, DomainKind::Indices] {
            assert_eq!(slots.get(domain).live_allocations(), 2, "{domain:?}: the old mesh's range was freed");
        }
        assert_eq!(pending_names(&mut cache), ["other", "new"]);
        Ok(())
    }

    /// Clearing (another scene's handles name other meshes) frees every
    /// mesh's ranges and owed uploads; a mesh resolved afterwards is
    /// allocated and uploaded anew.
    #[test]
    fn clear_frees_every_mesh() -> Result<(), SlotError> {
        let mut slots = SlotAllocators::default();
        let mut cache = GeometryCache::default();
        let a = mesh("a", 1.0);
        cache.resolve(handle(1, 1), &a, &mut slots)?;
        cache.resolve(handle(2, 1), &mesh("b", 1.0), &mut slots)?;
        cache.clear(&mut slots)?;
        assert_eq!(cache.resident(), 0);
        assert_eq!(cache.get(handle(1, 1)), None);
        for domain in [DomainKind::Vertices, DomainKind::Indices] {
            assert_eq!(slots.get(domain).live_allocations(), 0, "{domain:?}");
        }
        assert!(pending_names(&mut cache).is_empty(), "no upload owed for a freed range");
        cache.resolve(handle(1, 1), &a, &mut slots)?;
        assert_eq!((cache.resident(), pending_names(&mut cache)), (1, vec!["a".to_owned()]));
        Ok(())
    }
}
