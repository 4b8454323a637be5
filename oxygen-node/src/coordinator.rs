//! The coordinator: the application's side of a rig. It holds the views,
//! places them on the nodes that have joined, sends each frame's scene
//! delta and gathers every view's images of the frame (see the crate docs).

use std::collections::{BTreeMap, BTreeSet, HashSet};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use glam::UVec2;
use oxygen::group::{GroupViewId, best_move};
use oxygen_core::Scene;
use oxygen_core::scene::delta::DeltaStream;
use tracing::{info, info_span, warn};
use zenoh::Wait;
use zenoh::qos::CongestionControl;
use zenoh::sample::{Sample, SampleKind};

use crate::error::{NodeError, check_name};
use crate::net::NetConfig;
use crate::spec::{Planes, RigViewId, ViewSpec};
use crate::wire::{self, ImagePlanes, Keys, Order, Outcome, OutputTag, SceneUpdate, Status};

/// How a coordinator runs a rig.
#[derive(Clone, Debug)]
pub struct RigOptions {
    /// The images each view sends back.
    pub planes: Planes,
    /// How long a node may take over its share of a frame before it is
    /// treated as fallen behind (its views rendered elsewhere).
    pub stall_timeout: Duration,
    /// How far (a fraction) the most loaded node may carry more than the
    /// least loaded before a view moves; `f64::INFINITY` never moves one
    /// (joins and leaves still do).
    pub rebalance_margin: f64,
}

impl Default for RigOptions {
    /// Colour only, 30 s to answer, a 25 % margin.
    fn default() -> Self {
        RigOptions { planes: Planes::default(), stall_timeout: Duration::from_secs(30), rebalance_margin: 0.25 }
    }
}

/// One view's images of one frame, with their tags.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewOutput {
    /// The view.
    pub view: RigViewId,
    /// The rig's frame.
    pub frame: u64,
    /// The node that rendered it.
    pub node: String,
    /// Width and height.
    pub size: UVec2,
    /// The images.
    pub planes: ImagePlanes,
    /// Seconds from the frame starting (the scene as changed) to these images arriving.
    pub latency_seconds: f64,
}

/// What a rig's frame did.
#[derive(Clone, Debug, Default)]
pub struct RigFrame {
    /// The frame (from 1).
    pub frame: u64,
    /// Every view's images, one per view, in view order.
    pub outputs: Vec<ViewOutput>,
    /// Bytes of the frame's scene delta as encoded (0 when the scene did
    /// not change); it goes to every node in step.
    pub delta_bytes: usize,
    /// Bytes of scene on the wire this frame: the delta once per node in
    /// step, plus each snapshot sent.
    pub scene_wire_bytes: usize,
    /// Bytes of images received (duplicates included).
    pub image_bytes: usize,
    /// Seconds from the frame starting (the scene as changed) to the last view's images in: the end-to-end latency.
    pub latency_seconds: f64,
    /// Seconds making and encoding the delta (and snapshots).
    pub replicate_seconds: f64,
    /// Nodes that joined before this frame.
    pub joined: Vec<String>,
    /// Nodes that left (or were found gone) before or during this frame.
    pub left: Vec<String>,
    /// Nodes that did not answer in time during this frame.
    pub stalled: Vec<String>,
    /// Views rendered again on another node during this frame (their
    /// node left, failed or stalled).
    pub taken_over: Vec<RigViewId>,
    /// Views moved after this frame (from the next one): (view, from, to).
    pub moved: Vec<(RigViewId, String, String)>,
    /// Images received twice (a view rendered again whose first images
    /// came after all) and ignored.
    pub duplicates: usize,
    /// What each node reported of the frame, by name.
    pub nodes: BTreeMap<String, NodeReport>,
}

/// One node's account of a frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodeReport {
    /// Views whose images it sent (a frame rendered again counts again).
    pub views: u32,
    /// Seconds from its order's arrival to its last image sent.
    pub seconds: f64,
    /// Of which rendering (the renderer's frame and its GPU work, the
    /// images streamed back).
    pub render_seconds: f64,
}

enum Event {
    Output(Sample),
    Status(Sample),
    Node(String, bool),
}

/// A node as the coordinator knows it.
#[derive(Debug, Default)]
struct NodeState {
    /// Its replica holds the stream's revision (false: it gets a snapshot).
    in_step: bool,
    /// Views it will add and remove with its next order.
    add: BTreeSet<RigViewId>,
    remove: BTreeSet<RigViewId>,
    /// Not answering since this frame: gets no views, and no frame waits
    /// for it, until it reports a later frame done.
    stalled: Option<u64>,
}

impl NodeState {
    /// The node stops rendering `view`: not added after all, or removed
    /// with its next order.
    fn drop_view(&mut self, view: RigViewId) {
        if !self.add.remove(&view) {
            self.remove.insert(view);
        }
    }
}

struct RigView {
    spec: ViewSpec,
    node: Option<String>,
    /// Smoothed seconds a frame (its node's time ÷ its views).
    cost: Option<f64>,
}

/// The application's side of a rig (see the crate docs).
pub struct Coordinator {
    rig: String,
    keys: Keys,
    options: RigOptions,
    session: zenoh::Session,
    events: mpsc::Receiver<Event>,
    // Kept alive: dropping them undeclares them.
    _subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
    _token: zenoh::liveliness::LivelinessToken,
    nodes: BTreeMap<String, NodeState>,
    views: BTreeMap<RigViewId, RigView>,
    next_view: u32,
    stream: DeltaStream,
    frame: u64,
    /// Membership changes seen between frames, reported with the next.
    joined: Vec<String>,
    left: Vec<String>,
}

/// A node's orders of the frame not reported yet, and since when it has
/// owed one.
struct Awaited {
    since: Instant,
    orders: usize,
}

impl Awaited {
    /// Whether, at `now`, it has owed a report for longer than `timeout`
    /// (the node is then treated as fallen behind). At exactly `timeout` it
    /// is not yet late: the gather loop wakes at that deadline (see
    /// [`Awaited::wait`]) and looks again.
    fn overdue(&self, now: Instant, timeout: Duration) -> bool {
        now.duration_since(self.since) > timeout
    }

    /// How long the gather loop may block on its next event at `now`: until
    /// the earliest deadline of the nodes `waiting` (`timeout` after each
    /// one's `since`; zero once passed), or 100 ms when no node is awaited.
    /// Blocking until the deadline, not polling, keeps the coordinator off
    /// the CPU while the nodes render. A timeout past what the clock can
    /// hold (`Duration::MAX`: never give up on a node) has no deadline: the
    /// loop then looks again every second.
    fn wait(waiting: &BTreeMap<String, Awaited>, now: Instant, timeout: Duration) -> Duration {
        match waiting.values().map(|a| a.since).min() {
            None => Duration::from_millis(100),
            Some(since) => since
                .checked_add(timeout)
                .map_or(Duration::from_secs(1), |deadline| deadline.saturating_duration_since(now)),
        }
    }

    /// `node` reported one of its orders.
    fn reported(waiting: &mut BTreeMap<String, Awaited>, node: &str) {
        if let Some(awaited) = waiting.get_mut(node) {
            awaited.orders = awaited.orders.saturating_sub(1);
            if awaited.orders == 0 {
                waiting.remove(node);
            }
        }
    }
}

/// Weight of a new measurement in a view's smoothed cost.
const COST_SMOOTHING: f64 = 0.3;

impl Coordinator {
    /// A coordinator of rig `rig` on `net` (typically listening where the
    /// nodes connect).
    pub fn new(rig: &str, net: &NetConfig, options: RigOptions) -> Result<Self, NodeError> {
        check_name("rig", rig)?;
        let _span = info_span!("coordinator", rig).entered();
        let keys = Keys::new(rig);
        let session = net.open()?;
        let (tx, events) = mpsc::channel();
        let mut subscribers = Vec::new();
        for (key, status) in [(keys.output("*"), false), (keys.status("*"), true)] {
            let tx = tx.clone();
            let subscriber = session
                .declare_subscriber(key)
                .callback(move |sample| {
                    let _ = tx.send(if status { Event::Status(sample) } else { Event::Output(sample) });
                })
                .wait()
                .map_err(NodeError::zenoh)?;
            subscribers.push(subscriber);
        }
        let liveliness = session
            .liveliness()
            .declare_subscriber(keys.node("*"))
            .history(true)
            .callback(move |sample| {
                let name = Keys::last_chunk(sample.key_expr().as_str()).to_owned();
                let _ = tx.send(Event::Node(name, sample.kind() == SampleKind::Put));
            })
            .wait()
            .map_err(NodeError::zenoh)?;
        subscribers.push(liveliness);
        let token = session.liveliness().declare_token(keys.coordinator()).wait().map_err(NodeError::zenoh)?;
        info!(rig, "coordinator up");
        Ok(Coordinator {
            rig: rig.to_owned(),
            keys,
            options: RigOptions {
                rebalance_margin: if options.rebalance_margin.is_nan() {
                    0.25
                } else {
                    options.rebalance_margin.max(0.0)
                },
                ..options
            },
            session,
            events,
            _subscribers: subscribers,
            _token: token,
            nodes: BTreeMap::new(),
            views: BTreeMap::new(),
            next_view: 0,
            stream: DeltaStream::new(),
            frame: 0,
            joined: Vec::new(),
            left: Vec::new(),
        })
    }

    /// The rig's name.
    pub fn rig(&self) -> &str {
        &self.rig
    }

    /// Adds a view (checked now); it renders from the next frame on the
    /// least loaded node.
    pub fn add_view(&mut self, spec: ViewSpec) -> Result<RigViewId, NodeError> {
        spec.check()?;
        let id = RigViewId(self.next_view);
        self.next_view += 1;
        self.views.insert(id, RigView { spec, node: None, cost: None });
        Ok(id)
    }

    /// Removes a view (from its node with the next frame).
    pub fn remove_view(&mut self, view: RigViewId) -> Result<(), NodeError> {
        let removed = self.views.remove(&view).ok_or(NodeError::NoSuchView(view))?;
        if let Some(node) = removed.node.and_then(|n| self.nodes.get_mut(&n)) {
            node.drop_view(view);
        }
        Ok(())
    }

    /// Changes [`RigOptions::stall_timeout`] from now on.
    pub fn set_stall_timeout(&mut self, timeout: Duration) {
        self.options.stall_timeout = timeout;
    }

    /// The node rendering `view` (`None` before its first frame).
    pub fn node_of(&self, view: RigViewId) -> Option<&str> {
        self.views.get(&view)?.node.as_deref()
    }

    /// The nodes that have joined and not left, by name.
    pub fn nodes(&self) -> Vec<String> {
        self.nodes.keys().cloned().collect()
    }

    /// `view`'s measured cost, seconds a frame (`None` before measured).
    pub fn view_cost(&self, view: RigViewId) -> Option<f64> {
        self.views.get(&view)?.cost
    }

    /// Waits until at least `count` nodes have joined, or `timeout`.
    pub fn wait_for_nodes(&mut self, count: usize, timeout: Duration) -> Result<(), NodeError> {
        let started = Instant::now();
        loop {
            self.drain_membership(None);
            if self.nodes.len() >= count {
                return Ok(());
            }
            let left = timeout.saturating_sub(started.elapsed());
            if left.is_zero() {
                return Err(NodeError::JoinTimeout {
                    wanted: count,
                    joined: self.nodes.len(),
                    seconds: timeout.as_secs_f64(),
                });
            }
            match self.events.recv_timeout(left.min(Duration::from_millis(50))) {
                Ok(event) => self.handle_between_frames(event),
                Err(mpsc::RecvTimeoutError::Timeout) => {}
                Err(mpsc::RecvTimeoutError::Disconnected) => return Err(NodeError::Zenoh("session closed".into())),
            }
        }
    }

    /// Membership events queued (and anything else, dropped: between
    /// frames no output is awaited).
    fn drain_membership(&mut self, mut during: Option<&mut Vec<Event>>) {
        while let Ok(event) = self.events.try_recv() {
            match (event, during.as_deref_mut()) {
                (Event::Node(name, up), _) => self.membership(name, up),
                (other, Some(kept)) => kept.push(other),
                (_, None) => {}
            }
        }
    }

    fn handle_between_frames(&mut self, event: Event) {
        if let Event::Node(name, up) = event {
            self.membership(name, up);
        }
    }

    /// A node came or went.
    fn membership(&mut self, name: String, up: bool) {
        if up {
            if check_name("node", &name).is_err() || self.nodes.contains_key(&name) {
                return;
            }
            info!(node = %name, "node joined");
            self.nodes.insert(name.clone(), NodeState::default());
            self.joined.push(name);
        } else if self.nodes.remove(&name).is_some() {
            info!(node = %name, "node left");
            for view in self.views.values_mut() {
                if view.node.as_deref() == Some(&name) {
                    view.node = None;
                }
            }
            self.left.push(name);
        }
    }

    /// The mean measured cost of the views, 1 when none is measured: what
    /// an unmeasured view counts as, in placement and in moves alike (one
    /// rule, so that a move weighs a view as the loads it evens do).
    fn mean_cost(&self) -> f64 {
        let measured: Vec<f64> = self.views.values().filter_map(|v| v.cost).collect();
        if measured.is_empty() { 1.0 } else { measured.iter().sum::<f64>() / measured.len() as f64 }
    }

    /// Each usable node's load (its views' costs; an unmeasured view at
    /// the mean of the measured, 1 when none is).
    fn loads(&self) -> (Vec<String>, Vec<f64>) {
        let usable: Vec<String> =
            self.nodes.iter().filter(|(_, n)| n.stalled.is_none()).map(|(k, _)| k.clone()).collect();
        let mean = self.mean_cost();
        let mut loads = vec![0.0; usable.len()];
        for view in self.views.values() {
            if let Some(i) = view.node.as_ref().and_then(|n| usable.iter().position(|u| u == n)) {
                loads[i] += view.cost.unwrap_or(mean);
            }
        }
        (usable, loads)
    }

    /// Puts `view` on `node` (its old node, if any, removes it with its
    /// next order).
    fn assign(&mut self, view: RigViewId, node: &str) {
        let Some(placed) = self.views.get_mut(&view) else { return };
        if let Some(old) = placed.node.take().and_then(|o| self.nodes.get_mut(&o)) {
            old.drop_view(view);
        }
        placed.node = Some(node.to_owned());
        if let Some(state) = self.nodes.get_mut(node) {
            state.remove.remove(&view);
            state.add.insert(view);
        }
    }

    /// Views without a node go to the least loaded usable ones; after a
    /// join, views move until no move evens the loads further.
    fn place(&mut self, rebalance_fully: bool) -> Result<(), NodeError> {
        let homeless: Vec<RigViewId> = self.views.iter().filter(|(_, v)| v.node.is_none()).map(|(id, _)| *id).collect();
        for view in &homeless {
            let (usable, loads) = self.loads();
            let lightest = (0..usable.len()).min_by(|a, b| loads[*a].total_cmp(&loads[*b]));
            let Some(lightest) = lightest else {
                return Err(NodeError::NoNodes { frame: self.frame, views: homeless.len() });
            };
            let name = usable[lightest].clone();
            self.assign(*view, &name);
        }
        if rebalance_fully {
            for _ in 0..self.views.len() {
                if self.rebalance_once(0.0).is_none() {
                    break;
                }
            }
        }
        Ok(())
    }

    /// One move that evens the loads (unmeasured views count at the mean,
    /// as placement weighs them); returns it.
    fn rebalance_once(&mut self, margin: f64) -> Option<(RigViewId, String, String)> {
        let (usable, loads) = self.loads();
        if usable.len() < 2 {
            return None;
        }
        let mean = self.mean_cost();
        let candidates: Vec<(GroupViewId, usize, Option<f64>)> = self
            .views
            .iter()
            .filter_map(|(id, v)| {
                let member = usable.iter().position(|u| Some(u) == v.node.as_ref())?;
                Some((GroupViewId(id.0), member, Some(v.cost.unwrap_or(mean))))
            })
            .collect();
        let (view, from, to) = best_move(&loads, &candidates, margin)?;
        let view = RigViewId(view.0);
        self.assign(view, &usable[to]);
        Some((view, usable[from].clone(), usable[to].clone()))
    }

    /// Renders one frame of `scene` on the nodes: sends each its order
    /// (the scene's changes, its changes of views), gathers every view's
    /// images, takes over the views of nodes that leave, fail or stall
    /// meanwhile, then moves at most one view to even the loads.
    pub fn render_frame(&mut self, scene: &Scene) -> Result<RigFrame, NodeError> {
        let started = Instant::now();
        self.frame += 1;
        let frame = self.frame;
        let _span = info_span!("rig_frame", frame, views = self.views.len()).entered();
        let mut report = RigFrame { frame, ..Default::default() };
        let mut queued = Vec::new();
        self.drain_membership(Some(&mut queued));
        let had_joins = !self.joined.is_empty();
        report.joined = std::mem::take(&mut self.joined);
        self.place(had_joins)?;

        // The scene: one delta for the nodes in step, a snapshot for the others.
        let replicating = Instant::now();
        let delta = self.stream.next(scene);
        let unchanged = delta.base != 0 && delta.ops.is_empty() && delta.nodes.is_empty();
        let delta_bytes = if unchanged { Vec::new() } else { delta.encode() };
        report.delta_bytes = delta_bytes.len();
        let snapshot =
            self.nodes.values().any(|n| !n.in_step).then(|| scene.delta_since(0, &mut HashSet::new()).encode());
        report.replicate_seconds = replicating.elapsed().as_secs_f64();

        let sent_at = Instant::now();
        let names: Vec<String> = self.nodes.keys().cloned().collect();
        for name in &names {
            let Some(state) = self.nodes.get_mut(name) else { continue };
            let (update, payload) = match (&snapshot, state.in_step) {
                (Some(snapshot), false) => (SceneUpdate::Snapshot, snapshot.clone()),
                _ if unchanged => (SceneUpdate::Unchanged, Vec::new()),
                _ if delta.is_snapshot() => (SceneUpdate::Snapshot, delta_bytes.clone()),
                _ => (SceneUpdate::Delta, delta_bytes.clone()),
            };
            state.in_step = true;
            report.scene_wire_bytes += payload.len();
            let order = self.order(name, frame, update, None);
            self.send(name, &order, payload)?;
        }

        // Gather.
        let mut outputs: BTreeMap<RigViewId, ViewOutput> = BTreeMap::new();
        // No frame waits for a stalled node (it has no views).
        let mut waiting_since: BTreeMap<String, Awaited> = names
            .iter()
            .filter(|n| self.nodes.get(*n).is_some_and(|s| s.stalled.is_none()))
            .map(|n| (n.clone(), Awaited { since: sent_at, orders: 1 }))
            .collect();
        let mut tries: BTreeMap<RigViewId, usize> = BTreeMap::new();

        let mut pending = queued.into_iter();
        loop {
            // Done when every view's images are in and every node sent
            // an order has reported it (its time feeds placement).
            let missing: Vec<RigViewId> = self.views.keys().filter(|v| !outputs.contains_key(v)).copied().collect();
            if missing.is_empty() && waiting_since.is_empty() {
                break;
            }
            // A node that has not reported past the stall timeout is
            // treated as gone for this frame.
            let now = Instant::now();
            let overdue: Vec<String> = waiting_since
                .iter()
                .filter(|(_, a)| a.overdue(now, self.options.stall_timeout))
                .map(|(n, _)| n.clone())
                .collect();
            for name in overdue {
                warn!(node = %name, frame, "node fell behind: its views render elsewhere");
                if let Some(state) = self.nodes.get_mut(&name) {
                    state.stalled = Some(frame);
                }
                report.stalled.push(name.clone());
                waiting_since.remove(&name);
                self.take_over(&name, &missing, frame, &mut tries, &mut waiting_since, &mut report)?;
            }
            let wait = Awaited::wait(&waiting_since, Instant::now(), self.options.stall_timeout);
            let event = match pending.next() {
                Some(event) => event,
                None => match self.events.recv_timeout(wait.max(Duration::from_millis(1))) {
                    Ok(event) => event,
                    Err(mpsc::RecvTimeoutError::Timeout) => continue,
                    Err(mpsc::RecvTimeoutError::Disconnected) => {
                        return Err(NodeError::Zenoh("the session closed".into()));
                    }
                },
            };
            match event {
                Event::Output(sample) => {
                    let key = sample.key_expr().as_str().to_owned();
                    let node = Keys::last_chunk(&key).to_owned();
                    let tag = match sample.attachment().map(|a| wire::decode::<OutputTag>(&key, &a.to_bytes())) {
                        Some(Ok(tag)) => tag,
                        Some(Err(e)) => {
                            warn!(%e, "output refused");
                            continue;
                        }
                        None => continue,
                    };
                    if tag.frame != frame {
                        continue; // late images of an earlier frame
                    }
                    let payload = sample.payload().to_bytes();
                    report.image_bytes += payload.len();
                    match ImagePlanes::split_payload(&key, &tag, &payload) {
                        Ok(views) => {
                            let latency_seconds = started.elapsed().as_secs_f64();
                            for (view, planes) in views {
                                if !self.views.contains_key(&view) {
                                    continue;
                                }
                                match outputs.entry(view) {
                                    std::collections::btree_map::Entry::Occupied(_) => report.duplicates += 1,
                                    std::collections::btree_map::Entry::Vacant(slot) => {
                                        let node = node.clone();
                                        let size = tag.size;
                                        slot.insert(ViewOutput { view, frame, node, size, planes, latency_seconds });
                                    }
                                }
                            }
                        }
                        Err(e) => warn!(%e, "output refused"),
                    }
                }
                Event::Status(sample) => {
                    let key = sample.key_expr().as_str().to_owned();
                    let node = Keys::last_chunk(&key).to_owned();
                    let Ok(status) = wire::decode::<Status>(&key, &sample.payload().to_bytes()) else { continue };
                    if status.frame != frame {
                        // A stalled node that catches up is usable again.
                        if let (Outcome::Rendered { .. }, Some(state)) = (&status.outcome, self.nodes.get_mut(&node))
                            && state.stalled.is_some_and(|since| status.frame > since)
                        {
                            state.stalled = None;
                        }
                        continue;
                    }
                    match status.outcome {
                        Outcome::Rendered { views, seconds, render_seconds } => {
                            let account = report.nodes.entry(node.clone()).or_default();
                            account.views += views;
                            account.seconds += seconds;
                            account.render_seconds += render_seconds;
                            if let Some(state) = self.nodes.get_mut(&node) {
                                state.stalled = None;
                            }
                            Awaited::reported(&mut waiting_since, &node);
                        }
                        Outcome::Failed { reason, needs_snapshot } => {
                            warn!(%node, frame, %reason, "node failed its frame: its views render elsewhere");
                            if let Some(state) = self.nodes.get_mut(&node) {
                                state.in_step &= !needs_snapshot;
                            }
                            Awaited::reported(&mut waiting_since, &node);
                            let missing: Vec<RigViewId> =
                                self.views.keys().filter(|v| !outputs.contains_key(v)).copied().collect();
                            // Off this node for good: placement brings views back by cost.
                            self.take_over(&node, &missing, frame, &mut tries, &mut waiting_since, &mut report)?;
                        }
                    }
                }
                Event::Node(name, up) => {
                    let gone = !up && self.nodes.contains_key(&name);
                    let missing: Vec<RigViewId> =
                        self.views.keys().filter(|v| !outputs.contains_key(v)).copied().collect();
                    let theirs: Vec<RigViewId> = missing
                        .iter()
                        .filter(|v| self.views.get(v).and_then(|v| v.node.as_deref()) == Some(name.as_str()))
                        .copied()
                        .collect();
                    self.membership(name.clone(), up);
                    if gone {
                        waiting_since.remove(&name);
                        self.take_over(&name, &theirs, frame, &mut tries, &mut waiting_since, &mut report)?;
                    }
                }
            }
        }
        report.latency_seconds = started.elapsed().as_secs_f64();
        report.left = std::mem::take(&mut self.left);

        // Costs: each node's time spread over the views it rendered.
        for (node, account) in &report.nodes {
            let seconds = account.seconds;
            let rendered: Vec<RigViewId> = outputs.values().filter(|o| &o.node == node).map(|o| o.view).collect();
            if rendered.is_empty() {
                continue;
            }
            let each = seconds / rendered.len() as f64;
            for view in rendered {
                if let Some(v) = self.views.get_mut(&view) {
                    v.cost = Some(v.cost.map_or(each, |c| c + COST_SMOOTHING * (each - c)));
                }
            }
        }
        if self.options.rebalance_margin.is_finite() {
            report.moved.extend(self.rebalance_once(self.options.rebalance_margin));
        }
        report.outputs = outputs.into_values().collect();
        Ok(report)
    }

    /// Gives `from`'s views among `missing` to other usable nodes, which
    /// render this frame again for them (their replicas hold its scene).
    fn take_over(
        &mut self,
        from: &str,
        missing: &[RigViewId],
        frame: u64,
        tries: &mut BTreeMap<RigViewId, usize>,
        waiting_since: &mut BTreeMap<String, Awaited>,
        report: &mut RigFrame,
    ) -> Result<(), NodeError> {
        let orphans: Vec<RigViewId> = missing
            .iter()
            .filter(|v| self.views.get(v).is_some_and(|v| v.node.as_deref() == Some(from) || v.node.is_none()))
            .copied()
            .collect();
        if orphans.is_empty() {
            return Ok(());
        }
        let mut given: BTreeMap<String, Vec<RigViewId>> = BTreeMap::new();
        for view in &orphans {
            let attempt = tries.entry(*view).or_default();
            *attempt += 1;
            if *attempt > self.nodes.len().max(1) + 1 {
                return Err(NodeError::InvalidView {
                    view: self.views.get(view).map(|v| v.spec.name.clone()).unwrap_or_default(),
                    reason: format!("frame {frame}: every node failed to render it"),
                });
            }
            let (usable, loads) = self.loads();
            // Only a node whose replica holds this frame's scene can take over.
            let candidates: Vec<usize> = (0..usable.len())
                .filter(|i| usable[*i] != from && self.nodes.get(&usable[*i]).is_some_and(|n| n.in_step))
                .collect();
            let Some(&to) = candidates.iter().min_by(|a, b| loads[**a].total_cmp(&loads[**b])) else {
                return Err(NodeError::NoNodes { frame, views: orphans.len() });
            };
            let name = usable[to].clone();
            self.assign(*view, &name);
            given.entry(name).or_default().push(*view);
            report.taken_over.push(*view);
        }
        for (name, views) in given {
            if !self.nodes.contains_key(&name) {
                continue;
            }
            let order = self.order(&name, frame, SceneUpdate::Unchanged, Some(views));
            self.send(&name, &order, Vec::new())?;
            let awaited = waiting_since.entry(name).or_insert(Awaited { since: Instant::now(), orders: 0 });
            awaited.since = Instant::now();
            awaited.orders += 1;
        }
        Ok(())
    }

    /// Node `node`'s order for `frame`: its pending changes of views
    /// (taken), the planes, and `only` the views whose images it sends.
    fn order(&mut self, node: &str, frame: u64, scene: SceneUpdate, only: Option<Vec<RigViewId>>) -> Order {
        let (add, remove) = match self.nodes.get_mut(node) {
            Some(state) => (std::mem::take(&mut state.add), std::mem::take(&mut state.remove)),
            None => Default::default(),
        };
        let add = add.into_iter().filter_map(|id| Some((id, self.views.get(&id)?.spec.clone()))).collect();
        Order { frame, scene, add, remove: remove.into_iter().collect(), planes: self.options.planes, only }
    }

    fn send(&self, node: &str, order: &Order, payload: Vec<u8>) -> Result<(), NodeError> {
        self.session
            .put(self.keys.order(node), payload)
            .attachment(wire::encode(order))
            .congestion_control(CongestionControl::Block)
            .wait()
            .map_err(NodeError::zenoh)
    }
}

#[cfg(test)]
mod node_state_tests {
    use super::*;

    /// A view the node was only about to add is simply not added; one it
    /// renders already is removed with its next order. (Removing a view
    /// the node never got would make it drop one it does not have; adding
    /// back a dropped one would keep rendering it.)
    #[test]
    fn dropping_a_view_cancels_its_pending_add_or_schedules_its_removal() {
        let mut node = NodeState::default();
        node.add.insert(RigViewId(1));
        node.drop_view(RigViewId(1));
        assert!(node.add.is_empty() && node.remove.is_empty(), "a pending add is cancelled: {node:?}");
        node.drop_view(RigViewId(2));
        assert!(node.add.is_empty(), "{node:?}");
        assert_eq!(node.remove.iter().copied().collect::<Vec<_>>(), [RigViewId(2)], "a rendered view is removed");
    }
}

#[cfg(test)]
mod membership_tests {
    use super::*;

    /// A coordinator with no node, listening on a free local port.
    pub(super) fn coordinator() -> Coordinator {
        let port = std::net::TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).expect("a free port").port();
        let net = NetConfig::listen(format!("tcp/127.0.0.1:{port}"));
        Coordinator::new(&format!("membership-{}", std::process::id()), &net, RigOptions::default())
            .expect("coordinator")
    }

    /// An 8 × 8 view `name` added to `coordinator`.
    pub(super) fn view(coordinator: &mut Coordinator, name: &str) -> RigViewId {
        let camera = oxygen_core::Camera::perspective(1.0, 0.1, None);
        let spec = ViewSpec::look_at(name, camera, glam::DVec3::Z, glam::DVec3::ZERO, UVec2::splat(8));
        coordinator.add_view(spec).expect("view")
    }

    /// A node joins once: a second announcement of the same name, or a name
    /// that could not be a key expression, adds nobody.
    #[test]
    fn a_node_joins_once_and_only_under_a_usable_name() {
        let mut coordinator = coordinator();
        coordinator.membership("a".into(), true);
        coordinator.membership("a".into(), true);
        coordinator.membership("bad/name".into(), true);
        assert_eq!(coordinator.nodes(), ["a"]);
        assert_eq!(coordinator.joined, ["a"]);
    }

    /// A node that leaves takes its views' placement with it (they render
    /// elsewhere from the next frame); the other nodes keep theirs.
    #[test]
    fn a_leaving_node_frees_its_views_and_only_its_views() {
        let mut coordinator = coordinator();
        coordinator.membership("a".into(), true);
        coordinator.membership("b".into(), true);
        let (on_a, on_b) = (view(&mut coordinator, "on a"), view(&mut coordinator, "on b"));
        coordinator.assign(on_a, "a");
        coordinator.assign(on_b, "b");
        coordinator.membership("a".into(), false);
        assert_eq!(coordinator.nodes(), ["b"]);
        assert_eq!(coordinator.left, ["a"]);
        assert_eq!(coordinator.node_of(on_a), None);
        assert_eq!(coordinator.node_of(on_b), Some("b"));
    }

    /// Joins and departures queued since the last look are acted on when
    /// the next frame starts (or while waiting for nodes), in the order
    /// they came; a frame keeps the other events it finds for itself, and
    /// between frames they are dropped.
    #[test]
    fn queued_membership_is_acted_on_in_order_and_other_events_are_kept_for_the_frame() {
        let mut coordinator = coordinator();
        // The test's own channel in place of the session's, so that it
        // decides what is queued and when.
        let (tx, events) = mpsc::channel();
        coordinator.events = events;
        let status = || {
            let key = zenoh::key_expr::KeyExpr::try_from("membership/status/a").expect("key");
            Event::Status(zenoh::sample::SampleBuilder::put(key, Vec::<u8>::new()).into())
        };
        for event in
            [Event::Node("a".into(), true), status(), Event::Node("b".into(), true), Event::Node("a".into(), false)]
        {
            tx.send(event).expect("queued");
        }
        let mut kept = Vec::new();
        coordinator.drain_membership(Some(&mut kept));
        assert_eq!(coordinator.nodes(), ["b"]);
        assert_eq!(coordinator.joined, ["a", "b"]);
        assert_eq!(coordinator.left, ["a"]);
        assert!(matches!(kept.as_slice(), [Event::Status(_)]), "the frame keeps the status it found");

        tx.send(status()).expect("queued");
        tx.send(Event::Node("c".into(), true)).expect("queued");
        coordinator.drain_membership(None);
        assert_eq!(coordinator.nodes(), ["b", "c"]);
        assert!(coordinator.events.try_recv().is_err(), "between frames the status is dropped, not left queued");
    }
}

#[cfg(test)]
mod placement_tests {
    use super::membership_tests::{coordinator, view};
    use super::*;

    /// Gives `view` a measured cost.
    pub(super) fn measured(coordinator: &mut Coordinator, view: RigViewId, cost: f64) {
        coordinator.views.get_mut(&view).expect("view").cost = Some(cost);
    }

    /// An unmeasured view weighs in its node's load as the mean of the
    /// measured ones, (1 + 3) / 2 = 2 here; with none measured, as 1.
    #[test]
    fn an_unmeasured_view_weighs_the_mean_measured_cost_in_a_load() {
        let mut coordinator = coordinator();
        coordinator.membership("a".into(), true);
        coordinator.membership("b".into(), true);
        let new = view(&mut coordinator, "new");
        coordinator.assign(new, "b");
        assert_eq!(coordinator.loads(), (vec!["a".to_owned(), "b".to_owned()], vec![0.0, 1.0]), "none measured");
        let (cheap, dear) = (view(&mut coordinator, "cheap"), view(&mut coordinator, "dear"));
        measured(&mut coordinator, cheap, 1.0);
        measured(&mut coordinator, dear, 3.0);
        coordinator.assign(cheap, "a");
        coordinator.assign(dear, "a");
        assert_eq!(coordinator.loads(), (vec!["a".to_owned(), "b".to_owned()], vec![4.0, 2.0]));
    }

    /// A move weighs an unmeasured view at the mean measured cost too. With
    /// a carrying two unmeasured views (2 each) and one of 1, b one of 3 and
    /// c none, the loads are 5, 3 and 0: an unmeasured view moving from a to
    /// c leaves a gap of |5 − 2 × 2| = 1, the measured one |5 − 2 × 1| = 3.
    #[test]
    fn a_move_weighs_an_unmeasured_view_at_the_mean_measured_cost() {
        let mut coordinator = coordinator();
        for node in ["a", "b", "c"] {
            coordinator.membership(node.into(), true);
        }
        let (cheap, dear) = (view(&mut coordinator, "cheap"), view(&mut coordinator, "dear"));
        let (new, newer) = (view(&mut coordinator, "new"), view(&mut coordinator, "newer"));
        measured(&mut coordinator, cheap, 1.0);
        measured(&mut coordinator, dear, 3.0);
        for (view, node) in [(cheap, "a"), (new, "a"), (newer, "a"), (dear, "b")] {
            coordinator.assign(view, node);
        }
        assert_eq!(coordinator.rebalance_once(0.0), Some((new, "a".to_owned(), "c".to_owned())));
        assert_eq!(coordinator.node_of(new), Some("c"));
    }

    /// Two nodes are enough for a move: with both views on one, one goes to
    /// the other. A single node has nowhere to move a view.
    #[test]
    fn a_view_moves_between_two_nodes_and_never_on_one() {
        let mut coordinator = coordinator();
        coordinator.membership("a".into(), true);
        let (first, second) = (view(&mut coordinator, "first"), view(&mut coordinator, "second"));
        coordinator.assign(first, "a");
        coordinator.assign(second, "a");
        assert_eq!(coordinator.rebalance_once(0.0), None, "one node");
        coordinator.membership("b".into(), true);
        assert_eq!(coordinator.rebalance_once(0.0), Some((first, "a".to_owned(), "b".to_owned())));
        assert_eq!(coordinator.rebalance_once(0.0), None, "1 and 1: even");
    }
}

#[cfg(test)]
mod frame_tests {
    use oxygen_core::scene::delta::SceneDelta;
    use oxygen_core::{NodeKey, Transform};
    use zenoh::key_expr::KeyExpr;
    use zenoh::sample::SampleBuilder;

    use super::membership_tests::{coordinator, view};
    use super::placement_tests::measured;
    use super::*;

    /// Renders a frame of `scene` that finds `events` queued, as if they
    /// had come from the nodes, and nothing after them: the queue is closed,
    /// so a frame that waits for more fails at once (the session closed)
    /// instead of waiting out the stall timeout.
    fn frame(coordinator: &mut Coordinator, scene: &Scene, events: Vec<Event>) -> RigFrame {
        try_frame(coordinator, scene, events).expect("the frame")
    }

    /// As [`frame`], for a frame that may fail.
    fn try_frame(coordinator: &mut Coordinator, scene: &Scene, events: Vec<Event>) -> Result<RigFrame, NodeError> {
        let (tx, rx) = mpsc::channel();
        for event in events {
            tx.send(event).expect("queued");
        }
        drop(tx);
        coordinator.events = rx;
        coordinator.render_frame(scene)
    }

    /// As [`frame`], with `events` coming once the frame's first order went
    /// out (`orders` hears it), in the middle of the frame: what the frame
    /// finds queued when it starts it takes as having happened before it
    /// (joins and departures included).
    fn frame_after_orders(
        coordinator: &mut Coordinator,
        scene: &Scene,
        orders: mpsc::Receiver<Sample>,
        events: Vec<Event>,
    ) -> RigFrame {
        let (tx, rx) = mpsc::channel();
        coordinator.events = rx;
        let sender = std::thread::spawn(move || {
            orders.recv_timeout(Duration::from_secs(10)).expect("an order");
            for event in events {
                tx.send(event).expect("queued");
            }
        });
        let report = coordinator.render_frame(scene);
        sender.join().expect("the events sent");
        report.expect("the frame")
    }

    /// A coordinator whose nodes `names` joined before its first frame (no
    /// view moves on their account) and which moves no view after a frame
    /// either: each test puts its views where it wants them.
    fn rig(names: &[&str]) -> Coordinator {
        let mut coordinator = coordinator();
        for name in names {
            coordinator.membership((*name).to_owned(), true);
        }
        coordinator.joined.clear();
        coordinator.options.rebalance_margin = f64::INFINITY;
        coordinator
    }

    /// Node `node` reports frame `frame` rendered: `views` views in
    /// `seconds` (half of it rendering).
    fn rendered(coordinator: &Coordinator, node: &str, frame: u64, views: u32, seconds: f64) -> Event {
        let key = KeyExpr::try_from(coordinator.keys.status(node)).expect("key");
        let status = Status { frame, outcome: Outcome::Rendered { views, seconds, render_seconds: seconds / 2.0 } };
        Event::Status(SampleBuilder::put(key, wire::encode(&status)).into())
    }

    /// Node `node` reports that it could not render frame `frame` (its
    /// replica lost the scene when `needs_snapshot`).
    fn failed(coordinator: &Coordinator, node: &str, frame: u64, needs_snapshot: bool) -> Event {
        let key = KeyExpr::try_from(coordinator.keys.status(node)).expect("key");
        let outcome = Outcome::Failed { reason: "a test's failure".into(), needs_snapshot };
        Event::Status(SampleBuilder::put(key, wire::encode(&Status { frame, outcome })).into())
    }

    /// Node `node`'s images of `views` of frame `frame` (8 × 8, the
    /// default planes, every byte `fill`), and their size in bytes.
    fn images(coordinator: &Coordinator, node: &str, frame: u64, views: &[RigViewId], fill: u8) -> (Event, usize) {
        let (size, planes) = (UVec2::splat(8), coordinator.options.planes);
        let payload = vec![fill; views.len() * planes.bytes(size)];
        let bytes = payload.len();
        let tag = OutputTag { frame, views: views.to_vec(), size, planes };
        let key = KeyExpr::try_from(coordinator.keys.output(node)).expect("key");
        (Event::Output(SampleBuilder::put(key, payload).attachment(wire::encode(&tag)).into()), bytes)
    }

    /// A scene of one node, and the node.
    /// A coordinator with node a joined, one view and a scene of one node.
    fn one_node_one_view() -> (Coordinator, RigViewId, Scene) {
        let mut coordinator = coordinator();
        coordinator.membership("a".into(), true);
        let view = view(&mut coordinator, "v");
        (coordinator, view, scene().0)
    }

    fn scene() -> (Scene, NodeKey) {
        let mut scene = Scene::new();
        let node = scene.add_node("box", Transform::IDENTITY);
        (scene, node)
    }

    /// Moves `node` of `scene` to `x` along the x axis.
    fn shift(scene: &mut Scene, node: NodeKey, x: f32) {
        scene.set_local_transform(node, Transform::from_translation(glam::Vec3::X * x)).expect("moved");
    }

    /// The orders `coordinator` sends from now on, as they leave (its
    /// session hears its own puts).
    fn listen(coordinator: &Coordinator) -> (zenoh::pubsub::Subscriber<()>, mpsc::Receiver<Sample>) {
        let (tx, rx) = mpsc::channel();
        let subscriber = coordinator
            .session
            .declare_subscriber(coordinator.keys.order("*"))
            .callback(move |sample| {
                let _ = tx.send(sample);
            })
            .wait()
            .expect("subscriber");
        (subscriber, rx)
    }

    /// The next order sent: its node, its header and its payload.
    fn next_order(orders: &mpsc::Receiver<Sample>) -> (String, Order, Vec<u8>) {
        let sample = orders.recv_timeout(Duration::from_secs(10)).expect("an order");
        let key = sample.key_expr().as_str().to_owned();
        let order = wire::decode::<Order>(&key, &sample.attachment().expect("a header").to_bytes()).expect("order");
        (Keys::last_chunk(&key).to_owned(), order, sample.payload().to_bytes().to_vec())
    }

    /// Each node's order says what its payload is, and the payload is what
    /// the node's replica needs: the whole scene when it is not in step (its
    /// first frame, or after every node in step left: the stream's own
    /// delta would not apply to it), nothing when the scene did not change,
    /// the delta when it did, and the stream's snapshot, labelled a
    /// snapshot, when the scene is another one.
    #[test]
    fn each_node_gets_the_scene_update_its_replica_needs() {
        let mut coordinator = coordinator();
        let (_subscriber, orders) = listen(&coordinator);
        coordinator.membership("a".into(), true);
        let (mut scene, node) = scene();
        let whole = |scene: &Scene| scene.delta_since(0, &mut HashSet::new()).encode();

        // a's first frame: the whole scene.
        let events = vec![rendered(&coordinator, "a", 1, 0, 0.1)];
        let report = frame(&mut coordinator, &scene, events);
        let (to, order, payload) = next_order(&orders);
        assert_eq!((to.as_str(), order.frame, order.scene), ("a", 1, SceneUpdate::Snapshot));
        assert_eq!(payload, whole(&scene));
        assert_eq!(report.scene_wire_bytes, payload.len());

        // Nothing changed: nothing travels, and a is told so.
        let events = vec![rendered(&coordinator, "a", 2, 0, 0.1)];
        let report = frame(&mut coordinator, &scene, events);
        assert_eq!((report.delta_bytes, report.scene_wire_bytes), (0, 0), "an unchanged scene sends no bytes");
        let (_, order, payload) = next_order(&orders);
        assert_eq!((order.frame, order.scene, payload.len()), (2, SceneUpdate::Unchanged, 0));

        // The node moved: the delta from the revision a holds.
        shift(&mut scene, node, 1.0);
        let events = vec![rendered(&coordinator, "a", 3, 0, 0.1)];
        let report = frame(&mut coordinator, &scene, events);
        let (_, order, payload) = next_order(&orders);
        assert_eq!((order.frame, order.scene), (3, SceneUpdate::Delta));
        assert!(!payload.is_empty() && payload.len() == report.delta_bytes, "{} bytes", payload.len());
        assert!(!SceneDelta::decode(&payload).expect("a delta").is_snapshot());

        // Another scene: the stream starts again with a snapshot, which a
        // (in step) gets as the delta, labelled a snapshot.
        let (mut other, other_node) = self::scene();
        let events = vec![rendered(&coordinator, "a", 4, 0, 0.1)];
        let report = frame(&mut coordinator, &other, events);
        let (_, order, payload) = next_order(&orders);
        assert_eq!((order.frame, order.scene), (4, SceneUpdate::Snapshot));
        assert_eq!(payload.len(), report.delta_bytes);
        assert!(SceneDelta::decode(&payload).expect("a delta").is_snapshot());

        // a leaves and b joins, the scene changed: no node is in step, and
        // b gets the whole scene, not the delta.
        shift(&mut other, other_node, 2.0);
        let events =
            vec![Event::Node("a".into(), false), Event::Node("b".into(), true), rendered(&coordinator, "b", 5, 0, 0.1)];
        let report = frame(&mut coordinator, &other, events);
        let (to, order, payload) = next_order(&orders);
        assert_eq!((to.as_str(), order.frame, order.scene), ("b", 5, SceneUpdate::Snapshot));
        assert_eq!(payload, whole(&other));
        assert!(report.delta_bytes > 0 && report.delta_bytes < payload.len(), "the delta was smaller");
        assert_eq!(report.scene_wire_bytes, payload.len());
    }

    /// A frame ends when every view's images are in and every node sent an
    /// order has reported it, whichever comes last: the images alone leave
    /// the node's time (and so its views' costs) unknown; its report alone
    /// leaves a view without images.
    #[test]
    fn a_frame_waits_for_every_image_and_every_report() {
        let (mut coordinator, view, scene) = one_node_one_view();

        let events = vec![images(&coordinator, "a", 1, &[view], 1).0, rendered(&coordinator, "a", 1, 1, 0.5)];
        let report = frame(&mut coordinator, &scene, events);
        assert_eq!(report.outputs.iter().map(|o| o.view).collect::<Vec<_>>(), [view]);
        let account = NodeReport { views: 1, seconds: 0.5, render_seconds: 0.25 };
        assert_eq!(report.nodes.get("a"), Some(&account), "the report after the images is awaited");
        assert_eq!(coordinator.view_cost(view), Some(0.5));

        let events = vec![rendered(&coordinator, "a", 2, 1, 0.5), images(&coordinator, "a", 2, &[view], 2).0];
        let report = frame(&mut coordinator, &scene, events);
        assert_eq!(report.nodes.get("a"), Some(&account));
        let outputs: Vec<(RigViewId, u64, &str)> =
            report.outputs.iter().map(|o| (o.view, o.frame, o.node.as_str())).collect();
        assert_eq!(outputs, [(view, 2, "a")], "the images after the report are awaited");
    }

    /// Every image of the frame counts in `image_bytes`, a view's second
    /// images too, which count as a duplicate (the first are kept); late
    /// images of an earlier frame count in neither.
    #[test]
    fn every_image_of_the_frame_counts_in_bytes_and_a_second_one_as_a_duplicate() {
        let (mut coordinator, view, scene) = one_node_one_view();
        let events = vec![images(&coordinator, "a", 1, &[view], 1).0, rendered(&coordinator, "a", 1, 1, 0.5)];
        let report = frame(&mut coordinator, &scene, events);
        assert_eq!((report.image_bytes, report.duplicates), (images(&coordinator, "a", 1, &[view], 1).1, 0));

        let (late, _) = images(&coordinator, "a", 1, &[view], 1);
        let (first, bytes) = images(&coordinator, "a", 2, &[view], 2);
        let (again, again_bytes) = images(&coordinator, "a", 2, &[view], 3);
        let events = vec![late, first, again, rendered(&coordinator, "a", 2, 1, 0.5)];
        let report = frame(&mut coordinator, &scene, events);
        assert_eq!(report.image_bytes, bytes + again_bytes, "both of frame 2's, not frame 1's");
        assert_eq!(report.duplicates, 1);
        assert_eq!(report.outputs.len(), 1);
        assert_eq!(report.outputs[0].planes.color.as_deref(), Some(&[2u8; 8 * 8 * 4][..]), "the first kept");
    }

    /// A node is late once it has owed its report for longer than the stall
    /// timeout, not at the timeout itself; the gather loop blocks until the
    /// earliest of the awaited nodes' deadlines (none left once it passed),
    /// or 100 ms when no node is awaited.
    #[test]
    fn a_node_is_late_past_the_stall_timeout_and_the_loop_sleeps_until_then() {
        let (since, timeout) = (Instant::now(), Duration::from_secs(3));
        let awaited = Awaited { since, orders: 1 };
        assert!(!awaited.overdue(since, timeout));
        assert!(!awaited.overdue(since + timeout, timeout), "at the timeout: not yet");
        assert!(awaited.overdue(since + timeout + Duration::from_nanos(1), timeout));

        let mut waiting = BTreeMap::new();
        assert_eq!(Awaited::wait(&waiting, since, timeout), Duration::from_millis(100), "none awaited");
        let second = Duration::from_secs(1);
        waiting.insert("early".to_owned(), Awaited { since, orders: 1 });
        waiting.insert("later".to_owned(), Awaited { since: since + second, orders: 1 });
        assert_eq!(Awaited::wait(&waiting, since + second, timeout), 2 * second, "until the earliest deadline");
        assert_eq!(Awaited::wait(&waiting, since + 5 * second, timeout), Duration::ZERO, "passed");
        // Never giving up on a node is a timeout, not a panic.
        assert!(!awaited.overdue(since + 5 * second, Duration::MAX));
        assert_eq!(Awaited::wait(&waiting, since, Duration::MAX), second, "no deadline: look again every second");
    }

    /// A stalled node is usable again once it reports a frame later than
    /// the one it stalled in: its reports of that frame or of an earlier one
    /// are late answers, not a sign that it keeps up.
    #[test]
    fn a_stalled_node_is_usable_again_once_it_reports_a_later_frame() {
        let mut coordinator = rig(&["a", "b"]);
        let (scene, _) = scene();
        coordinator.frame = 3;
        coordinator.nodes.get_mut("a").expect("a").stalled = Some(2);
        let events = vec![
            rendered(&coordinator, "a", 1, 0, 0.1),
            rendered(&coordinator, "a", 2, 0, 0.1),
            rendered(&coordinator, "b", 4, 0, 0.1),
        ];
        frame(&mut coordinator, &scene, events);
        assert_eq!(coordinator.nodes["a"].stalled, Some(2), "frames 1 and 2 reported late: still stalled");
        assert_eq!(coordinator.loads().0, ["b"]);

        let events = vec![rendered(&coordinator, "a", 3, 0, 0.1), rendered(&coordinator, "b", 5, 0, 0.1)];
        frame(&mut coordinator, &scene, events);
        assert_eq!(coordinator.nodes["a"].stalled, None, "frame 3 reported: caught up");
        assert_eq!(coordinator.loads().0, ["a", "b"]);
    }

    /// A node that failed its frame stays in step unless its replica lost
    /// the scene: then, and only then, its next order carries the whole
    /// scene (a delta would not apply to it; a snapshot it does not need
    /// would cost the wire the whole scene).
    #[test]
    fn a_failed_node_gets_the_whole_scene_next_only_when_its_replica_lost_it() {
        let mut coordinator = rig(&["a"]);
        let (_subscriber, orders) = listen(&coordinator);
        let (scene, _) = scene();
        let events = vec![failed(&coordinator, "a", 1, false)];
        frame(&mut coordinator, &scene, events);
        assert_eq!(next_order(&orders).1.scene, SceneUpdate::Snapshot, "a's first frame");
        let events = vec![failed(&coordinator, "a", 2, true)];
        frame(&mut coordinator, &scene, events);
        let (_, order, payload) = next_order(&orders);
        assert_eq!((order.scene, payload.len()), (SceneUpdate::Unchanged, 0), "a failed, its replica intact");
        let events = vec![rendered(&coordinator, "a", 3, 0, 0.1)];
        frame(&mut coordinator, &scene, events);
        let (_, order, payload) = next_order(&orders);
        assert_eq!(order.scene, SceneUpdate::Snapshot, "a's replica lost the scene");
        assert_eq!(payload, scene.delta_since(0, &mut HashSet::new()).encode());
    }

    /// A failed node's views without images render again in the same frame
    /// on the least loaded other node whose replica holds the frame's scene
    /// (not on the node that failed, nor on one out of step however light),
    /// and the frame waits for that node's reports of both its orders.
    #[test]
    fn a_failed_nodes_views_render_again_on_the_lightest_other_node_in_step() {
        let mut coordinator = rig(&["a", "b", "c"]);
        let (_subscriber, orders) = listen(&coordinator);
        let (scene, _) = scene();
        let v = view(&mut coordinator, "v");
        let (w1, w2) = (view(&mut coordinator, "w1"), view(&mut coordinator, "w2"));
        for (view, node) in [(v, "a"), (w1, "b"), (w2, "b")] {
            measured(&mut coordinator, view, 1.0);
            coordinator.assign(view, node);
        }
        // Loads a 1, b 2, c 0; c falls out of step, then a fails.
        let events = vec![
            failed(&coordinator, "c", 1, true),
            images(&coordinator, "b", 1, &[w1, w2], 1).0,
            failed(&coordinator, "a", 1, false),
            images(&coordinator, "b", 1, &[v], 2).0,
            rendered(&coordinator, "b", 1, 2, 0.2),
            rendered(&coordinator, "b", 1, 1, 0.1),
        ];
        let report = frame(&mut coordinator, &scene, events);
        assert_eq!(report.taken_over, [v]);
        assert_eq!(coordinator.node_of(v), Some("b"));
        let sent: Vec<String> = (0..4).map(|_| next_order(&orders).0).collect();
        assert_eq!(sent, ["a", "b", "c", "b"], "the frame's three orders, then b's second");
        let outputs: Vec<(RigViewId, &str)> = report.outputs.iter().map(|o| (o.view, o.node.as_str())).collect();
        assert_eq!(outputs, [(v, "b"), (w1, "b"), (w2, "b")]);
        let account = report.nodes.get("b").expect("b's account");
        assert_eq!(account.views, 3, "both of b's reports were awaited: {account:?}");
        assert!((account.seconds - 0.3).abs() < 1e-12, "{account:?}");
    }

    /// A view whose node fails is tried once on each node and once more
    /// (a node that failed may well render it on a second try); failing
    /// after that, the frame gives up with an error that names the view.
    #[test]
    fn a_view_every_node_fails_is_given_up_after_a_try_on_each_node_and_one_more() {
        let mut coordinator = rig(&["a", "b"]);
        let (scene, _) = scene();
        let v = view(&mut coordinator, "v");
        coordinator.assign(v, "a");
        // Three tries: a fails it, then b, then a; b renders it.
        let events = vec![
            failed(&coordinator, "a", 1, false),
            rendered(&coordinator, "b", 1, 0, 0.1),
            failed(&coordinator, "b", 1, false),
            failed(&coordinator, "a", 1, false),
            images(&coordinator, "b", 1, &[v], 1).0,
            rendered(&coordinator, "b", 1, 1, 0.1),
        ];
        let report = frame(&mut coordinator, &scene, events);
        assert_eq!(report.taken_over, [v, v, v]);
        assert_eq!(report.outputs.iter().map(|o| o.node.as_str()).collect::<Vec<_>>(), ["b"]);

        // A fourth failure in a frame is one too many.
        let events = vec![
            failed(&coordinator, "b", 2, false),
            rendered(&coordinator, "a", 2, 0, 0.1),
            failed(&coordinator, "a", 2, false),
            failed(&coordinator, "b", 2, false),
            failed(&coordinator, "a", 2, false),
        ];
        match try_frame(&mut coordinator, &scene, events) {
            Err(NodeError::InvalidView { view, reason }) => {
                assert_eq!(view, "v");
                assert!(reason.contains("frame 2: every node failed"), "{reason}");
            }
            other => panic!("the fourth failure gives up on the view: {:?}", other.map(|r| r.taken_over)),
        }
    }

    /// A node's seconds are spread evenly over the views whose images it
    /// sent, which become their costs; a later measurement moves a cost
    /// 30 % of the way to it.
    #[test]
    fn a_nodes_seconds_are_spread_over_its_views_and_smoothed_into_their_costs() {
        let mut coordinator = rig(&["a", "b"]);
        let (scene, _) = scene();
        let (v1, v2, w) = (view(&mut coordinator, "v1"), view(&mut coordinator, "v2"), view(&mut coordinator, "w"));
        for (view, node) in [(v1, "a"), (v2, "a"), (w, "b")] {
            coordinator.assign(view, node);
        }
        let costs = |coordinator: &Coordinator| [v1, v2, w].map(|v| coordinator.view_cost(v).expect("measured"));
        let close = |got: [f64; 3], want: [f64; 3]| got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-12);
        for (frame_no, a_seconds, want) in [(1, 1.0, [0.5, 0.5, 3.0]), (2, 2.0, [0.65, 0.65, 3.0])] {
            let events = vec![
                images(&coordinator, "a", frame_no, &[v1, v2], 1).0,
                images(&coordinator, "b", frame_no, &[w], 1).0,
                rendered(&coordinator, "a", frame_no, 2, a_seconds),
                rendered(&coordinator, "b", frame_no, 1, 3.0),
            ];
            frame(&mut coordinator, &scene, events);
            let got = costs(&coordinator);
            assert!(close(got, want), "frame {frame_no}: costs {got:?}, not {want:?}");
        }
    }

    /// A node announced again while the frame waits for it (liveliness
    /// can deliver a token twice: its history and the live put) is the
    /// same node: it keeps its views, and the frame still waits for its
    /// images and its report.
    #[test]
    fn a_node_announced_again_mid_frame_keeps_its_views_and_is_still_awaited() {
        let mut coordinator = rig(&["a"]);
        let (_subscriber, orders) = listen(&coordinator);
        let (scene, _) = scene();
        let v = view(&mut coordinator, "v");
        coordinator.assign(v, "a");
        let events = vec![
            Event::Node("a".into(), true),
            images(&coordinator, "a", 1, &[v], 1).0,
            rendered(&coordinator, "a", 1, 1, 0.5),
        ];
        let report = frame_after_orders(&mut coordinator, &scene, orders, events);
        assert!(report.taken_over.is_empty() && report.left.is_empty(), "{report:?}");
        assert_eq!(report.outputs.iter().map(|o| o.node.as_str()).collect::<Vec<_>>(), ["a"]);
        assert_eq!(report.nodes.get("a").map(|r| r.views), Some(1), "a's report was awaited");
    }
}
