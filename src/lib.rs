//! # Oxygen
//!
//! A multi-view, coroutine-style frame pipeline for wgpu.
//!
//! An application registers *views* with a [`Renderer`]: each brings a
//! [`ViewResolver`](oxygen_core::ViewResolver) (camera → matrices and frustum)
//! and an async render-graph factory (a future that awaits its passes). Every
//! [`Renderer::render_frame`] then runs in two phases:
//!
//! 1. **PreRender** — ScenePrep collects the scene once and prepares one
//!    immutable [`PreparedSceneFrame`](oxygen_sceneprep::PreparedSceneFrame)
//!    per view, then uploads what the views need into the bindless heap;
//! 2. **Render** — each view's factory future is driven to completion against
//!    a [`RenderContext`](oxygen_passes::RenderContext), and the command
//!    buffers are submitted in view order.
//!
//! ```no_run
//! use oxygen::prelude::*;
//!
//! let mut renderer = Renderer::new_headless()?;
//! let demo = oxygen::core::demo::multi_view_scene();
//! let view = renderer.register_view(
//!     oxygen::core::demo::main_camera(UVec2::new(640, 480)),
//!     standard_render_graph,
//! );
//! renderer.render_frame(&demo.scene)?;
//! renderer.read_color(view)?.save("main.png")?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod gltf_import;
mod graph;
pub mod probes;
mod renderer;
pub mod shadows;
mod views;

pub use gltf_import::{
    GltfCamera, GltfError, GltfImport, ImportLimits, ImportOptions, NodeCameraResolver, SceneChoice, import_gltf,
    import_gltf_slice, import_gltf_with,
};
pub use graph::{ProbeFaceGraph, RenderGraph, ShadowGraph, StandardGraph, lit_render_graph, standard_render_graph};
pub use oxygen_sceneprep::RenderOrigin;
pub use probes::{ProbeUpdate, ReflectionProbe};
pub use renderer::{FrameReport, FrameWarning, RenderError, Renderer, RendererOptions, ViewReport, ViewRole};
pub use shadows::{LocalShadowSettings, PointShadowFaceResolver, SpotShadowResolver};
pub use views::{ViewDesc, Views};

/// The bindless heap.
pub use oxygen_bindless as bindless;
/// The core crate: math, scene, assets, views, GPU context.
pub use oxygen_core as core;
/// The render passes.
pub use oxygen_passes as passes;
/// ScenePrep.
pub use oxygen_sceneprep as sceneprep;

/// The names most applications use.
pub mod prelude {
    pub use crate::{
        FrameReport, FrameWarning, LocalShadowSettings, RenderError, RenderGraph, RenderOrigin, Renderer,
        RendererOptions, StandardGraph, ViewDesc, Views, lit_render_graph, standard_render_graph,
    };
    pub use crate::{ImportLimits, ImportOptions, SceneChoice, import_gltf, import_gltf_with};
    pub use oxygen_bindless::TexturePath;
    pub use oxygen_core::CascadeSettings;
    pub use oxygen_core::glam::{Mat4, Quat, UVec2, Vec3, Vec4};
    pub use oxygen_core::{
        AlphaMode, Camera, Geometry, Light, LookAtResolver, Material, NodeFlags, Renderable, ResolvedView, Scene,
        Transform, ViewContext, ViewId, ViewResolver,
    };
    pub use oxygen_passes::{
        CommandRecorder, DrawPath, ForwardLitConfig, MeshPass, Output, PassError, RenderContext, RenderPass,
        TonemapPass,
    };
    pub use oxygen_sceneprep::{PassMask, PreparedSceneFrame, ViewPrepOptions};
}
