//! Which WGSL a mesh pipeline compiles: the depth-only module for depth
//! passes, the forward lit module for shading; both on the device's texture
//! path.

use oxygen_bindless::TexturePath;

use super::PassKind;
use crate::shaders::{DEPTH_ONLY, FORWARD_LIT, LABELS};

/// The full WGSL of a pass, composed from `mesh/depth_only.wgsl` or
/// `mesh/forward_lit.wgsl` and what they include (the heap's declarations,
/// the GPU records, the generated constants, the shared vertex stage).
pub fn shader_source(pass: PassKind, textures: TexturePath) -> String {
    let module = match pass {
        PassKind::DepthPrePass | PassKind::Shadow => DEPTH_ONLY,
        PassKind::Shading | PassKind::ShadingAfterPrePass | PassKind::Transparent => FORWARD_LIT,
        PassKind::Labels => LABELS,
    };
    module.textured_source(textures)
}
