//! Shadows, a subsystem of the renderer: the shadow views it makes for the
//! lights of each frame (the planning is [`crate::shadows`]'), the graph
//! they record, and the `Renderer` methods about shadows.

use std::sync::Arc;

use oxygen_core::ViewId;
use oxygen_passes::DepthBias;

use super::Renderer;
use crate::graph::ErasedGraph;
use crate::shadows::{LocalShadowSettings, ShadowViews};

/// The renderer's shadow views and what they record.
pub(crate) struct Shadows {
    pub(crate) views: ShadowViews,
    /// The graph of every shadow view (the renderer's depth bias).
    pub(crate) graph: Arc<dyn ErasedGraph>,
}

impl Shadows {
    pub(crate) fn new(local: Option<LocalShadowSettings>, bias: DepthBias) -> Self {
        Shadows { views: ShadowViews::new(local), graph: Arc::new(crate::ShadowGraph { bias }) }
    }
}

impl Renderer {
    /// Turns shadow maps of spot and point lights on (`Some`) or off.
    pub fn set_local_shadows(&mut self, settings: Option<LocalShadowSettings>) {
        self.shadows.views.local_settings = settings;
    }

    /// The shadow cascades `view` owns now, nearest first.
    pub fn sun_cascades(&self, view: impl Into<ViewId>) -> Vec<ViewId> {
        self.shadows.views.cascades_of(view.into()).collect()
    }

    /// Every shadow view the renderer created itself (cascades and local).
    pub fn shadow_views(&self) -> Vec<ViewId> {
        self.shadows.views.all().collect()
    }
}
