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
//!   pass's group 3 binds (shadow atlas, probes, placeholders);
//! * [`MeshPass`]: the one pass that draws partitions, configured as depth
//!   pre-pass, shadow map, forward lit (metallic-roughness) or transparent
//!   (premultiplied alpha); [`TonemapPass`] (HDR → sRGB);
//! * typed [`Output`]s ([`Depth`], [`HdrColor`], [`ShadowMap`], [`ProbeCube`])
//!   through which a view reads what the views it is linked to rendered.
//!
//! Shaders read every per-draw datum through bindless slots: the draw's
//! `DrawMetadata` (found by `instance_index`), its world and normal matrix,
//! its material and its vertices. No per-draw bind group exists.

#![warn(missing_docs)]
// `!(x > 0.0)` is how this crate rejects NaN along with the out-of-range values;
// rewriting it with `partial_cmp` would hide that intent.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod context;
mod lighting;
mod mesh;
mod pipelines;
mod post;
mod reference;
mod shaders;
mod visibility;

pub use context::{
    CommandRecorder, DrawPath, FrameProgress, LinkedView, LocalShadowsInput, OutputKind, PassError, PrePassEstimate,
    ProbeCubeInput, RecordStats, RenderContext, RenderPass, Shading, ShadowMapInput, ViewInputs,
};
pub use lighting::LightingResources;
pub use lighting::ibl::cube_filter::{
    CUBE_FILTER_WGSL, EnvironmentQuality, HARMONICS_LAYER, HARMONICS_SCALE, MAX_ENVIRONMENT_SIZE, MAX_FILTER_SAMPLES,
    PROBE_FILTER_SAMPLES, prefiltered_levels,
};
pub use lighting::ibl::{CUBE_FACES_WGSL, ENVIRONMENT_WGSL};
pub use lighting::inputs::{PROBE_FACE_AXES, probe_view};
pub use lighting::params::{LightingInputs, MAX_CASCADES, MAX_PROBES, MAX_SHADOW_TILES, PROBE_FACES};
pub use lighting::shadow_atlas::{SHADOW_ATLAS_FORMAT, array_layer_count};
pub use lighting::split_sum::{SPLIT_SUM_LUT_FORMAT, SPLIT_SUM_LUT_SIZE, SPLIT_SUM_WGSL, split_sum_shader_source};
pub use mesh::{ColorOps, DrawList, ForwardLitConfig, MeshPass};
pub use oxygen_core::{Depth, HdrColor, Output, OutputSource, ProbeCube, ProbeId, ShadowMap};
pub use pipelines::{
    AlphaClass, CompilerGuard, DepthBias, Exposure, PassKind, PipelineFuture, PipelineKey, PipelineVariant, Pipelines,
    ShaderFeatures, fullscreen_pass, fullscreen_pipeline, shader_source,
};
pub use post::{TONEMAP_OPERATOR_WGSL, TONEMAP_WGSL, TonemapPass, pbr_neutral};
pub use reference::{ReferencePass, ReferenceSettings, ReferenceTracer, reference_shader_source};
pub use shaders::BRDF_WGSL;
pub use visibility::hiz;
pub use visibility::{GPU_VISIBILITY_FEATURES, GpuViewRequest, GpuVisibility, cull_shader_source};
