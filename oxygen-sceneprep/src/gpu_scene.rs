//! The persistent GPU scene: what GPU-driven visibility culls and compacts.
//!
//! The records and their layout are described on [`GpuScene`].

use std::collections::HashMap;
use std::ops::Range;

use oxygen_core::{NodeFlags, Scene};
use tracing::info_span;

use crate::finalize::geometry_cache::GeometryCache;
use crate::{FrameCollection, Partition, PassMask};

/// Where a view's visibility is decided.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Visibility {
    /// ScenePrep culls, sorts and emits every draw on the CPU: the exact
    /// reference, and the path for adapters without compute or indirect
    /// count. Draws are sorted front to back within each material.
    #[default]
    Cpu,
    /// A compute shader tests every instance against the view frustum (the
    /// same conservative box test as the CPU path) and compacts the
    /// survivors into instanced commands. Within a partition the order is
    /// the order the GPU's threads finished in, not front to back.
    GpuFrustum,
    /// As [`Visibility::GpuFrustum`], then two-phase occlusion culling
    /// against a depth pyramid: the depth pre-pass draws what was visible
    /// last frame, the pyramid is built from it, the rest is tested against
    /// it and the newly visible part is drawn too. Turns the depth pre-pass
    /// on.
    GpuOcclusion,
}

impl Visibility {
    /// True for the GPU paths.
    pub fn on_gpu(self) -> bool {
        self != Visibility::Cpu
    }

    /// Command lists in the view's indirect range (see the module docs).
    pub fn command_lists(self) -> u32 {
        match self {
            Visibility::Cpu => 0,
            Visibility::GpuFrustum => 1,
            Visibility::GpuOcclusion => 3,
        }
    }
}

oxygen_gpu::gpu_struct! {
    /// One opaque or masked submesh of one renderable, as the cull shader reads
    /// it (80 bytes).
    #[derive(Debug, Default, PartialEq)]
    pub struct GpuInstance: 80 bytes {
        /// World AABB minimum (absolute world space, as the CPU culls).
        pub aabb_min: [f32; 3],
        /// Group drawn at full detail.
        pub group: u32,
        /// World AABB maximum.
        pub aabb_max: [f32; 3],
        /// [`GpuInstance::CASTS_SHADOWS`].
        pub flags: u32,
        /// Bounding sphere: centre and radius (LOD selection).
        pub sphere: [f32; 4],
        /// Transform index (relative to the frame's transform slots).
        pub transform_index: u32,
        /// Stable node id.
        pub node_id: u32,
        /// Submesh number.
        pub submesh: u32,
        /// First LOD of the instance in [`GpuScene::lods`].
        pub lod_first: u32,
        /// Its LOD count (0: none).
        pub lod_count: u32,
        /// A skinned instance's first joint matrix, `INVALID_SLOT` when rigid.
        pub joint_base: u32,
        /// Its mesh's skin records, `INVALID_SLOT` when rigid.
        pub skin_slot: u32,
        /// Its morph header, `INVALID_SLOT` without morph targets.
        pub morph_base: u32,
    }
}

impl GpuInstance {
    /// `flags` bit: drawn into shadow views.
    pub const CASTS_SHADOWS: u32 = 1;
}

oxygen_gpu::gpu_struct! {
    /// Draws that share a mesh range, material and pass mask: one instanced
    /// command per command list (48 bytes).
    #[derive(Debug, Default, PartialEq, Eq)]
    pub struct GpuGroup: 48 bytes {
        /// First vertex of the mesh in the vertex domain.
        pub vertex_slot: u32,
        /// First index of the mesh in the index domain.
        pub index_slot: u32,
        /// First index of the submesh, relative to `index_slot`.
        pub first_index: u32,
        /// Indices drawn.
        pub index_count: u32,
        /// Added to every index (relative to `vertex_slot`).
        pub base_vertex: i32,
        /// Material handle.
        pub material: u32,
        /// Pass mask of its draws.
        pub pass_mask: u32,
        /// Its partition's first command (relative to a command list).
        pub command_base: u32,
        /// Its first draw (relative to the view's draw range).
        pub draw_base: u32,
        /// Its partition.
        pub partition_index: u32,
        /// Instances that may select it: its room in the draw range.
        pub capacity: u32,
        /// The mesh's attribute records in the vertex domain (colour, second
        /// UV set), [`oxygen_bindless::INVALID_SLOT`] when it has none.
        pub attributes_slot: u32,
    }
}

oxygen_gpu::gpu_struct! {
    /// One LOD level of an instance: used below a projected size (8 bytes).
    #[derive(Debug, Default, PartialEq)]
    pub struct GpuLod: 8 bytes {
        /// Used when the sphere's projected diameter (× LOD bias) is below this
        /// fraction of the viewport height.
        pub below_screen_fraction: f32,
        /// The group drawn at this level.
        pub group: u32,
    }
}

/// A run of groups with one pass class and variant.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GpuPartition {
    /// Partition bits.
    pub mask: PassMask,
    /// Its groups, which are also its command slots within a list.
    pub groups: Range<u32>,
    /// Its draws' room in the view's draw range.
    pub draws: Range<u32>,
}

/// What one rebuild of the [`GpuScene`] changed.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct GpuSceneChanges {
    /// Instance ranges to upload (all of them after a layout change).
    pub instances: Vec<Range<u32>>,
    /// Groups and LODs changed: upload both whole.
    pub layout: bool,
    /// [`GpuScene::ranks`] changed: upload them whole.
    pub ranks: bool,
}

type GroupKey = (u64, u32, u32, u32, u32, u32, i32, u32);
/// A group's place in the order: partition rank, material, pass mask, the
/// mesh's stable id, first index and index count.
type GroupOrder = (u64, u32, u32, u32, u32, u32);

/// The opaque and masked part of the scene as GPU records, rebuilt when the
/// frame phase recollected the scene, with what changed since the last
/// upload.
///
/// The CPU path ([`Visibility::Cpu`]) culls, sorts and emits every view's
/// draws each frame. The GPU paths keep the scene's opaque and masked
/// submeshes on the GPU instead, as [`GpuInstance`] records grouped into
/// [`GpuGroup`]s (one mesh range, material and pass mask each), and a compute
/// shader per view writes the surviving draws and their instanced commands
/// straight into the view's bindless ranges. `GpuScene` builds those records
/// on the CPU and says which of them changed, so that a static frame uploads
/// nothing; `oxygen-passes` (`visibility`) owns the buffers and shaders.
///
/// Layout of one view's ranges on a GPU path (`C` = [`GpuScene::capacity`],
/// `G` = groups, `L` = command lists: 1 for frustum culling, 3 with
/// occlusion):
///
/// ```text
/// draw metadata:  [ group 0's room | group 1's room | … (C) ][ transparent draws (CPU) ]
/// indirect args:  [ list A (G) | list B (G) | list C (G) ][ transparent commands (CPU) ]
/// counters:       [ A per partition | B | C ][ early count per group | late count per group ]
/// ```
///
/// Each group has room for every instance that may select it (an instance
/// with LODs may select one of several), so the compute shader never
/// overflows; a partition is a run of groups with one pass class and
/// variant, and its commands are compacted at the run's start, counted by
/// its counter, and drawn with `multi_draw_indexed_indirect_count`.
///
/// Transparent draws stay on the CPU path in every mode: blending needs them
/// back to front across the whole view, and the CPU sorts the (usually few)
/// transparent draws exactly; sorting them on the GPU would cost a sort
/// every frame to get what the CPU already has.
#[derive(Debug, Default)]
pub struct GpuScene {
    instances: Vec<GpuInstance>,
    groups: Vec<GpuGroup>,
    lods: Vec<GpuLod>,
    partitions: Vec<GpuPartition>,
    capacity: u32,
    /// Renderables with at least one transparent submesh (CPU path).
    transparent: Vec<u32>,
    changes: GpuSceneChanges,
    rebuilds: u64,
    /// Scratch: group key → index, reused.
    group_index: HashMap<GroupKey, u32>,
    /// Each instance's place in its full-detail group's room, then each LOD
    /// entry's place in its group's room: see [`GpuScene::ranks`].
    ranks: Vec<u32>,
    /// The instance of each submesh of the frame collection (by its index
    /// in `FrameCollection::submeshes`), `INVALID_SLOT` for a transparent
    /// submesh or a renderable left out.
    instance_of_submesh: Vec<u32>,
}

impl GpuScene {
    /// Instances in renderable, then submesh order.
    pub fn instances(&self) -> &[GpuInstance] {
        &self.instances
    }
    /// Groups in partition order.
    pub fn groups(&self) -> &[GpuGroup] {
        &self.groups
    }
    /// LOD table.
    pub fn lods(&self) -> &[GpuLod] {
        &self.lods
    }
    /// Partitions in draw order.
    pub fn partitions(&self) -> &[GpuPartition] {
        &self.partitions
    }
    /// Draw room one view needs for the GPU-written draws.
    pub fn capacity(&self) -> u32 {
        self.capacity
    }
    /// Indices (in the frame's renderables) of renderables with a
    /// transparent submesh, which the CPU path draws.
    pub fn transparent_renderables(&self) -> &[u32] {
        &self.transparent
    }
    /// Where each instance sits in the room of the group it selects, in
    /// instance order: entry `i` (< instances) for instance `i` at full
    /// detail, entry `instances + l` for LOD entry `l`. The deterministic
    /// mode writes each surviving instance at its rank and compacts the
    /// room in rank order, so that a group's draws come in instance order
    /// whatever order the GPU's threads ran in.
    pub fn ranks(&self) -> &[u32] {
        &self.ranks
    }
    /// The canonical draw order of the deterministic mode for an opaque or
    /// masked item: its group (groups are in partition, material, mesh
    /// order), then its instance (renderable, then submesh order) — the
    /// order the GPU path's compaction restores, so that both paths draw
    /// the same sequence. `submesh_index` indexes
    /// `FrameCollection::submeshes`; `lod` is the item's LOD level (`None`:
    /// full detail). `None` when the GPU scene does not hold the submesh.
    pub fn canonical_key(&self, submesh_index: usize, lod: Option<usize>) -> Option<u64> {
        let instance = *self.instance_of_submesh.get(submesh_index)?;
        let record = self.instances.get(instance as usize)?;
        let group = match lod {
            None => record.group,
            Some(level) if (level as u32) < record.lod_count => {
                self.lods.get((record.lod_first as usize) + level)?.group
            }
            Some(_) => return None,
        };
        Some((u64::from(group) << 32) | u64::from(instance))
    }
    /// Rebuilds so far (one per recollected frame that a GPU view needed).
    pub fn rebuilds(&self) -> u64 {
        self.rebuilds
    }
    /// What the last rebuild changed against the one before: an uploader
    /// that holds rebuild `rebuilds() - 1` applies these; one further
    /// behind uploads everything.
    pub fn last_changes(&self) -> &GpuSceneChanges {
        &self.changes
    }

    /// The partitions of one command list (`list` < [`Visibility::command_lists`]):
    /// each counted by counter `list × partitions + index`, its commands at
    /// `list × groups + first group`.
    pub fn list_partitions(&self, list: u32) -> impl Iterator<Item = Partition> + '_ {
        let (groups, partitions) = (self.groups.len() as u32, self.partitions.len() as u32);
        self.partitions.iter().enumerate().map(move |(index, p)| Partition {
            begin: p.draws.start,
            end: p.draws.end,
            mask: p.mask,
            first_command: list * groups + p.groups.start,
            command_count: p.groups.len() as u32,
            gpu_count: Some(list * partitions + index as u32),
        })
    }

    /// Rebuilds the records from the frame phase's output. Every geometry the
    /// records name must have slots in `geometry` (the caller resolves them
    /// first; a renderable whose mesh has none is left out).
    pub(crate) fn rebuild(&mut self, scene: &Scene, frame: &FrameCollection, geometry: &GeometryCache) {
        let _span = info_span!("gpu_scene_rebuild", renderables = frame.renderables.len()).entered();
        let previous = std::mem::take(&mut self.instances);
        let old_ranks = std::mem::take(&mut self.ranks);
        let (old_groups, old_lods) = (std::mem::take(&mut self.groups), std::mem::take(&mut self.lods));
        self.transparent.clear();
        self.group_index.clear();
        // Groups are first numbered in discovery order with their capacity,
        // then sorted into partition order and renumbered.
        // Each group's key, its capacity so far, and its sort order, which
        // names the mesh by its stable id, not its slots: slots are handed
        // out in the order views first drew each mesh, and the group order
        // must not depend on the frame history (the deterministic mode).
        let mut keys: Vec<(GroupKey, u32, GroupOrder)> = Vec::new();
        // Returns the group and the caller's rank in its room (instances
        // come in order, so ranks follow instance order).
        let mut group_of = |key: GroupKey, order: GroupOrder, keys: &mut Vec<(GroupKey, u32, GroupOrder)>| {
            let next = keys.len() as u32;
            let index = *self.group_index.entry(key).or_insert(next);
            if index == next {
                keys.push((key, 0, order));
            }
            let rank = keys[index as usize].1;
            keys[index as usize].1 += 1;
            (index, rank)
        };
        let mut ranks = Vec::with_capacity(previous.len());
        let mut lod_ranks = Vec::new();
        self.instance_of_submesh.clear();
        self.instance_of_submesh.resize(frame.submeshes.len(), oxygen_bindless::INVALID_SLOT);
        let mut instances = Vec::with_capacity(previous.len());
        let mut lods = Vec::new();
        // A mesh's attribute records, by its first vertex (which names it).
        let mut attributes_of: HashMap<u32, u32> = HashMap::new();
        for (index, entry) in frame.renderables.iter().enumerate() {
            let Some(base) = geometry.get(entry.geometry) else { continue };
            attributes_of.insert(base.vertices.start, base.attributes);
            let (start, count) = entry.submeshes;
            let submeshes = &frame.submeshes[start as usize..(start + count) as usize];
            if submeshes.iter().any(|s| s.pass_mask.contains(PassMask::TRANSPARENT)) {
                self.transparent.push(index as u32);
            }
            let (lod_start, lod_count) = entry.lods;
            let levels = &frame.lod_levels[lod_start as usize..(lod_start + lod_count) as usize];
            for (submesh, cached) in submeshes.iter().enumerate() {
                if cached.pass_mask.contains(PassMask::TRANSPARENT) {
                    continue;
                }
                let rank = partition_rank(cached.pass_mask);
                let mask = cached.pass_mask.bits();
                let key = |vertex_slot, index_slot, first_index, index_count| -> GroupKey {
                    (rank, cached.material, mask, vertex_slot, index_slot, first_index, 0, index_count)
                };
                let order = |geometry_id, first_index, index_count| -> GroupOrder {
                    (rank, cached.material, mask, geometry_id, first_index, index_count)
                };
                let base_key = key(base.vertices.start, base.index_slot, cached.first_index, cached.index_count);
                let base_order = order(entry.geometry_id, cached.first_index, cached.index_count);
                let (group, base_rank) = group_of(base_key, base_order, &mut keys);
                self.instance_of_submesh[start as usize + submesh] = instances.len() as u32;
                ranks.push(base_rank);
                let lod_first = lods.len() as u32;
                for level in levels {
                    // As the view phase: a LOD replaces the mesh and takes
                    // the same submesh's range from it.
                    let lod = scene.geometry(level.geometry).and_then(|mesh| {
                        let range = *mesh.submeshes().get(submesh)?;
                        let slots = geometry.get(level.geometry)?;
                        attributes_of.insert(slots.vertices.start, slots.attributes);
                        let id = oxygen_core::scene::geometry_index(level.geometry);
                        Some((
                            key(slots.vertices.start, slots.index_slot, range.first_index, range.index_count),
                            order(id, range.first_index, range.index_count),
                        ))
                    });
                    // A level the CPU path could not draw either falls back
                    // to the base mesh, so both paths draw something.
                    let (lod_key, lod_order) = lod.unwrap_or((base_key, base_order));
                    let (group, rank) = group_of(lod_key, lod_order, &mut keys);
                    lod_ranks.push(rank);
                    lods.push(GpuLod { below_screen_fraction: level.below_screen_fraction, group });
                }
                let sphere = entry.world_sphere;
                instances.push(GpuInstance {
                    aabb_min: entry.world_aabb.min.to_array(),
                    group,
                    aabb_max: entry.world_aabb.max.to_array(),
                    flags: if entry.flags.contains(NodeFlags::CASTS_SHADOWS) { GpuInstance::CASTS_SHADOWS } else { 0 },
                    sphere: sphere.center.extend(sphere.radius).to_array(),
                    transform_index: entry.transform_index,
                    node_id: entry.node_id,
                    submesh: submesh as u32,
                    lod_first,
                    lod_count: lods.len() as u32 - lod_first,
                    joint_base: entry.joint_base,
                    // A skinned renderable has no LODs (the frame phase drops
                    // them): its one group is its base mesh's.
                    skin_slot: skin_slot(entry.joint_base, base.skin),
                    morph_base: entry.morph_base,
                });
            }
        }

        // Partition order, then material and mesh: the CPU key's order.
        let mut order: Vec<u32> = (0..keys.len() as u32).collect();
        // Keys are unique, so an unstable sort is deterministic.
        order.sort_unstable_by_key(|&g| (keys[g as usize].2, keys[g as usize].0));
        let mut renumber = vec![0u32; keys.len()];
        for (new, &old) in order.iter().enumerate() {
            renumber[old as usize] = new as u32;
        }
        self.partitions.clear();
        let mut draw_base = 0u32;
        for (new, &old) in order.iter().enumerate() {
            let ((_, material, mask, vertex_slot, index_slot, first_index, base_vertex, index_count), capacity, _) =
                keys[old as usize];
            let partition_mask = PassMask::from_bits_truncate(mask) & PassMask::PARTITION_BITS;
            match self.partitions.last_mut() {
                Some(p) if p.mask == partition_mask => {
                    p.groups.end += 1;
                    p.draws.end += capacity;
                }
                _ => self.partitions.push(GpuPartition {
                    mask: partition_mask,
                    groups: new as u32..new as u32 + 1,
                    draws: draw_base..draw_base + capacity,
                }),
            }
            let partition = self.partitions.len() as u32 - 1;
            self.groups.push(GpuGroup {
                vertex_slot,
                index_slot,
                first_index,
                index_count,
                base_vertex,
                material,
                pass_mask: mask,
                command_base: self.partitions[partition as usize].groups.start,
                draw_base,
                partition_index: partition,
                capacity,
                attributes_slot: attributes_of.get(&vertex_slot).copied().unwrap_or(oxygen_bindless::INVALID_SLOT),
            });
            draw_base += capacity;
        }
        self.capacity = draw_base;
        for instance in &mut instances {
            instance.group = renumber[instance.group as usize];
        }
        for lod in &mut lods {
            lod.group = renumber[lod.group as usize];
        }
        self.lods = lods;
        self.instances = instances;
        ranks.extend_from_slice(&lod_ranks);
        self.ranks = ranks;

        self.changes.layout = self.groups != old_groups || self.lods != old_lods;
        self.changes.ranks = self.ranks != old_ranks;
        self.changes.instances = if self.changes.layout || previous.len() != self.instances.len() {
            std::iter::once(0..self.instances.len() as u32).collect()
        } else {
            changed_ranges(&previous, &self.instances)
        };
        self.rebuilds += 1;
    }
}

/// Sort rank of a partition: the top bits of the CPU sort key (class,
/// double-sided, mirrored), so partitions come in the CPU path's order.
fn partition_rank(mask: PassMask) -> u64 {
    (mask.pass_class() << 2)
        | (u64::from(mask.contains(PassMask::DOUBLE_SIDED)) << 1)
        | u64::from(mask.contains(PassMask::MIRRORED))
}

/// Runs of indices where `old` and `new` differ (same lengths), with runs
/// closer than a few records joined: one write of a short unchanged gap
/// costs less than two writes.
pub(crate) fn changed_ranges<T: PartialEq>(old: &[T], new: &[T]) -> Vec<Range<u32>> {
    const JOIN_GAP: usize = 4;
    let mut out: Vec<Range<u32>> = Vec::new();
    for (i, (a, b)) in old.iter().zip(new).enumerate() {
        if a == b {
            continue;
        }
        let i = i as u32;
        match out.last_mut() {
            Some(last) if (i - last.end) as usize <= JOIN_GAP => last.end = i + 1,
            _ => out.push(i..i + 1),
        }
    }
    out
}

/// The skin slot a draw or instance reads: `skin` (its geometry's skin
/// weights) when it has joints (`joint_base` valid), else none.
pub(crate) fn skin_slot(joint_base: u32, skin: u32) -> u32 {
    if joint_base == oxygen_bindless::INVALID_SLOT { oxygen_bindless::INVALID_SLOT } else { skin }
}

const _: () = {
    assert!(std::mem::size_of::<GpuInstance>() == 80);
    assert!(std::mem::size_of::<GpuGroup>() == 48);
    assert!(std::mem::size_of::<GpuLod>() == 8);
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn changed_ranges_join_close_runs_and_skip_equal_records() {
        let old = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15];
        let mut new = old;
        assert!(changed_ranges(&old, &new).is_empty());
        new[1] = 100;
        new[3] = 100;
        new[14] = 100;
        assert_eq!(changed_ranges(&old, &new), vec![1..4, 14..15]);
    }
}
