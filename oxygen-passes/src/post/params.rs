//! The tone-map shader's parameter block, written into the shader from this
//! declaration (a leaf: the shader registry reads it).

oxygen_gpu::gpu_struct! {
    /// The tone-map shader's uniform block (its WGSL twin is generated).
    pub(crate) struct TonemapParams: 16 bytes {
        pub(crate) exposure: f32,
        // Scalars, not an array: a uniform array's stride would be 16 bytes.
        pub(crate) pad0: f32,
        pub(crate) pad1: f32,
        pub(crate) pad2: f32,
    }
}

oxygen_gpu::gpu_struct! {
    /// The composition shader's uniform block: which part of the source
    /// texture (in its normalised coordinates) fills the destination
    /// rectangle (its WGSL twin is generated).
    pub(crate) struct CompositeParams: 16 bytes {
        /// Top-left corner of the source rectangle, in texture coordinates.
        pub(crate) uv_offset: [f32; 2] => "vec2<f32>",
        /// Size of the source rectangle, in texture coordinates.
        pub(crate) uv_scale: [f32; 2] => "vec2<f32>",
    }
}
