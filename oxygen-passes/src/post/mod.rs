//! Post-processing after shading: the tone map from the HDR target to the
//! displayable sRGB target, and the operator it shares with the forward
//! pass's in-pass tone map.

mod tonemap;

pub use tonemap::{TonemapPass, pbr_neutral};

/// The tone-map operator (`tone_map`, `pbr_neutral`), shared by the tone-map
/// pass and the forward lit pass's in-pass tone map.
pub const TONEMAP_OPERATOR_WGSL: &str = include_str!("tonemap_operator.wgsl");
/// The tone-map shader (self-contained: no bindless declarations): the
/// operator followed by the pass.
pub const TONEMAP_WGSL: &str = concat!(include_str!("tonemap_operator.wgsl"), "\n", include_str!("tonemap.wgsl"));
