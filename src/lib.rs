//! # Oxygen
//!
//! A multi-view, coroutine-style frame pipeline for wgpu.
//!
//! An application registers *views* with a [`Renderer`]: each brings a
//! [`ViewResolver`](oxygen_core::ViewResolver) (camera → matrices and frustum)
//! and a [`RenderGraph`](graph::RenderGraph) (an async closure, or a named
//! graph such as [`StandardGraph`](graph::StandardGraph), whose future awaits
//! its passes). A view may read what other views render through typed links
//! ([`ViewDesc::reads`],
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
pub mod batch;
mod environment_file;
mod gltf_import;
pub mod graph;
pub mod group;
mod probes;
mod renderer;
pub mod schedule;
mod shadows;
pub mod views;
pub mod windows;

pub use oxygen_sceneprep::RenderOrigin;
pub use renderer::{
    DepthImage, FrameReport, FrameWarning, LabelImage, RenderError, Renderer, RendererInternals, RendererOptions,
    ViewReport, ViewRole,
};

// Root paths the renderer's code and doc links name (`crate::WindowId`,
// `crate::ViewDesc::shown_in`, …); doc links alone do not count as uses.
#[allow(unused_imports)]
pub(crate) use {
    graph::{ProbeFaceGraph, ShadowGraph, standard_render_graph},
    probes::ReflectionProbe,
    views::ViewDesc,
    windows::{WindowId, WindowRect},
};

/// Importing glTF 2.0 files into a [`Scene`](oxygen_core::Scene): nodes,
/// meshes, materials, lights, cameras and animations, under
/// [`ImportLimits`](import::ImportLimits) when the file is untrusted.
pub mod import {
    pub use crate::gltf_import::{
        GltfCamera, GltfError, GltfImport, GraphError, ImportLimits, ImportOptions, LimitExceeded, MeshError,
        NodeCameraResolver, SUPPORTED_REQUIRED_EXTENSIONS, SceneChoice, UriError, import_gltf, import_gltf_slice,
        import_gltf_with,
    };
}

/// Lights and what they light: shadow settings and the shadow views'
/// resolvers, reflection probes, environments (the sky, HDR panoramas), and
/// how shading finds the lights of a pixel (clustered light culling).
pub mod lighting {
    pub use crate::environment_file::{EnvironmentFileError, MAX_ENVIRONMENT_SIDE, load_hdr_environment};
    pub use crate::probes::{ProbeFaceResolver, ProbeUpdate, ReflectionProbe};
    pub use crate::shadows::{LocalShadowSettings, PointShadowFaceResolver, SpotShadowResolver};
    pub use oxygen_core::{
        CascadeSettings, Environment, EnvironmentError, EquirectImage, Light, LightKind, Mobility, Sky,
    };
    pub use oxygen_passes::{
        AmbientOcclusion, AmbientOcclusionPass, AoQuality, AutoExposure, Bloom, ClusterGrid, ContactShadows,
        LightCulling, LinearDepthPass, ReflectionHistoryPass, ScreenSpaceReflections,
    };
}

/// The bindless heap.
pub use oxygen_bindless as bindless;
/// The core crate: math, scene, assets, views (no GPU).
pub use oxygen_core as core;
/// The GPU device, view targets and readback.
pub use oxygen_gpu as gpu;
/// The overlay layer, CPU side: shapes, text, debug lines and the grid
/// drawn over a view ([`Renderer::overlay`]).
pub use oxygen_overlay as overlay;
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

/// The names most applications use: the renderer, the scene, glTF import,
/// views, the standard graph, the passes a custom graph awaits and the
/// typed outputs views read. Everything else lives in a named module
/// ([`views`], [`graph`], [`import`], [`lighting`], [`windows`]) or in the
/// crate that owns it ([`core`], [`gpu`], [`bindless`], [`sceneprep`],
/// [`passes`]).
pub mod prelude {
    pub use crate::graph::{RenderGraph, StandardGraph, standard_render_graph};
    pub use crate::import::{SceneChoice, import_gltf};
    pub use crate::views::ViewDesc;
    pub use crate::{RenderError, Renderer, RendererOptions};
    pub use oxygen_core::glam::{UVec2, Vec3};
    pub use oxygen_core::{
        Camera, Geometry, Light, LookAtResolver, Material, Renderable, Scene, Transform, ViewId, ViewResolver,
    };
    pub use oxygen_passes::{
        CommandRecorder, ForwardLitConfig, MeshPass, Output, RenderContext, RenderPass, TonemapPass,
    };
}
