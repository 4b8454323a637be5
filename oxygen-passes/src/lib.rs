//! # oxygen-passes
//!
//! The passes of a view's render graph and what they share:
//!
//! * [`RenderContext`]: everything a pass may read for one view this frame
//!   (resolved view, prepared frame, scene constants, bindless heap, targets,
//!   pipeline cache); passes never mutate prepared data;
//! * [`CommandRecorder`]: the command encoder a view's passes record into;
//! * [`RenderPass`]: the async lifecycle, `prepare_resources` then `execute`;
//! * [`PipelineCache`] (`pso`): pipelines created lazily the first time a
//!   partition needs a variant, then cached for the renderer's lifetime;
//! * [`DepthPrePass`], [`ShaderPass`] (metallic-roughness), [`TransparentPass`]
//!   (premultiplied alpha) and [`TonemapPass`] (HDR → sRGB), each with its
//!   WGSL beside it.
//!
//! Shaders read every per-draw datum through bindless slots: the draw's
//! `DrawMetadata` (found by `instance_index`), its world and normal matrix,
//! its material and its vertices. No per-draw bind group exists.

// `!(x > 0.0)` is how this crate rejects NaN along with the out-of-range values;
// rewriting it with `partial_cmp` would hide that intent.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod depth_pre_pass;
mod lighting_inputs;
mod probe_mips;
mod pso;
mod render_context;
mod render_pass;
mod shader_pass;
mod shadow_atlas;
mod tonemap_pass;
mod transparent_pass;

pub use depth_pre_pass::{DepthPrePass, DepthPrePassOutput, ShadowPass};
pub use lighting_inputs::{
    LightingInputs, MAX_CASCADES, MAX_PROBES, MAX_SHADOW_TILES, PROBE_FACE_AXES, PROBE_FACES, probe_view,
};
pub use pso::{
    AlphaClass, DepthBias, PassKind, PipelineCache, PipelineKey, PipelineVariant, TONEMAP_WGSL, shader_source,
};
pub use render_context::{CommandRecorder, DrawPath, FrameViews, PassError, PassOutputs, RecordStats, RenderContext};
pub use render_pass::RenderPass;
pub use shader_pass::{ProbeInput, ShaderPass, ShaderPassConfig};
pub use shadow_atlas::SHADOW_ATLAS_FORMAT;
pub use tonemap_pass::{TonemapPass, pbr_neutral};
pub use transparent_pass::TransparentPass;
