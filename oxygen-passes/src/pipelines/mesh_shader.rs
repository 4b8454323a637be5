//! Which WGSL a mesh pipeline compiles: the depth-only module for depth
//! passes, the forward lit module for shading; both on the device's texture
//! path. Also which of the module's entry points a pipeline uses, so that
//! the pipeline cache and the registry's validation test read one answer.

use oxygen_bindless::TexturePath;

use super::PassKind;
use crate::shaders::{DEPTH_ONLY, FORWARD_LIT, LABELS, MeshVaryings, ShaderModule, VISIBILITY};

/// The registry's module a pass's pipelines are made from.
pub(crate) fn mesh_module(pass: PassKind) -> ShaderModule {
    match pass {
        PassKind::DepthPrePass | PassKind::Shadow => DEPTH_ONLY,
        PassKind::Shading | PassKind::ShadingAfterPrePass | PassKind::Transparent => FORWARD_LIT,
        PassKind::Labels => LABELS,
        PassKind::Visibility => VISIBILITY,
    }
}

/// The vertex and fragment entry points of a pipeline of `pass`, for an
/// alpha-tested (`masked`) variant or not; no fragment stage for an opaque
/// depth-only variant, which only writes depth. A shading or visibility
/// pass with `labels` writes the pixel labels beside its colour or surface
/// id; an opaque visibility variant without them has a vertex stage of its
/// own that writes nothing but the position and the surface id.
pub(crate) fn mesh_entry_points(pass: PassKind, masked: bool, labels: bool) -> (&'static str, Option<&'static str>) {
    let fragment = match pass {
        PassKind::DepthPrePass | PassKind::Shadow => masked.then_some("fs_alpha_test"),
        PassKind::ShadingAfterPrePass | PassKind::Shading => Some(match (masked, labels) {
            (false, false) => "fs_opaque",
            (true, false) => "fs_masked",
            (false, true) => "fs_opaque_labelled",
            (true, true) => "fs_masked_labelled",
        }),
        // Blended surfaces have their own stage whatever their alpha class.
        PassKind::Transparent => Some("fs_blend"),
        PassKind::Labels => Some(if masked { "fs_labels_masked" } else { "fs_labels" }),
        PassKind::Visibility => {
            return match (masked, labels) {
                (false, false) => ("vs_visibility", Some("fs_visibility")),
                (false, true) => ("vs_visibility_labelled", Some("fs_visibility_labelled")),
                (true, _) => ("vs_visibility_labelled", Some("fs_visibility_masked")),
            };
        }
    };
    ("vs_main", fragment)
}

/// The full WGSL of a pass, composed from `mesh/depth_only.wgsl` or
/// `mesh/forward_lit.wgsl` and what they include (the heap's declarations,
/// the GPU records, the generated constants, the shared vertex stage with
/// every vertex output: right for any scene).
#[cfg(any(test, feature = "testing"))]
pub fn shader_source(pass: PassKind, textures: TexturePath) -> String {
    mesh_module(pass).textured_source(textures)
}

/// The WGSL a pipeline of `pass` with `features` compiles: the vertex
/// stage carries vertex colours and the second UV set only when
/// [`ShaderFeatures::vertex_attributes`](crate::ShaderFeatures::vertex_attributes).
pub(crate) fn pipeline_source(pass: PassKind, textures: TexturePath, features: &crate::ShaderFeatures) -> String {
    mesh_module(pass).mesh_source(textures, MeshVaryings::of(features.vertex_attributes))
}
