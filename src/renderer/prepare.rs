//! Step 2 of a frame: pick the render origin, run ScenePrep's frame phase,
//! plan this frame's shadow views from the lights it found (the owners' sun
//! cascades, one view per local shadow tile), prepare every view and upload.

use std::sync::Arc;

use oxygen_core::Scene;
use oxygen_sceneprep::{ViewPrepOptions, ViewRequest};
use tracing::{info_span, warn};

use super::resolve::{FramePlan, FrameView, TargetPlan};
use super::{FrameWarning, RenderError, Renderer, ViewRole};
use crate::graph::ErasedGraph;
use crate::shadows::{ShadowRole, shadow_view_options};

impl Renderer {
    pub(super) fn prepare(
        &mut self,
        scene: &Scene,
        plan: &mut FramePlan,
        warnings: &mut Vec<FrameWarning>,
        frame_index: u64,
        time_seconds: f32,
    ) -> Result<(), RenderError> {
        let _span = info_span!("prepare", views = plan.views.len()).entered();
        // The origin follows the first colour view (shadow views are passed
        // over when there is another).
        let followed = plan.views.iter().find(|v| !v.options.depth_only).or(plan.views.first()).map(|v| &v.world);
        plan.origin = self.origin.resolve(followed);
        self.prep.set_render_origin(plan.origin);
        let frame = self.prep.begin_frame(scene, &mut self.heap.slots)?;

        let owners: Vec<_> = plan
            .views
            .iter()
            .filter_map(|v| Some((v.id, v.world, self.views.entries.get(&v.id)?.sun_shadows?)))
            .collect();
        let (planned, released) = self.shadows.plan(&owners, frame, scene, frame_index, time_seconds);
        for id in released {
            self.release_view(id)?;
        }
        let shadow_graph: Arc<dyn ErasedGraph> = Arc::clone(&self.shadow_graph);
        let mut taken = self.planned_target_bytes(plan);
        for shadow in planned {
            let resolved = shadow.resolved.map_err(RenderError::from).and_then(|view| {
                if let ShadowRole::Cascade { .. } = shadow.role {
                    self.admit_targets(view.viewport, false, 1, &mut taken).map_err(|e| e.for_view(shadow.id))?;
                }
                Ok(view)
            });
            let view = match resolved {
                Ok(view) => view,
                Err(e) => {
                    warn!(view = %shadow.id, "shadow view skipped this frame: {e}");
                    warnings.push(FrameWarning::ViewSkipped { view: shadow.id, reason: e.to_string() });
                    continue;
                }
            };
            // A sun cascade culls the way its owner does (frustum culling
            // for an owner with occlusion culling: a shadow map has no
            // pre-pass to build a pyramid from); local shadows the default way.
            let owner_visibility = match shadow.role {
                ShadowRole::Cascade { owner, .. } => {
                    plan.views.iter().find(|v| v.id == owner).map(|v| v.options.visibility)
                }
                ShadowRole::Local { .. } => None,
            };
            let visibility = self.view_visibility(owner_visibility, true, false);
            let (role, target) = match shadow.role {
                ShadowRole::Cascade { owner, index } => {
                    (ViewRole::SunCascade { owner, index }, TargetPlan::Own { with_color: false, samples: 1 })
                }
                ShadowRole::Local { light, face, tile } => {
                    (ViewRole::LocalShadow { light, face, tile }, TargetPlan::AtlasLayer { tile })
                }
            };
            plan.views.push(FrameView {
                id: shadow.id,
                role,
                world: view,
                gpu: view,
                options: ViewPrepOptions { visibility, ..shadow_view_options() },
                graph: Arc::clone(&shadow_graph),
                links: Vec::new(),
                target,
            });
        }

        let requests: Vec<ViewRequest<'_>> =
            plan.views.iter().map(|v| ViewRequest { view: &v.world, options: v.options }).collect();
        self.prep.prepare_views(scene, &requests, &mut self.heap.slots)?;
        self.prep.upload(&mut self.heap, &self.gpu.device, &self.gpu.queue)?;
        // The passes see every view relative to the render origin, as the
        // world matrices and lights were uploaded.
        for view in &mut plan.views {
            view.gpu = view.world.relative_to(plan.origin);
        }
        Ok(())
    }
}
