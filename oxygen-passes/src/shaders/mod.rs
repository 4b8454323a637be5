//! WGSL shared by the shaders of several folders: the reflectance model and
//! light falloff ([`BRDF_WGSL`]) that raster shading and the path-traced
//! reference both evaluate, so both model the same surfaces.

/// The reflectance model and light falloff shared by raster shading and the
/// path-traced reference.
pub const BRDF_WGSL: &str = include_str!("brdf.wgsl");
