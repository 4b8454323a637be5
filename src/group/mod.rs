//! Views spread over several GPUs in one process: a [`RendererGroup`].
//!
//! A group holds one [`Renderer`] per device ([`GpuContext::new_headless_many`]:
//! one device per GPU of the machine, or several devices of its one GPU)
//! and places each of its views on one of them. Every frame it sends the
//! scene's changes to the members as one [`SceneDelta`] (the same bytes a
//! render node on another machine would receive; the first member renders
//! the application's scene itself, the others a [`SceneReplica`] each),
//! renders the members concurrently, and gathers each view's report and
//! outputs tagged with the view and the frame.
//!
//! **Placement** uses each view's measured cost: a new view goes to the
//! member with the least load (the sum of its views' costs, a view not yet
//! measured counted at the mean of those that were); after each frame each
//! rendered view's cost (its prepare, record and GPU seconds, smoothed over
//! frames) is updated, and when the most loaded member carries more than
//! [`RendererGroup::set_rebalance_margin`] above the least loaded one, the
//! view whose move best evens them moves (one a frame: it re-registers on
//! its new member, which renders it from the next frame). In the
//! deterministic mode ([`RendererOptions::deterministic`]) a view renders
//! the same pixels whichever member renders it, on members of one kind of
//! adapter and driver.
//!
//! A group's views are independent of each other: a view that reads
//! another view's outputs (a link) is refused, since the two could land on
//! different devices. Their own shadow cascades render with them.

mod placement;

use std::collections::BTreeMap;
use std::sync::Arc;

use oxygen_core::Scene;
use oxygen_core::ViewId;
use oxygen_core::scene::delta::{DeltaStream, SceneDelta, SceneReplica};
use oxygen_gpu::{GpuContext, GpuOptions};
use tracing::info_span;

use crate::graph::RenderGraph;
use crate::views::ViewDesc;
use crate::{DepthImage, FrameReport, LabelImage, RenderError, Renderer, RendererOptions, ViewReport};
use placement::Placement;

/// A view of a [`RendererGroup`] (its members number their own views).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct GroupViewId(pub u32);

impl std::fmt::Display for GroupViewId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "group-view#{}", self.0)
    }
}

/// A view's output with where and when it was rendered.
#[derive(Clone, Debug, PartialEq)]
pub struct Tagged<T> {
    /// The view.
    pub view: GroupViewId,
    /// The group frame it was rendered in (counting from 1).
    pub frame: u64,
    /// The member that rendered it.
    pub member: usize,
    /// The output.
    pub value: T,
}

/// What one view did in a group's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct GroupViewReport {
    /// The view.
    pub view: GroupViewId,
    /// The member that rendered it.
    pub member: usize,
    /// Its member's report of it.
    pub report: ViewReport,
}

/// What a group's frame did.
#[derive(Clone, Debug)]
pub struct GroupFrameReport {
    /// The group frame (counting from 1).
    pub frame: u64,
    /// Every view the members rendered, each once, by group view.
    pub views: Vec<GroupViewReport>,
    /// Each member's whole report (shadow views included).
    pub members: Vec<FrameReport>,
    /// Bytes of the frame's scene delta, as encoded for the wire (0 when
    /// the scene did not change).
    pub delta_bytes: usize,
    /// Seconds making, encoding and applying the delta on every replica.
    pub replicate_seconds: f64,
    /// Seconds from the first member starting to the last finishing.
    pub render_seconds: f64,
    /// Views moved after this frame: (view, from member, to member).
    pub moved: Vec<(GroupViewId, usize, usize)>,
}

/// Registers a view on a member (the group's recipe for re-registering a
/// view it moves).
type Register = Arc<dyn Fn(&mut Renderer) -> Result<ViewId, RenderError> + Send + Sync>;

struct Member {
    renderer: Renderer,
    /// `None` for the first member, which renders the application's scene.
    replica: Option<SceneReplica>,
}

/// Several renderers, one per device, sharing a scene by deltas and
/// splitting the views between them (see the module docs).
pub struct RendererGroup {
    members: Vec<Member>,
    /// Where each view is and what it costs.
    placement: Placement<ViewId>,
    /// How to register each view again when it moves.
    registers: BTreeMap<GroupViewId, Register>,
    stream: DeltaStream,
    frame: u64,
    /// Members render one after another (GL: one EGL context per thread).
    sequential: bool,
}

impl RendererGroup {
    /// A group of `devices` headless renderers with `options` each, one
    /// device per GPU of the machine while there are GPUs
    /// ([`GpuContext::new_headless_many`]).
    pub fn new_headless(devices: usize, options: RendererOptions) -> Result<Self, RenderError> {
        Self::new_headless_spread(devices, options, true)
    }

    /// As [`RendererGroup::new_headless`], with `spread` false: every device
    /// on one GPU, however many the machine has (to measure what the
    /// members' own CPU threads gain apart from more GPUs).
    pub fn new_headless_spread(devices: usize, options: RendererOptions, spread: bool) -> Result<Self, RenderError> {
        let _span = info_span!("renderer_group", devices, spread).entered();
        if devices == 0 {
            return Err(RenderError::Unsupported("a renderer group needs at least one device".into()));
        }
        let gpu_options = GpuOptions {
            optional_features: Renderer::OPTIONAL_FEATURES,
            trust_indirect_args: options.trust_indirect_args,
            ..Default::default()
        };
        let contexts = GpuContext::new_headless_group(&gpu_options, devices, spread)?;
        let sequential = contexts.iter().any(|c| c.adapter_info.backend == wgpu::Backend::Gl);
        let mut members = Vec::with_capacity(devices);
        for (i, context) in contexts.into_iter().enumerate() {
            let renderer = Renderer::with_options(context, options)?;
            members.push(Member { renderer, replica: (i > 0).then(SceneReplica::new) });
        }
        Ok(RendererGroup {
            placement: Placement::new(members.len()),
            members,
            registers: BTreeMap::new(),
            stream: DeltaStream::new(),
            frame: 0,
            sequential,
        })
    }

    /// The members' devices.
    pub fn devices(&self) -> usize {
        self.members.len()
    }

    /// Member `index`'s renderer (for its adapter, its options, its views'
    /// reads).
    pub fn renderer(&self, index: usize) -> Option<&Renderer> {
        self.members.get(index).map(|m| &m.renderer)
    }

    /// The scene member `index` renders: `None` for the first, which
    /// renders the application's scene itself, and past the last; each
    /// other member's replica, which the frames' deltas keep equal to the
    /// application's.
    pub fn replica(&self, index: usize) -> Option<&Scene> {
        self.members.get(index)?.replica.as_ref().map(SceneReplica::scene)
    }

    /// The rebalance margin in force ([`RendererGroup::set_rebalance_margin`]).
    pub fn rebalance_margin(&self) -> f64 {
        self.placement.margin
    }

    /// How far (a fraction, default 0.25) the most loaded member may carry
    /// more than the least loaded before a view moves; `f64::INFINITY`
    /// never moves one.
    pub fn set_rebalance_margin(&mut self, margin: f64) {
        self.placement.set_margin(margin);
    }

    /// Registers a view made by `desc` (called again if the view moves to
    /// another member) with `graph`, on the least loaded member. A view
    /// with links to other views is refused (see the module docs).
    pub fn register_view<G>(
        &mut self,
        desc: impl Fn() -> ViewDesc + Send + Sync + 'static,
        graph: G,
    ) -> Result<GroupViewId, RenderError>
    where
        G: RenderGraph + Clone,
    {
        if !desc().links.is_empty() {
            return Err(RenderError::Unsupported(
                "a renderer group's views cannot read other views (they may render on other devices)".into(),
            ));
        }
        let register: Register = Arc::new(move |renderer: &mut Renderer| renderer.register_view(desc(), graph.clone()));
        let member = self.placement.lightest(None);
        let id = register(&mut self.members[member].renderer)?;
        let view = self.placement.add(member, id);
        self.registers.insert(view, register);
        Ok(view)
    }

    /// Removes a view from its member.
    pub fn unregister_view(&mut self, view: GroupViewId) -> Result<(), RenderError> {
        let placed = self.placement.remove(view).ok_or_else(|| no_such(view))?;
        self.registers.remove(&view);
        // Both registrations go even when the first refuses (none is left
        // behind); the first error is returned.
        let old = match placed.paused() {
            Some((member, id)) => self.members[member].renderer.unregister_view(id),
            None => Ok(()),
        };
        let current = self.members[placed.member].renderer.unregister_view(placed.id);
        old.and(current)
    }

    /// The member rendering `view`.
    pub fn member_of(&self, view: GroupViewId) -> Option<usize> {
        self.placement.get(view).map(|p| p.member)
    }

    /// Moves `view` to member `member` now: it renders there from the next
    /// frame, and its image stays readable on its old member (paused there)
    /// until then. What the automatic placement does, by hand.
    pub fn place(&mut self, view: GroupViewId, member: usize) -> Result<(), RenderError> {
        if member >= self.members.len() {
            return Err(RenderError::Unsupported(format!("member {member} of a group of {}", self.members.len())));
        }
        let register = self.registers.get(&view).map(Arc::clone).ok_or_else(|| no_such(view))?;
        let Some(plan) = self.placement.plan_move(view, member) else {
            return Ok(());
        };
        let id = match plan.resume {
            Some(id) => {
                self.members[member].renderer.set_view_active(id, true)?;
                id
            }
            None => register(&mut self.members[member].renderer)?,
        };
        let (from, old) = plan.from;
        let left = if plan.pause_left {
            // Rendered there: kept, paused, until the new member renders it.
            self.members[from].renderer.set_view_active(old, false)
        } else {
            self.members[from].renderer.unregister_view(old)
        };
        if let Err(e) = left {
            // The view stays where it was: the new registration goes, or
            // the old image's, resumed above, pauses again.
            let undo = if plan.resume.is_some() {
                self.members[member].renderer.set_view_active(id, false)
            } else {
                self.members[member].renderer.unregister_view(id)
            };
            undo.ok();
            return Err(e);
        }
        self.placement.moved(view, member, id);
        Ok(())
    }

    /// `view`'s measured cost in seconds a frame (its prepare, record and
    /// GPU time, smoothed over the frames it rendered); `None` before its
    /// first frame.
    pub fn view_cost(&self, view: GroupViewId) -> Option<f64> {
        self.placement.get(view)?.cost
    }

    /// Each member's load, as placement weighs it: the sum of its views'
    /// costs ([`RendererGroup::view_cost`]; a view not yet measured at the
    /// mean of those that were, 1 s when none was).
    pub fn member_loads(&self) -> Vec<f64> {
        self.placement.loads(None)
    }

    /// Renders one frame of `scene` through every view: the scene's
    /// changes go to the replicas as one delta, the members render
    /// concurrently, their reports are gathered by group view, and a view
    /// may move to even the load (see the module docs).
    pub fn render_frame(&mut self, scene: &Scene) -> Result<GroupFrameReport, RenderError> {
        let _span = info_span!("group_frame", members = self.members.len(), views = self.placement.len()).entered();
        self.frame += 1;
        let started = std::time::Instant::now();
        let mut delta_bytes = 0;
        if self.members.len() > 1 {
            let delta = self.stream.next(scene);
            let unchanged = delta.base != 0 && delta.ops.is_empty() && delta.nodes.is_empty();
            if !unchanged {
                // What crosses a wire, decoded as a receiver would.
                let bytes = delta.encode();
                delta_bytes = bytes.len();
                // Every replica gets the delta, even after one fails, so
                // that none misses the asset bodies it carries.
                let applied = SceneDelta::decode(&bytes).and_then(|delta| {
                    let results: Vec<_> =
                        self.members.iter_mut().filter_map(|m| m.replica.as_mut()).map(|r| r.apply(&delta)).collect();
                    results.into_iter().collect::<Result<(), _>>()
                });
                if let Err(e) = applied {
                    // A replica that failed waits for a snapshot: the next
                    // frame sends one, with every asset body again.
                    self.stream = DeltaStream::new();
                    return Err(replica_error(e));
                }
            }
        }
        let replicate_seconds = started.elapsed().as_secs_f64();

        let rendering = std::time::Instant::now();
        let results: Vec<Result<FrameReport, RenderError>> = if self.sequential {
            self.members.iter_mut().map(|m| render_member(m, scene)).collect()
        } else {
            std::thread::scope(|threads| {
                let handles: Vec<_> =
                    self.members.iter_mut().map(|m| threads.spawn(move || render_member(m, scene))).collect();
                handles
                    .into_iter()
                    .map(|h| h.join().unwrap_or_else(|_| Err(RenderError::Unsupported("a member panicked".into()))))
                    .collect()
            })
        };
        let render_seconds = rendering.elapsed().as_secs_f64();
        let members: Vec<FrameReport> = results.into_iter().collect::<Result<_, _>>()?;

        // Each member's views back to group views; costs updated.
        let renders: Vec<(usize, ViewId, f64)> = members
            .iter()
            .enumerate()
            .flat_map(|(member, report)| {
                report
                    .views
                    .iter()
                    .map(move |v| (member, v.view, v.prep_seconds + v.record_seconds + v.gpu_seconds.unwrap_or(0.0)))
            })
            .collect();
        let (group_views, stale) = self.placement.rendered(self.frame, &renders);
        let member_views =
            members.iter().enumerate().flat_map(|(member, report)| report.views.iter().map(move |v| (member, v)));
        let mut views: Vec<GroupViewReport> = group_views
            .into_iter()
            .zip(member_views)
            .filter_map(|(view, (member, report))| {
                Some(GroupViewReport { view: view?, member, report: report.clone() })
            })
            .collect();
        views.sort_by_key(|v| v.view);
        // Rendered where they now live: the old registrations, paused
        // since their moves, go.
        for (member, id) in stale {
            self.members[member].renderer.unregister_view(id)?;
        }
        let moved = self.rebalance()?;
        Ok(GroupFrameReport {
            frame: self.frame,
            views,
            members,
            delta_bytes,
            replicate_seconds,
            render_seconds,
            moved,
        })
    }

    /// Moves at most one view ([`best_move`]) to even the members' loads.
    fn rebalance(&mut self) -> Result<Vec<(GroupViewId, usize, usize)>, RenderError> {
        let Some((view, from, to)) = self.placement.next_move() else {
            return Ok(Vec::new());
        };
        self.place(view, to)?;
        Ok(vec![(view, from, to)])
    }

    /// Where `view`'s latest image is, and the frame it is from.
    fn placed(&self, view: GroupViewId) -> Result<(&Renderer, ViewId, usize, u64), RenderError> {
        let placed = self.placement.get(view).ok_or_else(|| no_such(view))?;
        let (member, id) = placed.readable();
        Ok((&self.members[member].renderer, id, member, placed.rendered))
    }

    /// `view`'s colour image, tagged with the frame and member that
    /// rendered it (waits for that member's GPU).
    pub fn read_color(&self, view: GroupViewId) -> Result<Tagged<image::RgbaImage>, RenderError> {
        let (renderer, id, member, frame) = self.placed(view)?;
        Ok(Tagged { view, frame, member, value: renderer.read_color(id)? })
    }

    /// `view`'s label planes, tagged (see [`Renderer::read_labels`]).
    pub fn read_labels(&self, view: GroupViewId) -> Result<Tagged<LabelImage>, RenderError> {
        let (renderer, id, member, frame) = self.placed(view)?;
        Ok(Tagged { view, frame, member, value: renderer.read_labels(id)? })
    }

    /// `view`'s depth, tagged (see [`Renderer::read_depth`]).
    pub fn read_depth(&self, view: GroupViewId) -> Result<Tagged<DepthImage>, RenderError> {
        let (renderer, id, member, frame) = self.placed(view)?;
        Ok(Tagged { view, frame, member, value: renderer.read_depth(id)? })
    }

    /// Every view's colour image, in view order, tagged: the frame's
    /// outputs gathered from every member.
    pub fn gather_colors(&self) -> Result<Vec<Tagged<image::RgbaImage>>, RenderError> {
        let _span = info_span!("gather_colors", views = self.placement.len()).entered();
        self.placement.views().map(|(view, _)| self.read_color(view)).collect()
    }
}

/// The move placement makes after a frame, given each member's load and
/// each view's member and measured cost: when the most loaded member
/// carries more than `margin` above the least loaded, the measured view of
/// the first whose move to the second leaves the smallest gap, if that gap
/// is smaller than the one it closes; otherwise none. Returned as (view,
/// from, to). The same rule places the views of render nodes
/// (`oxygen-node`).
pub fn best_move(
    loads: &[f64],
    views: &[(GroupViewId, usize, Option<f64>)],
    margin: f64,
) -> Option<(GroupViewId, usize, usize)> {
    let order = |a: &usize, b: &usize| loads[*a].total_cmp(&loads[*b]);
    let heavy = (0..loads.len()).max_by(order)?;
    let light = (0..loads.len()).min_by(order)?;
    if heavy == light || loads[heavy] <= loads[light] * (1.0 + margin) {
        return None;
    }
    let gap = loads[heavy] - loads[light];
    let (view, after) = views
        .iter()
        .filter(|(_, member, _)| *member == heavy)
        .filter_map(|(id, _, cost)| cost.map(|c| (*id, (gap - 2.0 * c).abs())))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    (after < gap).then_some((view, heavy, light))
}

fn render_member(member: &mut Member, scene: &Scene) -> Result<FrameReport, RenderError> {
    let scene = member.replica.as_ref().map_or(scene, SceneReplica::scene);
    member.renderer.render_frame(scene)
}

fn no_such(view: GroupViewId) -> RenderError {
    RenderError::Unsupported(format!("{view} is not registered with this group"))
}

fn replica_error(e: oxygen_core::scene::delta::DeltaError) -> RenderError {
    RenderError::Unsupported(format!("replicating the scene: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn view(id: u32, member: usize, cost: f64) -> (GroupViewId, usize, Option<f64>) {
        (GroupViewId(id), member, Some(cost))
    }

    #[test]
    fn group_view_ids_print_with_their_number() {
        assert_eq!(GroupViewId(12).to_string(), "group-view#12");
    }

    #[test]
    fn a_group_of_no_device_is_refused_before_any_gpu_is_asked() {
        let refused = RendererGroup::new_headless(0, RendererOptions::default());
        assert!(matches!(refused, Err(RenderError::Unsupported(_))));
    }

    #[test]
    fn the_move_that_best_evens_the_loads_is_made() {
        // 8 + 1 + 1 against 1 + 1 + 1: moving a 1 leaves 10 - 3 - 2 = 5,
        // better than the 7 now; moving the 8 would leave 9.
        let views =
            [view(0, 0, 8.0), view(1, 0, 1.0), view(2, 0, 1.0), view(3, 1, 1.0), view(4, 1, 1.0), view(5, 1, 1.0)];
        assert_eq!(best_move(&[10.0, 3.0], &views, 0.25), Some((GroupViewId(1), 0, 1)));
        // 8 alone against 5 ones: no move narrows the gap of 3 (moving the 8
        // leaves 13).
        let settled =
            [view(0, 0, 8.0), view(1, 1, 1.0), view(2, 1, 1.0), view(3, 1, 1.0), view(4, 1, 1.0), view(5, 1, 1.0)];
        assert_eq!(best_move(&[8.0, 5.0], &settled, 0.25), None);
        // Within the margin: nothing moves.
        assert_eq!(best_move(&[1.2, 1.0], &[view(0, 0, 0.6), view(1, 0, 0.6), view(2, 1, 1.0)], 0.25), None);
        // Unmeasured views stay; a third member is the lightest.
        let unmeasured = [(GroupViewId(0), 0, None), view(1, 0, 2.0), view(2, 1, 1.0)];
        assert_eq!(best_move(&[4.0, 1.0, 0.0], &unmeasured, 0.25), Some((GroupViewId(1), 0, 2)));
    }

    #[test]
    fn the_margin_is_a_fraction_of_the_lightest_load_and_a_move_must_narrow_the_gap() {
        // 12 against 10 is within 25 % of 10 (12.5): nothing moves, though
        // moving the 1 would even them.
        let views = [view(0, 0, 1.0), view(1, 0, 11.0), view(2, 1, 10.0)];
        assert_eq!(best_move(&[12.0, 10.0], &views, 0.25), None);
        assert_eq!(best_move(&[12.0, 10.0], &views, 0.1), Some((GroupViewId(0), 0, 1)));
        // A move that leaves the same gap the other way is not made: 8
        // against 4, the only view costs 4.
        assert_eq!(best_move(&[8.0, 4.0], &[view(0, 0, 4.0), view(1, 0, 4.0)], 0.25), None);
    }
}
