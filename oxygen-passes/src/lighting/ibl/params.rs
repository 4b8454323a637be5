//! The cube filter's parameter block, written into its shader from this
//! declaration (a leaf: the shader registry reads it).

oxygen_gpu::gpu_struct! {
    /// The uniform block of `cube_filter.wgsl` (its WGSL twin is generated),
    /// at 256-byte strides (dynamic offsets), one per pass that needs
    /// different values.
    #[derive(Debug, Default)]
    pub(crate) struct CubeFilterParams: 96 bytes {
        /// Procedural sky (a uniform environment is a sky of one colour).
        pub(crate) zenith: [f32; 4],
        pub(crate) horizon: [f32; 4],
        pub(crate) ground: [f32; 4],
        pub(crate) glow: [f32; 4],
        /// Direction the sunlight travels.
        pub(crate) sun_direction: [f32; 4],
        /// GGX roughness of the level being written.
        pub(crate) roughness: f32,
        /// GGX samples per texel.
        pub(crate) samples: u32,
        /// Side of the level being written.
        pub(crate) target_size: u32,
        /// Source level the harmonics read (a box-filtered copy of level 0).
        pub(crate) harmonics_level: u32,
    }
}
