//! GPU-driven visibility: the GPU scene's buffers and the compute passes that
//! cull it per view (frustum, then occlusion against a depth pyramid) and
//! write the view's draws and commands ([`GpuVisibility`]); the depth
//! pyramid ([`hiz`]) and the box test against it that the cull shader
//! includes.
//! `params` holds what the shaders share with Rust (parameter blocks, flag
//! bits), declared once.

mod cull;
pub mod hiz;
pub(crate) mod params;

#[cfg(feature = "testing")]
pub use cull::cull_shader_source;
pub(crate) use cull::dispatch_threads;
pub use cull::{GPU_VISIBILITY_FEATURES, GpuViewRequest, GpuVisibility};
