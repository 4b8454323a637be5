//! Schedules, a subsystem of the renderer: which of the frame's resolved
//! views render and which stay idle ([`crate::schedule`]).
//!
//! The decision is made in the prepare step, after the frame phase has
//! collected the scene (its renderables' bounds are what a
//! [`Schedule::WhenChanged`] view is checked against) and before any view
//! is culled, so an idle view costs nothing but its check. For "when
//! changed" views the subsystem keeps what every renderable and light
//! looked like last frame (world matrix, revision, bounds, a skin's joint
//! matrices) and compares: a changed renderable wakes the views whose
//! frustum its bounds meet, before or after the change; a changed light or
//! a scene-wide asset wakes them all. Changes are watched frame to frame,
//! so a view left out of a frame (paused, or its resolver failed) renders
//! when it comes back.

use std::collections::{HashMap, HashSet};

use oxygen_core::{Aabb, NodeKey, Scene, ViewId};
use oxygen_passes::OutputSource;
use oxygen_sceneprep::FrameCollection;

use super::resolve::{FrameClock, ResolvedFrameView};
use crate::schedule::{Change, FrameBudget, IdleReason, IdleView, RenderReason, Schedule};

/// What the schedules know of a registered view: its schedule and
/// priority.
pub(crate) struct Scheduled {
    pub(crate) schedule: Schedule,
    pub(crate) priority: u32,
}

/// What a renderable or light looked like in a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Seen {
    /// World matrix (`f64`, world space: independent of the render origin).
    world: oxygen_core::glam::DMat4,
    /// The node's own revision (its mesh, materials, flags, light, morph
    /// weights, semantic class).
    revision: u64,
    /// World bounds of a renderable (`None` for a light).
    bounds: Option<Aabb>,
    /// A skinned renderable's joints' world matrices, folded into one value.
    joints: u64,
}

/// One view's schedule state.
#[derive(Clone, Debug, Default)]
struct ViewState {
    /// Frame of its first render.
    first: Option<u64>,
    /// Frame of its last check (whether it rendered or not).
    checked: Option<u64>,
    /// [`Schedule::Rate`]: frame time of its next render.
    next_seconds: Option<f64>,
    /// Asked for by the application, not rendered yet.
    requested: bool,
    /// A change not rendered yet ([`Schedule::WhenChanged`]).
    pending: Option<Change>,
    /// The pose it last rendered with: world → clip and size.
    camera: Option<(oxygen_core::glam::Mat4, oxygen_core::glam::UVec2)>,
    /// Came due ([`Schedule::EveryNth`], [`Schedule::Rate`]) but was
    /// deferred by the budget: due until it renders.
    owed: bool,
    /// Frames in a row the budget deferred it.
    deferred: u32,
    /// Its estimated cost a frame (CPU and GPU seconds, averaged over the
    /// frames it rendered); `None` before it was measured.
    cost: Option<f64>,
}

/// The schedules of every registered view, and what the scene looked like
/// last frame.
#[derive(Default)]
pub(crate) struct Schedules {
    views: HashMap<ViewId, ViewState>,
    seen: HashMap<NodeKey, Seen>,
    /// (scene id, assets revision) of the last frame that looked.
    scene: Option<(u64, u64)>,
    /// (scene id, revision) `seen` reflects: an unchanged scene is not
    /// looked at again (a frame of still cameras over a still scene costs
    /// its watchers nothing).
    looked_at: Option<(u64, u64)>,
    /// The renderer's environment changed since the last frame.
    environment_changed: bool,
    /// The frame budget, if any.
    budget: Option<FrameBudget>,
}

/// What changed in the scene since the last frame.
struct SceneChanges {
    /// Renderables that moved or changed: their bounds before and after.
    nodes: Vec<(NodeKey, Option<Aabb>, Option<Aabb>)>,
    /// A light that moved or changed (the first found).
    light: Option<NodeKey>,
    /// A scene-wide asset or the environment changed (or the scene is new).
    assets: bool,
}

impl Schedules {
    /// The application asked `view` to render in the next frame.
    pub(crate) fn request(&mut self, view: ViewId) {
        self.views.entry(view).or_default().requested = true;
    }

    /// The renderer's environment changed: every "when changed" view renders.
    pub(crate) fn environment_changed(&mut self) {
        self.environment_changed = true;
    }

    /// Whether a frame budget is set (the views' costs are kept only then).
    pub(crate) fn budgeted(&self) -> bool {
        self.budget.is_some()
    }

    /// Sets (or lifts) the frame budget.
    pub(crate) fn set_budget(&mut self, budget: Option<FrameBudget>) {
        self.budget = budget;
    }

    /// `view` rendered at `seconds` of CPU and GPU time (its share of the
    /// last frames' measurements): its estimate follows, averaged.
    pub(crate) fn measured(&mut self, view: ViewId, seconds: f64) {
        if !seconds.is_finite() || seconds < 0.0 {
            return;
        }
        let state = self.views.entry(view).or_default();
        // An average over the last few frames: steady, yet following a
        // view whose cost changes.
        state.cost = Some(state.cost.map_or(seconds, |c| 0.75 * c + 0.25 * seconds));
    }

    /// Forgets a view (unregistered).
    pub(crate) fn forget(&mut self, view: ViewId) {
        self.views.remove(&view);
    }

    /// Decides which of `views` render this frame: the views kept, with why
    /// (in their order), and the idle ones; `registry` holds their schedules,
    /// priorities and names, and the probes' face views.
    pub(crate) fn decide(
        &mut self,
        clock: FrameClock,
        scene: &Scene,
        collection: &FrameCollection,
        views: Vec<ResolvedFrameView>,
        registry: &crate::views::Views,
    ) -> (Vec<(ResolvedFrameView, RenderReason)>, Vec<IdleView>) {
        let schedule_of = |id: ViewId| match registry.entries.get(&id) {
            Some(e) => Scheduled { schedule: e.schedule, priority: e.priority },
            None => Scheduled { schedule: Schedule::EveryFrame, priority: 0 },
        };
        let name_of = |id: ViewId| registry.name(id).map(str::to_owned);
        let probe_faces =
            |probe: oxygen_passes::ProbeId| registry.probes.get(&probe).map(|faces| faces.to_vec()).unwrap_or_default();
        let _span = tracing::info_span!("schedules", views = views.len()).entered();
        // Every view every frame and no budget: nothing to decide or keep
        // (a thousand-camera batch pays nothing for schedules it lacks).
        if self.budget.is_none() && views.iter().all(|v| schedule_of(v.id).schedule == Schedule::EveryFrame) {
            self.seen.clear();
            self.scene = None;
            self.looked_at = None;
            return (views.into_iter().map(|v| (v, RenderReason::EveryFrame)).collect(), Vec::new());
        }
        let watching = views.iter().any(|v| schedule_of(v.id).schedule == Schedule::WhenChanged);
        let changes = if watching { Some(self.scene_changes(scene, collection)) } else { None };
        if !watching {
            // Nothing watches: what the scene looked like is not kept, and
            // the next view that starts watching renders first.
            self.seen.clear();
            self.scene = None;
            self.looked_at = None;
        }
        let now = f64::from(clock.time_seconds);
        let mut decided: Vec<Result<RenderReason, IdleReason>> = Vec::with_capacity(views.len());
        for view in &views {
            let schedule = schedule_of(view.id).schedule;
            let state = self.views.entry(view.id).or_default();
            let missed_frames = state.checked.is_some_and(|c| c + 1 < clock.index);
            state.checked = Some(clock.index);
            let decision = match schedule {
                Schedule::EveryFrame => Ok(RenderReason::EveryFrame),
                _ if state.requested => Ok(RenderReason::Requested),
                Schedule::OnDemand => Err(IdleReason::NotRequested),
                _ if state.first.is_none() => Ok(RenderReason::FirstFrame),
                _ if state.owed => Ok(RenderReason::Due),
                Schedule::EveryNth(n) => {
                    let n = u64::from(n.max(1));
                    let since = clock.index.saturating_sub(state.first.unwrap_or(clock.index)) % n;
                    if since == 0 {
                        Ok(RenderReason::Due)
                    } else {
                        Err(IdleReason::NotDue { next_frame: clock.index + n - since })
                    }
                }
                Schedule::Rate(_) => match state.next_seconds {
                    Some(next) if now < next => Err(IdleReason::RateNotDue { next_seconds: next }),
                    _ => Ok(RenderReason::Due),
                },
                Schedule::Once => Err(IdleReason::NotRequested),
                Schedule::WhenChanged => {
                    let camera = Some((view.world.view_projection, view.world.viewport));
                    let change = state
                        .pending
                        .or_else(|| missed_frames.then_some(Change::Unwatched))
                        .or_else(|| (state.camera != camera).then_some(Change::Camera))
                        .or_else(|| changes.as_ref().and_then(|c| c.for_view(view)));
                    change.map(RenderReason::Changed).ok_or(IdleReason::Unchanged)
                }
            };
            if let Ok(RenderReason::Changed(change)) = decision {
                state.pending = Some(change);
            }
            decided.push(decision);
        }
        // A "when changed" view reading a view (or probe) that renders this
        // frame renders too, after it: until nothing more wakes.
        loop {
            let rendering: HashSet<ViewId> =
                views.iter().zip(&decided).filter(|(_, d)| d.is_ok()).map(|(v, _)| v.id).collect();
            let mut woke = false;
            for (view, decision) in views.iter().zip(decided.iter_mut()) {
                if decision.is_ok() || schedule_of(view.id).schedule != Schedule::WhenChanged {
                    continue;
                }
                let input = view.links.iter().find_map(|link| match *link {
                    OutputSource::View(id) => rendering.contains(&id).then_some(id),
                    OutputSource::Probe(probe) => probe_faces(probe).into_iter().find(|f| rendering.contains(f)),
                });
                if let Some(input) = input {
                    *decision = Ok(RenderReason::Changed(Change::Input(input)));
                    self.views.entry(view.id).or_default().pending = Some(Change::Input(input));
                    woke = true;
                }
            }
            if !woke {
                break;
            }
        }
        if let Some(budget) = self.budget {
            self.apply_budget(budget, &views, &mut decided, &schedule_of);
        }
        let mut kept = Vec::with_capacity(views.len());
        let mut idle = Vec::new();
        for (view, decision) in views.into_iter().zip(decided) {
            let state = self.views.entry(view.id).or_default();
            match decision {
                Ok(reason) => {
                    // A rate counts its periods from the first one, so the
                    // average rate holds; far behind (a pause, a slow or
                    // deferred frame) it counts from now.
                    if let Schedule::Rate(hz) = schedule_of(view.id).schedule
                        && matches!(reason, RenderReason::Due | RenderReason::FirstFrame)
                    {
                        let period = 1.0 / hz;
                        let next = state.next_seconds.map_or(now, |n| n) + period;
                        state.next_seconds = Some(if next <= now { now + period } else { next });
                    }
                    state.deferred = 0;
                    kept.push((view, reason));
                }
                Err(reason) => idle.push(IdleView { view: view.id, name: name_of(view.id), reason }),
            }
        }
        (kept, idle)
    }

    /// Defers the due views of `decided` the budget has no room for (see
    /// [`FrameBudget`]).
    fn apply_budget(
        &mut self,
        budget: FrameBudget,
        views: &[ResolvedFrameView],
        decided: &mut [Result<RenderReason, IdleReason>],
        schedule_of: &impl Fn(ViewId) -> Scheduled,
    ) {
        let mut due: Vec<usize> = (0..views.len()).filter(|i| decided[*i].is_ok()).collect();
        // Those deferred to the bound first, then by priority, then the
        // longest deferred, then by id: the order they get the budget in.
        due.sort_by_key(|i| {
            let id = views[*i].id;
            let deferred = self.views.get(&id).map_or(0, |s| s.deferred);
            (
                deferred < budget.max_deferral,
                std::cmp::Reverse(schedule_of(id).priority),
                std::cmp::Reverse(deferred),
                id,
            )
        });
        // A view never measured is guessed at the mean of those that were.
        let known: Vec<f64> = self.views.values().filter_map(|s| s.cost).collect();
        let guess = if known.is_empty() { 0.0 } else { known.iter().sum::<f64>() / known.len() as f64 };
        let mut spent = 0.0;
        for (k, i) in due.into_iter().enumerate() {
            let schedule = schedule_of(views[i].id).schedule;
            let state = self.views.entry(views[i].id).or_default();
            let cost = state.cost.unwrap_or(guess);
            let forced = state.deferred >= budget.max_deferral;
            if k == 0 || forced || spent + cost <= budget.seconds {
                spent += cost;
                continue;
            }
            state.deferred += 1;
            // Due views stay due; a change or a request stays pending.
            if matches!(schedule, Schedule::EveryNth(_) | Schedule::Rate(_)) {
                state.owed = true;
            }
            decided[i] = Err(IdleReason::Deferred { frames: state.deferred });
        }
    }

    /// `view` rendered in frame `clock` with `world` (its world-space pose).
    pub(crate) fn rendered(&mut self, view: ViewId, clock: FrameClock, world: &oxygen_core::ResolvedView) {
        let state = self.views.entry(view).or_default();
        state.first.get_or_insert(clock.index);
        state.requested = false;
        state.pending = None;
        state.owed = false;
        state.camera = Some((world.view_projection, world.viewport));
    }

    /// What changed since the last frame that looked, and what the scene
    /// looks like now (kept for the next frame).
    fn scene_changes(&mut self, scene: &Scene, collection: &FrameCollection) -> SceneChanges {
        let assets = self.scene != Some((scene.id(), scene.assets_revision())) || self.environment_changed;
        self.scene = Some((scene.id(), scene.assets_revision()));
        self.environment_changed = false;
        // No edit since the last look: nothing moved or changed.
        if self.looked_at == Some((scene.id(), scene.revision())) {
            return SceneChanges { nodes: Vec::new(), light: None, assets };
        }
        self.looked_at = Some((scene.id(), scene.revision()));
        let mut now: HashMap<NodeKey, Seen> = HashMap::with_capacity(self.seen.len());
        let joints_of = |node: &oxygen_core::Node| -> u64 {
            let Some(skin) = &node.skin else { return 0 };
            // Folds the joints' world matrices (their bits) into one value:
            // any joint that moved changes it.
            let mut folded = 0xcbf2_9ce4_8422_2325u64;
            for joint in &skin.joints {
                if let Some(m) = collection.world.get_f64(*joint) {
                    for x in m.to_cols_array() {
                        folded = (folded ^ x.to_bits()).wrapping_mul(0x0000_0100_0000_01b3);
                    }
                }
            }
            folded
        };
        for entry in &collection.renderables {
            let (Some(node), Some(world)) = (scene.node(entry.node), collection.world.get_f64(entry.node)) else {
                continue;
            };
            let seen =
                Seen { world, revision: node.revision(), bounds: Some(entry.world_aabb), joints: joints_of(node) };
            now.insert(entry.node, seen);
        }
        let mut light = None;
        for (key, node) in scene.nodes().filter(|(_, n)| n.light.is_some()) {
            let world = collection.world.get_f64(key).unwrap_or_default();
            let seen = Seen { world, revision: node.revision(), bounds: None, joints: 0 };
            let before = self.seen.get(&key);
            if light.is_none() && before != Some(&seen) {
                light = Some(key);
            }
            now.insert(key, seen);
        }
        let mut nodes = Vec::new();
        for (key, seen) in &now {
            let before = self.seen.get(key);
            if seen.bounds.is_some() && before != Some(seen) {
                nodes.push((*key, before.and_then(|b| b.bounds), seen.bounds));
            }
        }
        for (key, before) in &self.seen {
            if !now.contains_key(key) {
                match before.bounds {
                    // A renderable gone (removed, hidden, no longer renderable).
                    Some(bounds) => nodes.push((*key, Some(bounds), None)),
                    // A light gone.
                    None => light = light.or(Some(*key)),
                }
            }
        }
        // In node order, so that the change a report names does not
        // depend on the map's order.
        nodes.sort_by_key(|(key, _, _)| *key);
        self.seen = now;
        SceneChanges { nodes, light, assets }
    }
}

impl SceneChanges {
    /// The first change `view` sees: an asset, a light, or a renderable
    /// whose bounds, before or after, meet its frustum.
    fn for_view(&self, view: &ResolvedFrameView) -> Option<Change> {
        if self.assets {
            return Some(Change::Assets);
        }
        if let Some(light) = self.light {
            return Some(Change::Light(light));
        }
        let frustum = &view.world.frustum;
        self.nodes.iter().find_map(|(key, before, after)| {
            let meets = |b: &Option<Aabb>| b.as_ref().is_some_and(|b| frustum.intersects_aabb(b));
            (meets(before) || meets(after)).then_some(Change::Node(*key))
        })
    }
}
