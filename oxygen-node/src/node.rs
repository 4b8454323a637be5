//! A render node: a replica of the rig's scene, its share of the views as
//! batches (one per image size), and a loop that renders each order and
//! publishes the images.

use std::collections::{BTreeMap, HashMap};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use glam::UVec2;
use oxygen::batch::{BatchDesc, BatchId, StreamOptions};
use oxygen::gpu::{GpuContext, GpuOptions, Label, LabelSet};
use oxygen::{Renderer, RendererOptions};
use oxygen_core::ViewId;
use oxygen_core::scene::delta::{SceneDelta, SceneReplica};
use tracing::{info, info_span, warn};
use zenoh::Wait;
use zenoh::qos::CongestionControl;
use zenoh::sample::{Sample, SampleKind};

use crate::error::{NodeError, check_name};
use crate::net::NetConfig;
use crate::spec::{Planes, RigViewId};
use crate::wire::{self, Keys, MAX_OUTPUT_BYTES, Order, Outcome, OutputTag, SceneUpdate, Status};

/// GPUs a node may name ([`NodeOptions::gpu`] below this).
pub const MAX_GPU: usize = 64;

/// How a render node runs.
#[derive(Clone, Debug)]
pub struct NodeOptions {
    /// The rig to join.
    pub rig: String,
    /// This node's name, unique in the rig (A-Z, a-z, 0-9, `-`, `_`).
    pub name: String,
    /// Where the coordinator is.
    pub net: NetConfig,
    /// The renderer's options (the deterministic mode, for one).
    pub renderer: RendererOptions,
    /// Which of the machine's GPUs (of the kind the first one is) renders:
    /// 0 for the first; past the last it wraps, a second device of a GPU.
    /// Below [`MAX_GPU`].
    pub gpu: usize,
    /// How long to wait for the coordinator to appear before giving up.
    pub coordinator_wait: Duration,
}

impl NodeOptions {
    /// A node `name` of rig `rig` connecting to `endpoint`, default
    /// renderer, the first GPU, a minute's wait for the coordinator.
    pub fn new(rig: impl Into<String>, name: impl Into<String>, endpoint: impl Into<String>) -> Self {
        NodeOptions {
            rig: rig.into(),
            name: name.into(),
            net: NetConfig::connect(endpoint),
            renderer: RendererOptions::default(),
            gpu: 0,
            coordinator_wait: Duration::from_secs(60),
        }
    }

    /// What the node asks of the machine's GPUs: the device options its
    /// renderer would ask for itself (the features it uses where present,
    /// its trust in its own indirect arguments), and how many devices to
    /// open, one on each GPU up to [`NodeOptions::gpu`] (the last renders).
    fn devices(&self) -> (GpuOptions, usize) {
        let gpu_options = GpuOptions {
            optional_features: Renderer::OPTIONAL_FEATURES,
            trust_indirect_args: self.renderer.trust_indirect_args,
            ..Default::default()
        };
        (gpu_options, self.gpu + 1)
    }
}

/// What a node did before its coordinator left.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodeSummary {
    /// Orders rendered.
    pub frames: u64,
    /// View-frames whose images were sent.
    pub view_frames: u64,
    /// Bytes of images sent.
    pub bytes_sent: u64,
    /// Bytes of scene deltas and snapshots received.
    pub scene_bytes: u64,
    /// The adapter that rendered.
    pub adapter: String,
}

enum Event {
    Order(Sample),
    Coordinator(bool),
}

/// One view the node renders.
struct NodeView {
    id: ViewId,
    size: UVec2,
}

/// The node's renderer, replica and views.
struct Node {
    renderer: Renderer,
    replica: SceneReplica,
    views: BTreeMap<RigViewId, NodeView>,
    batches: HashMap<(u32, u32), BatchId>,
    by_view: HashMap<ViewId, RigViewId>,
    /// The renderer's deterministic mode is on.
    deterministic: bool,
}

/// Runs a render node until its coordinator leaves (or never comes):
/// joins rig `options.rig`, renders every order it gets and publishes each
/// view's images with their tags. Blocks; returns what it did.
pub fn run_node(options: &NodeOptions) -> Result<NodeSummary, NodeError> {
    check_name("rig", &options.rig)?;
    check_name("node", &options.name)?;
    if options.gpu >= MAX_GPU {
        let message =
            format!("GPU {} of a node: 0 to {} (it opens a device on each GPU up to it)", options.gpu, MAX_GPU - 1);
        return Err(NodeError::Render(oxygen::RenderError::Unsupported(message)));
    }
    let _span = info_span!("render_node", rig = %options.rig, node = %options.name).entered();
    let keys = Keys::new(&options.rig);

    // The device first: a node is announced only once it can render.
    let (gpu_options, devices) = options.devices();
    let context = GpuContext::new_headless_group(&gpu_options, devices, true)
        .map_err(|e| NodeError::Render(e.into()))?
        .pop()
        .ok_or_else(|| NodeError::Render(oxygen::RenderError::Unsupported("no GPU context".into())))?;
    let adapter = context.describe();
    info!(%adapter, "render node's adapter");
    let mut node = Node {
        renderer: Renderer::with_options(context, options.renderer)?,
        replica: SceneReplica::new(),
        views: BTreeMap::new(),
        batches: HashMap::new(),
        by_view: HashMap::new(),
        deterministic: options.renderer.deterministic,
    };

    let session = options.net.open()?;
    let (tx, rx) = mpsc::channel();
    let orders_tx = tx.clone();
    let _orders = session
        .declare_subscriber(keys.order(&options.name))
        .callback(move |sample| {
            let _ = orders_tx.send(Event::Order(sample));
        })
        .wait()
        .map_err(NodeError::zenoh)?;
    let _coordinator = session
        .liveliness()
        .declare_subscriber(keys.coordinator())
        .history(true)
        .callback(move |sample| {
            let _ = tx.send(Event::Coordinator(sample.kind() == SampleKind::Put));
        })
        .wait()
        .map_err(NodeError::zenoh)?;
    let outputs = session
        .declare_publisher(keys.output(&options.name))
        .congestion_control(CongestionControl::Block)
        .wait()
        .map_err(NodeError::zenoh)?;
    let statuses = session
        .declare_publisher(keys.status(&options.name))
        .congestion_control(CongestionControl::Block)
        .wait()
        .map_err(NodeError::zenoh)?;
    // Announced last: the coordinator's first order finds the subscriber.
    let _token = session.liveliness().declare_token(keys.node(&options.name)).wait().map_err(NodeError::zenoh)?;
    info!("render node up, waiting for the coordinator");

    let mut summary = NodeSummary { adapter, ..Default::default() };
    let started = Instant::now();
    let mut seen_coordinator = false;
    loop {
        let event = if seen_coordinator {
            rx.recv().ok()
        } else {
            let left = options.coordinator_wait.saturating_sub(started.elapsed());
            match rx.recv_timeout(left) {
                Ok(event) => Some(event),
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    return Err(NodeError::NoCoordinator {
                        rig: options.rig.clone(),
                        seconds: options.coordinator_wait.as_secs_f64(),
                    });
                }
                Err(mpsc::RecvTimeoutError::Disconnected) => None,
            }
        };
        match event {
            None | Some(Event::Coordinator(false)) => {
                info!(frames = summary.frames, "the coordinator left: stopping");
                break;
            }
            Some(Event::Coordinator(true)) => seen_coordinator = true,
            Some(Event::Order(sample)) => {
                seen_coordinator = true;
                let key = sample.key_expr().as_str().to_owned();
                let header = match sample.attachment().map(|a| wire::decode::<Order>(&key, &a.to_bytes())) {
                    Some(Ok(header)) => header,
                    Some(Err(e)) => {
                        warn!(%e, "order refused");
                        continue;
                    }
                    None => {
                        warn!(%key, "an order without its header: refused");
                        continue;
                    }
                };
                let frame = header.frame;
                let payload = sample.payload().to_bytes();
                summary.scene_bytes += payload.len() as u64;
                let order_started = Instant::now();
                let outcome = match node.obey(&header, &payload, |tag, body| {
                    summary.bytes_sent += body.len() as u64;
                    summary.view_frames += tag.views.len() as u64;
                    outputs.put(body).attachment(wire::encode(tag)).wait().map_err(NodeError::zenoh)
                }) {
                    Ok((views, render_seconds)) => {
                        summary.frames += 1;
                        Outcome::Rendered { views, seconds: order_started.elapsed().as_secs_f64(), render_seconds }
                    }
                    Err(e) => {
                        warn!(frame, %e, "order failed");
                        let needs_snapshot = node.replica.revision().is_none();
                        Outcome::Failed { reason: e.to_string(), needs_snapshot }
                    }
                };
                statuses.put(wire::encode(&Status { frame, outcome })).wait().map_err(NodeError::zenoh)?;
            }
        }
    }
    Ok(summary)
}

impl Node {
    /// Applies an order (scene, views), renders, and hands the views'
    /// images to `send`, a batch's views together (in messages of at most
    /// [`MAX_OUTPUT_BYTES`]); returns the views sent and the render time.
    fn obey(
        &mut self,
        order: &Order,
        payload: &[u8],
        mut send: impl FnMut(&OutputTag, Vec<u8>) -> Result<(), NodeError>,
    ) -> Result<(u32, f64), NodeError> {
        let _span =
            info_span!("node_order", frame = order.frame, add = order.add.len(), remove = order.remove.len()).entered();
        match order.scene {
            SceneUpdate::Unchanged => {
                if self.replica.revision().is_none() {
                    return Err(NodeError::Delta(oxygen_core::scene::delta::DeltaError::OutOfStep {
                        base: 0,
                        held: None,
                    }));
                }
            }
            SceneUpdate::Delta | SceneUpdate::Snapshot => {
                let delta = SceneDelta::decode(payload)?;
                self.replica.apply(&delta)?;
            }
        }
        for view in &order.remove {
            self.remove_view(*view)?;
        }
        for (view, spec) in &order.add {
            self.remove_view(*view)?;
            let desc = spec.desc()?;
            let batch = self.batch(spec.size, order.planes)?;
            let id = self.renderer.add_camera(batch, desc)?;
            self.views.insert(*view, NodeView { id, size: spec.size });
            self.by_view.insert(id, *view);
        }
        if self.views.is_empty() {
            return Ok((0, 0.0));
        }
        let wanted = |view: &RigViewId| order.only.as_ref().is_none_or(|only| only.contains(view));
        let rendering = Instant::now();
        self.renderer.render_frame(self.replica.scene())?;
        let mut sent = 0;
        if !order.planes.any() {
            // No images: once the GPU is done, the views' tags are the output.
            self.renderer.gpu().device.poll(oxygen::wgpu::PollType::wait_indefinitely()).map_err(|e| {
                NodeError::Render(oxygen::RenderError::Unsupported(format!("waiting for the GPU: {e}")))
            })?;
            let render_seconds = rendering.elapsed().as_secs_f64();
            let mut by_size: BTreeMap<(u32, u32), Vec<RigViewId>> = BTreeMap::new();
            for (view, placed) in self.views.iter().filter(|(view, _)| wanted(view)) {
                by_size.entry((placed.size.x, placed.size.y)).or_default().push(*view);
            }
            for ((w, h), views) in by_size {
                sent += views.len() as u32;
                let tag = OutputTag { frame: order.frame, views, size: UVec2::new(w, h), planes: Planes::NONE };
                send(&tag, Vec::new())?;
            }
            return Ok((sent, render_seconds));
        }
        let streamed = self.renderer.wait_streamed()?;
        let render_seconds = rendering.elapsed().as_secs_f64();
        for frame in streamed {
            let size = UVec2::new(frame.size.0, frame.size.1);
            let cameras: Vec<(RigViewId, oxygen::batch::StreamedCamera<'_>)> = frame
                .cameras()
                .filter_map(|camera| Some((*self.by_view.get(&camera.view)?, camera)))
                .filter(|(view, _)| wanted(view))
                .collect();
            let Some((_, first)) = cameras.first() else { continue };
            let planes = Planes {
                color: first.color.is_some(),
                depth: first.depth.is_some(),
                instances: first.instances.is_some(),
            };
            let per_message = (MAX_OUTPUT_BYTES / planes.bytes(size).max(1)).max(1);
            for chunk in cameras.chunks(per_message) {
                let mut payload = Vec::with_capacity(chunk.len() * planes.bytes(size));
                for (_, camera) in chunk {
                    wire::append_planes(&mut payload, camera.color, camera.depth, camera.instances);
                }
                let tag =
                    OutputTag { frame: order.frame, views: chunk.iter().map(|(v, _)| *v).collect(), size, planes };
                send(&tag, payload)?;
                sent += chunk.len() as u32;
            }
            drop(cameras);
            self.renderer.recycle_streamed(frame);
        }
        Ok((sent, render_seconds))
    }

    /// The batch of views of `size` (made, streaming `planes`, on first use).
    fn batch(&mut self, size: UVec2, planes: Planes) -> Result<BatchId, NodeError> {
        if let Some(batch) = self.batches.get(&(size.x, size.y)) {
            return Ok(*batch);
        }
        let mut desc = BatchDesc::new(format!("rig {}x{}", size.x, size.y), size);
        if self.deterministic {
            // A page of its own for each camera: a tile's place in a shared
            // page enters the rasteriser's window coordinates and moves
            // depth's last bits, and which cameras share a node's pages
            // changes as views move. Alone at the page's corner, a camera
            // renders the same bits on any node.
            desc = desc.with_max_page_side(size.x.max(size.y));
        }
        if planes.instances {
            desc = desc.with_label_planes(LabelSet::of(&[Label::Instance]));
        }
        let batch = self.renderer.register_batch(desc)?;
        if !planes.any() {
            self.batches.insert((size.x, size.y), batch);
            return Ok(batch);
        }
        let stream = StreamOptions {
            color: planes.color,
            depth: planes.depth,
            instances: planes.instances,
            ..Default::default()
        };
        self.renderer.stream_batch(batch, Some(stream))?;
        self.batches.insert((size.x, size.y), batch);
        Ok(batch)
    }

    /// Stops rendering `view` (nothing when it is not here); a batch left
    /// without cameras goes too.
    fn remove_view(&mut self, view: RigViewId) -> Result<(), NodeError> {
        let Some(removed) = self.views.remove(&view) else { return Ok(()) };
        self.by_view.remove(&removed.id);
        self.renderer.unregister_view(removed.id)?;
        let key = (removed.size.x, removed.size.y);
        if !self.views.values().any(|v| (v.size.x, v.size.y) == key)
            && let Some(batch) = self.batches.remove(&key)
        {
            self.renderer.unregister_batch(batch)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A node's device is asked for what a renderer of the node's options
    /// asks for on its own (without the optional features a renderer
    /// falls back to slower paths; without the trust, wgpu checks every
    /// indirect draw), and for GPU `n` it opens n + 1 devices, the last
    /// on GPU `n`.
    #[test]
    fn a_node_asks_the_gpu_for_its_renderers_features_and_a_device_up_to_its_gpu() {
        for trust in [false, true] {
            let mut options = NodeOptions::new("r", "n", "tcp/127.0.0.1:7447");
            options.renderer.trust_indirect_args = trust;
            options.gpu = 2;
            let (gpu, devices) = options.devices();
            assert_eq!(gpu.optional_features, Renderer::OPTIONAL_FEATURES);
            assert_eq!(gpu.required_features, oxygen::wgpu::Features::empty());
            assert_eq!(gpu.trust_indirect_args, trust);
            assert_eq!(devices, 3, "GPUs 0, 1 and 2");
        }
        assert_eq!(NodeOptions::new("r", "n", "tcp/127.0.0.1:7447").devices().1, 1, "GPU 0: one device");
    }
}
