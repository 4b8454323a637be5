//! Which WGSL a mesh pipeline compiles: the shared declarations, the
//! shared vertex stage, then the pass kind's own code.

use oxygen_bindless::{DomainKind, SCENE_CONSTANTS_WGSL, TexturePath};
use oxygen_sceneprep::{GPU_RECORDS_WGSL, PassMask};

use super::PassKind;
use crate::lighting::ibl::{CUBE_FACES_WGSL, ENVIRONMENT_WGSL};
use crate::post::TONEMAP_OPERATOR_WGSL;
use crate::shaders::BRDF_WGSL;

const MESH_VERTEX_WGSL: &str = include_str!("../mesh/mesh_vertex.wgsl");
const DEPTH_ONLY_WGSL: &str = include_str!("../mesh/depth_only.wgsl");
const FORWARD_LIT_WGSL: &str = include_str!("../mesh/forward_lit.wgsl");

/// The full WGSL of a pass: shared declarations (scene constants, GPU
/// records, domain bindings, the texture path's bindings), then the shared
/// vertex stage, then the pass's own code.
pub fn shader_source(pass: PassKind, textures: TexturePath) -> String {
    let body = match pass {
        PassKind::DepthPrePass | PassKind::Shadow => DEPTH_ONLY_WGSL.to_owned(),
        PassKind::Shading | PassKind::ShadingAfterPrePass | PassKind::Transparent => {
            format!("{TONEMAP_OPERATOR_WGSL}\n{BRDF_WGSL}\n{CUBE_FACES_WGSL}\n{ENVIRONMENT_WGSL}\n{FORWARD_LIT_WGSL}")
        }
    };
    // Enable directives must come before any declaration.
    let enables = match textures {
        TexturePath::BindingArray => "enable wgpu_binding_array;\n",
        TexturePath::GroupedArrays => "",
    };
    // Numbers defined in Rust, emitted rather than copied into the WGSL.
    let constants = [
        oxygen_bindless::wgsl_constants(),
        PassMask::wgsl_constants(),
        oxygen_sceneprep::MaterialRecord::wgsl_constants(),
        oxygen_sceneprep::PositionalLightRecord::wgsl_constants(),
        crate::lighting::inputs::wgsl_constants(),
    ]
    .concat();
    format!(
        "{enables}{constants}{SCENE_CONSTANTS_WGSL}\n{GPU_RECORDS_WGSL}\n{}\n{}\n{MESH_VERTEX_WGSL}\n{body}",
        DomainKind::wgsl_bindings(),
        textures.wgsl()
    )
}
