//! Visibility, a subsystem of the renderer: where each view decides what it
//! draws (`Visibility`: on the CPU, or on the GPU with frustum or occlusion
//! culling), and GPU visibility's state (the GPU scene's buffers, per-view
//! cull parameters, counts and depth pyramids) where the device runs it.

use oxygen_bindless::BindlessHeap;
use oxygen_gpu::GpuContext;
use oxygen_passes::{DrawPath, GpuViewRequest, GpuVisibility};
use oxygen_sceneprep::{PreparedSceneFrame, ScenePrep, ViewFilter, Visibility};
use tracing::warn;

use super::Renderer;
use super::prepare::{FrameView, TargetPlan};

/// The views' visibility paths and GPU visibility's state.
pub(crate) struct Visibilities {
    /// GPU-driven visibility, where the device can run it.
    pub(crate) gpu: Option<GpuVisibility>,
    /// The views' default path.
    pub(crate) default: Visibility,
}

impl Visibilities {
    /// GPU visibility where `draw_path` and the device allow it, and the
    /// default path: `asked`, or the fastest for the adapter.
    pub(crate) fn new(gpu: &GpuContext, draw_path: DrawPath, asked: Option<Visibility>) -> Self {
        // GPU visibility draws through multi-draw-indirect with counts.
        let gpu_visibility = (draw_path == DrawPath::MultiDrawIndirect && GpuVisibility::supported(gpu.features))
            .then(|| GpuVisibility::new(&gpu.device));
        let cpu_adapter = gpu.adapter_info.device_type == wgpu::DeviceType::Cpu;
        let default = match asked {
            Some(v) if v.on_gpu() && gpu_visibility.is_none() => {
                warn!(asked = ?v, adapter = %gpu.describe(), "GPU visibility needs multi-draw-indirect with counts; using the CPU path");
                Visibility::Cpu
            }
            Some(v) => v,
            None if gpu_visibility.is_some() && !cpu_adapter => Visibility::GpuFrustum,
            None => Visibility::Cpu,
        };
        Visibilities { gpu: gpu_visibility, default }
    }

    /// The path a view gets: what it asked for or the default; a GPU path
    /// the device lacks becomes the CPU path, and occlusion culling becomes
    /// frustum culling for a view without a depth pre-pass to build the
    /// pyramid from (depth-only views, graphs that do not run the two
    /// phases).
    pub(crate) fn for_view(&self, asked: Option<Visibility>, depth_only: bool, two_phase: bool) -> Visibility {
        match asked.unwrap_or(self.default) {
            v if v.on_gpu() && self.gpu.is_none() => Visibility::Cpu,
            Visibility::GpuOcclusion if depth_only || !two_phase => Visibility::GpuFrustum,
            v => v,
        }
    }

    /// Uploads the GPU scene's changes and the GPU views' cull parameters
    /// (after the targets, whose sizes the depth pyramids follow).
    pub(crate) fn prepare(
        &mut self,
        gpu: &GpuContext,
        heap: &BindlessHeap,
        prep: &ScenePrep,
        views: &[FrameView],
        frames: &[PreparedSceneFrame],
    ) {
        let Some(visibility) = self.gpu.as_mut() else { return };
        let requests: Vec<GpuViewRequest<'_>> = views
            .iter()
            .zip(frames)
            .filter(|(_, frame)| frame.gpu_plan().is_some())
            .map(|(view, frame)| GpuViewRequest {
                view: &view.world,
                prepared: frame,
                lod_bias: view.options.lod_bias,
                casters_only: view.options.filter == ViewFilter::ShadowCastersOnly,
                batch: match view.target {
                    TargetPlan::Tile { batch, .. } => Some(u64::from(batch.index())),
                    _ => None,
                },
            })
            .collect();
        visibility.prepare(&gpu.device, &gpu.queue, heap, prep.gpu_scene(), &requests);
    }

    /// Bytes the last `prepare` uploaded.
    pub(crate) fn uploaded_last_frame(&self) -> u64 {
        self.gpu.as_ref().map_or(0, GpuVisibility::uploaded_last_frame)
    }
}

impl Renderer {
    /// Where views decide visibility unless they say otherwise (the option,
    /// or the choice made for the adapter).
    pub fn visibility(&self) -> Visibility {
        self.visibility.default
    }

    /// GPU visibility's state (count buffers, depth pyramids, coverage
    /// estimates), where the device runs it.
    pub fn gpu_visibility(&self) -> Option<&GpuVisibility> {
        self.visibility.gpu.as_ref()
    }

    /// Whether the device runs the GPU visibility paths.
    pub fn gpu_visibility_supported(&self) -> bool {
        self.visibility.gpu.is_some()
    }
}
