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
    let mut node = Node::new(Renderer::with_options(context, options.renderer)?, options.renderer.deterministic);

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

/// How many views of `view_bytes` bytes of images each go in one output
/// message: as many as fit in [`MAX_OUTPUT_BYTES`], and at least one (a
/// view larger than that travels alone). A view of no bytes weighs one,
/// so that nothing divides by zero.
fn views_per_message(view_bytes: usize) -> usize {
    (MAX_OUTPUT_BYTES / view_bytes.max(1)).max(1)
}

impl Node {
    /// A node rendering with `renderer` (in its deterministic mode when
    /// `deterministic`): an empty replica, no views yet.
    fn new(renderer: Renderer, deterministic: bool) -> Self {
        Node {
            renderer,
            replica: SceneReplica::new(),
            views: BTreeMap::new(),
            batches: HashMap::new(),
            by_view: HashMap::new(),
            deterministic,
        }
    }

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
            let per_message = views_per_message(planes.bytes(size));
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
    use std::collections::HashSet;

    use oxygen_core::{Camera, Scene};

    use super::*;
    use crate::spec::ViewSpec;

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

    /// A node rendering on this machine's first adapter, no view yet.
    fn node() -> Node {
        let renderer = Renderer::new_headless().unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
        Node::new(renderer, false)
    }

    /// A camera `name` of `size` pixels looking at the origin.
    fn spec(name: &str, size: UVec2) -> (RigViewId, ViewSpec) {
        let id = RigViewId(name.trim_start_matches('v').parse().expect("v and a number"));
        let camera = Camera::perspective(1.0, 0.1, None);
        (id, ViewSpec::look_at(name, camera, glam::DVec3::new(0.0, 1.0, 4.0), glam::DVec3::ZERO, size))
    }

    /// Frame `frame`'s order: the scene as the replica holds it, views
    /// `add` and `remove`d, images of `planes` for every view.
    fn order(frame: u64, add: Vec<(RigViewId, ViewSpec)>, remove: Vec<RigViewId>, planes: Planes) -> Order {
        Order { frame, scene: SceneUpdate::Unchanged, add, remove, planes, only: None }
    }

    /// The messages a node sent for an order, by size: each one's tag and
    /// its payload's length.
    type Messages = BTreeMap<(u32, u32), (OutputTag, usize)>;

    /// `node` obeys `order` (with `payload` for its scene): the views it
    /// says it sent, and each message it sent (its tag, its payload's
    /// length), by size.
    fn obey(node: &mut Node, order: &Order, payload: &[u8]) -> (u32, Messages) {
        let mut messages = BTreeMap::new();
        let (sent, _) = node
            .obey(order, payload, |tag, body| {
                let previous = messages.insert((tag.size.x, tag.size.y), (tag.clone(), body.len()));
                assert!(previous.is_none(), "one message a size here: {tag:?}");
                Ok(())
            })
            .expect("the order");
        (sent, messages)
    }

    /// `node` obeys its first order: `order` with a snapshot of a scene of
    /// one node.
    fn first(node: &mut Node, mut order: Order) -> (u32, Messages) {
        let mut scene = Scene::new();
        scene.add_node("box", oxygen_core::Transform::IDENTITY);
        order.scene = SceneUpdate::Snapshot;
        obey(node, &order, &scene.delta_since(0, &mut HashSet::new()).encode())
    }

    /// A view's images travel in messages of as many whole views as fit in
    /// [`MAX_OUTPUT_BYTES`] (its quotient by a view's bytes: the remainder
    /// or the product would cut a batch into one view a message, or send
    /// it whole however large), a view larger than that alone, and a view
    /// of no bytes weighs one.
    #[test]
    fn an_output_message_holds_as_many_whole_views_as_fit() {
        assert_eq!(views_per_message(4096), 256, "256 views of 32 × 32 colour");
        assert_eq!(views_per_message(300_000), 3);
        assert_eq!(views_per_message(MAX_OUTPUT_BYTES), 1);
        assert_eq!(views_per_message(MAX_OUTPUT_BYTES + 1), 1, "a view over the limit goes alone");
        assert_eq!(views_per_message(0), MAX_OUTPUT_BYTES);
    }

    /// An order of no planes renders and answers with the views' tags
    /// alone, one message a size, and counts every view it answered for.
    #[test]
    fn a_node_asked_for_no_images_answers_with_each_sizes_views_and_counts_them() {
        let mut node = node();
        let small = UVec2::splat(8);
        let add = vec![spec("v0", small), spec("v1", small), spec("v2", UVec2::new(16, 8))];
        let (sent, messages) = first(&mut node, order(1, add, vec![], Planes::NONE));
        assert_eq!(sent, 3, "three views answered for");
        let tags: Vec<(Vec<RigViewId>, Planes, usize)> =
            messages.into_values().map(|(tag, bytes)| (tag.views, tag.planes, bytes)).collect();
        assert_eq!(tags, [(vec![RigViewId(0), RigViewId(1)], Planes::NONE, 0), (vec![RigViewId(2)], Planes::NONE, 0)]);
    }

    /// A batch streams the planes of the order that made it, and only
    /// those (neither colour nor depth unless asked for, though a stream
    /// has both by default); each view's images are sent, and counted.
    #[test]
    fn a_nodes_batch_streams_only_the_planes_ordered_and_the_views_sent_are_counted() {
        let mut node = node();
        let depth = Planes { color: false, depth: true, instances: false };
        let small = UVec2::splat(8);
        let (sent, messages) = first(&mut node, order(1, vec![spec("v0", small), spec("v1", small)], vec![], depth));
        assert_eq!(sent, 2);
        let (tag, bytes) = &messages[&(8, 8)];
        assert_eq!((&tag.views, tag.planes, *bytes), (&vec![RigViewId(0), RigViewId(1)], depth, 2 * 8 * 8 * 4));

        let color = Planes { color: true, depth: false, instances: false };
        let (sent, messages) = obey(&mut node, &order(2, vec![spec("v2", UVec2::new(16, 8))], vec![], color), &[]);
        assert_eq!(sent, 3, "the views of both batches");
        let (tag, bytes) = &messages[&(16, 8)];
        assert_eq!((&tag.views, tag.planes, *bytes), (&vec![RigViewId(2)], color, 16 * 8 * 4));
        assert_eq!(messages[&(8, 8)].0.planes, depth, "the first batch streams what it streamed");
    }

    /// A view removed, or added again elsewhere, no longer renders where it
    /// was, and a batch left without cameras is gone from the renderer too.
    #[test]
    fn a_removed_view_stops_rendering_and_takes_its_empty_batch_with_it() {
        let mut node = node();
        let (small, wide) = (UVec2::splat(8), UVec2::new(16, 8));
        let add = vec![spec("v0", small), spec("v1", small), spec("v2", wide)];
        first(&mut node, order(1, add, vec![], Planes::NONE));
        let wide_batch = node.batches[&(16, 8)];

        let (sent, messages) = obey(&mut node, &order(2, vec![], vec![RigViewId(0), RigViewId(2)], Planes::NONE), &[]);
        assert_eq!(sent, 1);
        assert_eq!(messages.into_values().map(|(tag, _)| tag.views).collect::<Vec<_>>(), [vec![RigViewId(1)]]);
        assert_eq!(node.renderer.views().count(), 1, "one camera left in the renderer");
        assert!(node.renderer.batch_cameras(wide_batch).is_err(), "the empty batch is unregistered");
        assert_eq!(node.batches.keys().collect::<Vec<_>>(), [&(8, 8)]);

        // v1 moves to the wide batch: its old camera and batch go.
        let small_batch = node.batches[&(8, 8)];
        let (sent, messages) = obey(&mut node, &order(3, vec![spec("v1", wide)], vec![], Planes::NONE), &[]);
        assert_eq!(sent, 1);
        assert_eq!(messages.keys().collect::<Vec<_>>(), [&(16, 8)]);
        assert_eq!(node.renderer.views().count(), 1);
        assert!(node.renderer.batch_cameras(small_batch).is_err());
    }
}
