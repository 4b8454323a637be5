//! Drawing prepared partitions: [`MeshPass`] in all its configurations
//! (depth pre-pass, shadow map, forward lit, transparent), the ID render
//! that draws a view's instance ids again into targets of its own, the bind group 1
//! a forward pass assembles from its view's inputs, and the mesh WGSL (the
//! shared vertex stage, the depth-only and the forward lit fragment stages).

mod deferred;
mod forward_lighting;
mod id_render;
mod pass;

pub use deferred::DeferredShading;
pub(crate) use deferred::{DeferredParams, DeferredTile, deferred_layout, wgsl_constants as deferred_constants};
pub use id_render::{ID_LABELS, id_targets, ids_over_depth, record_id_render, record_ids_over_depth, region_camera};
pub use pass::{ColorOps, DrawList, ForwardLitConfig, MeshPass, ShadowFilter};
