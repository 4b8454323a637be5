//! The registry: every named WGSL source a shader may include, and every
//! shader module the crate compiles with its entry points.
//!
//! WGSL files are named by their path below `oxygen-passes/src`; generated
//! sources by the folder or crate that owns their Rust values
//! (`lighting/constants`, `bindless/domains`); the WGSL twin of a
//! [`oxygen_gpu::GpuStruct`] by its folder and name
//! (`lighting/LightingInputs`). Generated text comes from leaf modules (each
//! folder's `params.rs`, other crates), never from the code that composes
//! shaders, so the registry depends on no pipeline-building module.

use oxygen_bindless::{DomainKind, TexturePath};
use oxygen_sceneprep::PassMask;

use super::compose::{ComposeError, Composer, Source};

/// Every source a shader may include.
pub(crate) static SOURCES: &[Source] = &[
    // Shared by several folders.
    Source::wgsl("shaders/brdf.wgsl", include_str!("brdf.wgsl")),
    Source::wgsl("shaders/noise.wgsl", include_str!("noise.wgsl")),
    Source::wgsl("shaders/half.wgsl", include_str!("half.wgsl")),
    Source::wgsl("shaders/fullscreen.wgsl", include_str!("fullscreen.wgsl")),
    Source::wgsl("shaders/color.wgsl", include_str!("color.wgsl")),
    // Mesh passes.
    Source::wgsl("mesh/mesh_vertex.wgsl", include_str!("../mesh/mesh_vertex.wgsl")),
    Source::wgsl("mesh/vertex_stage.wgsl", include_str!("../mesh/vertex_stage.wgsl")),
    Source::wgsl("mesh/depth_only.wgsl", include_str!("../mesh/depth_only.wgsl")),
    Source::wgsl("mesh/shading.wgsl", include_str!("../mesh/shading.wgsl")),
    Source::wgsl("mesh/forward_lit.wgsl", include_str!("../mesh/forward_lit.wgsl")),
    Source::wgsl("mesh/labels.wgsl", include_str!("../mesh/labels.wgsl")),
    Source::wgsl("mesh/label_values.wgsl", include_str!("../mesh/label_values.wgsl")),
    Source::wgsl("mesh/visibility.wgsl", include_str!("../mesh/visibility.wgsl")),
    Source::wgsl("mesh/deferred.wgsl", include_str!("../mesh/deferred.wgsl")),
    Source::generated("mesh/deferred_constants", crate::mesh::deferred_constants),
    Source::gpu_struct::<crate::mesh::DeferredParams>("mesh/DeferredParams"),
    Source::gpu_struct::<crate::mesh::DeferredTile>("mesh/DeferredTile"),
    Source::wgsl(DEFERRED_SCENE, include_str!("../mesh/deferred_scene.wgsl")),
    Source::wgsl(VARYINGS_PLAIN, include_str!("../mesh/varyings_plain.wgsl")),
    Source::wgsl(VARYINGS_WITH_ATTRIBUTES, include_str!("../mesh/varyings_attributes.wgsl")),
    // Lighting: group 1, the split-sum table, image-based lighting.
    Source::generated("lighting/constants", crate::lighting::params::wgsl_constants),
    Source::gpu_struct::<crate::lighting::params::LightingInputs>("lighting/LightingInputs"),
    Source::wgsl("lighting/split_sum.wgsl", include_str!("../lighting/split_sum.wgsl")),
    Source::wgsl("lighting/ibl/cube_faces.wgsl", include_str!("../lighting/ibl/cube_faces.wgsl")),
    Source::wgsl("lighting/ibl/environment.wgsl", include_str!("../lighting/ibl/environment.wgsl")),
    Source::wgsl("lighting/ibl/cube_filter.wgsl", include_str!("../lighting/ibl/cube_filter.wgsl")),
    Source::gpu_struct::<crate::lighting::ibl::params::CubeFilterParams>("lighting/ibl/CubeFilterParams"),
    Source::gpu_struct::<crate::lighting::clusters::ClusterParams>("lighting/ClusterParams"),
    Source::wgsl("lighting/clusters.wgsl", include_str!("../lighting/clusters.wgsl")),
    Source::gpu_struct::<crate::lighting::ambient_occlusion::AoParams>("lighting/AoParams"),
    Source::wgsl("lighting/ambient_occlusion.wgsl", include_str!("../lighting/ambient_occlusion.wgsl")),
    Source::gpu_struct::<crate::lighting::reflections::HistoryStep>("lighting/HistoryStep"),
    Source::wgsl("lighting/reflection_history.wgsl", include_str!("../lighting/reflection_history.wgsl")),
    // GPU visibility and the depth pyramid.
    Source::generated("visibility/constants", crate::visibility::params::wgsl_constants),
    Source::gpu_struct::<crate::visibility::params::CullParams>("visibility/CullParams"),
    Source::gpu_struct::<crate::visibility::params::LevelParams>("visibility/LevelParams"),
    Source::wgsl("visibility/cull.wgsl", include_str!("../visibility/cull.wgsl")),
    Source::wgsl("visibility/hiz.wgsl", include_str!("../visibility/hiz.wgsl")),
    Source::wgsl("visibility/hiz_test.wgsl", include_str!("../visibility/hiz_test.wgsl")),
    Source::wgsl("visibility/hiz_visible_boxes.wgsl", include_str!("../visibility/hiz_visible_boxes.wgsl")),
    // The path-traced reference.
    Source::generated("reference/constants", crate::reference::params::wgsl_constants),
    Source::gpu_struct::<crate::reference::params::TraceParams>("reference/TraceParams"),
    Source::wgsl("reference/trace.wgsl", include_str!("../reference/trace.wgsl")),
    // Post-processing.
    Source::gpu_struct::<crate::post::params::TonemapParams>("post/TonemapParams"),
    Source::wgsl("post/tonemap_operator.wgsl", include_str!("../post/tonemap_operator.wgsl")),
    Source::wgsl("post/tonemap.wgsl", include_str!("../post/tonemap.wgsl")),
    Source::gpu_struct::<crate::post::effects::BloomParams>("post/BloomParams"),
    Source::gpu_struct::<crate::post::effects::ExposureParams>("post/ExposureParams"),
    Source::gpu_struct::<crate::post::effects::EffectsParams>("post/EffectsParams"),
    Source::wgsl("post/effects.wgsl", include_str!("../post/effects.wgsl")),
    Source::wgsl("post/depth_copy.wgsl", include_str!("../post/depth_copy.wgsl")),
    Source::gpu_struct::<crate::post::params::CompositeParams>("post/CompositeParams"),
    Source::wgsl("post/composite.wgsl", include_str!("../post/composite.wgsl")),
    Source::wgsl("post/overlay.wgsl", include_str!("../post/overlay.wgsl")),
    Source::gpu_struct::<crate::post::params::OutlineParams>("post/OutlineParams"),
    Source::wgsl("post/outline.wgsl", include_str!("../post/outline.wgsl")),
    // Presenting: the renderer's window composition.
    Source::wgsl("present/compose_window.wgsl", include_str!("../present/compose_window.wgsl")),
    // oxygen-bindless: the heap's declarations.
    Source::generated("bindless/constants", oxygen_bindless::wgsl_constants),
    Source::gpu_struct::<oxygen_bindless::CameraConstants>("bindless/CameraConstants"),
    Source::gpu_struct::<oxygen_bindless::RendererConstants>("bindless/RendererConstants"),
    Source::gpu_struct::<oxygen_bindless::SceneConstants>("bindless/SceneConstants"),
    Source::wgsl("bindless/scene_constants.wgsl", oxygen_bindless::SCENE_CONSTANTS_WGSL),
    Source::generated("bindless/domains", DomainKind::wgsl_bindings),
    // Each texture path's sampling functions and the group-2 declarations
    // they include (generated from the heap's layout).
    Source::wgsl(BINDING_ARRAY, TexturePath::BindingArray.wgsl_sampling()),
    Source::generated(TexturePath::BindingArray.wgsl_bindings_name(), || TexturePath::BindingArray.wgsl_bindings()),
    Source::wgsl(GROUPED_ARRAYS, TexturePath::GroupedArrays.wgsl_sampling()),
    Source::generated(TexturePath::GroupedArrays.wgsl_bindings_name(), || TexturePath::GroupedArrays.wgsl_bindings()),
    // oxygen-sceneprep: the GPU records (the scene's, the GPU scene's, the
    // ray scene's) and their numbers.
    Source::gpu_struct::<oxygen_sceneprep::NormalMatrix>("sceneprep/NormalMatrix"),
    Source::gpu_struct::<oxygen_sceneprep::DrawMetadata>("sceneprep/DrawMetadata"),
    Source::gpu_struct::<oxygen_sceneprep::UvTransformRecord>("sceneprep/UvTransformRecord"),
    Source::gpu_struct::<oxygen_sceneprep::MaterialRecord>("sceneprep/MaterialRecord"),
    Source::gpu_struct::<oxygen_sceneprep::DirectionalLightRecord>("sceneprep/DirectionalLightRecord"),
    Source::gpu_struct::<oxygen_sceneprep::PositionalLightRecord>("sceneprep/PositionalLightRecord"),
    Source::gpu_struct::<oxygen_sceneprep::GpuInstance>("sceneprep/GpuInstance"),
    Source::gpu_struct::<oxygen_sceneprep::GpuGroup>("sceneprep/GpuGroup"),
    Source::gpu_struct::<oxygen_sceneprep::GpuLod>("sceneprep/GpuLod"),
    Source::gpu_struct::<oxygen_sceneprep::DrawIndexedIndirect>("sceneprep/DrawIndexedIndirect"),
    Source::gpu_struct::<oxygen_sceneprep::ray::BvhNode>("sceneprep/BvhNode"),
    Source::gpu_struct::<oxygen_sceneprep::RayInstance>("sceneprep/RayInstance"),
    Source::gpu_struct::<oxygen_sceneprep::VertexRecord>("sceneprep/VertexRecord"),
    Source::wgsl("sceneprep/gpu_records.wgsl", oxygen_sceneprep::GPU_RECORDS_WGSL),
    Source::generated("sceneprep/constants", || {
        [
            PassMask::wgsl_constants(),
            oxygen_sceneprep::MaterialRecord::wgsl_constants(),
            oxygen_sceneprep::PositionalLightRecord::wgsl_constants(),
        ]
        .concat()
    }),
];

/// What a shader includes for the texture path's bindings; each
/// composition of a textured module resolves it to one of the two below.
const TEXTURES: &str = "bindless/textures";
const BINDING_ARRAY: &str = "bindless/textures/binding_array";
const GROUPED_ARRAYS: &str = "bindless/textures/grouped_arrays";

/// What the mesh vertex stage includes for its outputs; each composition
/// of a mesh module resolves it to one of the two below.
const VARYINGS: &str = "mesh/varyings";
const VARYINGS_PLAIN: &str = "mesh/varyings_plain.wgsl";
const VARYINGS_WITH_ATTRIBUTES: &str = "mesh/varyings_attributes.wgsl";

/// The per-view constants' declaration, which deferred shading composes
/// as a copy in workgroup memory instead of a uniform per camera.
const SCENE_CONSTANTS: &str = "bindless/scene_constants.wgsl";
const DEFERRED_SCENE: &str = "mesh/deferred_scene.wgsl";

/// Which outputs a mesh module's vertex stage writes: the module is
/// composed once for each ([`crate::ShaderFeatures::vertex_attributes`]
/// picks one), since a location cannot be left out by an override constant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum MeshVaryings {
    /// Position, normal and UV packed in two locations, and the draw:
    /// for scenes whose meshes have no vertex colours or second UV set.
    Plain,
    /// Those and the vertex colour and second UV set: right for any scene.
    WithAttributes,
}

impl MeshVaryings {
    /// Both, for the tests that compose every variant.
    #[cfg(test)]
    pub(crate) const ALL: [MeshVaryings; 2] = [MeshVaryings::Plain, MeshVaryings::WithAttributes];

    /// The one that draws meshes with vertex attributes when `attributes`.
    pub(crate) fn of(attributes: bool) -> Self {
        if attributes { MeshVaryings::WithAttributes } else { MeshVaryings::Plain }
    }

    fn source(self) -> &'static str {
        match self {
            MeshVaryings::Plain => VARYINGS_PLAIN,
            MeshVaryings::WithAttributes => VARYINGS_WITH_ATTRIBUTES,
        }
    }
}

/// A shader module the crate compiles: a root source, composed with the
/// texture path's bindings when it reads textures, and with one of the
/// mesh vertex stage's output sets when it draws meshes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct ShaderModule {
    /// The root source.
    pub(crate) root: &'static str,
    /// Whether it includes the texture path's bindings (and so is composed
    /// once per path).
    pub(crate) textured: bool,
    /// Whether it includes the mesh vertex stage (and so is composed once
    /// per [`MeshVaryings`]).
    pub(crate) mesh: bool,
    /// Whether its per-view constants are a copy in workgroup memory each
    /// workgroup loads (deferred shading's compute pass), not a uniform.
    pub(crate) private_scene: bool,
}

impl ShaderModule {
    const fn plain(root: &'static str) -> Self {
        ShaderModule { root, textured: false, mesh: false, private_scene: false }
    }

    const fn textured(root: &'static str) -> Self {
        ShaderModule { root, textured: true, mesh: false, private_scene: false }
    }

    const fn mesh(root: &'static str) -> Self {
        ShaderModule { root, textured: true, mesh: true, private_scene: false }
    }

    /// The module's WGSL, with the bindings of `textures` (`None` for a
    /// module that reads no texture) and the vertex outputs of `varyings`
    /// (ignored by a module that draws no mesh).
    pub(crate) fn compose(self, textures: Option<TexturePath>, varyings: MeshVaryings) -> Result<String, ComposeError> {
        let texture_alias = match textures {
            Some(TexturePath::BindingArray) => Some((TEXTURES, BINDING_ARRAY)),
            Some(TexturePath::GroupedArrays) => Some((TEXTURES, GROUPED_ARRAYS)),
            None => None,
        };
        let scene_alias = self.private_scene.then_some((SCENE_CONSTANTS, DEFERRED_SCENE));
        let aliases: Vec<(&str, &str)> =
            texture_alias.into_iter().chain([(VARYINGS, varyings.source())]).chain(scene_alias).collect();
        Composer::new(SOURCES).with_aliases(&aliases).compose(self.root)
    }

    /// The WGSL of a module that reads no texture. The registry is static:
    /// it composes every time or never, and the tests compose every module,
    /// so a failure here is a bug in the registry, reported with the
    /// composer's message.
    pub(crate) fn source(self) -> String {
        self.compose(None, MeshVaryings::WithAttributes).unwrap_or_else(|e| panic!("shader {}: {e}", self.root))
    }

    /// The WGSL of a module that reads textures, on `textures` (fails as
    /// [`ShaderModule::source`] does); a mesh module with every vertex output.
    pub(crate) fn textured_source(self, textures: TexturePath) -> String {
        self.mesh_source(textures, MeshVaryings::WithAttributes)
    }

    /// The WGSL of a mesh module on `textures` whose vertex stage writes
    /// `varyings` (fails as [`ShaderModule::source`] does).
    pub(crate) fn mesh_source(self, textures: TexturePath, varyings: MeshVaryings) -> String {
        self.compose(Some(textures), varyings)
            .unwrap_or_else(|e| panic!("shader {} on {textures:?} ({varyings:?}): {e}", self.root))
    }
}

/// The depth pre-pass and shadow maps.
pub(crate) const DEPTH_ONLY: ShaderModule = ShaderModule::mesh("mesh/depth_only.wgsl");
/// Forward lit and transparent shading, and the sky behind them.
pub(crate) const FORWARD_LIT: ShaderModule = ShaderModule::mesh("mesh/forward_lit.wgsl");
/// Deferred shading's visibility pass (each pixel's surface id: its draw
/// and the vertex that starts its triangle, and its labels).
pub(crate) const VISIBILITY: ShaderModule = ShaderModule::mesh("mesh/visibility.wgsl");
/// Deferred shading's compute pass, over the visibility pass's pixels.
pub(crate) const DEFERRED: ShaderModule =
    ShaderModule { root: "mesh/deferred.wgsl", textured: true, mesh: true, private_scene: true };
/// The labels pass (instance ids and normals).
pub(crate) const LABELS: ShaderModule = ShaderModule::mesh("mesh/labels.wgsl");
/// The path-traced reference.
pub(crate) const REFERENCE: ShaderModule = ShaderModule::textured("reference/trace.wgsl");
/// The tone map.
pub(crate) const TONEMAP: ShaderModule = ShaderModule::plain("post/tonemap.wgsl");
/// The tone map's effects: bloom, automatic exposure, the tone map with them.
pub(crate) const EFFECTS: ShaderModule = ShaderModule::plain("post/effects.wgsl");
/// Another view's image drawn into a rectangle (insets).
pub(crate) const COMPOSITE: ShaderModule = ShaderModule::plain("post/composite.wgsl");
/// The overlay over a view's final image.
pub(crate) const OVERLAY: ShaderModule = ShaderModule::plain("post/overlay.wgsl");
/// The selection outline: its jump flood and its drawing.
pub(crate) const OUTLINE: ShaderModule = ShaderModule::plain("post/outline.wgsl");
/// Depth into a float texture, for depth readback on GL.
pub(crate) const DEPTH_COPY: ShaderModule = ShaderModule::plain("post/depth_copy.wgsl");
/// The cube filter (environment and probe prefiltering).
pub(crate) const CUBE_FILTER: ShaderModule = ShaderModule::plain("lighting/ibl/cube_filter.wgsl");
/// Clustered light culling's pass.
pub(crate) const LIGHT_CLUSTERS: ShaderModule = ShaderModule::plain("lighting/clusters.wgsl");
/// Screen-space ambient occlusion's steps.
pub(crate) const AMBIENT_OCCLUSION: ShaderModule = ShaderModule::plain("lighting/ambient_occlusion.wgsl");
/// Screen-space reflections' history (the HDR image kept, its levels).
pub(crate) const REFLECTION_HISTORY: ShaderModule = ShaderModule::plain("lighting/reflection_history.wgsl");
/// The split-sum table.
pub(crate) const SPLIT_SUM: ShaderModule = ShaderModule::plain("lighting/split_sum.wgsl");
/// GPU visibility's cull and command passes.
pub(crate) const CULL: ShaderModule = ShaderModule::plain("visibility/cull.wgsl");
/// The depth pyramid's copy and reduction.
pub(crate) const HIZ: ShaderModule = ShaderModule::plain("visibility/hiz.wgsl");
/// The test harness of the depth pyramid's visibility test (the root
/// crate's `tests/hiz_pyramid.rs`).
#[cfg(any(test, feature = "testing"))]
pub(crate) const HIZ_VISIBLE_BOXES: ShaderModule = ShaderModule::plain("visibility/hiz_visible_boxes.wgsl");
/// The renderer's window composition (the root crate's compositor).
pub(crate) const COMPOSE_WINDOW: ShaderModule = ShaderModule::plain("present/compose_window.wgsl");

/// A pipeline stage.
#[cfg(test)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stage {
    Vertex,
    Fragment,
    Compute,
}

/// One entry point a pipeline of the crate is created with.
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct EntryPoint {
    /// The module holding it.
    pub(crate) module: ShaderModule,
    /// Its name.
    pub(crate) name: &'static str,
    /// Its stage.
    pub(crate) stage: Stage,
}

#[cfg(test)]
const fn entry(module: ShaderModule, name: &'static str, stage: Stage) -> EntryPoint {
    EntryPoint { module, name, stage }
}

/// Every entry point of every shader module the crate compiles: the list
/// the validation test walks (`validate_tests.rs`; the pipelines name the
/// same entry points where they are created).
#[cfg(test)]
pub(crate) const ENTRY_POINTS: &[EntryPoint] = &[
    entry(DEPTH_ONLY, "vs_main", Stage::Vertex),
    entry(DEPTH_ONLY, "fs_alpha_test", Stage::Fragment),
    entry(FORWARD_LIT, "vs_main", Stage::Vertex),
    entry(FORWARD_LIT, "fs_opaque", Stage::Fragment),
    entry(FORWARD_LIT, "fs_masked", Stage::Fragment),
    entry(FORWARD_LIT, "fs_opaque_labelled", Stage::Fragment),
    entry(FORWARD_LIT, "fs_masked_labelled", Stage::Fragment),
    entry(FORWARD_LIT, "fs_blend", Stage::Fragment),
    entry(FORWARD_LIT, "vs_sky", Stage::Vertex),
    entry(FORWARD_LIT, "fs_sky", Stage::Fragment),
    entry(FORWARD_LIT, "vs_tile_clear", Stage::Vertex),
    entry(FORWARD_LIT, "fs_tile_clear", Stage::Fragment),
    entry(VISIBILITY, "vs_visibility", Stage::Vertex),
    entry(VISIBILITY, "fs_visibility", Stage::Fragment),
    entry(VISIBILITY, "vs_visibility_labelled", Stage::Vertex),
    entry(VISIBILITY, "fs_visibility_labelled", Stage::Fragment),
    entry(VISIBILITY, "fs_visibility_masked", Stage::Fragment),
    entry(DEFERRED, "cs_deferred", Stage::Compute),
    entry(LABELS, "vs_main", Stage::Vertex),
    entry(LABELS, "fs_labels", Stage::Fragment),
    entry(LABELS, "fs_labels_masked", Stage::Fragment),
    entry(REFERENCE, "trace_paths", Stage::Compute),
    entry(AMBIENT_OCCLUSION, "linearize", Stage::Compute),
    entry(AMBIENT_OCCLUSION, "linearize_multisampled", Stage::Compute),
    entry(AMBIENT_OCCLUSION, "gtao", Stage::Compute),
    entry(AMBIENT_OCCLUSION, "denoise", Stage::Compute),
    entry(AMBIENT_OCCLUSION, "temporal", Stage::Compute),
    entry(REFLECTION_HISTORY, "copy_hdr", Stage::Compute),
    entry(REFLECTION_HISTORY, "halve", Stage::Compute),
    entry(TONEMAP, "vs_fullscreen", Stage::Vertex),
    entry(TONEMAP, "fs_tonemap", Stage::Fragment),
    entry(EFFECTS, "vs_fullscreen", Stage::Vertex),
    entry(EFFECTS, "fs_bloom_down", Stage::Fragment),
    entry(EFFECTS, "fs_bloom_up", Stage::Fragment),
    entry(EFFECTS, "luminance_histogram", Stage::Compute),
    entry(EFFECTS, "adapt_exposure", Stage::Compute),
    entry(EFFECTS, "fs_tonemap_effects", Stage::Fragment),
    entry(COMPOSITE, "vs", Stage::Vertex),
    entry(COMPOSITE, "fs", Stage::Fragment),
    entry(OVERLAY, "vs", Stage::Vertex),
    entry(OVERLAY, "fs", Stage::Fragment),
    entry(OUTLINE, "seed", Stage::Compute),
    entry(OUTLINE, "flood", Stage::Compute),
    entry(OUTLINE, "vs_fullscreen", Stage::Vertex),
    entry(OUTLINE, "fs", Stage::Fragment),
    entry(DEPTH_COPY, "vs", Stage::Vertex),
    entry(DEPTH_COPY, "fs", Stage::Fragment),
    entry(CUBE_FILTER, "vs", Stage::Vertex),
    entry(CUBE_FILTER, "fs_downsample", Stage::Fragment),
    entry(CUBE_FILTER, "fs_sky", Stage::Fragment),
    entry(CUBE_FILTER, "fs_equirect", Stage::Fragment),
    entry(CUBE_FILTER, "fs_ggx", Stage::Fragment),
    entry(CUBE_FILTER, "fs_harmonics", Stage::Fragment),
    entry(LIGHT_CLUSTERS, "assign_lights", Stage::Compute),
    entry(SPLIT_SUM, "vs", Stage::Vertex),
    entry(SPLIT_SUM, "fs", Stage::Fragment),
    entry(CULL, "cull_early", Stage::Compute),
    entry(CULL, "commands_early", Stage::Compute),
    entry(CULL, "cull_late", Stage::Compute),
    entry(CULL, "commands_late", Stage::Compute),
    entry(CULL, "compact_early", Stage::Compute),
    entry(CULL, "compact_late", Stage::Compute),
    entry(HIZ, "copy_depth", Stage::Compute),
    entry(HIZ, "reduce", Stage::Compute),
    entry(HIZ_VISIBLE_BOXES, "visible_boxes", Stage::Compute),
    entry(COMPOSE_WINDOW, "vs", Stage::Vertex),
    entry(COMPOSE_WINDOW, "fs_color", Stage::Fragment),
    entry(COMPOSE_WINDOW, "fs_depth", Stage::Fragment),
];
