//! `RenderContext` and `CommandRecorder`: what a pass reads and where it records.

use oxygen_bindless::{BindlessHeap, SceneConstantsBuffer};
use oxygen_core::{ColorTargets, GpuContext, ResolvedView, ViewId, ViewTargets};
use oxygen_sceneprep::{Partition, PreparedSceneFrame};
use thiserror::Error;

use crate::PipelineCache;

/// A pass that cannot record.
#[derive(Debug, Error)]
pub enum PassError {
    /// `execute` ran before `prepare_resources`.
    #[error("{pass}: execute called before prepare_resources")]
    NotPrepared {
        /// The pass.
        pass: &'static str,
    },
    /// A partition has a mask this pass cannot draw.
    #[error("{pass}: no pipeline variant for partition mask {mask}")]
    UnsupportedPartition {
        /// The pass.
        pass: &'static str,
        /// The partition's mask names.
        mask: String,
    },
    /// A pass needs what an earlier pass should have produced.
    #[error("{pass}: needs {input}, which no earlier pass of this view produced")]
    MissingInput {
        /// The pass.
        pass: &'static str,
        /// The missing output's type.
        input: &'static str,
    },
    /// A colour pass ran in a depth-only view.
    #[error("{pass}: the view is depth-only and has no colour target")]
    NoColorTarget {
        /// The pass.
        pass: &'static str,
    },
    /// An input the pass cannot use, e.g. local-light shadow maps of
    /// different sizes.
    #[error("{pass}: {what}")]
    BadInput {
        /// The pass.
        pass: &'static str,
        /// What is wrong.
        what: String,
    },
    /// An application-defined failure inside a render graph.
    #[error("render graph: {0}")]
    Graph(String),
}

/// How a partition's draws are submitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DrawPath {
    /// One `draw_indexed` per draw; works on every backend.
    Direct,
    /// One `multi_draw_indexed_indirect` per partition over the indirect
    /// arguments ScenePrep wrote; needs `DownlevelFlags::INDIRECT_EXECUTION`
    /// and `Features::INDIRECT_FIRST_INSTANCE`.
    MultiDrawIndirect,
}

impl DrawPath {
    /// The fastest path the device supports.
    pub fn best_for(features: wgpu::Features, downlevel: &wgpu::DownlevelCapabilities) -> Self {
        if Self::MultiDrawIndirect.is_supported(features, downlevel) {
            DrawPath::MultiDrawIndirect
        } else {
            DrawPath::Direct
        }
    }

    /// Whether the device can use this path.
    pub fn is_supported(self, features: wgpu::Features, downlevel: &wgpu::DownlevelCapabilities) -> bool {
        match self {
            DrawPath::Direct => true,
            DrawPath::MultiDrawIndirect => {
                features.contains(wgpu::Features::INDIRECT_FIRST_INSTANCE)
                    && downlevel.flags.contains(wgpu::DownlevelFlags::INDIRECT_EXECUTION)
            }
        }
    }
}

/// Outputs passes publish for later passes of the same view, looked up by
/// type. Explicit configuration (e.g. `ShaderPassConfig::depth_from_pre_pass`)
/// is the primary way passes find each other's results; this is the
/// secondary path, and the one that lets a pass check its inputs exist.
#[derive(Default)]
pub struct PassOutputs {
    values: std::cell::RefCell<Vec<Box<dyn std::any::Any>>>,
}

impl PassOutputs {
    /// Publishes (or replaces) the value of type `T`.
    pub fn publish<T: std::any::Any>(&self, value: T) {
        let mut values = self.values.borrow_mut();
        values.retain(|v| !v.is::<T>());
        values.push(Box::new(value));
    }

    /// The value of type `T`, if some pass published one.
    pub fn get<T: std::any::Any + Clone>(&self) -> Option<T> {
        self.values.borrow().iter().find_map(|v| v.downcast_ref::<T>().cloned())
    }
}

/// Everything a pass may read for one view in one frame. Immutable: passes
/// communicate through the textures they write, never by changing this.
pub struct RenderContext<'a> {
    /// Device and queue.
    pub gpu: &'a GpuContext,
    /// The resolved view, relative to [`RenderContext::origin`]
    /// ([`ResolvedView::relative_to`]).
    pub view: &'a ResolvedView,
    /// ScenePrep's result for this view.
    pub prepared: &'a PreparedSceneFrame,
    /// This view's uniform block (bind group 1).
    pub scene_constants: &'a SceneConstantsBuffer,
    /// The bindless heap (bind group 0, shared index buffer).
    pub heap: &'a BindlessHeap,
    /// Colour and depth targets of the view.
    pub targets: &'a ViewTargets,
    /// Shared pipeline cache.
    pub pipelines: &'a PipelineCache,
    /// How partitions are drawn.
    pub draw_path: DrawPath,
    /// What earlier passes of this view published.
    pub outputs: PassOutputs,
    /// Every view of this frame with its targets; views are submitted in
    /// order, so a view may sample what an earlier one rendered.
    pub frame_views: &'a FrameViews<'a>,
    /// The render origin: every matrix and position the GPU sees this frame
    /// (`view`, `frame_views`, world matrices, lights) is relative to it. A
    /// pass that uploads a world position of its own subtracts it.
    pub origin: glam::DVec3,
}

impl RenderContext<'_> {
    /// The view's colour targets, or [`PassError::NoColorTarget`] naming
    /// `pass` when the view is depth-only.
    pub fn color_targets(&self, pass: &'static str) -> Result<&ColorTargets, PassError> {
        self.targets.color.as_ref().ok_or(PassError::NoColorTarget { pass })
    }
}

/// The views of one frame, in submission order, with their targets.
#[derive(Default)]
pub struct FrameViews<'a> {
    /// (id, resolved view, targets) per view.
    pub entries: Vec<(ViewId, &'a ResolvedView, &'a ViewTargets)>,
}

impl<'a> FrameViews<'a> {
    /// The resolved view and targets of `id`, if it is part of this frame.
    pub fn get(&self, id: ViewId) -> Option<(&'a ResolvedView, &'a ViewTargets)> {
        self.entries.iter().find(|(v, _, _)| *v == id).map(|(_, view, targets)| (*view, *targets))
    }
}

/// Counts of what a view's passes recorded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RecordStats {
    /// wgpu render passes begun.
    pub render_passes: u32,
    /// Pipelines set (one per partition drawn).
    pub pipeline_binds: u32,
    /// Draw calls.
    pub draw_calls: u32,
}

/// The command encoder of one view plus counters.
pub struct CommandRecorder {
    encoder: wgpu::CommandEncoder,
    /// What was recorded so far.
    pub stats: RecordStats,
}

impl CommandRecorder {
    /// A recorder with a fresh encoder.
    pub fn new(device: &wgpu::Device, label: &str) -> Self {
        CommandRecorder {
            encoder: device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) }),
            stats: RecordStats::default(),
        }
    }

    /// The encoder.
    pub fn encoder(&mut self) -> &mut wgpu::CommandEncoder {
        &mut self.encoder
    }

    /// Finishes recording.
    pub fn finish(self) -> (wgpu::CommandBuffer, RecordStats) {
        (self.encoder.finish(), self.stats)
    }
}

/// Sets the bindless and scene-constant bind groups and the shared index buffer.
fn bind_view_resources(pass: &mut wgpu::RenderPass<'_>, ctx: &RenderContext<'_>, shadows: &wgpu::BindGroup) {
    pass.set_bind_group(0, ctx.heap.bind_group(), &[]);
    pass.set_bind_group(1, ctx.scene_constants.bind_group(), &[]);
    pass.set_bind_group(2, ctx.heap.texture_bind_group(), &[]);
    pass.set_bind_group(3, shadows, &[]);
    pass.set_index_buffer(ctx.heap.index_buffer().slice(..), wgpu::IndexFormat::Uint32);
}

/// Draws every draw of `partition`. Either way the draw's position in the
/// view's array reaches the shader as `first_instance`, which is how the
/// vertex shader finds its `DrawMetadata`.
fn draw_partition(
    pass: &mut wgpu::RenderPass<'_>,
    ctx: &RenderContext<'_>,
    partition: &Partition,
    stats: &mut RecordStats,
) {
    if ctx.draw_path == DrawPath::MultiDrawIndirect {
        let stride = std::mem::size_of::<oxygen_sceneprep::DrawIndexedIndirect>() as u64;
        let first = ctx.prepared.slots().indirect_args.start as u64 + partition.begin as u64;
        let buffer = ctx.heap.buffer(oxygen_bindless::DomainKind::IndirectArgs);
        pass.multi_draw_indexed_indirect(buffer, first * stride, partition.len());
        stats.draw_calls += 1;
        return;
    }
    let draws = &ctx.prepared.draws()[partition.range()];
    for (offset, draw) in draws.iter().enumerate() {
        let draw_index = partition.begin + offset as u32;
        pass.draw_indexed(
            draw.index_range(),
            draw.absolute_base_vertex(),
            draw_index..draw_index + draw.instance_count,
        );
        stats.draw_calls += 1;
    }
}

/// The pipeline of every partition in `partitions` for `pass`, from the
/// shared cache (created the first time a partition needs its variant).
pub(crate) fn partition_pipelines<'a>(
    ctx: &RenderContext<'_>,
    pass: crate::PassKind,
    color_format: Option<wgpu::TextureFormat>,
    depth_bias: crate::DepthBias,
    partitions: impl Iterator<Item = &'a Partition>,
) -> Vec<wgpu::RenderPipeline> {
    partitions
        .map(|p| {
            ctx.pipelines.get(
                &ctx.gpu.device,
                crate::PipelineKey {
                    pass,
                    variant: crate::PipelineVariant::from_mask(p.mask),
                    color_format,
                    depth_format: oxygen_core::ViewTargets::DEPTH_FORMAT,
                    depth_bias,
                },
            )
        })
        .collect()
}

/// Binds the view's bindless resources and `shadows` (group 3; the cache's
/// empty group for passes that sample none), then draws each partition with
/// its pipeline (one pipeline bind per partition).
pub(crate) fn draw_partitions<'a>(
    pass: &mut wgpu::RenderPass<'_>,
    ctx: &RenderContext<'_>,
    partitions: impl Iterator<Item = &'a Partition>,
    pipelines: &[wgpu::RenderPipeline],
    shadows: &wgpu::BindGroup,
    stats: &mut RecordStats,
) {
    bind_view_resources(pass, ctx, shadows);
    for (partition, pipeline) in partitions.zip(pipelines) {
        pass.set_pipeline(pipeline);
        stats.pipeline_binds += 1;
        draw_partition(pass, ctx, partition, stats);
    }
}
