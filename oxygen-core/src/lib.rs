//! # oxygen-core
//!
//! The foundation every other Oxygen crate stands on. It owns:
//!
//! * [`math`]: bounding volumes ([`Aabb`], [`Sphere`]), the view [`Frustum`]
//!   and reverse-Z projections;
//! * [`scene`]: the node table (hierarchy, local TRS, flags) with its
//!   renderables, lights and cameras, and the world-transform resolution that
//!   ScenePrep runs once per frame;
//! * [`geometry`] and [`material`]: the assets a renderable points at;
//! * [`view`]: [`ViewId`], [`ViewContext`], [`ResolvedView`] and the
//!   [`ViewResolver`] contract.
//!
//! It needs no GPU (the device, targets and readback are `oxygen-gpu`'s) and
//! knows nothing about ScenePrep or passes: data flows out of this crate,
//! never back in.

#![warn(missing_docs)]
// `!(x > 0.0)` is how this crate rejects NaN along with the out-of-range values;
// rewriting it with `partial_cmp` would hide that intent.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod animation;
pub mod camera;
pub mod environment;
pub mod geometry;
pub mod light;
pub mod material;
pub mod math;
pub mod output;
pub mod scene;
pub mod shadow;
pub mod texture;
pub mod view;

pub use animation::{Animation, Channel, ChannelError, ChannelValues, Interpolation};
pub use camera::{Camera, CameraError, Projection};
pub use environment::{Environment, EnvironmentError, EquirectImage, PrefilteredEnvironment, Sky, split_sum_brdf};
pub use geometry::{
    Geometry, GeometryError, MAX_JOINTS, MAX_MORPH_TARGETS, MorphTarget, SkinWeights, Submesh, Vertex, VertexAttributes,
};
pub use light::{Light, LightKind, Mobility};
pub use material::{AlphaMode, Material, MaterialUvs, UvTransform};
pub use math::{Aabb, DAabb, Frustum, Plane, Sphere};
pub use output::{
    Color, Depth, HdrColor, InstanceIds, LinearDepth, Normals, Output, OutputSource, ProbeCube, ProbeId, ProbeIds,
    SemanticClasses, ShadowMap,
};
pub use scene::{
    GeometryHandle, LodLevel, MaterialHandle, Node, NodeFlags, NodeKey, Renderable, Scene, SceneError, Skin,
    TextureHandle, Transform, WorldTransforms,
};
pub use shadow::{Cascade, CascadeResolver, CascadeSettings, cascade_splits, fit_cascade};
pub use texture::{ColorSpace, Filter, Sampling, TextureError, TextureImage, Wrap};
pub use view::{
    DLookAtResolver, LookAtResolver, ResolvedView, ViewContext, ViewError, ViewId, ViewIdHasher, ViewIdHashing,
    ViewIdMap, ViewIdRange, ViewIdSet, ViewIds, ViewResolver,
};

/// Re-exported so that users name the same `glam` types Oxygen uses.
pub use glam;
