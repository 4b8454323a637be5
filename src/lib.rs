//! # Oxygen
//!
//! A multi-view, coroutine-style frame pipeline for wgpu.
//!
//! An application registers *views* with a [`Renderer`]: each brings a
//! [`ViewResolver`](oxygen_core::ViewResolver) (camera → matrices and frustum)
//! and a [`RenderGraph`] (an async closure, or a named graph such as
//! [`StandardGraph`], whose future awaits its passes). A view may read what
//! other views render through typed links ([`ViewDesc::reads`],
//! [`Renderer::link`]): another view's depth or HDR colour, a reflection
//! probe's cube; a view registered with [`ViewDesc::with_sun_shadows`] owns
//! its shadow cascades. Every [`Renderer::render_frame`] then:
//!
//! 1. **resolves** the views and picks the render origin;
//! 2. **prepares**: ScenePrep collects the scene once, the renderer plans the
//!    frame's shadow views from the lights it found, and one immutable
//!    [`PreparedSceneFrame`](oxygen_sceneprep::PreparedSceneFrame) per view is
//!    prepared and uploaded into the bindless heap;
//! 3. **allocates targets** and writes each view's constants;
//! 4. **records**: every view's graph future is polled together on the worker
//!    threads, each into its own encoder (a pass awaiting a pipeline that is
//!    still compiling, or another view's output, lets its thread record other
//!    views), and the command buffers are submitted in link order.
//!
//! ```no_run
//! use oxygen::prelude::*;
//!
//! let mut renderer = Renderer::new_headless()?;
//! let demo = oxygen_demo::multi_view_scene();
//! let view = renderer.register_view(
//!     oxygen_demo::main_camera(UVec2::new(640, 480)),
//!     standard_render_graph,
//! )?;
//! renderer.render_frame(&demo.scene)?;
//! renderer.read_color(view)?.save("main.png")?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]
mod environment_file;
pub mod gltf_import;
mod graph;
pub mod probes;
mod renderer;
pub mod shadows;
mod views;
pub mod windows;

pub use environment_file::{EnvironmentFileError, MAX_ENVIRONMENT_SIDE, load_hdr_environment};
pub use gltf_import::{
    GltfCamera, GltfError, GltfImport, ImportLimits, ImportOptions, NodeCameraResolver, SceneChoice, import_gltf,
    import_gltf_slice, import_gltf_with,
};
pub use graph::{
    PrePass, ProbeFaceGraph, ReferenceGraph, RenderGraph, ShadowGraph, StandardGraph, lit_render_graph,
    reference_render_graph, standard_render_graph,
};
pub use oxygen_sceneprep::RenderOrigin;
pub use probes::{ProbeUpdate, ReflectionProbe};
pub use renderer::{FrameReport, FrameWarning, RenderError, Renderer, RendererOptions, ViewReport, ViewRole};
pub use shadows::{LocalShadowSettings, PointShadowFaceResolver, SpotShadowResolver};
pub use views::{ViewDesc, Views};
pub use windows::{PresentMode, WindowId, WindowRect};

/// The bindless heap.
pub use oxygen_bindless as bindless;
/// The core crate: math, scene, assets, views (no GPU).
pub use oxygen_core as core;
/// The GPU device, view targets and readback.
pub use oxygen_gpu as gpu;
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
        FrameReport, FrameWarning, LocalShadowSettings, PrePass, ReferenceGraph, RenderError, RenderGraph,
        RenderOrigin, Renderer, RendererOptions, StandardGraph, ViewDesc, Views, lit_render_graph,
        reference_render_graph, standard_render_graph,
    };
    pub use crate::{
        GltfCamera, GltfError, GltfImport, ImportLimits, ImportOptions, SceneChoice, import_gltf, import_gltf_with,
    };
    pub use crate::{PresentMode, WindowId, WindowRect};
    pub use crate::{ProbeUpdate, ReflectionProbe, ViewRole};
    pub use oxygen_bindless::TexturePath;
    pub use oxygen_core::glam::{DVec3, Mat4, Quat, UVec2, Vec2, Vec3, Vec4};
    pub use oxygen_core::{
        AlphaMode, Camera, CameraError, CascadeSettings, DAabb, DLookAtResolver, Geometry, GeometryHandle, Light,
        LightKind, LookAtResolver, Material, MaterialHandle, NodeFlags, NodeKey, Projection, Renderable, ResolvedView,
        Scene, Transform, ViewContext, ViewError, ViewId, ViewResolver,
    };
    pub use oxygen_gpu::{HdrFormat, Msaa};
    pub use oxygen_passes::{
        CommandRecorder, DrawPath, ForwardLitConfig, MeshPass, Output, PassError, PrePassEstimate, ReferenceSettings,
        RenderContext, RenderPass, TonemapPass,
    };
    pub use oxygen_sceneprep::{PassMask, PreparedSceneFrame, ViewPrepOptions, Visibility};
}
