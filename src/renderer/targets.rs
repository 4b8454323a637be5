//! Step 3 of a frame: every view's targets (its own, reallocated when its
//! size changes; a layer of the local shadow atlas; a face of its probe's
//! cube) and its scene constants.

use oxygen_bindless::{CameraConstants, SceneConstantsBuffer};
use oxygen_gpu::ViewTargets;
use oxygen_passes::{GpuViewRequest, ReferenceTracer};
use oxygen_sceneprep::ViewFilter;
use tracing::info_span;

use super::resolve::{FramePlan, TargetPlan};
use super::{RenderError, Renderer, ViewGpu};

impl Renderer {
    /// Tiles of the local shadow atlas this frame (one past the highest).
    pub(super) fn atlas_layers(plan: &FramePlan) -> u32 {
        plan.views
            .iter()
            .filter_map(|v| match v.target {
                TargetPlan::AtlasLayer { tile } => Some(tile + 1),
                _ => None,
            })
            .max()
            .unwrap_or(0)
    }

    pub(super) fn allocate_targets(&mut self, plan: &FramePlan, time_seconds: f32) -> u64 {
        let _span = info_span!("targets", views = plan.views.len()).entered();
        let layers = Self::atlas_layers(plan);
        let atlas = (layers > 0).then(|| {
            let resolution = self.shadows.local_settings.map_or(1024, |s| s.resolution).max(1);
            self.lighting.local_shadow_atlas(&self.gpu.device, resolution, layers)
        });
        let frames = self.prep.frames();
        let mut written = 0;
        for (view, frame) in plan.views.iter().zip(frames) {
            let device = &self.gpu.device;
            let heap = &self.heap;
            let entry = self.gpu_views.entry(view.id).or_insert_with(|| ViewGpu {
                targets: None,
                constants: SceneConstantsBuffer::new(
                    device,
                    heap.scene_constants_layout(),
                    &format!("{} scene constants", view.id),
                ),
                last_view: None,
                hdr_written: false,
            });
            let (width, height, label) = (view.gpu.viewport.x, view.gpu.viewport.y, view.id.to_string());
            match view.target {
                TargetPlan::Own { with_color, samples } => {
                    if !entry.targets.as_ref().is_some_and(|t| t.fits(width, height, with_color, samples)) {
                        entry.targets = Some(if with_color {
                            ViewTargets::with_hdr_format(device, width, height, &label, self.hdr_format)
                                .with_msaa(device, samples, &label)
                        } else {
                            ViewTargets::depth_only(device, width, height, &label)
                        });
                    }
                }
                TargetPlan::AtlasLayer { tile } => {
                    // Resolved above whenever a view renders into the atlas.
                    if let Some(atlas) = &atlas {
                        entry.targets = Some(ViewTargets::atlas_layer(atlas, tile));
                    }
                }
                TargetPlan::ProbeFace { probe, face } => {
                    if let Some(cube) = self.probes.get(&probe).map(|p| &p.texture) {
                        let current = entry
                            .targets
                            .as_ref()
                            .and_then(|t| t.color.as_ref())
                            .is_some_and(|c| c.hdr == *cube && c.hdr_layer == face && c.hdr.width() == width);
                        if !current {
                            entry.targets = Some(ViewTargets::probe_face(device, cube, face, &label));
                        }
                    }
                }
            }
            let v = &view.gpu;
            written += entry.constants.set_camera(
                &self.gpu.queue,
                &CameraConstants::new(
                    v.view,
                    v.projection,
                    v.view_projection,
                    v.inverse_view_projection,
                    v.camera_position,
                ),
            );
            written += entry.constants.set_renderer(&self.gpu.queue, &frame.renderer_constants(time_seconds));
            entry.last_view = Some(view.gpu);
        }
        written
    }

    /// Uploads the GPU scene's changes and the GPU views' cull parameters
    /// (after the targets, whose sizes the depth pyramids follow).
    pub(super) fn prepare_gpu_visibility(&mut self, plan: &FramePlan) {
        let Some(visibility) = self.visibility.as_mut() else { return };
        let frames = self.prep.frames();
        let requests: Vec<GpuViewRequest<'_>> = plan
            .views
            .iter()
            .zip(frames)
            .filter(|(_, frame)| frame.gpu_plan().is_some())
            .map(|(view, frame)| GpuViewRequest {
                view: &view.world,
                prepared: frame,
                lod_bias: view.options.lod_bias,
                casters_only: view.options.filter == ViewFilter::ShadowCastersOnly,
            })
            .collect();
        let scene = self.prep.gpu_scene();
        visibility.prepare(&self.gpu.device, &self.gpu.queue, &self.heap, scene, &requests);
    }

    /// Creates the path-traced reference's tracer when a view of the frame
    /// is path traced, and uploads ScenePrep's ray-tracing scene to it.
    pub(super) fn prepare_reference(&mut self, plan: &FramePlan) -> Result<(), RenderError> {
        let traced: Vec<_> = plan.views.iter().filter(|v| v.options.ray_scene).map(|v| v.id).collect();
        if traced.is_empty() && self.reference.is_none() {
            return Ok(());
        }
        let tracer = self.reference.get_or_insert_with(|| ReferenceTracer::new(&self.gpu.device, &self.heap));
        tracer
            .prepare(&self.gpu.device, &self.gpu.queue, &mut self.heap, self.prep.ray_scene(), &traced)
            .map_err(|e| RenderError::Prep(oxygen_sceneprep::PrepError::from(e)))
    }
}
