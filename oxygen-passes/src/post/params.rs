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

oxygen_gpu::gpu_struct! {
    /// One step of the selection outline's jump flood, or its drawing
    /// (`post/outline.wgsl`; its WGSL twin is generated).
    #[derive(Debug, PartialEq)]
    pub(crate) struct OutlineParams: 64 bytes {
        /// The view's width and height, the step's stride in pixels, a zero.
        pub(crate) size: [u32; 4] => "vec4<u32>",
        /// Where the view is drawn in its target (a batch camera's tile:
        /// `xy`) and where its instance ids lie in theirs (`zw`: the same
        /// tile in the page's labels, 0 in an ID render of its own).
        pub(crate) origin: [u32; 4] => "vec4<u32>",
        /// The outline's colour: sRGB, straight alpha.
        pub(crate) color: [f32; 4] => "vec4<f32>",
        /// Its width in pixels, three zeroes.
        pub(crate) shape: [f32; 4] => "vec4<f32>",
    }
}
