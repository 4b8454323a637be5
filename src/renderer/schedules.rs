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
    views: oxygen_core::ViewIdMap<ViewState>,
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
        // (One walk of the registry, not a lookup per view: a thousand
        // lookups a frame were a thousand walks down its tree.)
        if self.budget.is_none() && registry.entries.values().all(|e| e.schedule == Schedule::EveryFrame) {
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
            // Hashes the joints' world matrices (their bits) into one value:
            // any joint that moved changes it (but for a collision, one in
            // 2^64). `DefaultHasher::new` has fixed keys: the same matrices
            // give the same value every frame.
            let mut hasher = std::hash::DefaultHasher::new();
            for joint in &skin.joints {
                if let Some(m) = collection.world.get_f64(*joint) {
                    for x in m.to_cols_array() {
                        std::hash::Hasher::write_u64(&mut hasher, x.to_bits());
                    }
                }
            }
            std::hash::Hasher::finish(&hasher)
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

#[cfg(test)]
mod tests {
    //! The schedules' decisions frame by frame, without a device: views
    //! registered in a [`Views`] registry, resolved and collected on the
    //! CPU as the renderer's first steps do, decided, and the kept ones
    //! marked rendered.

    use std::sync::Arc;

    use oxygen_bindless::SlotAllocators;
    use oxygen_core::glam::{UVec2, Vec3};
    use oxygen_core::{Camera, LookAtResolver, Transform, ViewResolver};
    use oxygen_gpu::LabelSet;
    use oxygen_sceneprep::ScenePrep;

    use super::*;
    use crate::graph::standard_render_graph;
    use crate::renderer::ViewRole;
    use crate::renderer::prepare::TargetPlan;
    use crate::views::{ViewDesc, Views};

    /// What a frame decided: the views kept with why, the idle ones with why.
    type Decided = (Vec<(ViewId, RenderReason)>, Vec<(ViewId, IdleReason)>);

    struct Rig {
        demo: oxygen_demo::DemoScene,
        views: Views,
        schedules: Schedules,
        prep: ScenePrep,
        slots: SlotAllocators,
        frame: u64,
    }

    fn camera() -> LookAtResolver {
        oxygen_demo::main_camera(UVec2::new(32, 24))
    }

    /// A camera looking away from every cube, ground and light.
    fn away() -> LookAtResolver {
        LookAtResolver {
            camera: Camera::perspective(40f32.to_radians(), 0.1, Some(50.0)),
            eye: Vec3::new(0.0, 5.0, -60.0),
            target: Vec3::new(0.0, 5.0, -120.0),
            up: Vec3::Y,
            viewport: UVec2::new(32, 24),
        }
    }

    impl Rig {
        fn new() -> Self {
            Rig {
                demo: oxygen_demo::multi_view_scene(),
                views: Views::new(),
                schedules: Schedules::default(),
                prep: ScenePrep::with_threads(1),
                slots: SlotAllocators::new(128 << 20),
                frame: 0,
            }
        }

        fn add(&mut self, desc: ViewDesc) -> ViewId {
            self.views.register(desc, standard_render_graph).unwrap()
        }

        fn on(&mut self, resolver: impl ViewResolver + 'static, schedule: Schedule) -> ViewId {
            self.add(ViewDesc::new(resolver).with_schedule(schedule))
        }

        /// Frame `self.frame + 1` at `seconds`, every view in it.
        fn at(&mut self, seconds: f32) -> Decided {
            self.without(seconds, &[])
        }

        /// The next frame, a second after the last.
        fn next(&mut self) -> Decided {
            self.at(self.frame as f32 + 1.0)
        }

        /// A frame at `seconds` that leaves `out` out (paused, say).
        fn without(&mut self, seconds: f32, out: &[ViewId]) -> Decided {
            self.frame += 1;
            let clock = FrameClock { index: self.frame, time_seconds: seconds };
            let scene = &self.demo.scene;
            let resolved: Vec<ResolvedFrameView> = self
                .views
                .entries
                .iter()
                .filter(|(id, _)| !out.contains(id))
                .map(|(id, entry)| {
                    let mut world = entry.resolver.resolve(&clock.context(*id), scene).unwrap();
                    world.view_id = *id;
                    ResolvedFrameView {
                        id: *id,
                        name: entry.name.clone(),
                        role: ViewRole::Registered,
                        world,
                        options: entry.options,
                        graph: Arc::clone(&entry.graph),
                        links: entry.links.clone(),
                        target: TargetPlan::Own { with_color: true, samples: 1, labels: LabelSet::NONE },
                    }
                })
                .collect();
            let collection = self.prep.begin_frame(scene, &mut self.slots).unwrap();
            let (kept, idle) = self.schedules.decide(clock, scene, collection, resolved, &self.views);
            for (view, _) in &kept {
                self.schedules.rendered(view.id, clock, &view.world);
            }
            (
                kept.into_iter().map(|(v, reason)| (v.id, reason)).collect(),
                idle.into_iter().map(|v| (v.view, v.reason)).collect(),
            )
        }

        fn lift(&mut self, node: NodeKey, y: f32) {
            self.demo.scene.set_local_transform(node, Transform::from_translation(Vec3::new(0.0, y, 0.0))).unwrap();
        }
    }

    /// A view due every frame with `priority`, as the budget tests rank them.
    fn every_frame(priority: u32) -> ViewDesc {
        ViewDesc::new(camera()).with_schedule(Schedule::EveryNth(1)).with_priority(priority)
    }

    fn why(decided: &Decided, view: ViewId) -> Result<RenderReason, IdleReason> {
        match decided.0.iter().find(|(v, _)| *v == view) {
            Some((_, reason)) => Ok(*reason),
            None => Err(decided.1.iter().find(|(v, _)| *v == view).map(|(_, r)| *r).expect("decided")),
        }
    }

    #[test]
    fn every_frame_views_render_every_frame_and_nothing_is_idle() {
        let mut rig = Rig::new();
        let a = rig.on(camera(), Schedule::EveryFrame);
        let b = rig.on(away(), Schedule::EveryFrame);
        for _ in 0..3 {
            let decided = rig.next();
            assert_eq!(decided.0, [(a, RenderReason::EveryFrame), (b, RenderReason::EveryFrame)]);
            assert!(decided.1.is_empty());
        }
    }

    #[test]
    fn every_nth_renders_first_then_every_nth_frame_from_its_first() {
        let mut rig = Rig::new();
        rig.on(camera(), Schedule::EveryFrame);
        // Joins at frame 2: it renders at 2, 5, 8.
        rig.next();
        let third = rig.on(camera(), Schedule::EveryNth(3));
        let mut seen = Vec::new();
        for _ in 2..=8 {
            seen.push(why(&rig.next(), third));
        }
        let not_due = |next_frame| Err(IdleReason::NotDue { next_frame });
        assert_eq!(
            seen,
            [
                Ok(RenderReason::FirstFrame),
                not_due(5),
                not_due(5),
                Ok(RenderReason::Due),
                not_due(8),
                not_due(8),
                Ok(RenderReason::Due)
            ]
        );
    }

    #[test]
    fn a_rate_counts_periods_from_its_first_and_from_now_when_far_behind() {
        let mut rig = Rig::new();
        let sensor = rig.on(camera(), Schedule::Rate(4.0));
        assert_eq!(why(&rig.at(0.0), sensor), Ok(RenderReason::FirstFrame));
        assert_eq!(why(&rig.at(0.1), sensor), Err(IdleReason::RateNotDue { next_seconds: 0.25 }));
        // Late by 0.05 s: the next is still due at 0.5, not 0.55.
        assert_eq!(why(&rig.at(0.3), sensor), Ok(RenderReason::Due));
        assert_eq!(why(&rig.at(0.45), sensor), Err(IdleReason::RateNotDue { next_seconds: 0.5 }));
        assert_eq!(why(&rig.at(0.5), sensor), Ok(RenderReason::Due));
        // Three periods late: from now (2.0), so the next is at 2.25.
        assert_eq!(why(&rig.at(2.0), sensor), Ok(RenderReason::Due));
        assert_eq!(why(&rig.at(2.2), sensor), Err(IdleReason::RateNotDue { next_seconds: 2.25 }));
    }

    #[test]
    fn once_and_on_demand_views_render_when_asked() {
        let mut rig = Rig::new();
        let once = rig.on(camera(), Schedule::Once);
        let asked = rig.on(camera(), Schedule::OnDemand);
        let first = rig.next();
        assert_eq!(why(&first, once), Ok(RenderReason::FirstFrame));
        assert_eq!(why(&first, asked), Err(IdleReason::NotRequested), "on demand: not even a first frame");
        let second = rig.next();
        assert_eq!(why(&second, once), Err(IdleReason::NotRequested));
        rig.schedules.request(once);
        rig.schedules.request(asked);
        let third = rig.next();
        assert_eq!(why(&third, once), Ok(RenderReason::Requested));
        assert_eq!(why(&third, asked), Ok(RenderReason::Requested));
        // A request is for one frame.
        let fourth = rig.next();
        assert_eq!(why(&fourth, once), Err(IdleReason::NotRequested));
        assert_eq!(why(&fourth, asked), Err(IdleReason::NotRequested));
        // A request beats a rate that is not due, too.
        let sensor = rig.on(camera(), Schedule::Rate(0.001));
        rig.at(100.0);
        rig.schedules.request(sensor);
        assert_eq!(why(&rig.at(101.0), sensor), Ok(RenderReason::Requested));
    }

    #[test]
    fn when_changed_follows_its_camera_the_nodes_it_sees_lights_and_assets() {
        let mut rig = Rig::new();
        let watcher = rig.on(camera(), Schedule::WhenChanged);
        let elsewhere = rig.on(away(), Schedule::WhenChanged);
        let first = rig.next();
        assert_eq!(why(&first, watcher), Ok(RenderReason::FirstFrame));
        assert_eq!(why(&first, elsewhere), Ok(RenderReason::FirstFrame));
        let still = rig.next();
        assert_eq!(why(&still, watcher), Err(IdleReason::Unchanged));
        assert_eq!(why(&still, elsewhere), Err(IdleReason::Unchanged));
        // A cube in view moves: the watcher renders, the other does not.
        let cube = rig.demo.cubes[4];
        rig.lift(cube, 2.0);
        let moved = rig.next();
        assert_eq!(why(&moved, watcher), Ok(RenderReason::Changed(Change::Node(cube))));
        assert_eq!(why(&moved, elsewhere), Err(IdleReason::Unchanged));
        assert_eq!(why(&rig.next(), watcher), Err(IdleReason::Unchanged), "seen once, then still");
        // Its camera moves.
        rig.views.entries.get_mut(&watcher).unwrap().resolver =
            Box::new(LookAtResolver { eye: Vec3::new(5.0, 7.0, 12.0), ..camera() });
        assert_eq!(why(&rig.next(), watcher), Ok(RenderReason::Changed(Change::Camera)));
        // The light moves: every watcher renders.
        let sun = rig.demo.sun;
        rig.lift(sun, 9.0);
        let lit = rig.next();
        assert_eq!(why(&lit, watcher), Ok(RenderReason::Changed(Change::Light(sun))));
        assert_eq!(why(&lit, elsewhere), Ok(RenderReason::Changed(Change::Light(sun))));
        // The environment changes: every watcher renders, once.
        rig.schedules.environment_changed();
        let environment = rig.next();
        assert_eq!(why(&environment, watcher), Ok(RenderReason::Changed(Change::Assets)));
        assert_eq!(why(&environment, elsewhere), Ok(RenderReason::Changed(Change::Assets)));
        assert_eq!(why(&rig.next(), elsewhere), Err(IdleReason::Unchanged));
    }

    #[test]
    fn a_node_leaving_or_entering_the_view_wakes_it_and_a_removed_one_too() {
        let mut rig = Rig::new();
        let watcher = rig.on(camera(), Schedule::WhenChanged);
        rig.next();
        // Out of every view: seen where it was (in view), so it wakes.
        let cube = rig.demo.cubes[0];
        rig.lift(cube, -500.0);
        assert_eq!(why(&rig.next(), watcher), Ok(RenderReason::Changed(Change::Node(cube))));
        // Moving about out of view: nothing.
        rig.lift(cube, -600.0);
        assert_eq!(why(&rig.next(), watcher), Err(IdleReason::Unchanged));
        // Back into view, from out of it.
        rig.lift(cube, 1.0);
        assert_eq!(why(&rig.next(), watcher), Ok(RenderReason::Changed(Change::Node(cube))));
        // Gone from the scene.
        rig.demo.scene.remove_node(cube).unwrap();
        assert_eq!(why(&rig.next(), watcher), Ok(RenderReason::Changed(Change::Node(cube))));
        assert_eq!(why(&rig.next(), watcher), Err(IdleReason::Unchanged));
    }

    #[test]
    fn a_moved_joint_wakes_the_watchers_of_its_skinned_mesh() {
        use oxygen_core::glam::{Mat4, Vec4};
        use oxygen_core::{Geometry, Material, Renderable, Skin, SkinWeights};
        let mut rig = Rig::new();
        let scene = &mut rig.demo.scene;
        let cube = Geometry::cube(1.0);
        // Every vertex follows the first joint; the second moves nothing.
        let weights = vec![SkinWeights::new([0, 1, 0, 0], [1.0, 0.0, 0.0, 0.0]); cube.vertices().len()];
        let geometry = scene.add_geometry(cube.with_skin_weights(weights).unwrap());
        let material = scene.add_material(Material::opaque("skin", Vec4::ONE));
        let held = scene.add_node("held", Transform::from_translation(Vec3::new(0.0, 1.0, 0.0)));
        let idle = scene.add_node("idle", Transform::IDENTITY);
        let mesh = scene.add_node("skinned", Transform::IDENTITY);
        scene.set_renderable(mesh, Renderable { geometry, materials: vec![material] }).unwrap();
        let skin = Skin { joints: vec![held, idle], inverse_bind_matrices: vec![Mat4::IDENTITY; 2] };
        scene.set_skin(mesh, Some(skin)).unwrap();
        let watcher = rig.on(camera(), Schedule::WhenChanged);
        rig.next();
        assert_eq!(why(&rig.next(), watcher), Err(IdleReason::Unchanged));
        // A joint moved: the mesh's pose changed, whatever its bounds did.
        rig.demo.scene.set_local_transform(idle, Transform::from_translation(Vec3::X)).unwrap();
        assert_eq!(why(&rig.next(), watcher), Ok(RenderReason::Changed(Change::Node(mesh))));
        assert_eq!(why(&rig.next(), watcher), Err(IdleReason::Unchanged));
    }

    #[test]
    fn a_watcher_left_out_of_a_frame_renders_when_it_comes_back() {
        let mut rig = Rig::new();
        let watcher = rig.on(camera(), Schedule::WhenChanged);
        let other = rig.on(camera(), Schedule::WhenChanged);
        rig.next();
        rig.next();
        let (kept, _) = rig.without(3.0, &[watcher]);
        assert!(kept.is_empty());
        let back = rig.at(4.0);
        assert_eq!(why(&back, watcher), Ok(RenderReason::Changed(Change::Unwatched)));
        assert_eq!(why(&back, other), Err(IdleReason::Unchanged), "it watched every frame");
    }

    #[test]
    fn a_watcher_reading_a_view_that_renders_renders_after_it() {
        let mut rig = Rig::new();
        let source = rig.on(camera(), Schedule::EveryNth(2));
        let reader = rig.add(ViewDesc::new(away()).with_schedule(Schedule::WhenChanged).reads(source.color()));
        let chained = rig.add(ViewDesc::new(away()).with_schedule(Schedule::WhenChanged).reads(reader.color()));
        rig.next();
        // Frame 2: the source is not due, so nothing reads anything new.
        let idle = rig.next();
        assert_eq!(why(&idle, reader), Err(IdleReason::Unchanged));
        assert_eq!(why(&idle, chained), Err(IdleReason::Unchanged));
        // Frame 3: the source renders, the reader after it, and its reader.
        let woke = rig.next();
        assert_eq!(why(&woke, source), Ok(RenderReason::Due));
        assert_eq!(why(&woke, reader), Ok(RenderReason::Changed(Change::Input(source))));
        assert_eq!(why(&woke, chained), Ok(RenderReason::Changed(Change::Input(reader))));
    }

    #[test]
    fn views_that_are_not_watched_forget_the_scene_and_a_new_watcher_renders_first() {
        let mut rig = Rig::new();
        let nth = rig.on(camera(), Schedule::EveryNth(2));
        rig.next();
        rig.next();
        assert!(rig.schedules.seen.is_empty() && rig.schedules.scene.is_none(), "nothing watches");
        let watcher = rig.on(camera(), Schedule::WhenChanged);
        let decided = rig.next();
        assert_eq!(why(&decided, watcher), Ok(RenderReason::FirstFrame));
        assert_eq!(why(&decided, nth), Ok(RenderReason::Due));
        assert!(!rig.schedules.seen.is_empty(), "a watcher keeps what the scene looked like");
        // Every view every frame again: nothing kept.
        rig.schedules.forget(watcher);
        rig.views.entries.remove(&watcher);
        rig.views.entries.remove(&nth);
        rig.on(camera(), Schedule::EveryFrame);
        rig.next();
        assert!(rig.schedules.seen.is_empty() && rig.schedules.looked_at.is_none());
    }

    #[test]
    fn measurements_average_and_nonsense_is_ignored() {
        let mut schedules = Schedules::default();
        let view = oxygen_demo::view_id(1);
        schedules.measured(view, 0.004);
        schedules.measured(view, f64::NAN);
        schedules.measured(view, -1.0);
        schedules.measured(view, f64::INFINITY);
        assert_eq!(schedules.views[&view].cost, Some(0.004));
        schedules.measured(view, 0.008);
        assert_eq!(schedules.views[&view].cost, Some(0.75 * 0.004 + 0.25 * 0.008));
        schedules.measured(view, 0.0);
        assert_eq!(schedules.views[&view].cost, Some(0.75 * (0.75 * 0.004 + 0.25 * 0.008)));
        schedules.forget(view);
        assert!(!schedules.views.contains_key(&view));
        assert!(!schedules.budgeted());
        schedules.set_budget(Some(FrameBudget { seconds: 0.01, max_deferral: 2 }));
        assert!(schedules.budgeted());
        schedules.set_budget(None);
        assert!(!schedules.budgeted());
    }

    #[test]
    fn a_budget_keeps_the_first_view_then_what_fits_by_priority_and_defers_the_rest_boundedly() {
        let mut rig = Rig::new();
        let low = rig.add(every_frame(1));
        let high = rig.add(every_frame(5));
        let mid = rig.add(every_frame(3));
        rig.schedules.set_budget(Some(FrameBudget { seconds: 0.005, max_deferral: 2 }));
        for view in [low, high, mid] {
            rig.schedules.measured(view, 0.003);
        }
        // Room for one of 3 ms in 5 ms after the first: by priority, high
        // (always kept, first) and mid; low is deferred.
        let first = rig.next();
        assert_eq!(why(&first, high), Ok(RenderReason::FirstFrame));
        assert_eq!(why(&first, mid), Err(IdleReason::Deferred { frames: 1 }), "3 + 3 > 5");
        assert_eq!(why(&first, low), Err(IdleReason::Deferred { frames: 1 }));
        // Deferred views stay due; the longest deferred of equal priority go first.
        let second = rig.next();
        assert_eq!(why(&second, high), Ok(RenderReason::Due));
        assert_eq!(why(&second, mid), Err(IdleReason::Deferred { frames: 2 }));
        assert_eq!(why(&second, low), Err(IdleReason::Deferred { frames: 2 }));
        // At the bound (2 frames) they render, whatever the budget.
        let third = rig.next();
        assert_eq!(why(&third, mid), Ok(RenderReason::FirstFrame));
        assert_eq!(why(&third, low), Ok(RenderReason::FirstFrame));
        // Rendered: their deferral starts again.
        assert_eq!(rig.schedules.views[&low].deferred, 0);
        // A view never measured is guessed at the mean of those that were
        // (3 ms): 3 + 3 > 5, so it waits.
        let new = rig.add(every_frame(4));
        let fourth = rig.next();
        assert_eq!(why(&fourth, high), Ok(RenderReason::Due));
        assert_eq!(why(&fourth, new), Err(IdleReason::Deferred { frames: 1 }));
    }

    #[test]
    fn views_deferred_to_the_bound_take_the_budget_first() {
        let mut rig = Rig::new();
        let (first, middle, last) = (rig.add(every_frame(9)), rig.add(every_frame(5)), rig.add(every_frame(1)));
        rig.schedules.measured(first, 0.003);
        rig.schedules.measured(middle, 0.001);
        rig.schedules.measured(last, 0.003);
        rig.schedules.set_budget(Some(FrameBudget { seconds: 0.005, max_deferral: 1 }));
        // By priority: 3 ms, then 1 ms (4), then 3 more do not fit.
        let one = rig.next();
        assert_eq!(why(&one, last), Err(IdleReason::Deferred { frames: 1 }));
        // At its bound it goes first (3 ms); the first by priority (3 more)
        // no longer fits, the middle one (1 ms) does.
        let two = rig.next();
        assert_eq!(why(&two, last), Ok(RenderReason::FirstFrame));
        assert_eq!(why(&two, first), Err(IdleReason::Deferred { frames: 1 }));
        assert_eq!(why(&two, middle), Ok(RenderReason::Due));
    }

    #[test]
    fn an_unmeasured_view_is_guessed_at_the_mean_cost() {
        let mut rig = Rig::new();
        let (high, new, low) = (rig.add(every_frame(9)), rig.add(every_frame(5)), rig.add(every_frame(1)));
        rig.schedules.measured(high, 0.001);
        rig.schedules.measured(low, 0.001);
        rig.schedules.set_budget(Some(FrameBudget { seconds: 0.0025, max_deferral: 4 }));
        // The new one counts 1 ms (the mean): 1 + 1 fits in 2.5, the third
        // 1 ms does not.
        let decided = rig.next();
        assert_eq!(why(&decided, high), Ok(RenderReason::FirstFrame));
        assert_eq!(why(&decided, new), Ok(RenderReason::FirstFrame));
        assert_eq!(why(&decided, low), Err(IdleReason::Deferred { frames: 1 }));
    }

    #[test]
    fn a_view_deferred_when_due_is_owed_until_it_renders() {
        let mut rig = Rig::new();
        let first = rig.add(every_frame(9));
        let third = rig.add(ViewDesc::new(camera()).with_priority(1).with_schedule(Schedule::EveryNth(3)));
        rig.schedules.measured(first, 0.004);
        rig.schedules.measured(third, 0.004);
        // Frame 1 renders both (no budget yet); frames 2 and 3 are not due.
        assert_eq!(why(&rig.next(), third), Ok(RenderReason::FirstFrame));
        rig.next();
        rig.next();
        rig.schedules.set_budget(Some(FrameBudget { seconds: 0.005, max_deferral: 9 }));
        // Frame 4: due, deferred; frame 5, not due by its count, but owed.
        assert_eq!(why(&rig.next(), third), Err(IdleReason::Deferred { frames: 1 }));
        rig.schedules.set_budget(None);
        assert_eq!(why(&rig.next(), third), Ok(RenderReason::Due));
        // Rendered: frame 6 is not due again.
        assert_eq!(why(&rig.next(), third), Err(IdleReason::NotDue { next_frame: 7 }));
    }

    #[test]
    fn a_budget_with_room_defers_nothing_and_a_cheap_view_fits_beside_a_dear_one() {
        let mut rig = Rig::new();
        let dear = rig.add(every_frame(2));
        let cheap = rig.add(every_frame(1));
        rig.schedules.measured(dear, 0.004);
        rig.schedules.measured(cheap, 0.001);
        rig.schedules.set_budget(Some(FrameBudget { seconds: 0.005, max_deferral: 3 }));
        // 4 + 1 is exactly the budget: both render.
        let decided = rig.next();
        assert_eq!(why(&decided, dear), Ok(RenderReason::FirstFrame));
        assert_eq!(why(&decided, cheap), Ok(RenderReason::FirstFrame));
        assert!(decided.1.is_empty());
    }
}
