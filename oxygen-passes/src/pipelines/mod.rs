//! Pipelines: which ones exist and how they are made. A mesh pass picks one
//! variant per partition, opaque/masked × back-face/double-sided (blend ×
//! back-face/double-sided for transparency), specialised by the optional
//! shader code its view needs ([`ShaderFeatures`]); the [`Pipelines`] cache
//! creates each on first request, compiled by whichever recording thread
//! is idle. Also here: the WGSL each mesh pass kind compiles, the non-mesh
//! pipelines the cache keeps (tone map, sky), and the full-screen triangle
//! other folders build their screen-space pipelines with.

mod cache;
mod compute;
mod features;
mod fullscreen;
mod key;
mod mesh_shader;
mod screen;

pub use cache::{CompilerGuard, PipelineFuture, Pipelines};
pub(crate) use compute::{compute_pipeline, compute_step};
pub use features::{Exposure, ShaderFeatures};
pub use fullscreen::{fullscreen_pass, fullscreen_pipeline};
pub use key::{AlphaClass, DepthBias, PassKind, PipelineKey, PipelineVariant};
pub(crate) use mesh_shader::mesh_entry_points;
#[cfg(test)]
pub(crate) use mesh_shader::mesh_module;
pub(crate) use mesh_shader::pipeline_source;
#[cfg(any(test, feature = "testing"))]
pub use mesh_shader::shader_source;
