//! The path-traced reference: the ground truth raster shading is compared
//! with. [`ReferenceTracer`] holds the ray scene on the GPU and the compute
//! pipeline; [`ReferencePass`] accumulates a view's samples.

mod tracer;

pub use tracer::{ReferencePass, ReferenceSettings, ReferenceTracer, reference_shader_source};
