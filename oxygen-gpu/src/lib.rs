//! # oxygen-gpu
//!
//! The GPU device every Oxygen renderer draws on: adapter and device
//! selection ([`GpuContext`], shared wgpu instances per backend set), the
//! offscreen targets of a view ([`ViewTargets`]: HDR colour, display colour,
//! depth, MSAA), readback into images ([`HdrImage`], RGBA8), and the two
//! declarations every pass shares with its shaders: bind-group layouts
//! ([`bindings`]: typed entries numbered in order, instead of hand-written
//! `BindGroupLayoutEntry` literals) and structs shared with WGSL
//! ([`gpu_struct!`], checked against naga's layout by [`check_layout`]).
//!
//! It sits beside `oxygen-core` rather than in it: the scene, assets and view
//! contracts are plain data that ScenePrep and the snapshot tests use without
//! a device, while everything here needs wgpu.

#![warn(missing_docs)]

pub mod bindings;
mod context;
pub mod gpu_struct;
mod labels;
mod readback;
mod target;

pub use bindings::LayoutEntries;
pub use context::{GpuContext, GpuError, GpuOptions};
pub use gpu_struct::{FieldLayout, GpuStruct, StructLayout, WgslType, check_layout, check_overlay};
pub use labels::{Label, LabelPlane, LabelSet, LabelTargets};
pub use readback::{HdrImage, f16_to_f32, unpack_rg11b10_ufloat};
pub use target::{
    AtlasPage, ColorTargets, DeferredTargets, HdrFormat, Msaa, MsaaTargets, Tile, TileAtlas, ViewTargets, texture_2d,
};
