//! The emit step: one view's sorted render items become its draws.
//!
//! In: the view's [`RenderItem`]s, their `(sort key, item index)` pairs
//! already sorted, the geometry slots resolved in the serial step, and the
//! slots of the frame and of this view. Out: the view's
//! [`PreparedSceneFrame`], filled in place — [`DrawMetadata`], indirect
//! arguments, sort keys, partitions and slots.
//!
//! It runs in parallel, one view per worker, so it must not allocate slots
//! or touch anything shared mutably; it reuses the frame's buffers, so a
//! steady-state frame allocates nothing here. Draws come out in sorted
//! order, which makes the result a pure function of its inputs.

use std::sync::Arc;

use oxygen_bindless::Allocation;
use oxygen_core::ViewId;

use crate::finalize::geometry_cache::GeometryCache;
use crate::finalize::partition::{build_commands, build_partitions};
use crate::gpu_scene::GpuScene;
use crate::prepared_frame::FrameTransforms;
use crate::{
    DrawMetadata, GpuViewPlan, Instancing, Partition, PassMask, PreparedSceneFrame, PreparedSlots, RenderItem,
    Visibility,
};

/// What every view of a frame emits against: shared, read-only.
pub(crate) struct FrameEmit<'a> {
    /// Geometry slots, complete for every item of every view (the serial
    /// step resolved the missing ones).
    pub geometry: &'a GeometryCache,
    /// The frame's matrices, shared by every view's prepared frame.
    pub transforms: &'a Arc<FrameTransforms>,
    /// Frame-global and persistent slots; the per-view ones are replaced.
    pub frame_slots: PreparedSlots,
    /// The frame sequence number.
    pub frame_index: u64,
    /// Tag each draw with its range's generation (debug mode).
    pub debug_generations: bool,
}

/// One view's sorted items and the draw ranges allocated for it.
pub(crate) struct ViewEmit<'a> {
    /// The view the frame is for.
    pub view_id: ViewId,
    /// Render items in (node id, submesh) order.
    pub items: &'a [RenderItem],
    /// `(sort key, index into items)`, sorted.
    pub keyed: &'a [(u64, u32)],
    /// This view's draw-metadata range.
    pub draw_allocation: Allocation,
    /// This view's indirect-argument range (room for one command per draw).
    pub indirect_allocation: Allocation,
    /// Whether runs of draws sharing a mesh become one command.
    pub instancing: Instancing,
    /// A GPU visibility path: the GPU scene whose partitions come first.
    pub gpu: Option<(&'a GpuScene, Visibility)>,
    /// The deterministic mode (see [`GpuViewPlan::deterministic`]).
    pub deterministic: bool,
}

/// Fills `out` with the draws of `view`, reusing its buffers. Leaves
/// `out.prep_seconds` to the caller, which times the whole view.
pub(crate) fn emit_view(frame: &FrameEmit<'_>, view: &ViewEmit<'_>, out: &mut PreparedSceneFrame) {
    out.draws.clear();
    out.indirect_args.clear();
    out.sort_keys.clear();
    out.depth_pass_indices = 0;
    let generation_tag = if frame.debug_generations { view.draw_allocation.generation() } else { 0 };
    for &(key, item_index) in view.keyed {
        let item = &view.items[item_index as usize];
        // Resolved in the serial step; a mesh missing from the scene was
        // never turned into an item.
        let Some(g) = frame.geometry.get(item.geometry) else { continue };
        if !item.pass_mask.contains(PassMask::TRANSPARENT) {
            out.depth_pass_indices += u64::from(item.index_count);
        }
        out.draws.push(DrawMetadata {
            vertex_slot: g.vertices.start,
            index_slot: g.index_slot,
            first_index: item.first_index,
            index_count: item.index_count,
            base_vertex: 0,
            instance_count: 1,
            transform_index: item.transform_index,
            material_handle: item.material,
            pass_mask: item.pass_mask.bits(),
            node_id: item.node_id,
            submesh: item.submesh,
            generation: generation_tag,
            attributes_slot: g.attributes,
            skin_slot: crate::gpu_scene::skin_slot(item.joint_base, g.skin),
            joint_base: item.joint_base,
            morph_base: item.morph_base,
        });
        out.sort_keys.push(key);
    }
    build_partitions(&out.draws, &mut out.partitions);
    build_commands(&out.draws, &mut out.partitions, view.instancing != Instancing::Off, &mut out.indirect_args);
    // Last frame's plan lends its vectors, so a steady frame allocates nothing.
    let previous = out.gpu.take();
    if let Some((scene, visibility)) = view.gpu {
        out.gpu = Some(gpu_plan(scene, visibility, view.deterministic, previous, out));
    }
    out.view_id = view.view_id;
    out.frame_index = frame.frame_index;
    out.debug_generations = frame.debug_generations;
    out.deterministic = view.deterministic;
    out.surface_vertex_bits = frame.geometry.surface_vertex_bits();
    out.triangle_tables = frame.geometry.triangle_tables();
    out.transforms = Arc::clone(frame.transforms);
    out.slots = PreparedSlots {
        draw_metadata: view.draw_allocation,
        indirect_args: view.indirect_allocation,
        ..frame.frame_slots
    };
}

/// Places a GPU path's partitions before the CPU's (transparent) ones,
/// which move past the GPU's room in the view's ranges.
fn gpu_plan(
    scene: &GpuScene,
    visibility: Visibility,
    deterministic: bool,
    previous: Option<GpuViewPlan>,
    out: &mut PreparedSceneFrame,
) -> GpuViewPlan {
    let (mut early, mut late) = previous.map_or((Vec::new(), Vec::new()), |p| (p.early_partitions, p.late_partitions));
    early.clear();
    late.clear();
    let shading_offset = shading_offset(scene, visibility, deterministic);
    let mut plan = GpuViewPlan {
        visibility,
        capacity: scene.capacity() + shading_offset,
        deterministic,
        shading_offset,
        groups: scene.groups().len() as u32,
        partitions: scene.partitions().len() as u32,
        instances: scene.instances().len() as u32,
        early_partitions: early,
        late_partitions: late,
    };
    let (draws, commands) = (plan.cpu_draw_offset(), plan.cpu_command_offset());
    for command in &mut out.indirect_args {
        command.first_instance += draws;
    }
    for partition in &mut out.partitions {
        partition.begin += draws;
        partition.end += draws;
        partition.first_command += commands;
    }
    // Occlusion culling draws lists A then B in the depth pre-pass and
    // list C (every draw) when shading; frustum culling has list A only.
    let shading_list = if visibility == Visibility::GpuOcclusion {
        plan.early_partitions.extend(scene.list_partitions(0));
        plan.late_partitions.extend(scene.list_partitions(1));
        2
    } else {
        0
    };
    out.partitions.splice(
        0..0,
        scene.list_partitions(shading_list).map(|p| Partition {
            begin: p.begin + shading_offset,
            end: p.end + shading_offset,
            ..p
        }),
    );
    plan
}

/// Where list C's draws start in a GPU view's room (see
/// [`GpuViewPlan::shading_offset`]): a second room for occlusion culling in
/// the deterministic mode, else none.
pub(crate) fn shading_offset(scene: &GpuScene, visibility: Visibility, deterministic: bool) -> u32 {
    if deterministic && visibility == Visibility::GpuOcclusion { scene.capacity() } else { 0 }
}
