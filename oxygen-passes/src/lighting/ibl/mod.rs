//! Image-based lighting: the prefiltered environment and reflection probes.
//! The cube filter builds both on the GPU (level 0, box mips, GGX levels,
//! irradiance harmonics); the WGSL here is the cube layout every cube shares
//! and the reading of the environment that shading and the reference share.
//! `params` holds the cube filter's parameter block, declared once for Rust
//! and WGSL.

pub(crate) mod cube_filter;
pub(crate) mod half;
pub(crate) mod params;

/// The cube layout every cube shares (probes, the environment, point-light
/// shadow faces): `cube_face`, `cube_face_uv`, `cube_face_point`.
pub const CUBE_FACES_WGSL: &str = include_str!("cube_faces.wgsl");
/// Reading the environment (irradiance harmonics, prefiltered levels) and
/// the split-sum table; shared by shading and the path-traced reference.
pub const ENVIRONMENT_WGSL: &str = include_str!("environment.wgsl");
