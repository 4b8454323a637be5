//! Post-processing after shading: the tone map from the HDR target to the
//! displayable sRGB target (with its optional effects: bloom and automatic
//! exposure), the operator it shares with the forward pass's in-pass
//! tone map, other views' images drawn into a rectangle (composite) and
//! the overlay drawn over the final image.
//! `params` holds the pass's parameter block, declared once for Rust and
//! WGSL.

mod composite;
mod depth_copy;
pub(crate) mod effects;
pub(crate) mod overlay;
pub(crate) mod params;
mod tonemap;

pub use composite::CompositePass;
pub use depth_copy::DepthCopy;
pub use effects::{AutoExposure, Bloom};
pub use overlay::OverlayPass;
pub use tonemap::TonemapPass;
pub(crate) use tonemap::pbr_neutral;
/// The tone-map shader (self-contained: no bindless declarations): the
/// pass with the operator and its parameter block.
pub static TONEMAP_WGSL: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| crate::shaders::TONEMAP.source());
