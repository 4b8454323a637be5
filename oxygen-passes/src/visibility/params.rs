//! What the visibility shaders share with Rust: the cull shader's
//! parameter block and flag bits, the depth pyramid's level block, written
//! into the shaders from these declarations (a leaf: the shader registry
//! reads it).

/// `CullParams::flags`: the view takes shadow casters only.
pub(crate) const CULL_CASTERS_ONLY: u32 = 1;
/// `CullParams::flags`: two-phase occlusion culling.
pub(crate) const CULL_OCCLUSION: u32 = 2;
/// `CullParams::flags`: the deterministic mode (survivors marked at their
/// rank, then compacted in rank order; commands at fixed places).
pub(crate) const CULL_DETERMINISTIC: u32 = 4;

oxygen_gpu::gpu_struct! {
    /// The cull shader's per-view parameters (its WGSL twin is generated).
    #[derive(Debug, Default, PartialEq)]
    pub(crate) struct CullParams: 256 bytes {
        pub(crate) planes: [[f32; 4]; 6] => "array<vec4<f32>, 6>",
        pub(crate) view_row_z: [f32; 4],
        pub(crate) view_projection: [[f32; 4]; 4],
        pub(crate) lod_scale: f32,
        pub(crate) perspective: u32,
        pub(crate) near: f32,
        pub(crate) lod_bias: f32,
        pub(crate) instance_count: u32,
        pub(crate) group_count: u32,
        pub(crate) partition_count: u32,
        pub(crate) flags: u32,
        pub(crate) draw_slot: u32,
        pub(crate) command_slot: u32,
        pub(crate) generation: u32,
        pub(crate) hiz_levels: u32,
        pub(crate) hiz_size: [u32; 2],
        pub(crate) group_counters: u32,
        /// Viewport area of a disc one viewport height across, as a fraction
        /// of the viewport (pi / 4 / aspect): the overdraw estimate's unit.
        pub(crate) disc: f32,
        /// Where the view's counters start in the counts buffer (0 for a
        /// view of its own; a batch's cameras share one buffer).
        pub(crate) counter_base: u32,
        /// Where the view's history starts in the history buffer.
        pub(crate) history_base: u32,
        /// Where list C's draws start in each group's room (see
        /// `GpuViewPlan::shading_offset`).
        pub(crate) shading_offset: u32,
        /// Where the view's occupancy (the deterministic mode's marks, one
        /// per draw of the room) starts in the history buffer.
        pub(crate) occupancy_base: u32,
    }
}

oxygen_gpu::gpu_struct! {
    /// One reduction step as the shader reads it (its WGSL twin is generated).
    pub(crate) struct LevelParams: 32 bytes {
        pub(crate) src_offset: u32,
        pub(crate) src_width: u32,
        pub(crate) src_height: u32,
        pub(crate) dst_offset: u32,
        pub(crate) dst_width: u32,
        pub(crate) dst_height: u32,
        pub(crate) reserved: [u32; 2],
    }
}

/// WGSL `const` declarations of the cull shader's flag bits and the GPU
/// scene's instance flag it tests.
pub(crate) fn wgsl_constants() -> String {
    crate::shaders::compose::u32_constants(&[
        ("CULL_CASTERS_ONLY", CULL_CASTERS_ONLY),
        ("CULL_OCCLUSION", CULL_OCCLUSION),
        ("CULL_DETERMINISTIC", CULL_DETERMINISTIC),
        ("INSTANCE_CASTS_SHADOWS", oxygen_sceneprep::GpuInstance::CASTS_SHADOWS),
    ])
}
