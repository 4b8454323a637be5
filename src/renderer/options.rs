//! Choices made when the renderer is created.

use oxygen_bindless::TexturePath;
use oxygen_gpu::HdrFormat;
use oxygen_passes::{DepthBias, DrawPath};
use oxygen_sceneprep::{RenderOrigin, Visibility};

use crate::shadows::LocalShadowSettings;
#[cfg(doc)]
use crate::{FrameWarning, Renderer};
#[cfg(doc)]
use oxygen_gpu::{GpuOptions, ViewTargets};

/// Choices made when the renderer is created.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RendererOptions {
    /// Force a draw path; `None` picks the fastest the device supports.
    pub draw_path: Option<DrawPath>,
    /// Threads for ScenePrep's per-view phases and for recording the views'
    /// graphs; `None` uses every core.
    pub prep_threads: Option<usize>,
    /// Force a texture path; `None` picks the binding array where supported.
    pub texture_path: Option<TexturePath>,
    /// Debug mode: shaders check each draw's slot generation and paint draws
    /// read through a stale range magenta.
    pub debug_generations: bool,
    /// Where the GPU's coordinates are centred (camera-relative rendering).
    pub origin: RenderOrigin,
    /// Skip wgpu's indirect-argument validation on the device the renderer
    /// creates ([`Renderer::new_headless_with`]); see
    /// [`GpuOptions::trust_indirect_args`]. A renderer given a context uses
    /// that context's setting.
    pub trust_indirect_args: bool,
    /// GPU memory all views' targets may take together, bytes
    /// ([`ViewTargets::bytes_for`] says what one view takes). A view whose
    /// targets would pass it is skipped with a [`FrameWarning`] instead of
    /// allocated; default 2 GiB (about 130 views of 1920×1080).
    pub target_budget_bytes: u64,
    /// Render shadow maps for shadow-casting spot and point lights
    /// ([`Renderer::set_local_shadows`]); `None` renders none.
    pub local_shadows: Option<LocalShadowSettings>,
    /// Rasterizer depth bias of every shadow map the renderer renders (sun
    /// cascades and local shadows), against acne; see [`DepthBias`].
    pub shadow_bias: DepthBias,
    /// Format of every view's HDR target. [`HdrFormat::Rg11b10Ufloat`]
    /// halves its memory and bandwidth at the price of coarser gradients
    /// (measured in docs/performance.md); on an adapter without
    /// `Features::RG11B10UFLOAT_RENDERABLE` the renderer falls back to
    /// `Rgba16Float` with a warning ([`Renderer::hdr_format`] says which).
    pub hdr_format: HdrFormat,
    /// Write every view's HDR target even when nothing reads it, so that
    /// [`Renderer::read_hdr`] sees what shading wrote (tests, debugging).
    /// Off, a view without transparent surfaces whose HDR no other view
    /// reads tone-maps at the end of shading and skips the tone-map pass.
    pub keep_hdr: bool,
    /// Specialise shading pipelines to what each view has this frame
    /// (see `oxygen_passes::ShaderFeatures`); `false` runs the fully featured
    /// shader everywhere.
    pub specialize_shaders: bool,
    /// Where views decide visibility unless they say
    /// ([`crate::ViewDesc::with_visibility`]); `None` picks per adapter:
    /// [`Visibility::GpuFrustum`] on a hardware GPU that counts indirect
    /// draws, [`Visibility::Cpu`] on a CPU adapter (lavapipe, llvmpipe:
    /// compute there runs on the same cores as ScenePrep, measured in
    /// docs/performance.md) and wherever the GPU paths cannot run.
    /// [`Renderer::visibility`] reports the choice.
    pub visibility: Option<Visibility>,
    /// The deterministic mode: the same scene, cameras and options give
    /// bit-identical outputs on one adapter and driver, whatever the number
    /// of threads, the order views were registered in, the visibility path
    /// and the frame history. Draws come in one canonical order on every
    /// path ([`oxygen_sceneprep::ScenePrep::set_deterministic`]) and the
    /// shading pass resolves exact depth ties as a depth pre-pass does, so
    /// that the automatic pre-pass changes no pixel
    /// ([`oxygen_passes::PipelineKey::last_tie_wins`]).
    /// What it costs and what it cannot promise across adapters:
    /// docs/determinism.md. Off by default.
    pub deterministic: bool,
}

impl Default for RendererOptions {
    fn default() -> Self {
        RendererOptions {
            draw_path: None,
            prep_threads: None,
            texture_path: None,
            debug_generations: false,
            origin: RenderOrigin::default(),
            trust_indirect_args: false,
            target_budget_bytes: 2 << 30,
            local_shadows: None,
            shadow_bias: DepthBias::SHADOW_DEFAULT,
            hdr_format: HdrFormat::Rgba16Float,
            keep_hdr: false,
            specialize_shaders: true,
            visibility: None,
            deterministic: false,
        }
    }
}
