//! The path-traced reference: the ground truth raster shading is compared
//! with. [`ReferenceTracer`] holds the ray scene on the GPU and the compute
//! pipeline; [`ReferencePass`] accumulates a view's samples.
//! `params` holds the parameter block and flag bits the shader shares with
//! Rust, declared once.

pub(crate) mod params;
mod tracer;

#[cfg(feature = "testing")]
pub use tracer::reference_shader_source;
pub use tracer::{ReferencePass, ReferenceSettings, ReferenceTracer};
