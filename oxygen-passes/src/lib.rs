//! # oxygen-passes
//!
//! The passes of a view's render graph and what they share:
//!
//! * [`RenderContext`]: everything a pass may read for one view this frame
//!   (resolved view, prepared frame, scene constants, bindless heap, targets,
//!   pipeline cache); passes never mutate prepared data;
//! * [`CommandRecorder`]: the command encoder a view's passes record into;
//! * [`RenderPass`]: one async `run`, which awaits what the pass does not
//!   have yet (a pipeline compiling on another thread, another view's output);
//! * [`Pipelines`]: pipelines created lazily the first time a partition needs
//!   a variant, compiled by whichever recording thread is idle, then cached
//!   for the renderer's lifetime; [`LightingResources`]: what the forward
//!   pass's group 1 binds (shadow atlas, probes, placeholders);
//! * [`MeshPass`]: the one pass that draws partitions, configured as depth
//!   pre-pass, shadow map, forward lit (metallic-roughness) or transparent
//!   (premultiplied alpha); [`TonemapPass`] (HDR → sRGB);
//! * typed [`Output`]s ([`Depth`], [`HdrColor`], [`Color`], [`InstanceIds`],
//!   [`SemanticClasses`], [`LinearDepth`],
//!   [`Normals`], [`ShadowMap`], [`ProbeCube`])
//!   through which a view reads what the views it is linked to rendered.
//!
//! Shaders read every per-draw datum through bindless slots: the draw's
//! `DrawMetadata` (found by `instance_index`), its world and normal matrix,
//! its material and its vertices. No per-draw bind group exists.
//!
//! The WGSL sources and their assembly, the lighting group's parameter
//! block and the HiZ pyramid are crate-private; the `testing` feature, which
//! only this crate's tests and the root crate's GPU tests turn on, exposes
//! what they validate in a `testing` module.

#![warn(missing_docs)]
// `!(x > 0.0)` is how this crate rejects NaN along with the out-of-range values;
// rewriting it with `partial_cmp` would hide that intent.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod context;
mod lighting;
mod mesh;
mod pipelines;
mod post;
mod present;
mod reference;
mod shaders;
mod visibility;

pub use context::{
    CommandRecorder, DrawPath, FrameProgress, LinkedImage, LinkedView, LocalShadowsInput, OutputKind, PassError,
    PrePassEstimate, ProbeCubeInput, RecordStats, RenderContext, RenderPass, Shading, ShadowMapInput, ViewInputs,
};
pub use lighting::ambient_occlusion::{AmbientOcclusion, AmbientOcclusionPass, AoQuality, LinearDepthPass};
pub use lighting::clusters::{ClusterGrid, LightCulling};
pub use lighting::contact_shadows::ContactShadows;
pub use lighting::ibl::cube_filter::{
    EnvironmentQuality, HARMONICS_LAYER, HARMONICS_SCALE, MAX_ENVIRONMENT_SIZE, MAX_FILTER_SAMPLES,
    PROBE_FILTER_SAMPLES, prefiltered_levels,
};
pub use lighting::inputs::PROBE_FACE_AXES;
pub use lighting::params::{MAX_CASCADES, PROBE_FACES};
pub use lighting::reflections::{ReflectionHistoryPass, ScreenSpaceReflections};
pub use lighting::shadow_atlas::array_layer_count;
pub use lighting::split_sum::SPLIT_SUM_LUT_SIZE;
pub use lighting::{LightingResources, ScreenBuffers};
pub use mesh::{
    ColorOps, DeferredShading, DrawList, ForwardLitConfig, ID_LABELS, MeshPass, ShadowFilter, id_targets,
    ids_over_depth, record_id_render, record_ids_over_depth, region_camera,
};
pub use oxygen_core::{
    Color, Depth, HdrColor, InstanceIds, LinearDepth, Normals, Output, OutputSource, ProbeCube, ProbeId,
    SemanticClasses, ShadowMap,
};
pub use pipelines::{
    AlphaClass, CompilerGuard, DepthBias, Exposure, PassKind, PipelineFuture, PipelineKey, PipelineVariant, Pipelines,
    ShaderFeatures, fullscreen_pass, fullscreen_pipeline,
};
pub use post::{AutoExposure, Bloom, CompositePass, DepthCopy, OverlayPass, TonemapPass};
pub use present::compose_window_wgsl;
pub use reference::{ReferencePass, ReferenceSettings, ReferenceTracer};
pub use visibility::{GPU_VISIBILITY_FEATURES, GpuViewRequest, GpuVisibility};

// Crate-private, for the crate's own `crate::` paths: the lighting group's
// parameter block and probe limit, the probe cube view, the CPU twin of the
// tone-map operator.
pub(crate) use lighting::inputs::probe_view;
pub(crate) use lighting::params::{LightingInputs, MAX_PROBES};
pub(crate) use post::pbr_neutral;

/// What the crate's own tests and the root crate's GPU tests reach below the
/// public API, behind the `testing` feature (turned on by those tests'
/// dev-dependencies): the shader sources as the pipelines assemble them, the
/// lighting group's parameter block and limits, and the HiZ pyramid. Not part
/// of the public surface.
#[cfg(feature = "testing")]
pub mod testing {
    pub use crate::lighting::ibl::cube_filter::CUBE_FILTER_WGSL;
    pub use crate::lighting::params::{LightingInputs, MAX_PROBES, MAX_SHADOW_TILES};
    pub use crate::lighting::split_sum::split_sum_shader_source;
    pub use crate::pipelines::shader_source;
    pub use crate::post::TONEMAP_WGSL;
    pub use crate::reference::reference_shader_source;
    pub use crate::visibility::cull_shader_source;
    pub use crate::visibility::hiz::{HizPipelines, HizPyramid, hiz_shader_source, hiz_visible_boxes_wgsl};
}
