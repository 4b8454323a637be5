//! # oxygen-sceneprep
//!
//! ScenePrep turns a [`Scene`](oxygen_core::Scene) and a set of resolved
//! views into one immutable [`PreparedSceneFrame`] per view:
//!
//! ```text
//! Scene ─frame phase─► FrameCollection (world + normal matrices, lights, renderables
//!   │                   with world AABB and sphere) — once per frame, shared by views
//!   └─ per view ─view phase─► pre-filter → visibility cull → RenderItem[]
//!                 ─finalize─► DrawMetadata emit → sort (64-bit key) → partitions
//!                            ▼
//!                   PreparedSceneFrame (immutable, dumpable, snapshot-testable)
//! ```
//!
//! Slots are assigned on the CPU ([`oxygen_bindless::SlotAllocators`]), so
//! everything up to the prepared frame runs and is tested without a GPU;
//! [`ScenePrep::upload`] then writes the frame's data into the bindless heap.
//! This crate knows nothing of passes.
//!
//! Its internals (the worker pool behind [`WorkerPool`], finalization's sort
//! keys, radix sort and caches, the BVH builder) are crate-private; the
//! `testing` feature, which only the crate's own tests and benchmarks turn
//! on, exposes what they need in a `testing` module.

#![warn(missing_docs)]
// `!(x > 0.0)` is how this crate rejects NaN along with the out-of-range values;
// rewriting it with `partial_cmp` would hide that intent.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod collect;
mod draw_metadata;
mod finalize;
mod gpu_records;
mod gpu_scene;
mod overdraw;
mod pass_mask;
mod prepared_frame;
pub mod ray;
mod scene_prep;
#[cfg(feature = "testing")]
pub mod testing;
mod worker_pool;

pub use collect::{
    CullBound, FrameCollection, Instancing, LocalShadowCaster, LocalShadowKind, RenderOrigin, RenderableEntry,
    SkippedNode, SubmeshEntry, ViewFilter, ViewPrepOptions,
};
pub use draw_metadata::{DrawIndexedIndirect, DrawMetadata};
pub use finalize::materials::MaterialFeatures;
pub use gpu_records::{
    DirectionalLightRecord, GPU_RECORDS_WGSL, MAX_SHADOW_TILES, MaterialRecord, NormalMatrix, PositionalLightRecord,
    UvTransformRecord, VertexRecord, material_flags, vertex_record_overlays,
};
pub use gpu_scene::{GpuGroup, GpuInstance, GpuLod, GpuPartition, GpuScene, GpuSceneChanges, Visibility};
pub use overdraw::expected_shaded_layers;
pub use pass_mask::PassMask;
pub use prepared_frame::{GpuViewPlan, Partition, PreparedSceneFrame, PreparedSlots, canonical_draws, canonical_dump};
pub use ray::{RayInstance, RayScene};
pub use scene_prep::{PrepError, PrepStats, ScenePrep, ViewRequest};
pub use worker_pool::WorkerPool;

// Crate-private names the crate reaches by `crate::` paths.
pub(crate) use collect::RenderItem;
pub(crate) use gpu_records::shadow_tiles_for;
