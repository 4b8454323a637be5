//! What the forward pass lights with, beyond the frame's lights: bind group
//! 3 ([`inputs`]: cascades, the local shadow atlas, probes, the environment
//! and the split-sum table), the resources every view shares
//! ([`LightingResources`]), the local shadow atlas, the split-sum table and
//! image-based lighting ([`ibl`]). Data flows one way: the split-sum table
//! and the shadow atlas are built first, group 3 binds them, the resources
//! hold group 3; pipelines read the layout, never the other way round.

pub(crate) mod ibl;
pub(crate) mod inputs;
mod resources;
pub(crate) mod shadow_atlas;
pub(crate) mod split_sum;

pub use resources::LightingResources;
