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
pub mod probes;
mod renderer;
pub mod shadows;

pub use gltf_import::{
    GltfCamera, GltfError, GltfImport, ImportLimits, ImportOptions, NodeCameraResolver, SceneChoice, import_gltf,
    import_gltf_slice, import_gltf_with,
};
pub use probes::{ProbeUpdate, ReflectionProbe};
pub use renderer::{
    FrameReport, FrameWarning, RenderError, RenderGraphFuture, RenderOrigin, Renderer, RendererOptions, ViewReport,
    lit_render_graph, standard_render_graph,
};
pub use shadows::{
    PointShadowFaceResolver, SpotShadowResolver, register_local_shadows, register_sun_cascades, shadowed_render_graph,
};

/// The bindless heap.
pub use oxygen_bindless as bindless;
/// The core crate: math, scene, assets, views, GPU context.
pub use oxygen_core as core;
/// The render passes.
pub use oxygen_passes as passes;
/// ScenePrep.
pub use oxygen_sceneprep as sceneprep;

/// The `image` crate of [`Renderer::read_color`]'s `RgbaImage`, to save or
/// inspect a read-back without depending on a matching `image` version.
pub use image;
/// The `glam` Oxygen's math is written in, so positions and matrices you
/// build have the types Oxygen takes (no second `glam` in `Cargo.toml`).
pub use oxygen_core::glam;
/// The `wgpu` Oxygen renders with, for code that reaches the device through
/// [`Renderer::gpu`] or writes its own passes.
pub use wgpu;

/// Compiles the Rust blocks of `README.md` as doctests, so the README's
/// examples cannot drift from the API.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

/// The names most applications use.
pub mod prelude {
    pub use crate::{
        FrameReport, FrameWarning, RenderError, RenderGraphFuture, RenderOrigin, Renderer, RendererOptions,
        lit_render_graph, standard_render_graph,
    };
    pub use crate::{
        GltfCamera, GltfError, GltfImport, ImportLimits, ImportOptions, SceneChoice, import_gltf, import_gltf_with,
    };
    pub use crate::{
        ProbeUpdate, ReflectionProbe, register_local_shadows, register_sun_cascades, shadowed_render_graph,
    };
    pub use oxygen_bindless::TexturePath;
    pub use oxygen_core::glam::{Mat4, Quat, UVec2, Vec2, Vec3, Vec4};
    pub use oxygen_core::{
        AlphaMode, Camera, CameraError, CascadeSettings, Geometry, GeometryHandle, Light, LightKind, LookAtResolver,
        Material, MaterialHandle, NodeFlags, NodeKey, Projection, Renderable, ResolvedView, Scene, Transform,
        ViewContext, ViewError, ViewId, ViewResolver,
    };
    pub use oxygen_passes::{
        CommandRecorder, DepthPrePass, DrawPath, PassError, RenderContext, RenderPass, ShaderPass, ShaderPassConfig,
        TonemapPass, TransparentPass,
    };
    pub use oxygen_sceneprep::{PassMask, PreparedSceneFrame, ViewPrepOptions};
}
