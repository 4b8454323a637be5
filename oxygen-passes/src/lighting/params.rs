//! Bind group 1's layout as its WGSL reads it: the uniform block
//! ([`LightingInputs`]), the sizes and binding numbers, and the split-sum
//! table's size, written into the shaders as generated constants
//! ([`wgsl_constants`]). A leaf: the shader registry reads it, and so does
//! every module of the folder that builds group 1.

/// Cascades the shading pass can sample.
pub const MAX_CASCADES: usize = 4;

oxygen_gpu::gpu_struct! {
    /// The uniform block of group 1; its WGSL twin is generated from this
    /// declaration ([`oxygen_gpu::GpuStruct::wgsl`]) and included by
    /// `mesh/shading.wgsl`.
    #[derive(Debug, PartialEq)]
    pub struct LightingInputs: 1904 bytes {
        /// World → light clip space, per cascade.
        pub light_view_projection: [[[f32; 4]; 4]; MAX_CASCADES] => "array<mat4x4<f32>, MAX_CASCADES>",
        /// World size of one map texel, per cascade.
        pub texel_world_size: [f32; MAX_CASCADES] => "vec4<f32>",
        /// One texel in UV (1 / map side), per cascade.
        pub uv_texel: [f32; MAX_CASCADES] => "vec4<f32>",
        /// Cascades in use (0 = no shadows).
        pub count: u32,
        /// PCF kernel radius in texels: (2r + 1)² comparison taps.
        pub pcf_radius: u32,
        /// Normal offset, in texels of the cascade.
        pub normal_offset: f32,
        /// Zero: explicit padding, so `probe_positions` starts on the 16-byte
        /// boundary where WGSL's uniform layout puts an array of `vec4`.
        pub padding: u32,
        /// World positions of the reflection probes (`w` = 1).
        pub probe_positions: [[f32; 4]; MAX_PROBES] => "array<vec4<f32>, MAX_PROBES>",
        /// Smallest corner of each probe's parallax box, relative to the
        /// render origin; `w` is 1 when the probe has a box, 0 when it takes
        /// its surroundings as infinitely far.
        pub probe_box_min: [[f32; 4]; MAX_PROBES] => "array<vec4<f32>, MAX_PROBES>",
        /// Largest corner of each probe's parallax box (`w` unused).
        pub probe_box_max: [[f32; 4]; MAX_PROBES] => "array<vec4<f32>, MAX_PROBES>",
        /// World → light clip space, per tile of the local-light shadow atlas
        /// (a spot's map, or one cube face of a point light's).
        pub tile_view_projection: [[[f32; 4]; 4]; MAX_SHADOW_TILES] => "array<mat4x4<f32>, MAX_SHADOW_TILES>",
        /// `2 tan(fov / 2) / resolution` per tile: a texel's world size per
        /// unit of distance from the light (scales the normal offset). Packed
        /// four to a `vec4` in WGSL: uniform arrays have a 16-byte stride.
        pub tile_texel_angle: [f32; MAX_SHADOW_TILES] => "array<vec4<f32>, MAX_SHADOW_TILES / 4u>",
        /// One past the highest tile in use.
        pub tile_count: u32,
        /// Reflection probes in use; each surface samples the nearest.
        pub probe_count: u32,
        /// Mip levels of the prefiltered environment (0: none; the constant
        /// ambient term lights the scene instead).
        pub environment_levels: u32,
        /// Width of the view's screen-space buffers (one float a pixel, row
        /// by row: its ambient occlusion at `AMBIENT_OCCLUSION_BINDING`, its
        /// depth in metres at `VIEW_DEPTH_BINDING`); 0 without either.
        pub screen_width: u32,
        /// Clustered light culling's grid (`HAS_CLUSTERED_LIGHTS`, see
        /// `lighting/clusters.rs`): tiles across, tiles down, depth slices,
        /// and 32-bit words of light bits per cluster. Zero without it.
        pub cluster_grid: [u32; 4] => "vec4<u32>",
        /// The grid's depth slicing: the far depth of slice 0 (metres in
        /// front of the eye), 1 / ln of the ratio of one slice's far depth to
        /// the next's, and two zeroes.
        pub cluster_depth: [f32; 4] => "vec4<f32>",
        /// The sun's soft shadows (`HAS_SOFT_SHADOWS`, `ShadowFilter::Pcss`):
        /// gathers per side of the blocker search (0: PCF of `pcf_radius`),
        /// the widest penumbra's radius in texels, comparisons per side of
        /// the filter, a zero.
        pub shadow_filter: [f32; 4] => "vec4<f32>",
        /// Contact shadows (`HAS_CONTACT_SHADOWS`, `ContactShadows`): the
        /// march's length and the surfaces' thickness in metres, its steps,
        /// a zero.
        pub contact_shadows: [f32; 4] => "vec4<f32>",
        /// Per tile, the device depth of a point z metres along its light's
        /// axis is a + b / z: (a, b) of two tiles a `vec4` (soft shadows of
        /// spot lights with a radius).
        pub tile_depth: [[f32; 4]; MAX_SHADOW_TILES / 2] => "array<vec4<f32>, MAX_SHADOW_TILES / 2u>",
        /// Screen-space reflections (`HAS_SCREEN_REFLECTIONS`): this
        /// frame's world (relative to the render origin) → the clip space
        /// of the frame the reflection history holds.
        pub reflection_reprojection: [[f32; 4]; 4] => "mat4x4<f32>",
        /// Screen-space reflections' settings (`ScreenSpaceReflections`):
        /// max roughness, thickness (m), max distance (m), steps.
        pub screen_reflections: [f32; 4] => "vec4<f32>",
        /// The reflection history at `REFLECTION_HISTORY_BINDING`: width,
        /// height, levels, and 1 when it holds a frame (0: reflections fall
        /// back to the probe or environment everywhere).
        pub reflection_history: [u32; 4] => "vec4<u32>",
        /// The view's near plane (metres), which a reflected ray heading
        /// for the camera stops before; 1 when the view's ambient occlusion
        /// is bound at `AMBIENT_OCCLUSION_BINDING` (0: the binding holds a
        /// placeholder, even where `screen_width` is set for the depth, and
        /// a shader with the code compiled in must not read it); two zeroes.
        pub screen_view: [f32; 4] => "vec4<f32>",
    }
}

/// Reflection probes the shading pass can choose from.
pub const MAX_PROBES: usize = 4;

/// Tiles of the local-light shadow atlas: one per shadow-casting spot, six
/// per shadow-casting point light.
pub const MAX_SHADOW_TILES: usize = 16;

const _: () = assert!(MAX_SHADOW_TILES as u32 == oxygen_sceneprep::MAX_SHADOW_TILES);
// The WGSL twin packs the per-cascade floats into one vec4 each and the
// per-tile floats four to a vec4 (uniform arrays have a 16-byte stride), and
// declares one texture per cascade and probe with a `switch` over them:
// other counts need those declarations changed, not just the constants.
const _: () = assert!(MAX_CASCADES == 4 && MAX_PROBES == 4);
const _: () = assert!(MAX_SHADOW_TILES.is_multiple_of(4));

/// The numbers of group 1 that the shading pass's WGSL reads, by their
/// Rust names: [`wgsl_constants`] emits exactly these.
fn shared_numbers() -> [(&'static str, u32); 17] {
    [
        ("MAX_CASCADES", MAX_CASCADES as u32),
        ("MAX_SHADOW_TILES", MAX_SHADOW_TILES as u32),
        ("MAX_PROBES", MAX_PROBES as u32),
        ("PROBE_FACES", PROBE_FACES as u32),
        ("COMPARISON_SAMPLER_BINDING", COMPARISON_SAMPLER_BINDING),
        ("UNIFORM_BINDING", UNIFORM_BINDING),
        ("PROBE_SAMPLER_BINDING", PROBE_SAMPLER_BINDING),
        ("SHADOW_ATLAS_BINDING", SHADOW_ATLAS_BINDING),
        ("FIRST_PROBE_BINDING", FIRST_PROBE_BINDING),
        ("ENVIRONMENT_BINDING", ENVIRONMENT_BINDING),
        ("ENVIRONMENT_SAMPLER_BINDING", ENVIRONMENT_SAMPLER_BINDING),
        ("SPLIT_SUM_BINDING", SPLIT_SUM_BINDING),
        ("CLUSTER_LIGHTS_BINDING", CLUSTER_LIGHTS_BINDING),
        ("AMBIENT_OCCLUSION_BINDING", AMBIENT_OCCLUSION_BINDING),
        ("VIEW_DEPTH_BINDING", VIEW_DEPTH_BINDING),
        ("REFLECTION_HISTORY_BINDING", REFLECTION_HISTORY_BINDING),
        ("SPLIT_SUM_LUT_SIZE", SPLIT_SUM_LUT_SIZE),
    ]
}

/// WGSL `const` declarations of the sizes the shading pass shares with
/// [`LightingInputs`] (`MAX_CASCADES`, `MAX_SHADOW_TILES`, `MAX_PROBES`,
/// `PROBE_FACES`) and the bindings of group 1, under their Rust names.
/// Included by every mesh shader (through `mesh/mesh_vertex.wgsl`) and the
/// reference tracer.
pub(crate) fn wgsl_constants() -> String {
    crate::shaders::compose::u32_constants(&shared_numbers())
}

// Bindings of group 1 after the cascade maps (0..MAX_CASCADES).
pub(crate) const COMPARISON_SAMPLER_BINDING: u32 = MAX_CASCADES as u32;
pub(crate) const UNIFORM_BINDING: u32 = MAX_CASCADES as u32 + 1;
pub(crate) const PROBE_SAMPLER_BINDING: u32 = MAX_CASCADES as u32 + 2;
pub(crate) const SHADOW_ATLAS_BINDING: u32 = MAX_CASCADES as u32 + 3;
pub(crate) const FIRST_PROBE_BINDING: u32 = MAX_CASCADES as u32 + 4;
pub(crate) const ENVIRONMENT_BINDING: u32 = FIRST_PROBE_BINDING + MAX_PROBES as u32;
pub(crate) const ENVIRONMENT_SAMPLER_BINDING: u32 = ENVIRONMENT_BINDING + 1;
pub(crate) const SPLIT_SUM_BINDING: u32 = ENVIRONMENT_SAMPLER_BINDING + 1;
/// The view's light clusters (a storage buffer of light bits per cluster;
/// one zero word when the view does not cull its lights).
pub(crate) const CLUSTER_LIGHTS_BINDING: u32 = SPLIT_SUM_BINDING + 1;
/// The view's ambient occlusion (a storage buffer of one float a pixel;
/// one zero word when the view has none).
pub(crate) const AMBIENT_OCCLUSION_BINDING: u32 = CLUSTER_LIGHTS_BINDING + 1;
/// The view's depth in metres (a storage buffer of one float a pixel, for
/// contact shadows; one zero word when the view has none).
pub(crate) const VIEW_DEPTH_BINDING: u32 = AMBIENT_OCCLUSION_BINDING + 1;
/// The view's reflection history (a storage buffer of three half floats a
/// pixel in two words, over a chain of levels, for screen-space
/// reflections; a zeroed placeholder of 16 bytes when the view has none).
pub(crate) const REFLECTION_HISTORY_BINDING: u32 = VIEW_DEPTH_BINDING + 1;

/// Layers of a probe texture: +X, −X, +Y, −Y, +Z, −Z.
pub const PROBE_FACES: usize = 6;

/// Side of the split-sum table: texel `(i, j)` holds n·v = i / (N − 1),
/// roughness j / (N − 1); the shader samples it bilinearly between those.
pub const SPLIT_SUM_LUT_SIZE: u32 = 32;

/// Bytes of the split-sum table: N² texels of four half floats.
pub(crate) const SPLIT_SUM_LUT_BYTES: u64 = (SPLIT_SUM_LUT_SIZE * SPLIT_SUM_LUT_SIZE * 8) as u64;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_lighting_size_is_a_wgsl_constant_with_its_value() {
        let wgsl = wgsl_constants();
        for (name, value) in [
            ("MAX_CASCADES", MAX_CASCADES),
            ("MAX_SHADOW_TILES", MAX_SHADOW_TILES),
            ("MAX_PROBES", MAX_PROBES),
            ("PROBE_FACES", PROBE_FACES),
        ] {
            let line = format!("const {name}: u32 = {value:#x}u;");
            assert!(wgsl.lines().any(|l| l == line), "{line} missing from\n{wgsl}");
        }
        for (name, binding) in [
            ("COMPARISON_SAMPLER_BINDING", COMPARISON_SAMPLER_BINDING),
            ("UNIFORM_BINDING", UNIFORM_BINDING),
            ("PROBE_SAMPLER_BINDING", PROBE_SAMPLER_BINDING),
            ("SHADOW_ATLAS_BINDING", SHADOW_ATLAS_BINDING),
            ("FIRST_PROBE_BINDING", FIRST_PROBE_BINDING),
            ("ENVIRONMENT_BINDING", ENVIRONMENT_BINDING),
            ("ENVIRONMENT_SAMPLER_BINDING", ENVIRONMENT_SAMPLER_BINDING),
            ("SPLIT_SUM_BINDING", SPLIT_SUM_BINDING),
            ("CLUSTER_LIGHTS_BINDING", CLUSTER_LIGHTS_BINDING),
            ("AMBIENT_OCCLUSION_BINDING", AMBIENT_OCCLUSION_BINDING),
            ("VIEW_DEPTH_BINDING", VIEW_DEPTH_BINDING),
            ("REFLECTION_HISTORY_BINDING", REFLECTION_HISTORY_BINDING),
        ] {
            let line = format!("const {name}: u32 = {binding:#x}u;");
            assert!(wgsl.lines().any(|l| l == line), "{line} missing from\n{wgsl}");
        }
        assert_eq!(wgsl.lines().count(), shared_numbers().len());
    }
}
