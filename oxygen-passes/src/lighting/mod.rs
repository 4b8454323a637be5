//! What the forward pass lights with, beyond the frame's lights: bind group
//! 3 (`params`: its uniform block, sizes and bindings as the WGSL reads
//! them; `inputs`: its layout and bind groups over the cascades, the local
//! shadow atlas, probes, the environment and the split-sum table), the
//! resources every view shares ([`LightingResources`]), the local shadow
//! atlas, the split-sum table and image-based lighting (`ibl`). Data flows
//! one way: `params` is a leaf (the shader registry reads it too), the
//! split-sum table and the shadow atlas are built from it, group 1 binds
//! them, the resources hold group 1; the pipelines read its layout, never
//! the other way round.

pub(crate) mod ambient_occlusion;
pub(crate) mod clusters;
pub(crate) mod contact_shadows;
pub(crate) mod ibl;
pub(crate) mod inputs;
pub(crate) mod params;
pub(crate) mod reflections;
mod resources;
pub(crate) mod shadow_atlas;
pub(crate) mod split_sum;

pub use inputs::ScreenBuffers;
pub use resources::LightingResources;
