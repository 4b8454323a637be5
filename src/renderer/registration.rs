//! Registering views: the `Renderer` methods that add, link, pause and
//! remove views (the registry itself is [`Views`](crate::views::Views), which needs no GPU).

use oxygen_core::ViewId;
use oxygen_passes::Output;
use oxygen_sceneprep::ViewPrepOptions;
use tracing::warn;

use super::{RenderError, Renderer, ViewRole};
use crate::batch::{BatchDesc, BatchId};
use crate::graph::RenderGraph;
use crate::views::ViewDesc;

impl Renderer {
    /// Registers a view: a resolver (camera → matrices, each frame) or a
    /// [`ViewDesc`] (resolver plus ScenePrep options, links to other views'
    /// outputs, sun shadows), and the [`RenderGraph`] it records each frame
    /// ([`standard_render_graph`](crate::standard_render_graph) is the
    /// default). The renderer records views after the views whose outputs
    /// they read, whatever the registration order.
    pub fn register_view(&mut self, desc: impl Into<ViewDesc>, graph: impl RenderGraph) -> Result<ViewId, RenderError> {
        let desc = desc.into();
        let (asked, samples) = (desc.msaa.samples(), self.msaa_samples(desc.msaa));
        let id = self.views.register(desc, graph)?;
        if samples != asked {
            warn!(view = %id, asked, samples, "the adapter cannot multisample the view's targets as asked");
        }
        Ok(id)
    }

    /// Registers a view with explicit ScenePrep options (filter, cull bound).
    pub fn register_view_with_options(
        &mut self,
        resolver: impl oxygen_core::ViewResolver + 'static,
        options: ViewPrepOptions,
        graph: impl RenderGraph,
    ) -> Result<ViewId, RenderError> {
        self.views.register(ViewDesc::new(resolver).with_options(options), graph)
    }

    /// Links `view` to `output` after registration ([`Views::link`](crate::views::Views::link)).
    pub fn link<K>(&mut self, view: impl Into<ViewId>, output: Output<K>) -> Result<(), RenderError> {
        self.views.link(view, output)
    }

    /// Registers a batch of cameras ([`crate::batch`]): one graph, one
    /// size, one atlas of tiles for all of them; cameras come with
    /// [`Renderer::add_camera`].
    pub fn register_batch(&mut self, desc: BatchDesc) -> Result<BatchId, RenderError> {
        let deferred = desc.graph.shading == crate::batch::BatchShading::Deferred;
        if deferred && let Err(reason) = oxygen_passes::DeferredShading::adapter_can(&self.gpu, &self.pipelines) {
            return Err(RenderError::InvalidBatch { name: desc.name, reason });
        }
        let id = self.views.register_batch(desc)?;
        if deferred {
            // Deferred shading finds a pixel's triangle in its mesh's
            // table: meshes are uploaded with them from the next frame on
            // (and keep them after the batch is gone).
            self.prep.set_triangle_tables(true);
        }
        Ok(id)
    }

    /// Adds a camera to `batch` ([`Views::add_camera`](crate::views::Views::add_camera)):
    /// a view of its own id that renders into a tile of the batch's atlas
    /// from the next frame on. Remove it with [`Renderer::unregister_view`].
    pub fn add_camera(&mut self, batch: BatchId, desc: impl Into<ViewDesc>) -> Result<ViewId, RenderError> {
        self.views.add_camera(batch, desc)
    }

    /// Removes a batch, its cameras and its atlas.
    pub fn unregister_batch(&mut self, batch: BatchId) -> Result<(), RenderError> {
        let cameras = self.views.batch_cameras(batch)?;
        self.views.unregister_batch(batch)?;
        for camera in cameras {
            self.release_view(camera)?;
        }
        Ok(())
    }

    /// The cameras of `batch`, in tile order.
    pub fn batch_cameras(&self, batch: BatchId) -> Result<Vec<ViewId>, RenderError> {
        self.views.batch_cameras(batch)
    }

    /// The name `view` was registered with ([`ViewDesc::named`]), if any.
    pub fn view_name(&self, view: ViewId) -> Option<&str> {
        self.views.name(view)
    }

    /// The registered view called `name`, if one is.
    pub fn find_view(&self, name: &str) -> Option<ViewId> {
        self.views.find(name)
    }

    /// Removes a view, the shadow cascades it owns, and frees their slots.
    pub fn unregister_view(&mut self, id: impl Into<ViewId>) -> Result<(), RenderError> {
        let id = id.into();
        self.views.unregister(id)?;
        let owned: Vec<ViewId> = self.shadows.views.cascades_of(id).collect();
        self.shadows.views.forget_owner(id);
        for view in std::iter::once(id).chain(owned) {
            self.release_view(view)?;
        }
        Ok(())
    }

    /// Frees a view's slots, targets and constants.
    pub(crate) fn release_view(&mut self, id: ViewId) -> Result<(), RenderError> {
        self.targets.release(id);
        self.schedules.forget(id);
        self.overlays.remove(&id);
        self.prep.forget_view(id, &mut self.heap.slots)?;
        Ok(())
    }

    /// What the application draws over view `id`'s final image: screen
    /// shapes and text, world debug shapes, an editor grid
    /// ([`oxygen_overlay::Overlay`]; its immediate canvas is cleared after
    /// each frame the view renders, its retained one kept). Made empty the
    /// first time it is asked for; a view whose overlay is empty records no
    /// overlay pass. The standard graph draws it last
    /// ([`oxygen_passes::OverlayPass`]), the batch graph last for each
    /// camera of a batch; a graph of one's own records that pass where it
    /// wants it.
    pub fn overlay(&mut self, id: impl Into<ViewId>) -> Result<&mut oxygen_overlay::Overlay, RenderError> {
        let id = id.into();
        if !self.views.contains(id) {
            return Err(RenderError::NoSuchView(id));
        }
        Ok(self.overlays.entry(id).or_default().get_mut().unwrap_or_else(std::sync::PoisonError::into_inner))
    }

    /// Draws the frustum of every other view the renderer last rendered
    /// (cameras, batch cameras, shadow cascades, probe faces, reference
    /// views) into `overview`'s immediate overlay, as it was rendered (its
    /// far side at most `max_distance` in front of its eye), each labelled
    /// with its name (or id) at its far centre: a tool's view of its own
    /// views. Call it before the frame that is to show them; returns how
    /// many it drew.
    pub fn draw_view_frusta(
        &mut self,
        overview: impl Into<ViewId>,
        max_distance: f64,
        width: f32,
        color: oxygen_overlay::Rgba,
    ) -> Result<usize, RenderError> {
        let overview = overview.into();
        let mut views: Vec<(ViewId, oxygen_core::ResolvedView)> =
            self.targets.last_world_views().filter(|(id, _)| *id != overview).map(|(id, v)| (id, *v)).collect();
        views.sort_by_key(|(id, _)| *id);
        let names: Vec<String> =
            views.iter().map(|(id, _)| self.views.name(*id).map_or_else(|| id.to_string(), str::to_string)).collect();
        let overlay = self.overlay(overview)?;
        let mut canvas = overlay.immediate();
        let mut drawn = 0;
        for ((_, view), name) in views.iter().zip(&names) {
            let Some(corners) = oxygen_overlay::frustum_corners(view, max_distance) else { continue };
            canvas.view_frustum(view, max_distance, width, color, oxygen_overlay::DepthMode::OnTop);
            let far_centre = corners[4..].iter().copied().sum::<glam::DVec3>() / 4.0;
            canvas.world_text(
                far_centre,
                glam::Vec2::new(2.0, 2.0),
                12.0,
                color,
                name,
                oxygen_overlay::DepthMode::OnTop,
            );
            drawn += 1;
        }
        Ok(drawn)
    }

    /// Changes when `id` renders ([`crate::ViewDesc::with_schedule`]), from
    /// the next frame on. Refuses what registration would refuse.
    pub fn set_schedule(
        &mut self,
        id: impl Into<ViewId>,
        schedule: crate::schedule::Schedule,
    ) -> Result<(), RenderError> {
        self.views.set_schedule(id, schedule)
    }

    /// Sets (`Some`) or lifts (`None`) the frame budget: the views due in a
    /// frame render in order of priority while their estimated costs fit
    /// it, the others later ([`crate::schedule::FrameBudget`]). Refuses a
    /// budget that cannot be kept.
    pub fn set_frame_budget(&mut self, budget: Option<crate::schedule::FrameBudget>) -> Result<(), RenderError> {
        if let Some(reason) = budget.as_ref().and_then(crate::schedule::FrameBudget::problem) {
            return Err(RenderError::InvalidSchedule { view: None, reason });
        }
        self.schedules.set_budget(budget);
        Ok(())
    }

    /// Asks `id` to render in the next frame whatever its schedule (how
    /// [`Schedule::Once`](crate::schedule::Schedule::Once) and
    /// [`Schedule::OnDemand`](crate::schedule::Schedule::OnDemand) views
    /// render again). Fails for a view that is not registered.
    pub fn request_render(&mut self, id: impl Into<ViewId>) -> Result<(), RenderError> {
        let id = id.into();
        if !self.views.entries.contains_key(&id) {
            return Err(RenderError::NoSuchView(id));
        }
        self.schedules.request(id);
        Ok(())
    }

    /// Pauses (`false`) or resumes a view: a paused view is neither resolved,
    /// prepared nor rendered, and keeps its last image (e.g. a reflection
    /// probe updated every N frames).
    pub fn set_view_active(&mut self, id: impl Into<ViewId>, active: bool) -> Result<(), RenderError> {
        self.views.set_active(id, active)
    }

    /// Registered views, in id order (not the views the renderer creates
    /// itself for shadows).
    pub fn views(&self) -> impl Iterator<Item = ViewId> + '_ {
        self.views.ids()
    }

    /// What the views of the last frame were for, in submission order.
    pub fn last_frame_views(&self) -> &[(ViewId, ViewRole)] {
        &self.frames.last
    }
}
