//! `PreparedSceneFrame`: the immutable result of ScenePrep for one view.
//!
//! Passes read it and never change it. It holds the sorted draws, their
//! partitions, the frame's shared transforms, and the slots where each of
//! these lives on the GPU. [`PreparedSceneFrame::dump`] is a stable,
//! human-readable text used by snapshot tests.

use std::fmt::Write;
use std::sync::Arc;

use glam::Mat4;
use oxygen_bindless::{Allocation, DomainKind, INVALID_SLOT, RendererConstants};
use oxygen_core::ViewId;

pub use crate::finalize::partition::Partition;
use crate::{DrawIndexedIndirect, DrawMetadata, NormalMatrix, PassMask, Visibility};

/// Where a prepared frame's data lives in the bindless heap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PreparedSlots {
    /// This view's draws (per view, per frame).
    pub draw_metadata: Allocation,
    /// This view's indirect draw arguments, parallel to `draw_metadata`.
    pub indirect_args: Allocation,
    /// World matrices (frame-global).
    pub world_transforms: Allocation,
    /// Normal matrices (frame-global).
    pub normal_transforms: Allocation,
    /// Material table (persistent).
    pub materials: Allocation,
    /// Directional lights (frame-global).
    pub directional_lights: Allocation,
    /// Positional lights (frame-global).
    pub positional_lights: Allocation,
}

impl PreparedSlots {
    /// Every range empty (no slot), as before a frame is prepared.
    pub fn unallocated() -> Self {
        PreparedSlots {
            draw_metadata: Allocation::empty(DomainKind::DrawMetadata),
            indirect_args: Allocation::empty(DomainKind::IndirectArgs),
            world_transforms: Allocation::empty(DomainKind::WorldTransforms),
            normal_transforms: Allocation::empty(DomainKind::NormalTransforms),
            materials: Allocation::empty(DomainKind::Materials),
            directional_lights: Allocation::empty(DomainKind::DirectionalLights),
            positional_lights: Allocation::empty(DomainKind::PositionalLights),
        }
    }
}

/// The frame's transforms, shared by every view's prepared frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameTransforms {
    /// World matrices by transform index.
    pub world: Vec<Mat4>,
    /// Normal matrices by transform index.
    pub normal: Vec<NormalMatrix>,
}

/// How a view on a GPU visibility path lays out its ranges (the layout is
/// drawn in [`GpuScene`](crate::GpuScene)'s docs).
#[derive(Clone, Debug, PartialEq)]
pub struct GpuViewPlan {
    /// The path.
    pub visibility: Visibility,
    /// Draw room of the GPU-written draws; the CPU's (transparent) draws
    /// follow it in the view's draw range.
    pub capacity: u32,
    /// The deterministic mode ([`crate::ScenePrep::set_deterministic`]):
    /// the cull shader writes each survivor at its rank
    /// ([`crate::GpuScene::ranks`]) and a compaction pass restores instance
    /// order within each group, every group writes its command in a fixed
    /// place (empty ones too).
    pub deterministic: bool,
    /// Where list C's draws start in the room: 0, except for occlusion
    /// culling in the deterministic mode, whose list C holds every drawn
    /// instance in one order (early and late merged) in a second room
    /// after the first.
    pub shading_offset: u32,
    /// Groups of the GPU scene: the commands of one list.
    pub groups: u32,
    /// Partitions of one list.
    pub partitions: u32,
    /// Instances the cull shader tests.
    pub instances: u32,
    /// Occlusion culling: the partitions of the draws visible last frame
    /// (list A), which the depth pre-pass draws first.
    pub early_partitions: Vec<Partition>,
    /// Occlusion culling: the partitions of the draws found visible only
    /// after the depth pyramid was built (list B), drawn second.
    pub late_partitions: Vec<Partition>,
}

impl GpuViewPlan {
    /// Where the CPU-written draws start in the view's draw range.
    pub fn cpu_draw_offset(&self) -> u32 {
        self.capacity
    }
    /// Where the CPU-written commands start in the view's indirect range.
    pub fn cpu_command_offset(&self) -> u32 {
        self.visibility.command_lists() * self.groups
    }
    /// Counters in the view's count buffer: per list and partition, then
    /// two per group (early and late instance counts).
    pub fn counters(&self) -> u32 {
        self.visibility.command_lists() * self.partitions + 2 * self.groups
    }
    /// The first per-group counter (early counts; late counts follow).
    pub fn group_counters(&self) -> u32 {
        self.visibility.command_lists() * self.partitions
    }
}

/// ScenePrep's immutable output for one view.
#[derive(Debug)]
pub struct PreparedSceneFrame {
    pub(crate) view_id: ViewId,
    pub(crate) frame_index: u64,
    pub(crate) draws: Vec<DrawMetadata>,
    pub(crate) indirect_args: Vec<DrawIndexedIndirect>,
    pub(crate) sort_keys: Vec<u64>,
    pub(crate) partitions: Vec<Partition>,
    pub(crate) transforms: Arc<FrameTransforms>,
    pub(crate) slots: PreparedSlots,
    pub(crate) debug_generations: bool,
    pub(crate) prep_seconds: f32,
    pub(crate) estimated_overdraw: f32,
    pub(crate) depth_pass_indices: u64,
    pub(crate) gpu: Option<GpuViewPlan>,
    pub(crate) deterministic: bool,
    pub(crate) surface_vertex_bits: u32,
    pub(crate) triangle_tables: bool,
}

fn slot(a: &Allocation) -> String {
    if a.start == INVALID_SLOT { "none".to_owned() } else { format!("{}+{}", a.start, a.count) }
}

impl PreparedSceneFrame {
    /// An empty frame of `view_id` whose buffers ScenePrep fills and
    /// reuses (for whichever view takes its place in later frames).
    pub(crate) fn empty(view_id: ViewId, transforms: Arc<FrameTransforms>) -> Self {
        PreparedSceneFrame {
            view_id,
            frame_index: 0,
            draws: Vec::new(),
            indirect_args: Vec::new(),
            sort_keys: Vec::new(),
            partitions: Vec::new(),
            transforms,
            debug_generations: false,
            prep_seconds: 0.0,
            estimated_overdraw: 0.0,
            depth_pass_indices: 0,
            gpu: None,
            deterministic: false,
            surface_vertex_bits: 1,
            triangle_tables: false,
            slots: PreparedSlots::unallocated(),
        }
    }

    /// The view it was prepared for.
    pub fn view_id(&self) -> ViewId {
        self.view_id
    }
    /// The frame sequence number.
    pub fn frame_index(&self) -> u64 {
        self.frame_index
    }
    /// Sorted draws.
    pub fn draws(&self) -> &[DrawMetadata] {
        &self.draws
    }
    /// Indirect draw arguments, one per draw, same order.
    pub fn indirect_args(&self) -> &[DrawIndexedIndirect] {
        &self.indirect_args
    }
    /// The sort key of each draw (same order as [`Self::draws`]).
    pub fn sort_keys(&self) -> &[u64] {
        &self.sort_keys
    }
    /// Partitions in draw order: on a GPU path the GPU-written ones first
    /// (for occlusion culling, those of every draw, list C), then the CPU's.
    pub fn partitions(&self) -> &[Partition] {
        &self.partitions
    }
    /// The GPU visibility plan, `None` on the CPU path.
    pub fn gpu_plan(&self) -> Option<&GpuViewPlan> {
        self.gpu.as_ref()
    }
    /// Where the CPU-written draws and commands start in the view's ranges:
    /// (0, 0) on the CPU path, after the GPU's room on a GPU path.
    pub fn cpu_offsets(&self) -> (u32, u32) {
        self.gpu.as_ref().map_or((0, 0), |g| (g.cpu_draw_offset(), g.cpu_command_offset()))
    }
    /// The draws of a CPU-written partition (empty for a GPU-written one,
    /// whose draws exist only on the GPU).
    pub fn draws_of(&self, partition: &Partition) -> &[DrawMetadata] {
        if partition.gpu_count.is_some() {
            return &[];
        }
        let offset = self.cpu_offsets().0;
        self.draws.get((partition.begin - offset) as usize..(partition.end - offset) as usize).unwrap_or(&[])
    }
    /// The commands of a CPU-written partition (empty for a GPU-written one).
    pub fn commands_of(&self, partition: &Partition) -> &[DrawIndexedIndirect] {
        if partition.gpu_count.is_some() {
            return &[];
        }
        let start = (partition.first_command - self.cpu_offsets().1) as usize;
        self.indirect_args.get(start..start + partition.command_count as usize).unwrap_or(&[])
    }
    /// Partitions whose mask has any bit of `required` and none of `excluded`.
    pub fn partitions_matching(&self, required: PassMask, excluded: PassMask) -> impl Iterator<Item = &Partition> {
        self.partitions.iter().filter(move |p| p.mask.intersects(required) && !p.mask.intersects(excluded))
    }
    /// The frame's world and normal matrices (shared by all views).
    pub fn transforms(&self) -> &Arc<FrameTransforms> {
        &self.transforms
    }
    /// The times a forward pass without a depth pre-pass is expected to
    /// shade a pixel. Over the runs of one material in draw order (each run
    /// goes front to back, so early depth testing shades a pixel about once
    /// per run), each run's viewport coverage (the fractions its draws'
    /// bounding spheres cover), capped at 1, adds up to the layers of runs
    /// over a pixel, never more than the sum of every draw's coverage (runs
    /// side by side do not cover each other); a pixel under `k` runs in no
    /// particular depth order is shaded `H(k) = 1 + 1/2 + … + 1/k` times on
    /// average ([`crate::expected_shaded_layers`]). About 1 when the
    /// materials tile the view, 2.08 under four overlapping runs. An
    /// estimate from data the view phase has anyway (spheres overestimate
    /// what they bound); the standard graph's automatic pre-pass decides
    /// from it.
    pub fn estimated_overdraw(&self) -> f32 {
        self.estimated_overdraw
    }
    /// The indices a depth pre-pass over this frame's CPU-written draws
    /// would draw: those of its opaque and masked draws (the GPU path's
    /// draws are counted on the GPU, see `GpuVisibility`). What the
    /// automatic pre-pass weighs against the shading it would spare.
    pub fn depth_pass_indices(&self) -> u64 {
        self.depth_pass_indices
    }
    /// Whether the frame was prepared in the deterministic mode
    /// ([`crate::ScenePrep::set_deterministic`]): its draws come in the
    /// canonical order, and the shading pass resolves exact depth ties as a
    /// depth pre-pass does (whatever reads it must not choose passes that
    /// change pixels by estimates, which depend on the path and the frame
    /// history).
    pub fn deterministic(&self) -> bool {
        self.deterministic
    }

    /// Wall time this view's view phase and finalization took (the frame
    /// phase, shared by all views, is not included).
    pub fn prep_seconds(&self) -> f32 {
        self.prep_seconds
    }
    /// Heap slots.
    pub fn slots(&self) -> &PreparedSlots {
        &self.slots
    }

    /// How many low bits of the 32-bit surface id a deferred visibility
    /// pass writes name the vertex that starts the pixel's triangle (the
    /// high bits holding the draw's index plus one): enough for the index
    /// values of every mesh resident this frame.
    pub fn surface_vertex_bits(&self) -> u32 {
        self.surface_vertex_bits
    }

    /// Whether each pixel of this view can be named in the 32 bits of a
    /// deferred visibility pass's surface id, and its triangle found from
    /// the id: the meshes have their triangle tables, and the draw's index
    /// plus one fits in the bits above [`Self::surface_vertex_bits`]; `Err` says why not
    /// (the view is then shaded forward). Counted on the view's draw range,
    /// which a GPU-culled view fills up to.
    pub fn surface_ids_fit(&self) -> Result<(), String> {
        if !self.triangle_tables {
            return Err(format!(
                "{}: the meshes were uploaded without triangle tables (ScenePrep::set_triangle_tables)",
                self.view_id
            ));
        }
        let bits = self.surface_vertex_bits;
        let draws = u64::from(self.slots.draw_metadata.count);
        let room = if bits >= 32 { 0 } else { (1u64 << (32 - bits)) - 1 };
        if bits >= 32 || draws > room {
            return Err(format!(
                "{}'s {draws} draws and meshes of up to 2^{bits} vertices do not fit a 32-bit surface id \
                 ({room} draws at most with such meshes)",
                self.view_id
            ));
        }
        Ok(())
    }

    /// The renderer-owned half of `SceneConstants` for this view.
    pub fn renderer_constants(&self, time_seconds: f32) -> RendererConstants {
        let s = &self.slots;
        RendererConstants {
            frame_sequence: self.frame_index as u32,
            time_seconds_bits: time_seconds.to_bits(),
            draw_metadata_slot: s.draw_metadata.start,
            draw_count: self.draws.len() as u32 + self.cpu_offsets().0,
            world_transforms_slot: s.world_transforms.start,
            normal_transforms_slot: s.normal_transforms.start,
            materials_slot: s.materials.start,
            directional_lights_slot: s.directional_lights.start,
            directional_light_count: s.directional_lights.count,
            positional_lights_slot: s.positional_lights.start,
            positional_light_count: s.positional_lights.count,
            debug_flags: if self.debug_generations { RendererConstants::DEBUG_GENERATIONS } else { 0 },
            draw_metadata_generation: s.draw_metadata.generation(),
            surface_vertex_bits: self.surface_vertex_bits,
            reserved1: 0,
            reserved2: 0,
        }
    }

    /// The CPU-written draws per partition mask in canonical order (see
    /// [`canonical_draws`]): for a CPU-path frame, every draw.
    pub fn canonical_draws(&self) -> Vec<(PassMask, Vec<DrawMetadata>)> {
        canonical_draws(self.partitions.iter().map(|p| (p.mask, self.draws_of(p).to_vec())).collect())
    }

    /// A stable, human-readable dump for snapshot tests: slots, partitions and
    /// every draw with its key. Node and material ids are slot indices, so the
    /// text depends only on the scene's construction order.
    pub fn dump(&self) -> String {
        let mut out = String::new();
        let s = &self.slots;
        // Writing to a String cannot fail.
        let _ = writeln!(out, "PreparedSceneFrame {} frame {}", self.view_id, self.frame_index);
        let _ = writeln!(
            out,
            "slots: draws={} worlds={} normals={} materials={} directional_lights={} positional_lights={}",
            slot(&s.draw_metadata),
            slot(&s.world_transforms),
            slot(&s.normal_transforms),
            slot(&s.materials),
            slot(&s.directional_lights),
            slot(&s.positional_lights)
        );
        let _ = writeln!(out, "partitions ({}):", self.partitions.len());
        for p in &self.partitions {
            let _ = match p.gpu_count {
                None => writeln!(out, "  [{}, {}) {}", p.begin, p.end, p.mask.names()),
                Some(counter) => writeln!(out, "  [{}, {}) {} gpu counter {counter}", p.begin, p.end, p.mask.names()),
            };
        }
        let _ = writeln!(out, "draws ({}):", self.draws.len());
        for (i, (d, key)) in self.draws.iter().zip(&self.sort_keys).enumerate() {
            let _ = writeln!(out, "  #{i:<3} {} key={key:016x} {}", draw_fields(d), d.mask().names());
        }
        out
    }
}

/// A draw's node, mesh range, transform and material, as both dumps print them.
fn draw_fields(d: &DrawMetadata) -> String {
    // Printed only when present, so dumps of scenes without vertex colours
    // or a second UV set read as they always did.
    let optional = |name: &str, slot: u32| match slot {
        oxygen_bindless::INVALID_SLOT => String::new(),
        slot => format!(" {name}@{slot}"),
    };
    let attributes = format!(
        "{}{}{}{}",
        optional("attributes", d.attributes_slot),
        optional("skin", d.skin_slot),
        optional("joints", d.joint_base),
        optional("morph", d.morph_base)
    );
    format!(
        "node={:<3} submesh={} vertices@{}{attributes} indices@{}+{}..{} transform={} material={}",
        d.node_id,
        d.submesh,
        d.vertex_slot,
        d.index_slot,
        d.first_index,
        d.first_index + d.index_count,
        d.transform_index,
        d.material_handle
    )
}

/// Draws per partition mask in an order that does not depend on the path
/// that produced them: masks in the CPU sort key's order (pass class,
/// double-sided, mirrored), draws of one mask merged and ordered by
/// (node id, submesh). The CPU path orders draws by material and depth
/// within a partition; the GPU paths in whatever order their threads won
/// their slots; this order is how the two are compared (and dumped,
/// [`canonical_dump`]).
pub fn canonical_draws(mut partitions: Vec<(PassMask, Vec<DrawMetadata>)>) -> Vec<(PassMask, Vec<DrawMetadata>)> {
    let rank = |mask: PassMask| {
        (mask.pass_class(), mask.contains(PassMask::DOUBLE_SIDED), mask.contains(PassMask::MIRRORED), mask.bits())
    };
    partitions.sort_by_key(|(mask, _)| rank(*mask));
    let mut out: Vec<(PassMask, Vec<DrawMetadata>)> = Vec::new();
    for (mask, draws) in partitions {
        match out.last_mut() {
            Some((last, merged)) if *last == mask => merged.extend(draws),
            _ => out.push((mask, draws)),
        }
    }
    out.retain(|(_, draws)| !draws.is_empty());
    for (_, draws) in &mut out {
        draws
            .sort_by_key(|d| (d.node_id, d.submesh, d.transform_index, d.material_handle, d.index_slot, d.first_index));
    }
    out
}

/// A text dump of [`canonical_draws`]' output, for snapshot tests and
/// failure messages.
pub fn canonical_dump(partitions: &[(PassMask, Vec<DrawMetadata>)]) -> String {
    let mut out = String::new();
    for (mask, draws) in partitions {
        let _ = writeln!(out, "{} ({} draws):", mask.names(), draws.len());
        for d in draws {
            let _ = writeln!(out, "  {} {}", draw_fields(d), d.mask().names());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use oxygen_bindless::{DomainKind, SlotAllocators};
    use oxygen_core::{ViewIdRange, ViewIds};

    use super::*;

    /// A frame of `draws` draw slots whose largest mesh needs `bits`.
    fn frame(draws: u32, bits: u32, slots: &mut SlotAllocators) -> PreparedSceneFrame {
        let view = ViewIds::new(ViewIdRange::Application).allocate();
        let mut frame = PreparedSceneFrame::empty(view, Arc::default());
        frame.surface_vertex_bits = bits;
        frame.triangle_tables = true;
        if draws > 0 {
            frame.slots.draw_metadata = slots.allocate(DomainKind::DrawMetadata, draws).expect("a draw range");
        }
        frame
    }

    /// A surface id holds the draw's index plus one above the vertex bits:
    /// with 20 of them, 4 095 draws fit and 4 096 do not (the error names
    /// the view and both counts), and the constants carry the bits.
    #[test]
    fn surface_ids_fit_up_to_the_bits_left_for_draws() {
        let mut slots = SlotAllocators::default();
        assert!(frame(4095, 20, &mut slots).surface_ids_fit().is_ok());
        let error = frame(4096, 20, &mut slots).surface_ids_fit().expect_err("one draw too many");
        assert!(error.contains("view#") && error.contains("4096") && error.contains("4095"), "{error}");
        assert!(frame(0, 31, &mut slots).surface_ids_fit().is_ok(), "one bit left: one draw");
        assert!(frame(0, 32, &mut slots).surface_ids_fit().is_err(), "no bit left for the draw");
        assert_eq!(frame(1, 5, &mut slots).renderer_constants(0.0).surface_vertex_bits, 5);
        let mut untabled = frame(1, 5, &mut slots);
        untabled.triangle_tables = false;
        let error = untabled.surface_ids_fit().expect_err("no triangle tables");
        assert!(error.contains("triangle tables"), "{error}");
    }
}
