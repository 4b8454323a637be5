//! GPU-driven visibility: the GPU scene's buffers, and per view the compute
//! dispatches that cull it and write the view's draws and commands.
//!
//! ScenePrep builds the records ([`oxygen_sceneprep::GpuScene`]) and plans
//! each GPU view's ranges ([`oxygen_sceneprep::GpuViewPlan`]); this module
//! uploads what changed, keeps per view a parameter block, a count buffer
//! (the indirect counts the passes draw with), the last frame's visibility
//! (occlusion culling) and a depth pyramid, and records:
//!
//! * before the view's graph, [`GpuVisibility::record_early`]: clear the
//!   counters, cull (frustum; with occlusion only last frame's visible), and
//!   write list A's commands;
//! * from the graph, after the depth pre-pass drew list A
//!   ([`crate::RenderContext::cull_occluded`]): build the depth pyramid,
//!   test the rest against it and write lists B and C.
//!
//! The passes only see partitions with a `gpu_count`, which they draw with
//! `multi_draw_indexed_indirect_count` and this view's count buffer.

use std::collections::HashMap;

use oxygen_bindless::{BindlessHeap, DomainKind};
use oxygen_core::{ResolvedView, ViewId};
use oxygen_gpu::bindings::{self, LayoutEntries};
use oxygen_sceneprep::{GpuScene, GpuSceneChanges, PreparedSceneFrame, Visibility};
use tracing::info_span;

use super::hiz::{HizPipelines, HizPyramid};
use super::params::{CULL_CASTERS_ONLY, CULL_DETERMINISTIC, CULL_OCCLUSION, CullParams};

/// Coverage counters before the per-group ones: the coverage sum, the
/// capped sum, the indices drawn, the draws (see the cull shader).
const COVERAGE_COUNTERS: u64 = 4;

/// Workgroups per dimension every adapter allows.
const MAX_WORKGROUPS: u32 = 65_535;

/// The features a GPU visibility path needs on top of the multi-draw
/// indirect path: counts written by the GPU.
pub const GPU_VISIBILITY_FEATURES: wgpu::Features =
    wgpu::Features::MULTI_DRAW_INDIRECT_COUNT.union(wgpu::Features::INDIRECT_FIRST_INSTANCE);

/// Where a view's coverage readback stands (see [`GpuVisibility::record_readback`]).
const READBACK_IDLE: u8 = 0;
const READBACK_COPIED: u8 = 1;
const READBACK_MAPPING: u8 = 2;
const READBACK_MAPPED: u8 = 3;
const READBACK_FAILED: u8 = 4;

/// One GPU view this frame, as [`GpuVisibility::prepare`] takes it.
#[derive(Clone, Copy, Debug)]
pub struct GpuViewRequest<'a> {
    /// The view in absolute world space (as ScenePrep culls it).
    pub view: &'a ResolvedView,
    /// Its prepared frame (which carries the plan and the view's slots).
    pub prepared: &'a PreparedSceneFrame,
    /// LOD bias, as in `ViewPrepOptions::lod_bias`.
    pub lod_bias: f32,
    /// Shadow casters only (shadow views).
    pub casters_only: bool,
    /// The batch the view is a camera of (any number the caller picks per
    /// batch): a batch's frustum-culled cameras are culled in one dispatch
    /// ([`GpuVisibility::record_early_batch`]).
    pub batch: Option<u64>,
}

/// A storage buffer that grows by doubling.
struct GrowingBuffer {
    buffer: wgpu::Buffer,
    label: &'static str,
    usage: wgpu::BufferUsages,
}

impl GrowingBuffer {
    fn new(device: &wgpu::Device, label: &'static str, usage: wgpu::BufferUsages, bytes: u64) -> Self {
        let usage = usage | wgpu::BufferUsages::COPY_DST;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(16),
            usage,
            mapped_at_creation: false,
        });
        GrowingBuffer { buffer, label, usage }
    }

    /// Makes room for `bytes`; true when the buffer was replaced (its
    /// contents are lost and bind groups naming it are stale).
    fn reserve(&mut self, device: &wgpu::Device, bytes: u64) -> bool {
        if bytes <= self.buffer.size() {
            return false;
        }
        *self = Self::new(device, self.label, self.usage, bytes.next_power_of_two());
        true
    }
}

/// Per-view state kept between frames.
struct ViewCull {
    params: wgpu::Buffer,
    written: Option<CullParams>,
    counts: GrowingBuffer,
    history: GrowingBuffer,
    hiz: Option<HizPyramid>,
    bind_group: Option<wgpu::BindGroup>,
    /// What `bind_group` was made from: buffer generation, heap growths,
    /// pyramid size.
    bound: (u64, u64, Option<(u32, u32)>),
    plan_visibility: Visibility,
    instances: u32,
    groups: u32,
    partitions: u32,
    /// The plan's counters (the coverage counter follows them).
    counters: u32,
    /// Seen this frame (views not seen are dropped at the next prepare).
    seen: bool,
    /// The coverage counter copied here after the frame, mapped, read at
    /// the next prepare; its state (`READBACK_*`), shared with the mapping
    /// callback.
    readback: wgpu::Buffer,
    readback_state: std::sync::Arc<std::sync::atomic::AtomicU8>,
    /// Depth complexity estimated from the last coverage read back.
    overdraw: Option<f32>,
    /// Indices of the opaque and masked draws, from the same readback.
    depth_pass_indices: Option<u64>,
    /// The draws the GPU kept, from the same readback.
    draws: Option<u64>,
    /// The deterministic mode: its occupancy follows the history, one
    /// entry per draw of the GPU scene's room.
    deterministic: bool,
    /// The GPU scene's room (one list's draws).
    room: u32,
}

/// A batch's frustum-culled cameras, culled together: every camera's
/// parameters in one buffer, every camera's counters in one buffer (each
/// from its own base), one bind group, one dispatch per step with the
/// camera as its z.
struct BatchCull {
    params: GrowingBuffer,
    /// What `params` holds.
    written: Vec<CullParams>,
    counts: GrowingBuffer,
    /// Unused by frustum culling, bound because the layout has it.
    history: GrowingBuffer,
    bind_group: Option<wgpu::BindGroup>,
    /// What `bind_group` was made from: scene generation, heap growths,
    /// buffer generations.
    bound: (u64, u64, u64),
    buffers: u64,
    /// The cameras in dispatch order, each with its first counter.
    cameras: Vec<(ViewId, u32)>,
    instances: u32,
    groups: u32,
    /// The deterministic mode: `history` holds each camera's occupancy
    /// (`room` entries each).
    deterministic: bool,
    room: u32,
    seen: bool,
}

/// The GPU scene's buffers, the cull pipelines and every GPU view's state.
pub struct GpuVisibility {
    instances: GrowingBuffer,
    groups: GrowingBuffer,
    lods: GrowingBuffer,
    /// [`GpuScene::ranks`], which the deterministic mode reads.
    ranks: GrowingBuffer,
    /// Bumped whenever a scene buffer is replaced.
    generation: u64,
    layout: wgpu::BindGroupLayout,
    cull_early: wgpu::ComputePipeline,
    commands_early: wgpu::ComputePipeline,
    cull_late: wgpu::ComputePipeline,
    commands_late: wgpu::ComputePipeline,
    compact_early: wgpu::ComputePipeline,
    compact_late: wgpu::ComputePipeline,
    /// Bound in place of a pyramid by views without occlusion culling.
    no_hiz: wgpu::Buffer,
    hiz: HizPipelines,
    views: oxygen_core::ViewIdMap<ViewCull>,
    /// Batches whose cameras are culled in one dispatch, by the key their
    /// requests carry.
    batches: HashMap<u64, BatchCull>,
    /// Each batch camera's batch and first counter this frame (a lookup a
    /// camera, not a search through its batch: a thousand cameras ask).
    batch_members: oxygen_core::ViewIdMap<(u64, u32)>,
    uploaded_last_frame: u64,
    /// The GPU scene rebuild the buffers hold.
    uploaded_rebuild: Option<u64>,
}

/// The cull shader's full source: `visibility/cull.wgsl` with the GPU
/// records, its parameter block and flags, and the pyramid test.
pub fn cull_shader_source() -> String {
    crate::shaders::CULL.source()
}

impl GpuVisibility {
    /// Whether `features` allow the GPU paths (the device also needs
    /// compute shaders, which every adapter wgpu runs on Vulkan, Metal and
    /// DX12 has).
    pub fn supported(features: wgpu::Features) -> bool {
        features.contains(GPU_VISIBILITY_FEATURES)
    }

    /// Pipelines and empty buffers.
    pub fn new(device: &wgpu::Device) -> Self {
        let _span = info_span!("gpu_visibility_new").entered();
        let layout = LayoutEntries::new(wgpu::ShaderStages::COMPUTE)
            // Every view's `CullParams`; instances, groups, LODs; counts,
            // history, draws, commands; the depth pyramid; the ranks
            // (cull.wgsl's group 0).
            .repeat(4, bindings::storage_read_only())
            .repeat(4, bindings::storage_read_write())
            .repeat(2, bindings::storage_read_only())
            .create_layout(device, "gpu visibility");
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("visibility cull"),
            source: wgpu::ShaderSource::Wgsl(cull_shader_source().into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("visibility cull"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |entry: &'static str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let no_hiz = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("no depth pyramid"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let read = wgpu::BufferUsages::STORAGE;
        GpuVisibility {
            instances: GrowingBuffer::new(device, "gpu scene instances", read, 0),
            groups: GrowingBuffer::new(device, "gpu scene groups", read, 0),
            lods: GrowingBuffer::new(device, "gpu scene lods", read, 0),
            ranks: GrowingBuffer::new(device, "gpu scene ranks", read, 0),
            generation: 0,
            cull_early: pipeline("cull_early"),
            commands_early: pipeline("commands_early"),
            cull_late: pipeline("cull_late"),
            commands_late: pipeline("commands_late"),
            compact_early: pipeline("compact_early"),
            compact_late: pipeline("compact_late"),
            layout,
            no_hiz,
            hiz: HizPipelines::new(device),
            views: oxygen_core::ViewIdMap::default(),
            batches: HashMap::new(),
            batch_members: oxygen_core::ViewIdMap::default(),
            uploaded_last_frame: 0,
            uploaded_rebuild: None,
        }
    }

    /// Bytes the last [`GpuVisibility::prepare`] uploaded (scene records and
    /// view parameters).
    pub fn uploaded_last_frame(&self) -> u64 {
        self.uploaded_last_frame
    }

    /// Uploads what changed in `scene` and each view's parameters (only when
    /// they changed), and makes sure every view culled alone has its
    /// buffers, pyramid and bind group; a batch's cameras culled together
    /// share the batch's instead, and have none of their own. Views not
    /// named are forgotten.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        heap: &BindlessHeap,
        scene: &GpuScene,
        views: &[GpuViewRequest<'_>],
    ) {
        let _span = info_span!("gpu_visibility_prepare", views = views.len()).entered();
        self.collect_coverage(device);
        let mut uploaded = 0u64;
        let everything = GpuSceneChanges {
            instances: std::iter::once(0..scene.instances().len() as u32).collect(),
            layout: true,
            ranks: true,
        };
        let mut changes = match self.uploaded_rebuild {
            Some(held) if held == scene.rebuilds() => GpuSceneChanges::default(),
            Some(held) if held + 1 == scene.rebuilds() => scene.last_changes().clone(),
            _ => everything.clone(),
        };
        self.uploaded_rebuild = Some(scene.rebuilds());
        let bytes = |n: usize, size: usize| (n * size) as u64;
        let instance_size = std::mem::size_of::<oxygen_sceneprep::GpuInstance>();
        let mut replaced = self.instances.reserve(device, bytes(scene.instances().len(), instance_size));
        replaced |= self.groups.reserve(device, bytes(scene.groups().len(), 48));
        replaced |= self.lods.reserve(device, bytes(scene.lods().len(), 8));
        replaced |= self.ranks.reserve(device, bytes(scene.ranks().len(), 4));
        if replaced {
            self.generation += 1;
            changes = everything;
        }
        if changes.layout {
            queue.write_buffer(&self.groups.buffer, 0, bytemuck::cast_slice(scene.groups()));
            queue.write_buffer(&self.lods.buffer, 0, bytemuck::cast_slice(scene.lods()));
            uploaded += bytes(scene.groups().len(), 48) + bytes(scene.lods().len(), 8);
        }
        if changes.ranks {
            queue.write_buffer(&self.ranks.buffer, 0, bytemuck::cast_slice(scene.ranks()));
            uploaded += bytes(scene.ranks().len(), 4);
        }
        for range in &changes.instances {
            let records = &scene.instances()[range.start as usize..range.end as usize];
            if !records.is_empty() {
                let offset = bytes(range.start as usize, instance_size);
                queue.write_buffer(&self.instances.buffer, offset, bytemuck::cast_slice(records));
                uploaded += bytes(records.len(), instance_size);
            }
        }

        // Batches first: a camera culled with its batch needs no buffers,
        // parameter upload or bind group of its own (a rig of a thousand
        // moving cameras would otherwise write a thousand of each a frame).
        uploaded += self.prepare_batches(device, queue, heap, views);
        for state in self.views.values_mut() {
            state.seen = false;
        }
        for request in views {
            let Some(plan) = request.prepared.gpu_plan() else { continue };
            let id = request.view.view_id;
            if self.batch_members.contains_key(&id) {
                continue;
            }
            let state = self.views.entry(id).or_insert_with(|| ViewCull {
                params: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("cull params"),
                    size: std::mem::size_of::<CullParams>() as u64,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                written: None,
                counts: GrowingBuffer::new(
                    device,
                    "cull counts",
                    // COPY_SRC: tests read the counts back.
                    wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_SRC,
                    0,
                ),
                history: GrowingBuffer::new(device, "cull history", wgpu::BufferUsages::STORAGE, 0),
                hiz: None,
                bind_group: None,
                bound: (u64::MAX, u64::MAX, None),
                plan_visibility: plan.visibility,
                instances: 0,
                groups: 0,
                partitions: 0,
                counters: 0,
                seen: true,
                readback: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("cull coverage readback"),
                    size: 16,
                    usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                    mapped_at_creation: false,
                }),
                readback_state: std::sync::Arc::new(std::sync::atomic::AtomicU8::new(READBACK_IDLE)),
                overdraw: None,
                depth_pass_indices: None,
                draws: None,
                deterministic: false,
                room: 0,
            });
            state.seen = true;
            // After the plan's counters, the coverage counters: the sum, the
            // capped sum, the indices drawn, the draws, one per group (see
            // the cull shader).
            let coverage_counters = COVERAGE_COUNTERS + u64::from(plan.groups);
            let mut stale = state.counts.reserve(device, (u64::from(plan.counters()) + coverage_counters) * 4);
            // New instance numbering or a new path: last frame's visibility
            // means nothing, so start from "nothing was visible" (phase 2
            // then tests everything).
            let renumbered = state.instances != plan.instances || state.plan_visibility != plan.visibility;
            let room = plan.capacity - plan.shading_offset;
            let occupancy = if plan.deterministic { room } else { 0 };
            stale |= state.history.reserve(device, (u64::from(plan.instances) + u64::from(occupancy)) * 4);
            (state.deterministic, state.room) = (plan.deterministic, room);
            if renumbered || changes.layout {
                queue.write_buffer(&state.history.buffer, 0, &vec![0u8; plan.instances as usize * 4]);
                uploaded += u64::from(plan.instances) * 4;
            }
            (state.instances, state.groups, state.partitions) = (plan.instances, plan.groups, plan.partitions);
            state.counters = plan.counters();
            state.plan_visibility = plan.visibility;
            let occlusion = plan.visibility == Visibility::GpuOcclusion;
            let size = (request.view.viewport.x.max(1), request.view.viewport.y.max(1));
            // A pyramid too large for one storage binding is not built: the
            // late test then finds everything visible (correct, no culling).
            let pyramid_bytes = u64::from(size.0) * u64::from(size.1) * 4 * 4 / 3 + 64;
            let fits = pyramid_bytes <= device.limits().max_storage_buffer_binding_size;
            if occlusion && fits && state.hiz.as_ref().is_none_or(|h| h.size() != size) {
                state.hiz = Some(HizPyramid::new(device, &self.hiz, size.0, size.1));
            } else if !occlusion || !fits {
                state.hiz = None;
            }
            let hiz_size = state.hiz.as_ref().map(HizPyramid::size);
            let bound = (self.generation, heap.growth_count(), hiz_size);
            if stale || state.bind_group.is_none() || state.bound != bound {
                let scene_buffers =
                    [&self.instances.buffer, &self.groups.buffer, &self.lods.buffer, &self.ranks.buffer];
                let hiz = state.hiz.as_ref().map_or(&self.no_hiz, |h| h.buffer());
                let own = [&state.params, &state.counts.buffer, &state.history.buffer, hiz];
                state.bind_group = Some(bind_group(device, &self.layout, scene_buffers, heap, own));
                state.bound = bound;
            }

            let params = cull_params(request, plan, state.hiz.as_ref());
            if state.written != Some(params) {
                queue.write_buffer(&state.params, 0, bytemuck::bytes_of(&params));
                state.written = Some(params);
                uploaded += std::mem::size_of::<CullParams>() as u64;
            }
        }
        self.views.retain(|_, state| state.seen);
        self.uploaded_last_frame = uploaded;
    }

    /// Gathers each batch's frustum-culled cameras (every camera of the
    /// batch, or the batch is culled camera by camera) into one parameter
    /// buffer and one counts buffer; returns the bytes uploaded.
    fn prepare_batches(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        heap: &BindlessHeap,
        views: &[GpuViewRequest<'_>],
    ) -> u64 {
        let mut uploaded = 0;
        for batch in self.batches.values_mut() {
            batch.seen = false;
        }
        self.batch_members.clear();
        let mut members: HashMap<u64, Vec<&GpuViewRequest<'_>>> = HashMap::new();
        for request in views {
            if let Some(key) = request.batch {
                members.entry(key).or_default().push(request);
            }
        }
        for (key, requests) in members {
            let plans: Option<Vec<_>> = requests.iter().map(|r| r.prepared.gpu_plan()).collect();
            let Some(plans) = plans else { continue };
            let frustum_only = plans.iter().all(|p| p.visibility == Visibility::GpuFrustum);
            let same_scene = plans.iter().all(|p| p.instances == plans[0].instances && p.groups == plans[0].groups);
            // One dispatch holds at most MAX_WORKGROUPS cameras (its z).
            if !frustum_only || !same_scene || requests.len() < 2 || requests.len() > MAX_WORKGROUPS as usize {
                continue;
            }
            let batch = self.batches.entry(key).or_insert_with(|| BatchCull {
                params: GrowingBuffer::new(device, "batch cull params", wgpu::BufferUsages::STORAGE, 0),
                written: Vec::new(),
                counts: GrowingBuffer::new(
                    device,
                    "batch cull counts",
                    wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_SRC,
                    0,
                ),
                history: GrowingBuffer::new(device, "batch cull history", wgpu::BufferUsages::STORAGE, 0),
                bind_group: None,
                bound: (u64::MAX, u64::MAX, u64::MAX),
                buffers: 0,
                cameras: Vec::new(),
                instances: 0,
                groups: 0,
                deterministic: false,
                room: 0,
                seen: true,
            });
            batch.seen = true;
            batch.cameras.clear();
            let mut params = Vec::with_capacity(requests.len());
            let mut base = 0u32;
            // Frustum culling: the room is the plan's whole GPU capacity.
            let (deterministic, room) = (plans[0].deterministic, plans[0].capacity);
            for (camera, (request, plan)) in requests.iter().zip(&plans).enumerate() {
                let id = request.view.view_id;
                // Each camera's occupancy in the batch's history, one after
                // the other. Frustum culling only: no depth pyramid.
                let occupancy_base = camera as u32 * room;
                params.push(CullParams { counter_base: base, occupancy_base, ..cull_params(request, plan, None) });
                batch.cameras.push((id, base));
                self.batch_members.insert(id, (key, base));
                // The plan's counters, then the coverage counters (see `prepare`).
                base += plan.counters() + COVERAGE_COUNTERS as u32 + plan.groups;
            }
            (batch.instances, batch.groups) = (plans[0].instances, plans[0].groups);
            (batch.deterministic, batch.room) = (deterministic, room);
            let occupancy = if deterministic { requests.len() as u64 * u64::from(room) } else { 1 };
            let param_bytes = (params.len() * std::mem::size_of::<CullParams>()) as u64;
            let mut replaced = batch.params.reserve(device, param_bytes);
            replaced |= batch.counts.reserve(device, u64::from(base) * 4);
            replaced |= batch.history.reserve(device, occupancy * 4);
            if replaced {
                batch.buffers += 1;
                batch.written.clear();
            }
            if batch.written != params {
                queue.write_buffer(&batch.params.buffer, 0, bytemuck::cast_slice(&params));
                uploaded += param_bytes;
                batch.written = params;
            }
            let bound = (self.generation, heap.growth_count(), batch.buffers);
            if batch.bind_group.is_none() || batch.bound != bound {
                let scene_buffers =
                    [&self.instances.buffer, &self.groups.buffer, &self.lods.buffer, &self.ranks.buffer];
                let own = [&batch.params.buffer, &batch.counts.buffer, &batch.history.buffer, &self.no_hiz];
                batch.bind_group = Some(bind_group(device, &self.layout, scene_buffers, heap, own));
                batch.bound = bound;
            }
        }
        self.batches.retain(|_, batch| batch.seen);
        uploaded
    }

    /// How many cameras `view` is culled with in one dispatch this frame
    /// (its batch's frustum-culled cameras, itself included); `None` for a
    /// view culled on its own.
    pub fn culled_together(&self, view: ViewId) -> Option<usize> {
        self.batch_of(view).map(|b| b.cameras.len())
    }

    /// The batch culling `view` with the others of its batch this frame.
    fn batch_of(&self, view: ViewId) -> Option<&BatchCull> {
        self.batches.get(&self.batch_members.get(&view)?.0)
    }

    /// Where `view`'s counters are this frame: its buffer and the byte
    /// offset of its first counter.
    fn counters_of(&self, view: ViewId) -> Option<(&wgpu::Buffer, u64)> {
        if let Some((key, base)) = self.batch_members.get(&view)
            && let Some(batch) = self.batches.get(key)
        {
            return Some((&batch.counts.buffer, u64::from(*base) * 4));
        }
        self.views.get(&view).map(|s| (&s.counts.buffer, 0))
    }

    /// Collects the coverage counters the GPU has finished copying (never
    /// waits): each view's depth complexity estimate for the next frames.
    fn collect_coverage(&mut self, device: &wgpu::Device) {
        use std::sync::atomic::Ordering;
        // Advances mapping callbacks without blocking.
        let _ = device.poll(wgpu::PollType::Poll);
        for state in self.views.values_mut() {
            match state.readback_state.load(Ordering::Acquire) {
                // Recorded but never submitted (a frame that failed): the
                // copy never happened.
                READBACK_COPIED => state.readback_state.store(READBACK_IDLE, Ordering::Release),
                READBACK_MAPPED => {
                    let counters = match state.readback.slice(..).get_mapped_range() {
                        Ok(bytes) => bytes.get(..16).map(|b| {
                            let word =
                                |i: usize| u32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]]);
                            // The smaller of the sum and the capped sum; the indices; the draws.
                            (word(0).min(word(1)), word(2), word(3))
                        }),
                        Err(_) => None,
                    };
                    state.readback.unmap();
                    if let Some((units, indices, draws)) = counters {
                        state.overdraw = Some(oxygen_sceneprep::expected_shaded_layers(units as f32 / 1024.0));
                        state.depth_pass_indices = Some(u64::from(indices));
                        state.draws = Some(u64::from(draws));
                    }
                    state.readback_state.store(READBACK_IDLE, Ordering::Release);
                }
                READBACK_FAILED => state.readback_state.store(READBACK_IDLE, Ordering::Release),
                _ => {}
            }
        }
    }

    /// The depth complexity `view`'s draws covered last time it was read
    /// back, estimated as the CPU path does (over each group of one mesh
    /// and material the viewport fractions its draws' bounding spheres
    /// cover, capped at 1 per group and summed, never more than all draws'
    /// coverage, then turned into times shaded by
    /// [`oxygen_sceneprep::expected_shaded_layers`]): `None` before the
    /// first readback, and for a camera culled with its batch (no coverage
    /// is read back for those).
    pub fn estimated_overdraw(&self, view: ViewId) -> Option<f32> {
        self.views.get(&view)?.overdraw
    }

    /// The indices of the opaque and masked draws `view`'s culling kept,
    /// from the same readback as [`GpuVisibility::estimated_overdraw`]:
    /// what a depth pre-pass would draw. `None` before the first readback.
    pub fn depth_pass_indices(&self, view: ViewId) -> Option<u64> {
        self.views.get(&view)?.depth_pass_indices
    }

    /// The draws (instances) `view`'s culling kept, from the same readback
    /// as [`GpuVisibility::estimated_overdraw`]. `None` before the first
    /// readback.
    pub fn gpu_draws(&self, view: ViewId) -> Option<u64> {
        self.views.get(&view)?.draws
    }

    /// Copies `view`'s coverage counter for reading back, when its last
    /// copy has been read: call after the view's passes, in its encoder.
    pub fn record_readback(&self, encoder: &mut wgpu::CommandEncoder, view: ViewId) {
        use std::sync::atomic::Ordering;
        let Some(state) = self.views.get(&view) else { return };
        let swapped =
            state.readback_state.compare_exchange(READBACK_IDLE, READBACK_COPIED, Ordering::AcqRel, Ordering::Acquire);
        if swapped.is_ok()
            && let Some((counts, base)) = self.counters_of(view)
        {
            // The coverage counter is the one after the plan's counters.
            let offset = base + u64::from(state.counters) * 4;
            encoder.copy_buffer_to_buffer(counts, offset, &state.readback, 0, 4 * COVERAGE_COUNTERS);
        }
    }

    /// Starts mapping the coverage copies of the frame just submitted.
    pub fn after_submit(&self) {
        use std::sync::atomic::Ordering;
        for state in self.views.values() {
            let swapped = state.readback_state.compare_exchange(
                READBACK_COPIED,
                READBACK_MAPPING,
                Ordering::AcqRel,
                Ordering::Acquire,
            );
            if swapped.is_ok() {
                let flag = std::sync::Arc::clone(&state.readback_state);
                state.readback.slice(..).map_async(wgpu::MapMode::Read, move |result| {
                    let next = if result.is_ok() { READBACK_MAPPED } else { READBACK_FAILED };
                    flag.store(next, Ordering::Release);
                });
            }
        }
    }

    /// The buffer whose counters a GPU-written partition's `gpu_count`
    /// indexes, for `view` this frame, and the byte offset of its counter 0
    /// (a batch's cameras share one buffer, each from its own offset).
    pub fn count_buffer(&self, view: ViewId) -> Option<(&wgpu::Buffer, u64)> {
        self.counters_of(view)
    }

    /// One compute pass over `bind_group`: each step with threads, for
    /// each of `views` views (one, or a batch's cameras).
    fn dispatch(
        encoder: &mut wgpu::CommandEncoder,
        bind_group: Option<&wgpu::BindGroup>,
        steps: &[(&wgpu::ComputePipeline, u32)],
        views: u32,
    ) {
        let Some(bind_group) = bind_group else { return };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("visibility cull"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, bind_group, &[]);
        for (pipeline, threads) in steps {
            if *threads > 0 {
                pass.set_pipeline(pipeline);
                dispatch_threads_for(&mut pass, *threads, views);
            }
        }
    }

    /// Phase 1 for `view`: clears its counters, culls, writes list A.
    /// Nothing for a view that is not on a GPU path this frame, nor for a
    /// camera culled with its batch ([`GpuVisibility::record_early_batch`]).
    pub fn record_early(&self, encoder: &mut wgpu::CommandEncoder, view: ViewId) {
        let Some(state) = self.views.get(&view) else { return };
        let _span = info_span!("cull_early", view = %view).entered();
        encoder.clear_buffer(&state.counts.buffer, 0, None);
        if state.deterministic {
            let occupancy = u64::from(state.instances) * 4;
            encoder.clear_buffer(&state.history.buffer, occupancy, Some(u64::from(state.room) * 4));
        }
        let steps = self.early_steps(state.instances, state.groups, state.deterministic);
        Self::dispatch(encoder, state.bind_group.as_ref(), &steps, 1);
    }

    /// Phase 1's steps: cull, compact (the deterministic mode only: no
    /// threads otherwise), commands.
    fn early_steps(&self, instances: u32, groups: u32, deterministic: bool) -> [(&wgpu::ComputePipeline, u32); 3] {
        let compact = if deterministic { workgroup_each(groups) } else { 0 };
        [(&self.cull_early, instances), (&self.compact_early, compact), (&self.commands_early, groups)]
    }

    /// Phase 1 for every view of `views` (a batch's cameras): the cameras
    /// culled together in one clear and one dispatch per step, the others
    /// on a GPU path each with its own counters and steps, in one compute
    /// pass (what [`GpuVisibility::record_early`] does view by view,
    /// without a compute pass per view); cameras on the CPU path are
    /// skipped.
    pub fn record_early_batch(&self, encoder: &mut wgpu::CommandEncoder, views: &[ViewId]) {
        let _span = info_span!("cull_early_batch", views = views.len()).entered();
        // The cameras culled together (every camera of the batch on the
        // GPU frustum path): one clear and one dispatch per step for all
        // of them, in the batch's buffers. A batch may also hold cameras
        // that are not (another visibility path, or none on the GPU): they
        // are culled one by one below, each in its own buffers.
        let key = views.iter().find_map(|v| self.batch_members.get(v)).map(|(key, _)| *key);
        if let Some(batch) = key.and_then(|key| self.batches.get(&key))
            && batch.bind_group.is_some()
        {
            encoder.clear_buffer(&batch.counts.buffer, 0, None);
            if batch.deterministic {
                let occupancy = batch.cameras.len() as u64 * u64::from(batch.room) * 4;
                encoder.clear_buffer(&batch.history.buffer, 0, Some(occupancy));
            }
            let steps = self.early_steps(batch.instances, batch.groups, batch.deterministic);
            Self::dispatch(encoder, batch.bind_group.as_ref(), &steps, batch.cameras.len() as u32);
        }
        let states: Vec<&ViewCull> =
            views.iter().filter(|v| !self.batch_members.contains_key(v)).filter_map(|v| self.views.get(v)).collect();
        if states.is_empty() {
            return;
        }
        for state in &states {
            encoder.clear_buffer(&state.counts.buffer, 0, None);
            if state.deterministic {
                let occupancy = u64::from(state.instances) * 4;
                encoder.clear_buffer(&state.history.buffer, occupancy, Some(u64::from(state.room) * 4));
            }
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("visibility cull (batch)"),
            timestamp_writes: None,
        });
        let mut bound: Option<&wgpu::ComputePipeline> = None;
        for state in states {
            let Some(bind_group) = &state.bind_group else { continue };
            pass.set_bind_group(0, bind_group, &[]);
            for (pipeline, threads) in self.early_steps(state.instances, state.groups, state.deterministic) {
                if threads == 0 {
                    continue;
                }
                if bound != Some(pipeline) {
                    pass.set_pipeline(pipeline);
                    bound = Some(pipeline);
                }
                dispatch_threads(&mut pass, threads);
            }
        }
    }

    /// Phase 2 for `view` (occlusion culling): builds the depth pyramid from
    /// `depth` (what phase 1's draws left), tests the instances phase 1 did
    /// not draw, writes lists B and C. Nothing for other views.
    pub fn record_late(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        view: ViewId,
        depth: &wgpu::TextureView,
    ) {
        let Some(state) = self.views.get(&view) else { return };
        if state.plan_visibility != Visibility::GpuOcclusion {
            return;
        }
        let _span = info_span!("cull_late", view = %view).entered();
        if let Some(hiz) = &state.hiz {
            hiz.build(device, &self.hiz, encoder, depth);
        }
        let compact = if state.deterministic { workgroup_each(state.groups) } else { 0 };
        let steps =
            [(&self.cull_late, state.instances), (&self.compact_late, compact), (&self.commands_late, state.groups)];
        Self::dispatch(encoder, state.bind_group.as_ref(), &steps, 1);
    }
}

/// A cull bind group: the GPU scene's buffers, the heap's draws and
/// commands, and the culled views' own parameters, counts, history and
/// depth pyramid (one view's, or a batch's shared ones).
fn bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    [instances, groups, lods, ranks]: [&wgpu::Buffer; 4],
    heap: &BindlessHeap,
    [params, counts, history, hiz]: [&wgpu::Buffer; 4],
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("gpu visibility"),
        layout,
        entries: &[
            buffer(0, params),
            buffer(1, instances),
            buffer(2, groups),
            buffer(3, lods),
            buffer(4, counts),
            buffer(5, history),
            buffer(6, heap.buffer(DomainKind::DrawMetadata)),
            buffer(7, heap.buffer(DomainKind::IndirectArgs)),
            buffer(8, hiz),
            buffer(9, ranks),
        ],
    })
}

fn buffer(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry { binding, resource: buffer.as_entire_binding() }
}

impl GpuVisibility {
    /// Reads back what the GPU wrote for `prepared`'s view last frame: per
    /// GPU-written partition its mask and draws, in the order the GPU wrote
    /// them (which varies from run to run: threads race for slots). Waits
    /// for the GPU. Empty for a view not on a GPU path.
    pub fn read_draws(
        &self,
        gpu: &oxygen_gpu::GpuContext,
        heap: &BindlessHeap,
        prepared: &PreparedSceneFrame,
    ) -> Result<Vec<(oxygen_sceneprep::PassMask, Vec<oxygen_sceneprep::DrawMetadata>)>, oxygen_gpu::GpuError> {
        let _span = info_span!("read_draws", view = %prepared.view_id()).entered();
        // A camera culled with its batch has its counters in the batch's buffer.
        let (Some(plan), Some((counts, base))) = (prepared.gpu_plan(), self.counters_of(prepared.view_id())) else {
            return Ok(Vec::new());
        };
        let words = |bytes: Vec<u8>| -> Vec<u32> { bytemuck::pod_collect_to_vec(&bytes) };
        let counts = words(gpu.read_buffer(counts, base, u64::from(plan.counters()) * 4)?);
        let slots = prepared.slots();
        let command_size = std::mem::size_of::<oxygen_sceneprep::DrawIndexedIndirect>() as u64;
        let draw_size = std::mem::size_of::<oxygen_sceneprep::DrawMetadata>() as u64;
        let commands: Vec<oxygen_sceneprep::DrawIndexedIndirect> = bytemuck::pod_collect_to_vec(&gpu.read_buffer(
            heap.buffer(DomainKind::IndirectArgs),
            u64::from(slots.indirect_args.start) * command_size,
            u64::from(plan.cpu_command_offset()) * command_size,
        )?);
        let draws: Vec<oxygen_sceneprep::DrawMetadata> = bytemuck::pod_collect_to_vec(&gpu.read_buffer(
            heap.buffer(DomainKind::DrawMetadata),
            u64::from(slots.draw_metadata.start) * draw_size,
            u64::from(plan.capacity) * draw_size,
        )?);
        let mut out = Vec::new();
        for partition in prepared.partitions() {
            let Some(counter) = partition.gpu_count else { continue };
            let written = counts.get(counter as usize).copied().unwrap_or(0).min(partition.command_count);
            let first = partition.first_command as usize;
            let mut partition_draws = Vec::new();
            for command in commands.get(first..first + written as usize).unwrap_or(&[]) {
                let range = command.first_instance as usize..(command.first_instance + command.instance_count) as usize;
                partition_draws.extend_from_slice(draws.get(range).unwrap_or(&[]));
            }
            out.push((partition.mask, partition_draws));
        }
        Ok(out)
    }
}

/// The parameter block for one view.
fn cull_params(
    request: &GpuViewRequest<'_>,
    plan: &oxygen_sceneprep::GpuViewPlan,
    hiz: Option<&HizPyramid>,
) -> CullParams {
    let view = request.view;
    let slots = request.prepared.slots();
    let mut planes = [[0.0; 4]; 6];
    for (out, plane) in planes.iter_mut().zip(&view.frustum.planes) {
        *out = plane.normal.extend(plane.d).to_array();
    }
    let mut flags = 0;
    if request.casters_only {
        flags |= CULL_CASTERS_ONLY;
    }
    if plan.visibility == Visibility::GpuOcclusion {
        flags |= CULL_OCCLUSION;
    }
    if plan.deterministic {
        flags |= CULL_DETERMINISTIC;
    }
    let generation = request.prepared.renderer_constants(0.0).debug_flags;
    let generation = if generation != 0 { slots.draw_metadata.generation() } else { 0 };
    CullParams {
        planes,
        view_row_z: view.view.row(2).to_array(),
        view_projection: (view.projection * view.view).to_cols_array_2d(),
        lod_scale: view.projection.y_axis.y,
        perspective: u32::from(view.projection.w_axis.w == 0.0),
        near: view.near,
        lod_bias: request.lod_bias,
        instance_count: plan.instances,
        group_count: plan.groups,
        partition_count: plan.partitions,
        flags,
        draw_slot: slots.draw_metadata.start,
        command_slot: slots.indirect_args.start,
        generation,
        hiz_levels: hiz.map_or(0, HizPyramid::levels),
        hiz_size: hiz.map_or([1, 1], |h| [h.size().0, h.size().1]),
        group_counters: plan.group_counters(),
        disc: std::f32::consts::FRAC_PI_4 / view.aspect().max(f32::MIN_POSITIVE),
        counter_base: 0,
        history_base: 0,
        shading_offset: plan.shading_offset,
        // A view of its own: after its history.
        occupancy_base: plan.instances,
    }
}

/// The `threads` argument of a step that runs one workgroup per item (the
/// compact steps): [`dispatch_threads_for`] makes one workgroup per 64
/// threads.
fn workgroup_each(items: u32) -> u32 {
    items.saturating_mul(64)
}

/// Dispatches `threads` invocations of 64: past 65 535 workgroups the rest
/// go into y; the shader rebuilds the linear index and skips the overshoot.
pub(crate) fn dispatch_threads(pass: &mut wgpu::ComputePass<'_>, threads: u32) {
    dispatch_threads_for(pass, threads, 1);
}

/// [`dispatch_threads`] for each of `views` views at once (the shader's
/// `id.z` is the view).
fn dispatch_threads_for(pass: &mut wgpu::ComputePass<'_>, threads: u32, views: u32) {
    let groups = threads.div_ceil(64);
    let x = groups.min(MAX_WORKGROUPS);
    pass.dispatch_workgroups(x, groups.div_ceil(x), views.min(MAX_WORKGROUPS));
}
