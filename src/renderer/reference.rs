//! The path-traced reference, a subsystem of the renderer: the tracer,
//! made when a view first asks for it, fed with ScenePrep's ray-tracing
//! scene each frame a path-traced view renders.

use oxygen_bindless::BindlessHeap;
use oxygen_core::ViewId;
use oxygen_gpu::GpuContext;
use oxygen_passes::ReferenceTracer;
use oxygen_sceneprep::ScenePrep;

use super::prepare::FrameView;
use super::{RenderError, Renderer};

/// The renderer's path tracer, when a view has asked for one.
#[derive(Default)]
pub(crate) struct Reference {
    pub(crate) tracer: Option<ReferenceTracer>,
}

impl Reference {
    /// Creates the tracer when a view of the frame is path traced, and
    /// uploads ScenePrep's ray-tracing scene to it.
    pub(crate) fn prepare(
        &mut self,
        gpu: &GpuContext,
        heap: &mut BindlessHeap,
        prep: &ScenePrep,
        views: &[FrameView],
    ) -> Result<(), RenderError> {
        let traced: Vec<_> = views.iter().filter(|v| v.options.ray_scene).map(|v| v.id).collect();
        if traced.is_empty() && self.tracer.is_none() {
            return Ok(());
        }
        let tracer = self.tracer.get_or_insert_with(|| ReferenceTracer::new(&gpu.device, heap));
        tracer
            .prepare(&gpu.device, &gpu.queue, heap, prep.ray_scene(), &traced)
            .map_err(|e| RenderError::Prep(oxygen_sceneprep::PrepError::from(e)))
    }
}

impl Renderer {
    /// Samples per pixel a path-traced view's image holds
    /// ([`ViewDesc::path_traced`](crate::ViewDesc::path_traced)); 0 for other views.
    pub fn reference_samples(&self, view: ViewId) -> u32 {
        self.reference.tracer.as_ref().map_or(0, |r| r.samples(view))
    }
}
