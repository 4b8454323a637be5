//! What the tracer's shader shares with Rust: its parameter block and the
//! bits of its `flags`, written into the shader from these declarations (a
//! leaf: the shader registry reads it).

/// Flag: the raster pass's light transport instead of global illumination.
pub(crate) const RASTER_MODEL: u32 = 1;
/// Flag: with [`RASTER_MODEL`], also a perfect reflection probe's term.
pub(crate) const RASTER_REFLECTIONS: u32 = 2;
/// Flag: escaping paths (and the raster model's ambient) read the
/// renderer's environment.
pub(crate) const ENVIRONMENT_MAP: u32 = 4;

oxygen_gpu::gpu_struct! {
    /// The tracer's parameters (its WGSL twin is generated).
    pub(crate) struct TraceParams: 64 bytes {
        pub(crate) width: u32,
        pub(crate) height: u32,
        /// Samples already in the running sum (0: start over).
        pub(crate) samples_done: u32,
        pub(crate) samples_this_frame: u32,
        pub(crate) max_bounces: u32,
        pub(crate) flags: u32,
        /// `INVALID_SLOT` when the scene has nothing to hit.
        pub(crate) tlas_root: u32,
        pub(crate) seed: u32,
        /// Where the ray scene's ranges start in the heap's domains; the
        /// scene's indices are relative to them.
        pub(crate) node_base: u32,
        pub(crate) word_base: u32,
        pub(crate) instance_base: u32,
        pub(crate) reserved: u32,
        pub(crate) environment: [f32; 4],
    }
}

/// WGSL `const` declarations of the flag bits.
pub(crate) fn wgsl_constants() -> String {
    crate::shaders::compose::u32_constants(&[
        ("RASTER_MODEL", RASTER_MODEL),
        ("RASTER_REFLECTIONS", RASTER_REFLECTIONS),
        ("ENVIRONMENT_MAP", ENVIRONMENT_MAP),
    ])
}
