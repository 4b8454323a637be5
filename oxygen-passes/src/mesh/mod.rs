//! Drawing prepared partitions: [`MeshPass`] in all its configurations
//! (depth pre-pass, shadow map, forward lit, transparent), the bind group 1
//! a forward pass assembles from its view's inputs, and the mesh WGSL (the
//! shared vertex stage, the depth-only and the forward lit fragment stages).

mod forward_lighting;
mod pass;

pub use pass::{ColorOps, DrawList, ForwardLitConfig, MeshPass, ShadowFilter};
