//! # oxygen-bindless
//!
//! The bindless heap. Shaders never receive per-draw bindings: they receive
//! *slots*, indices into a few large typed GPU buffers called *domains*
//! (draw metadata, world and normal matrices, materials, lights, vertices,
//! indices). This crate owns:
//!
//! * [`DomainKind`]: the domains, their record sizes and WGSL bindings;
//! * [`SlotAllocator`]: CPU-side range allocation with generation-checked
//!   [`Allocation`] handles, usable without a GPU (ScenePrep snapshot tests);
//! * [`BindlessHeap`]: the GPU buffers behind the allocators, grown (with the
//!   live data copied) when the allocators outgrow them, and the bind group
//!   every pass sets once;
//! * [`TexturePath`]: textures addressed by slot through a binding array
//!   or, where the device has none, through texture arrays grouped by size;
//! * [`SceneConstants`]: the per-view uniform block, declared once
//!   (`gpu_struct!`: the Rust structs and their generated WGSL twins),
//!   bound by [`SCENE_CONSTANTS_WGSL`];
//! * [`wgsl_constants`]: the numbers shaders share with this crate
//!   (`INVALID_SLOT`, texture-location bit fields, …), generated from their
//!   Rust definitions rather than copied.
//!
//! It knows nothing of scenes or passes. `u32::MAX` ([`INVALID_SLOT`]) is the
//! absent slot, and shaders treat it so.

#![warn(missing_docs)]
// `!(x > 0.0)` is how this crate rejects NaN along with the out-of-range values;
// rewriting it with `partial_cmp` would hide that intent.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod domain;
mod heap;
mod scene_constants;
mod slot;
mod textures;
mod wgsl_constants;

pub use domain::DomainKind;
pub use heap::{BindlessError, BindlessHeap};
pub use scene_constants::{
    CameraConstants, RendererConstants, SCENE_CONSTANTS_WGSL, SceneConstants, SceneConstantsBlock, SceneConstantsBuffer,
};
pub use slot::{Allocation, INVALID_SLOT, SlotAllocator, SlotAllocators, SlotError};
pub use textures::{MAX_TEXTURES, SAMPLERS, TexturePath, TextureUpload, allocate_texture_slot, resample_rgba8};
pub use wgsl_constants::wgsl_constants;
