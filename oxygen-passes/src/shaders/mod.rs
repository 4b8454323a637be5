//! How WGSL becomes a shader module: one composer ([`compose`]) resolving
//! `#include "name"` lines against one registry of named sources
//! ([`registry`]: every WGSL file of the crate, the WGSL of `oxygen-bindless`
//! and `oxygen-sceneprep`, constants and GPU structs written from their Rust
//! declarations), and the list of every module and entry point the crate
//! compiles, which the validation test walks. Also here: WGSL shared by
//! several folders ([`BRDF_WGSL`]).

pub(crate) mod compose;
pub(crate) mod registry;

#[cfg(any(test, feature = "testing"))]
pub(crate) use registry::HIZ_VISIBLE_BOXES;
pub(crate) use registry::{
    AMBIENT_OCCLUSION, COMPOSE_WINDOW, COMPOSITE, CUBE_FILTER, CULL, DEFERRED, DEPTH_COPY, DEPTH_ONLY, EFFECTS,
    FORWARD_LIT, HIZ, LABELS, LIGHT_CLUSTERS, MeshVaryings, OUTLINE, OVERLAY, REFERENCE, REFLECTION_HISTORY, SPLIT_SUM,
    ShaderModule, TONEMAP, VISIBILITY,
};

#[cfg(test)]
mod layout_tests;
#[cfg(test)]
mod validate_tests;
