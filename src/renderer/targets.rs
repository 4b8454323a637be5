//! The views' targets, a subsystem of the renderer: per view its colour and
//! depth targets (its own, reallocated when its size changes; a layer of
//! the local shadow atlas; a face of its probe's cube), its `SceneConstants`
//! buffer and what the targets hold now; the target memory budget; and the
//! `Renderer` methods about target memory.

use std::collections::HashMap;

use oxygen_bindless::{BindlessHeap, CameraConstants, SceneConstantsBlock, SceneConstantsBuffer};
use oxygen_core::{ResolvedView, ViewId};
use oxygen_gpu::{GpuContext, HdrFormat, LabelSet, Msaa, TileAtlas, ViewTargets};
use oxygen_sceneprep::PreparedSceneFrame;

use super::prepare::{FrameView, TargetPlan};
use super::probes::Probes;
use super::record::{RecordedView, RenderedView};
use super::{RenderError, Renderer};
use crate::batch::BatchId;
use crate::views::Views;

/// What the renderer keeps per view on the GPU.
pub(crate) struct ViewGpu {
    pub(crate) targets: Option<ViewTargets>,
    pub(crate) constants: SceneConstantsBuffer,
    /// For a batch camera: the block its constants live in (the batch and
    /// the block's generation) and its slot; `None` for a buffer of its own.
    constants_home: Option<(BatchId, u64, u32)>,
    /// What the targets hold: the last frame that rendered into them, so
    /// that a view reading a paused view knows its pose, and a readback
    /// knows whether the HDR image was written.
    pub(crate) holds: Option<RenderedView>,
    /// Bytes of its own constants written this frame (a batch camera's
    /// are staged into its batch's block, whose write the frame counts).
    pub(crate) constants_written: u64,
}

/// Targets that would pass the target budget; the caller names whose.
pub(crate) struct OverBudget {
    width: u32,
    height: u32,
    bytes: u64,
    budget: u64,
    taken: u64,
}

impl OverBudget {
    /// The error for `view`'s targets.
    pub(crate) fn for_view(self, view: ViewId) -> RenderError {
        let OverBudget { width, height, bytes, budget, taken } = self;
        RenderError::TargetBudget { view, width, height, bytes, budget, taken }
    }
}

/// What a batch's atlas must hold this frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct BatchPlan {
    /// Every camera's size.
    pub(crate) size: glam::UVec2,
    /// Tiles (one past the highest a camera holds).
    pub(crate) tiles: u32,
    /// Whether the frame writes HDR colour (blended draws, a reader of a
    /// camera's HDR image, `keep_hdr`).
    pub(crate) hdr: bool,
    /// The largest page side asked for (the device's limit otherwise).
    pub(crate) max_page_side: Option<u32>,
    /// The label planes the cameras draw.
    pub(crate) labels: LabelSet,
    /// Whether the batch shades deferred (its atlas has the textures).
    pub(crate) deferred: bool,
}

/// Every view's targets and constants, and the budget they share.
pub(crate) struct Targets {
    /// Boxed: a `ViewGpu` is kilobytes (its constants' CPU copy), and a
    /// frame of a thousand cameras looks each up several times; probing
    /// the map then stays within small entries.
    views: oxygen_core::ViewIdMap<Box<ViewGpu>>,
    /// Each batch's atlas, kept between frames (its cameras' images stay
    /// readable) and reallocated when the batch outgrows it.
    atlases: HashMap<BatchId, TileAtlas>,
    /// Each batch's cameras' constants, one buffer a batch (one upload a
    /// frame), and how many blocks were made so far (a block's generation).
    blocks: HashMap<BatchId, (SceneConstantsBlock, u64)>,
    blocks_made: u64,
    /// The HDR format in use (the option, or its fallback).
    pub(crate) hdr_format: HdrFormat,
    pub(crate) budget: u64,
}

impl Targets {
    pub(crate) fn new(hdr_format: HdrFormat, budget: u64) -> Self {
        Targets {
            views: oxygen_core::ViewIdMap::default(),
            atlases: HashMap::new(),
            blocks: HashMap::new(),
            blocks_made: 0,
            hdr_format,
            budget,
        }
    }

    /// What the renderer keeps for `view`, once a frame has prepared it.
    pub(crate) fn get(&self, view: ViewId) -> Option<&ViewGpu> {
        self.views.get(&view).map(|v| &**v)
    }

    /// `batch`'s atlas, once a frame has allocated it.
    pub(crate) fn atlas(&self, batch: BatchId) -> Option<&TileAtlas> {
        self.atlases.get(&batch)
    }

    /// Forgets a view's targets and constants.
    pub(crate) fn release(&mut self, view: ViewId) {
        self.views.remove(&view);
    }

    /// Bytes the views' targets and the batches' atlases take now.
    pub(crate) fn memory(&self) -> u64 {
        let views: u64 = self.views.values().filter_map(|v| v.targets.as_ref()).map(ViewTargets::bytes).sum();
        views + self.atlases.values().map(TileAtlas::bytes).sum::<u64>()
    }

    /// Gives each batch of `plans` an atlas that holds what it needs this
    /// frame (allocated anew when the batch outgrew it, changed size or
    /// needs HDR colour it lacks) and forgets the atlases of batches that
    /// are no longer registered (`registered`).
    pub(crate) fn allocate_atlases(
        &mut self,
        device: &wgpu::Device,
        plans: &std::collections::BTreeMap<BatchId, BatchPlan>,
        registered: impl Fn(BatchId) -> bool,
        name: impl Fn(BatchId) -> String,
    ) {
        self.atlases.retain(|batch, _| registered(*batch));
        self.blocks.retain(|batch, _| registered(*batch));
        for (batch, plan) in plans {
            let size = (plan.size.x, plan.size.y);
            let fits = self.atlases.get(batch).is_some_and(|a| {
                a.tile_size == size
                    && a.capacity() >= plan.tiles
                    && (a.has_hdr() || !plan.hdr)
                    && a.max_side == plan.max_page_side
                    && a.labels() == plan.labels
                    && a.has_deferred() == plan.deferred
            });
            if fits {
                continue;
            }
            let hdr = plan.hdr.then_some(self.hdr_format);
            let _span = tracing::info_span!("batch_atlas", batch = %batch, tiles = plan.tiles).entered();
            // The resolve step refused batches whose atlas the device cannot hold.
            if let Some(atlas) = TileAtlas::new(
                device,
                size,
                plan.tiles,
                hdr,
                plan.labels,
                plan.deferred,
                plan.max_page_side,
                &name(*batch),
            ) {
                tracing::info!(batch = %batch, pages = atlas.pages.len(), columns = atlas.columns, rows = atlas.rows, "batch atlas allocated");
                self.atlases.insert(*batch, atlas);
            }
        }
    }

    /// What targets of a `viewport`-sized view take with the HDR format in use.
    pub(crate) fn bytes_for(&self, viewport: glam::UVec2, with_color: bool, samples: u32, labels: LabelSet) -> u64 {
        ViewTargets::bytes_for_msaa(viewport.x, viewport.y, with_color.then_some(self.hdr_format), samples)
            + u64::from(viewport.x) * u64::from(viewport.y) * labels.bytes_per_pixel()
    }

    /// Adds a `viewport`-sized view's targets to `taken`, or says they would
    /// pass the target budget (leaving `taken` as it was).
    pub(crate) fn admit(
        &self,
        viewport: glam::UVec2,
        with_color: bool,
        samples: u32,
        labels: LabelSet,
        taken: &mut u64,
    ) -> Result<(), OverBudget> {
        let bytes = self.bytes_for(viewport, with_color, samples, labels);
        match taken.checked_add(bytes) {
            Some(total) if total <= self.budget => {
                *taken = total;
                Ok(())
            }
            // Past the budget, or past what a u64 counts (a sum that would
            // wrap is over any budget).
            _ => {
                let (width, height, budget) = (viewport.x, viewport.y, self.budget);
                Err(OverBudget { width, height, bytes, budget, taken: *taken })
            }
        }
    }

    /// Target bytes of paused views: they keep their targets, so their
    /// memory stays taken.
    pub(crate) fn paused_bytes(&self, views: &Views) -> u64 {
        views
            .entries
            .iter()
            .filter(|(_, v)| !v.active)
            .filter_map(|(id, _)| self.views.get(id)?.targets.as_ref())
            .map(ViewTargets::bytes)
            .sum()
    }

    /// Gives every view of the frame its targets (`atlas`: the local
    /// shadow atlas, when a view renders into it) and writes its constants
    /// (`frames[i]` is `views[i]`'s prepared frame); returns the bytes the
    /// constants wrote.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn allocate(
        &mut self,
        gpu: &GpuContext,
        heap: &BindlessHeap,
        probes: &Probes,
        views: &[FrameView],
        frames: &[PreparedSceneFrame],
        atlas: Option<&wgpu::Texture>,
        time_seconds: f32,
        kept_batches: &std::collections::HashSet<BatchId>,
    ) -> u64 {
        let device = &gpu.device;
        let mut written = 0;
        // Each batch's constants block holds a slot past the highest tile
        // of its cameras this frame (grown to at least twice its size when
        // it does not: the cameras move into the new block).
        let mut slots: HashMap<BatchId, u32> = HashMap::new();
        for view in views {
            if let TargetPlan::Tile { batch, slot } = view.target {
                let needed = slots.entry(batch).or_default();
                *needed = (*needed).max(slot + 1);
            }
        }
        for (batch, needed) in slots {
            let capacity = self.blocks.get(&batch).map(|(block, _)| block.capacity());
            if capacity.is_none_or(|c| c < needed) {
                self.blocks_made += 1;
                let slots = needed.max(2 * capacity.unwrap_or(0));
                let label = format!("{batch} scene constants");
                let block = SceneConstantsBlock::new(device, heap.scene_constants_layout(), slots, &label);
                self.blocks.insert(batch, (block, self.blocks_made));
            }
        }
        for (view, frame) in views.iter().zip(frames) {
            let entry = self.views.entry(view.id).or_insert_with(|| {
                Box::new(ViewGpu {
                    targets: None,
                    constants: SceneConstantsBuffer::new(
                        device,
                        heap.scene_constants_layout(),
                        &format!("{} scene constants", view.id),
                    ),
                    constants_home: None,
                    holds: None,
                    constants_written: 0,
                })
            });
            let (width, height) = (view.gpu.viewport.x, view.gpu.viewport.y);
            // Only new targets need it: not made every frame for every camera.
            let label = || view.id.to_string();
            match view.target {
                TargetPlan::Own { with_color, samples, labels } => {
                    let fits = entry.targets.as_ref().is_some_and(|t| {
                        t.fits(width, height, with_color, samples)
                            && t.labels.as_ref().map_or(LabelSet::NONE, |l| l.set()) == labels
                    });
                    if !fits {
                        let label = label();
                        let targets = if with_color {
                            let targets = ViewTargets::with_hdr_format(device, width, height, &label, self.hdr_format);
                            // A graph's screen-space effects read the
                            // multisampled depth; GL's cannot be read (see
                            // `ViewTargets::with_msaa_sampled_depth`).
                            if view.graph.screen_depth() && gpu.adapter_info.backend != wgpu::Backend::Gl {
                                targets.with_msaa_sampled_depth(device, samples, &label)
                            } else {
                                targets.with_msaa(device, samples, &label)
                            }
                        } else {
                            ViewTargets::depth_only(device, width, height, &label)
                        };
                        entry.targets = Some(targets.with_labels(device, labels, &label));
                    }
                }
                TargetPlan::AtlasLayer { tile } => {
                    // Made by the prepare step whenever a view renders into it.
                    if let Some(atlas) = atlas {
                        entry.targets = Some(ViewTargets::atlas_layer(atlas, tile));
                    }
                }
                TargetPlan::Tile { batch, slot } => {
                    // New targets only when the camera moved to another
                    // tile or its batch to another atlas.
                    if let Some(atlas) = self.atlases.get(&batch) {
                        let current = entry.targets.as_ref().is_some_and(|t| {
                            t.tile.is_some_and(|tile| tile.index == slot)
                                && atlas.pages.get(tile_page(t)).is_some_and(|p| p.depth == t.depth)
                        });
                        if !current {
                            entry.targets = atlas.view_targets(slot);
                        }
                        if let Some(targets) = &mut entry.targets {
                            targets.page_kept = kept_batches.contains(&batch);
                        }
                    }
                }
                TargetPlan::ProbeFace { probe, face } => {
                    if let Some(cube) = probes.cube(probe) {
                        let current = entry
                            .targets
                            .as_ref()
                            .and_then(|t| t.color.as_ref())
                            .is_some_and(|c| c.hdr == *cube && c.hdr_layer == face && c.hdr.width() == width);
                        if !current {
                            entry.targets = Some(ViewTargets::probe_face(device, cube, face, &label()));
                        }
                    }
                }
            }
            let v = &view.gpu;
            let camera = CameraConstants::new(
                v.view,
                v.projection,
                v.view_projection,
                v.inverse_view_projection,
                v.camera_position,
            );
            let renderer = frame.renderer_constants(time_seconds);
            match view.target {
                // A batch's cameras: staged into the batch's block, which
                // is written once below.
                TargetPlan::Tile { batch, slot } => {
                    let Some((block, generation)) = self.blocks.get_mut(&batch) else { continue };
                    let home = Some((batch, *generation, slot));
                    if entry.constants_home != home
                        && let Some(constants) = block.view(slot)
                    {
                        entry.constants = constants;
                        entry.constants_home = home;
                    }
                    // Counted when the block is written, below.
                    entry.constants_written = 0;
                    block.stage(&gpu.queue, &mut entry.constants, &camera, &renderer);
                }
                _ => {
                    if entry.constants_home.is_some() {
                        // A camera that left its batch gets a buffer of its own again.
                        let label = format!("{} scene constants", view.id);
                        entry.constants = SceneConstantsBuffer::new(device, heap.scene_constants_layout(), &label);
                        entry.constants_home = None;
                    }
                    entry.constants_written = entry.constants.set_camera(&gpu.queue, &camera)
                        + entry.constants.set_renderer(&gpu.queue, &renderer);
                    written += entry.constants_written;
                }
            }
        }
        for (block, _) in self.blocks.values_mut() {
            written += block.upload(&gpu.queue);
        }
        written
    }

    /// Records what the targets of the views a frame rendered hold now.
    /// (`rendered` indexes `views`, the frame's.)
    pub(crate) fn hold(&mut self, rendered: &[RecordedView], views: &[FrameView]) {
        for recorded in rendered {
            if let (Some(gpu), Some(view)) = (self.views.get_mut(&recorded.id), views.get(recorded.index)) {
                gpu.holds = Some(RenderedView { view: view.gpu, world: view.world, hdr_written: recorded.hdr_written });
            }
        }
    }

    /// Every view whose targets hold an image, with the pose it was last
    /// rendered with, in world space.
    pub(crate) fn last_world_views(&self) -> impl Iterator<Item = (ViewId, &ResolvedView)> {
        self.views.iter().filter_map(|(id, gpu)| gpu.holds.as_ref().map(|h| (*id, &h.world)))
    }

    /// The pose `view`'s targets were last rendered with (relative to that
    /// frame's origin).
    pub(crate) fn last_view(&self, view: ViewId) -> Option<&ResolvedView> {
        self.views.get(&view)?.holds.as_ref().map(|h| &h.view)
    }
}

impl Renderer {
    /// Where `view`'s scene constants are on the GPU, for interop: the
    /// uniform buffer and the byte offset of the view's
    /// [`oxygen_bindless::SceneConstants`] in it. A batch's cameras share
    /// one buffer, each at its own offset (written with one upload a
    /// frame). `None` before the view's first frame.
    pub fn view_constants(&self, view: ViewId) -> Option<(&wgpu::Buffer, u64)> {
        let constants = &self.targets.get(view)?.constants;
        Some((constants.buffer(), u64::from(constants.dynamic_offset())))
    }

    /// What the targets of a `viewport`-sized view take, bytes (colour and
    /// depth, or depth only), with the default HDR format.
    pub fn target_bytes(viewport: glam::UVec2, depth_only: bool) -> u64 {
        ViewTargets::bytes_for(viewport.x, viewport.y, !depth_only)
    }

    /// Bytes the views' targets take now.
    pub fn target_memory(&self) -> u64 {
        self.targets.memory()
    }

    /// The target budget ([`RendererOptions::target_budget_bytes`](crate::RendererOptions::target_budget_bytes)).
    pub fn target_budget(&self) -> u64 {
        self.targets.budget
    }

    /// Checks, before anything is allocated, that views of these sizes
    /// (`(viewport, depth_only)`) fit the target budget together; returns
    /// their total. The error ([`RenderError::TargetBudgetEntry`]) names
    /// the first entry that does not fit by its position.
    pub fn check_target_budget(&self, views: &[(glam::UVec2, bool)]) -> Result<u64, RenderError> {
        let mut taken = 0u64;
        for (index, (viewport, depth_only)) in views.iter().enumerate() {
            self.targets.admit(*viewport, !depth_only, 1, LabelSet::NONE, &mut taken).map_err(|e| {
                RenderError::TargetBudgetEntry {
                    index,
                    width: e.width,
                    height: e.height,
                    bytes: e.bytes,
                    budget: e.budget,
                    taken: e.taken,
                }
            })?;
        }
        Ok(taken)
    }

    /// The format of the views' HDR targets ([`RendererOptions::hdr_format`](crate::RendererOptions::hdr_format),
    /// or `Rgba16Float` where the adapter cannot render the one asked for).
    pub fn hdr_format(&self) -> HdrFormat {
        self.targets.hdr_format
    }

    /// Samples per pixel a view asking for `msaa` gets: what it asks
    /// where the adapter can multisample the HDR and depth formats at that
    /// count, else the largest count below it that it can (1 at least).
    pub fn msaa_samples(&self, msaa: Msaa) -> u32 {
        let asked = msaa.samples();
        // The adapter's own counts only count once the device has enabled
        // them; without the feature, WebGPU guarantees 1 and 4.
        let adapter_specific = self.gpu.features.contains(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES);
        let supports = |samples: u32| {
            [self.targets.hdr_format.texture_format(), ViewTargets::DEPTH_FORMAT].iter().all(|f| {
                if adapter_specific {
                    self.gpu.adapter.get_texture_format_features(*f).flags.sample_count_supported(samples)
                } else {
                    f.guaranteed_format_features(self.gpu.features).flags.sample_count_supported(samples)
                }
            })
        };
        [4, 2, 1].into_iter().find(|s| *s <= asked && (*s == 1 || supports(*s))).unwrap_or(1)
    }
}

/// Layers of the local shadow atlas the frame's views render into (one past
/// the highest tile; 0 when none does).
pub(crate) fn atlas_layers(views: &[FrameView]) -> u32 {
    views
        .iter()
        .filter_map(|v| match v.target {
            TargetPlan::AtlasLayer { tile } => Some(tile + 1),
            _ => None,
        })
        .max()
        .unwrap_or(0)
}

/// The page of a batch camera's targets.
fn tile_page(targets: &ViewTargets) -> usize {
    targets.tile.map_or(0, |t| t.page as usize)
}

#[cfg(test)]
mod tests {
    use oxygen_gpu::Label;

    use super::*;

    #[test]
    fn a_views_targets_are_its_attachments_and_its_label_planes() {
        let targets = Targets::new(HdrFormat::Rgba16Float, 1 << 30);
        let size = glam::UVec2::new(40, 30);
        let labels = LabelSet::of(&[Label::Instance, Label::Semantic]);
        let planes = 40 * 30 * labels.bytes_per_pixel();
        assert!(planes > 0);
        assert_eq!(
            targets.bytes_for(size, true, 4, labels),
            ViewTargets::bytes_for_msaa(40, 30, Some(HdrFormat::Rgba16Float), 4) + planes
        );
        assert_eq!(targets.bytes_for(size, false, 1, LabelSet::NONE), ViewTargets::bytes_for_msaa(40, 30, None, 1));
        assert!(targets.bytes_for(size, false, 1, LabelSet::NONE) < targets.bytes_for(size, true, 1, LabelSet::NONE));
    }

    #[test]
    fn views_are_admitted_up_to_the_budget_exactly_and_a_refusal_takes_nothing() {
        let size = glam::UVec2::new(64, 64);
        let one = Targets::new(HdrFormat::Rgba16Float, 0).bytes_for(size, true, 1, LabelSet::NONE);
        // Room for exactly two.
        let targets = Targets::new(HdrFormat::Rgba16Float, 2 * one);
        let mut taken = 0;
        assert!(targets.admit(size, true, 1, LabelSet::NONE, &mut taken).is_ok());
        assert!(targets.admit(size, true, 1, LabelSet::NONE, &mut taken).is_ok());
        assert_eq!(taken, 2 * one);
        let refused =
            targets.admit(size, true, 1, LabelSet::NONE, &mut taken).err().map(|e| e.for_view(oxygen_demo::view_id(3)));
        let Some(RenderError::TargetBudget { width, height, bytes, budget, taken: before, .. }) = refused else {
            panic!("the third view is refused: {refused:?}");
        };
        assert_eq!((width, height, bytes, budget, before), (64, 64, one, 2 * one, 2 * one));
        assert_eq!(taken, 2 * one, "a refused view takes nothing");
        // Near the top of u64 a sum that would wrap round is refused, even
        // under a budget of everything.
        let mut almost_all = u64::MAX - 1;
        assert!(
            Targets::new(HdrFormat::Rgba16Float, u64::MAX)
                .admit(size, true, 1, LabelSet::NONE, &mut almost_all)
                .is_err()
        );
    }
}
