//! Image-based lighting: the prefiltered environment and reflection probes.
//! The cube filter builds both on the GPU (level 0, box mips, GGX levels,
//! irradiance harmonics); the WGSL here is the cube layout every cube shares
//! and the reading of the environment that shading and the reference share.
//! `params` holds the cube filter's parameter block, declared once for Rust
//! and WGSL.

pub(crate) mod cube_filter;
pub(crate) mod half;
pub(crate) mod params;
