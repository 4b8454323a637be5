//! Batches of views: many cameras of one size that share one graph and one
//! set of targets, for rigs of tens to thousands of small sensor cameras.
//!
//! A batch is registered once ([`Renderer::register_batch`]); cameras are
//! added and removed at any frame ([`Renderer::add_camera`],
//! [`Renderer::unregister_view`]) without registering the batch again.
//! Each camera is still a view: it has its own [`ViewId`], resolver,
//! [`PreparedSceneFrame`](oxygen_sceneprep::PreparedSceneFrame) and
//! outputs ([`Renderer::read_color`], [`Renderer::read_depth`]), so links,
//! snapshot dumps and the CPU reference work for it as for any view. What
//! the cameras share is what a view costs on its own: they draw into tiles
//! of one atlas ([`oxygen_gpu::TileAtlas`], one layer a page), with one
//! render pass per page for each pass of the batch's graph ([`BatchGraph`])
//! and one command buffer for the whole batch, instead of targets, passes
//! and a command buffer per view. Where the cameras' pixels have lighting
//! to do, [`BatchShading::Deferred`] shades them in one compute dispatch
//! per page after a visibility pass (on GPUs that run fragments on a part
//! of the chip, several times faster: docs/performance.md).
//!
//! [`Renderer::register_batch`]: crate::Renderer::register_batch
//! [`Renderer::add_camera`]: crate::Renderer::add_camera
//! [`Renderer::unregister_view`]: crate::Renderer::unregister_view
//! [`Renderer::read_color`]: crate::Renderer::read_color
//! [`Renderer::read_depth`]: crate::Renderer::read_depth

use std::fmt;
use std::sync::Arc;

use glam::UVec2;
use oxygen_core::ViewId;
use oxygen_gpu::LabelSet;

pub use crate::graph::{BatchGraph, BatchShading, standard_batch_graph};
pub use crate::renderer::{StreamOptions, StreamedCamera, StreamedFrame};

/// Names a registered batch; handed out by [`crate::views::Views::register_batch`],
/// never made from a number.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct BatchId {
    index: u32,
}

impl BatchId {
    /// The batch's number (unique among the renderer's batches).
    pub(crate) fn index(self) -> u32 {
        self.index
    }
}

impl fmt::Display for BatchId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "batch#{}", self.index)
    }
}

impl fmt::Debug for BatchId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

/// How a batch is registered: its name (in reports, errors and file
/// names), the size of every camera's image and the graph every camera
/// records.
#[derive(Clone, Debug)]
pub struct BatchDesc {
    pub(crate) name: String,
    pub(crate) size: UVec2,
    pub(crate) graph: BatchGraph,
    pub(crate) max_page_side: Option<u32>,
    pub(crate) labels: LabelSet,
}

impl BatchDesc {
    /// A batch called `name` whose cameras render `size` pixels each with
    /// the standard batch graph ([`standard_batch_graph`]).
    pub fn new(name: impl Into<String>, size: UVec2) -> Self {
        BatchDesc { name: name.into(), size, graph: standard_batch_graph, max_page_side: None, labels: LabelSet::NONE }
    }

    /// Pages of the batch's atlas no wider or taller than `side` pixels
    /// (by default the device's largest texture): more pages, each a render
    /// pass of its own, but less memory left unused in the last page.
    pub fn with_max_page_side(self, side: u32) -> Self {
        BatchDesc { max_page_side: Some(side), ..self }
    }

    /// Every camera draws every label plane (instance ids, world normals,
    /// semantic classes, linear depth; see [`crate::ViewDesc::with_labels`])
    /// into label pages of the atlas.
    pub fn with_labels(self) -> Self {
        self.with_label_planes(LabelSet::ALL)
    }

    /// Every camera draws the label planes of `planes` (and no others)
    /// into label pages of the atlas: a batch pays only for the planes it
    /// reads ([`Label::bytes_per_pixel`](oxygen_gpu::Label::bytes_per_pixel)
    /// a pixel each).
    pub fn with_label_planes(self, planes: LabelSet) -> Self {
        BatchDesc { labels: planes, ..self }
    }

    /// The same batch with another graph.
    pub fn with_graph(self, graph: BatchGraph) -> Self {
        BatchDesc { graph, ..self }
    }
}

/// A registered batch: its description and which camera holds which tile.
pub(crate) struct BatchEntry {
    pub(crate) name: String,
    pub(crate) size: UVec2,
    pub(crate) graph: Arc<BatchGraph>,
    pub(crate) max_page_side: Option<u32>,
    /// The label planes every camera draws.
    pub(crate) labels: LabelSet,
    /// Tile `i` of the batch's atlas belongs to `slots[i]`; a removed
    /// camera's tile is free for the next one added, so the others keep
    /// theirs (and their targets) when cameras come and go.
    pub(crate) slots: Vec<Option<ViewId>>,
}

impl BatchEntry {
    /// The first free tile, taken for `view`.
    pub(crate) fn take_slot(&mut self, view: ViewId) -> u32 {
        match self.slots.iter().position(Option::is_none) {
            Some(free) => {
                self.slots[free] = Some(view);
                free as u32
            }
            None => {
                self.slots.push(Some(view));
                self.slots.len() as u32 - 1
            }
        }
    }

    /// Frees `view`'s tile; trailing free tiles are dropped, so the atlas
    /// can shrink when the last cameras go.
    pub(crate) fn free_slot(&mut self, view: ViewId) {
        for slot in self.slots.iter_mut().filter(|s| **s == Some(view)) {
            *slot = None;
        }
        while self.slots.last().is_some_and(Option::is_none) {
            self.slots.pop();
        }
    }

    /// The largest page side on a device whose textures reach `limit`.
    pub(crate) fn page_side(&self, limit: u32) -> u32 {
        self.max_page_side.map_or(limit, |side| side.min(limit))
    }

    /// The cameras, in tile order.
    pub(crate) fn cameras(&self) -> impl Iterator<Item = ViewId> + '_ {
        self.slots.iter().flatten().copied()
    }
}

/// Hands out batch ids, each once.
#[derive(Debug, Default)]
pub(crate) struct BatchIds {
    next: u32,
}

impl BatchIds {
    pub(crate) fn allocate(&mut self) -> BatchId {
        let id = BatchId { index: self.next };
        self.next = self.next.wrapping_add(1);
        id
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry() -> BatchEntry {
        BatchEntry {
            name: "rig".into(),
            size: UVec2::new(8, 8),
            graph: Arc::new(standard_batch_graph),
            max_page_side: None,
            labels: LabelSet::NONE,
            slots: Vec::new(),
        }
    }

    #[test]
    fn removed_cameras_free_their_tiles_for_the_next_and_the_others_keep_theirs() {
        let mut ids = oxygen_core::ViewIds::default();
        let [a, b, c, d] = std::array::from_fn(|_| ids.allocate());
        let mut batch = entry();
        assert_eq!([batch.take_slot(a), batch.take_slot(b), batch.take_slot(c)], [0, 1, 2]);
        batch.free_slot(b);
        assert_eq!(batch.cameras().collect::<Vec<_>>(), [a, c], "c keeps tile 2");
        assert_eq!(batch.take_slot(d), 1, "the freed tile is reused");
        batch.free_slot(c);
        batch.free_slot(d);
        assert_eq!(batch.slots.len(), 1, "trailing free tiles go");
        assert_eq!(batch.cameras().collect::<Vec<_>>(), [a]);
    }

    /// A batch is named by its number in reports and errors.
    #[test]
    fn a_batch_id_names_its_number() {
        let id = BatchId { index: 3 };
        assert_eq!(id.index(), 3);
        assert_eq!(id.to_string(), "batch#3");
        assert_eq!(format!("{id:?}"), "batch#3");
    }

    /// Each builder of a batch's description sets its own field.
    #[test]
    fn a_batch_description_keeps_what_each_builder_sets() {
        let graph = BatchGraph { exposure: 2.0, ..standard_batch_graph };
        let desc = BatchDesc::new("walls", UVec2::new(4, 4))
            .with_max_page_side(512)
            .with_label_planes(LabelSet::ALL)
            .with_graph(graph.clone());
        assert_eq!(desc.max_page_side, Some(512));
        assert_eq!(desc.labels, LabelSet::ALL);
        assert_eq!(desc.graph, graph);
    }

    /// A page is as large as the device allows, or as the batch asked if
    /// that is smaller.
    #[test]
    fn a_page_is_no_larger_than_asked_or_than_the_device_allows() {
        let mut batch = entry();
        assert_eq!(batch.page_side(4096), 4096);
        batch.max_page_side = Some(512);
        assert_eq!(batch.page_side(4096), 512);
        assert_eq!(batch.page_side(256), 256);
    }
}
