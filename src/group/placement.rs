//! Where a group's views live and what they cost: the bookkeeping of a
//! [`RendererGroup`](super::RendererGroup) without its devices.
//!
//! The group asks this table where a new view goes, what a move must do
//! on the devices, which registrations a frame left stale and which view
//! to move next; it then does that on its renderers and tells the table
//! what happened. Generic over the members' own view ids (`K`), so the
//! rules are tested with plain numbers and given costs.

use std::collections::{BTreeMap, HashMap};
use std::hash::Hash;

use super::{GroupViewId, best_move};

/// Weight of a new measurement in a view's smoothed cost.
const COST_SMOOTHING: f64 = 0.3;

/// The rebalance margin a group starts with, and the one a NaN margin
/// falls back to.
pub(crate) const DEFAULT_MARGIN: f64 = 0.25;

/// One view's place.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Placed<K> {
    /// The member it renders on from the next frame.
    pub member: usize,
    /// Its id on that member.
    pub id: K,
    /// Where its latest image is: the member and id that rendered it last.
    /// After a move this stays on the old member (paused there) until the
    /// new one has rendered the view, so that reads never find nothing.
    pub last: Option<(usize, K)>,
    /// Smoothed seconds per frame (prepare, record, GPU); `None` until
    /// measured.
    pub cost: Option<f64>,
    /// The last group frame it rendered in (0: none yet).
    pub rendered: u64,
}

impl<K: Copy + PartialEq> Placed<K> {
    /// The registration its latest image is in, when that is not its
    /// current one (paused on its old member since a move).
    pub fn paused(&self) -> Option<(usize, K)> {
        self.last.filter(|last| *last != (self.member, self.id))
    }

    /// The member and id whose image a read returns: the latest rendered,
    /// or the current registration before any.
    pub fn readable(&self) -> (usize, K) {
        self.last.unwrap_or((self.member, self.id))
    }
}

/// What moving a view to another member takes on the devices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Move<K> {
    /// The member it leaves, and its id there.
    pub from: (usize, K),
    /// Its registration on the new member to resume (the view goes back
    /// to where its latest image is, before it rendered on the member it
    /// left); `None`: it registers there anew.
    pub resume: Option<K>,
    /// Whether the registration it leaves stays, paused (it holds the
    /// latest image until the new member renders), or goes.
    pub pause_left: bool,
}

/// The group's table of views: their members, ids, images and costs.
#[derive(Debug)]
pub(crate) struct Placement<K> {
    members: usize,
    views: BTreeMap<GroupViewId, Placed<K>>,
    next_view: u32,
    /// How far the most loaded member may carry more than the least loaded
    /// before a view moves ([`Placement::set_margin`]).
    pub margin: f64,
}

impl<K: Copy + Eq + Hash> Placement<K> {
    /// An empty table for `members` members.
    pub fn new(members: usize) -> Self {
        Placement { members, views: BTreeMap::new(), next_view: 0, margin: DEFAULT_MARGIN }
    }

    /// How far the most loaded member may carry more than the least loaded
    /// before a view moves: a fraction, at least 0; NaN means the default;
    /// infinity never moves one.
    pub fn set_margin(&mut self, margin: f64) {
        self.margin = if margin.is_nan() { DEFAULT_MARGIN } else { margin.max(0.0) };
    }

    /// How many views it holds.
    pub fn len(&self) -> usize {
        self.views.len()
    }

    /// The views in order.
    pub fn views(&self) -> impl Iterator<Item = (GroupViewId, &Placed<K>)> {
        self.views.iter().map(|(view, placed)| (*view, placed))
    }

    /// `view`'s place.
    pub fn get(&self, view: GroupViewId) -> Option<&Placed<K>> {
        self.views.get(&view)
    }

    /// Records a view registered on `member` as `id`, under a new group id.
    pub fn add(&mut self, member: usize, id: K) -> GroupViewId {
        let view = GroupViewId(self.next_view);
        self.next_view += 1;
        self.views.insert(view, Placed { member, id, last: None, cost: None, rendered: 0 });
        view
    }

    /// Forgets `view`, returning its place (both registrations, see
    /// [`Placed::paused`], are for the caller to drop).
    pub fn remove(&mut self, view: GroupViewId) -> Option<Placed<K>> {
        self.views.remove(&view)
    }

    /// Each member's load: its views' smoothed costs, a view not measured
    /// yet counted at the mean of those that were (1 when none was);
    /// `excluding`'s view not counted.
    pub fn loads(&self, excluding: Option<GroupViewId>) -> Vec<f64> {
        let measured: Vec<f64> = self.views.values().filter_map(|v| v.cost).collect();
        let mean = if measured.is_empty() { 1.0 } else { measured.iter().sum::<f64>() / measured.len() as f64 };
        let mut loads = vec![0.0; self.members];
        for (view, placed) in &self.views {
            if Some(*view) != excluding {
                loads[placed.member] += placed.cost.unwrap_or(mean);
            }
        }
        loads
    }

    /// The member with the least load (the first of equals), not counting
    /// `excluding`'s view: where a new view goes.
    pub fn lightest(&self, excluding: Option<GroupViewId>) -> usize {
        let loads = self.loads(excluding);
        (0..self.members).min_by(|a, b| loads[*a].total_cmp(&loads[*b])).unwrap_or(0)
    }

    /// What moving `view` to `member` takes; `None` when it is there
    /// already. The caller must have checked both exist.
    pub fn plan_move(&self, view: GroupViewId, member: usize) -> Option<Move<K>> {
        let placed = self.views.get(&view)?;
        if placed.member == member {
            return None;
        }
        let from = (placed.member, placed.id);
        Some(Move {
            from,
            // Back where its latest image is: that registration resumes.
            resume: placed.last.filter(|(m, _)| *m == member).map(|(_, id)| id),
            pause_left: placed.last == Some(from),
        })
    }

    /// Records that `view` now renders on `member` as `id`.
    pub fn moved(&mut self, view: GroupViewId, member: usize, id: K) {
        if let Some(placed) = self.views.get_mut(&view) {
            (placed.member, placed.id) = (member, id);
        }
    }

    /// Records group frame `frame`'s renders, each (member, its id of the
    /// view, seconds it took): costs smoothed, latest images moved. Returns
    /// each render's group view (`None` for a view the table does not
    /// hold: a shadow or probe view of the member) and the registrations
    /// left stale (paused since a move, now rendered on their new member).
    pub fn rendered(&mut self, frame: u64, renders: &[(usize, K, f64)]) -> (Vec<Option<GroupViewId>>, Vec<(usize, K)>) {
        let mut by_member: Vec<HashMap<K, GroupViewId>> = vec![HashMap::new(); self.members];
        for (view, placed) in &self.views {
            by_member[placed.member].insert(placed.id, *view);
        }
        let mut stale = Vec::new();
        let views = renders
            .iter()
            .map(|&(member, id, seconds)| {
                let view = *by_member.get(member)?.get(&id)?;
                let placed = self.views.get_mut(&view)?;
                placed.cost = Some(match placed.cost {
                    Some(cost) => cost + COST_SMOOTHING * (seconds - cost),
                    None => seconds,
                });
                placed.rendered = frame;
                if let Some(old) = placed.last.filter(|last| *last != (member, id)) {
                    stale.push(old);
                }
                placed.last = Some((member, id));
                Some(view)
            })
            .collect();
        (views, stale)
    }

    /// The move that best evens the members' loads ([`best_move`]), if the
    /// margin allows one.
    pub fn next_move(&self) -> Option<(GroupViewId, usize, usize)> {
        if self.members < 2 || !self.margin.is_finite() {
            return None;
        }
        let views: Vec<(GroupViewId, usize, Option<f64>)> =
            self.views.iter().map(|(view, placed)| (*view, placed.member, placed.cost)).collect();
        best_move(&self.loads(None), &views, self.margin)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(members: usize, costs: &[(usize, Option<f64>)]) -> (Placement<u32>, Vec<GroupViewId>) {
        let mut table = Placement::new(members);
        let views = costs
            .iter()
            .enumerate()
            .map(|(i, &(member, cost))| {
                let view = table.add(member, 100 + i as u32);
                if let Some(placed) = table.views.get_mut(&view) {
                    placed.cost = cost;
                }
                view
            })
            .collect();
        (table, views)
    }

    #[test]
    fn views_get_consecutive_ids_and_can_be_removed() {
        let (mut table, views) = table(2, &[(0, None), (1, None), (0, None)]);
        assert_eq!(views, [GroupViewId(0), GroupViewId(1), GroupViewId(2)]);
        assert_eq!(table.len(), 3);
        let removed = table.remove(GroupViewId(1)).map(|p| (p.member, p.id));
        assert_eq!(removed, Some((1, 101)));
        assert_eq!(table.remove(GroupViewId(1)), None);
        // Ids are never reused.
        assert_eq!(table.add(1, 7), GroupViewId(3));
        assert_eq!(table.views().map(|(v, _)| v.0).collect::<Vec<_>>(), [0, 2, 3]);
    }

    #[test]
    fn loads_count_unmeasured_views_at_the_mean_of_the_measured() {
        // Measured: 2 and 4 (mean 3); the unmeasured one on member 1 counts 3.
        let (table, views) = table(3, &[(0, Some(2.0)), (1, Some(4.0)), (1, None)]);
        assert_eq!(table.loads(None), [2.0, 7.0, 0.0]);
        assert_eq!(table.loads(Some(views[1])), [2.0, 3.0, 0.0]);
        assert_eq!(table.loads(Some(views[0])), [0.0, 7.0, 0.0]);
        // Nothing measured: each view counts 1.
        let (unmeasured, _) = table_of(2, &[0, 0, 1]);
        assert_eq!(unmeasured.loads(None), [2.0, 1.0]);
    }

    fn table_of(members: usize, on: &[usize]) -> (Placement<u32>, Vec<GroupViewId>) {
        table(members, &on.iter().map(|m| (*m, None)).collect::<Vec<_>>())
    }

    #[test]
    fn a_new_view_goes_to_the_lightest_member_the_first_of_equals() {
        let (table, views) = table(3, &[(0, Some(1.0)), (1, Some(3.0)), (2, Some(2.0))]);
        assert_eq!(table.lightest(None), 0);
        // Without its only view, member 1 is empty: the lightest.
        assert_eq!(table.lightest(Some(views[1])), 1);
        assert_eq!(Placement::<u32>::new(3).lightest(None), 0, "ties go to the first");
        let (two, _) = table_of(2, &[0]);
        assert_eq!(two.lightest(None), 1);
        assert_eq!(Placement::<u32>::new(0).lightest(None), 0, "no member: 0, not a panic");
    }

    #[test]
    fn a_margin_is_never_negative_or_nan() {
        let mut table = Placement::<u32>::new(2);
        assert_eq!(table.margin, DEFAULT_MARGIN);
        table.set_margin(0.5);
        assert_eq!(table.margin, 0.5);
        table.set_margin(-1.0);
        assert_eq!(table.margin, 0.0);
        table.set_margin(f64::NAN);
        assert_eq!(table.margin, DEFAULT_MARGIN);
        table.set_margin(f64::INFINITY);
        assert_eq!(table.margin, f64::INFINITY);
    }

    #[test]
    fn moves_resume_or_register_and_pause_or_drop_what_they_leave() {
        let (mut table, views) = table_of(3, &[0]);
        let view = views[0];
        assert_eq!(table.plan_move(view, 0), None, "already there");
        assert_eq!(table.plan_move(GroupViewId(9), 1), None, "no such view");
        // Never rendered: a new registration, the old one dropped.
        assert_eq!(table.plan_move(view, 1), Some(Move { from: (0, 100), resume: None, pause_left: false }));
        // Rendered on member 0: its registration there pauses.
        table.rendered(1, &[(0, 100, 0.5)]);
        assert_eq!(table.plan_move(view, 1), Some(Move { from: (0, 100), resume: None, pause_left: true }));
        table.moved(view, 1, 200);
        assert_eq!(table.get(view).map(|p| (p.member, p.id, p.paused())), Some((1, 200, Some((0, 100)))));
        // Moved back before member 1 rendered it: member 0's paused
        // registration resumes, and the one on member 1 goes.
        assert_eq!(table.plan_move(view, 0), Some(Move { from: (1, 200), resume: Some(100), pause_left: false }));
        // Or on to member 2: registered there; member 1's goes.
        assert_eq!(table.plan_move(view, 2), Some(Move { from: (1, 200), resume: None, pause_left: false }));
    }

    #[test]
    fn a_frame_smooths_costs_moves_images_and_finds_stale_registrations() {
        let (mut table, views) = table_of(2, &[0, 1]);
        // Member 1 also rendered a view the table does not hold (a shadow
        // view, say): no group view.
        let (seen, stale) = table.rendered(1, &[(0, 100, 2.0), (1, 101, 1.0), (1, 999, 5.0)]);
        assert_eq!(seen, [Some(views[0]), Some(views[1]), None]);
        assert!(stale.is_empty());
        assert_eq!(table.get(views[0]).map(|p| (p.cost, p.rendered, p.last)), Some((Some(2.0), 1, Some((0, 100)))));
        // The next measurement weighs 0.3: 2 + 0.3 × (5 − 2).
        table.rendered(2, &[(0, 100, 5.0)]);
        let cost = table.get(views[0]).and_then(|p| p.cost).unwrap_or(f64::NAN);
        assert!((cost - 2.9).abs() < 1e-12, "{cost}");
        assert_eq!(table.get(views[1]).map(|p| p.rendered), Some(1), "not rendered in frame 2");
        // Moved to member 1 as 300: until it renders there, reads go to
        // member 0; once it has, member 0's registration is stale.
        table.moved(views[0], 1, 300);
        assert_eq!(table.get(views[0]).map(Placed::readable), Some((0, 100)));
        let (seen, stale) = table.rendered(3, &[(1, 300, 1.0), (0, 100, 9.0)]);
        assert_eq!(seen, [Some(views[0]), None], "member 0's old id is no longer the view's");
        assert_eq!(stale, [(0, 100)]);
        assert_eq!(table.get(views[0]).map(|p| (p.readable(), p.paused())), Some(((1, 300), None)));
        // A render on a member the table does not have: ignored.
        assert_eq!(table.rendered(4, &[(7, 100, 1.0)]).0, [None]);
    }

    #[test]
    fn the_next_move_follows_the_margin_and_needs_two_members() {
        // 3 + 1 + 1 against 0: moving the 3 narrows the gap of 5 to 1.
        let (mut table, views) = table(2, &[(0, Some(3.0)), (0, Some(1.0)), (0, Some(1.0))]);
        assert_eq!(table.next_move(), Some((views[0], 0, 1)));
        table.set_margin(f64::INFINITY);
        assert_eq!(table.next_move(), None, "an infinite margin never moves");
        table.set_margin(0.0);
        assert_eq!(table.next_move(), Some((views[0], 0, 1)));
        let (alone, _) = table_of(1, &[0, 0]);
        assert_eq!(alone.next_move(), None, "one member: nowhere to go");
        // Three members: the heaviest gives to the lightest.
        let (three, views) = super::tests::table(3, &[(0, Some(3.0)), (0, Some(1.0)), (0, Some(1.0)), (1, Some(1.0))]);
        assert_eq!(three.next_move(), Some((views[0], 0, 2)));
    }
}
