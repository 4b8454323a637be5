//! World transforms resolved from the hierarchy once per frame.

use glam::{DMat4, Mat4};
use slotmap::SecondaryMap;

use super::{NodeKey, Scene};

/// Every node's world matrix and its effective visibility, kept up to date
/// across frames.
///
/// A node is effectively visible when it and all its ancestors are visible:
/// hiding a parent hides its subtree. Resolution is incremental: a subtree
/// whose newest edit is older than the last resolution is skipped without
/// being visited, and within a visited subtree only nodes whose own or an
/// ancestor's transform changed are recomputed.
#[derive(Default)]
pub struct WorldTransforms {
    world: SecondaryMap<NodeKey, (DMat4, bool)>,
    stack: Vec<(NodeKey, DMat4, bool, bool)>,
    scene_id: u64,
    resolved_revision: u64,
    recomputed_last: usize,
}

impl WorldTransforms {
    /// An empty table.
    pub fn new() -> Self {
        Self::default()
    }

    pub(super) fn resolve(&mut self, scene: &Scene) {
        self.recomputed_last = 0;
        if self.scene_id != scene.id() {
            self.world.clear();
            self.scene_id = scene.id();
            self.resolved_revision = 0;
        }
        if self.resolved_revision == scene.revision() {
            return;
        }
        self.stack.clear();
        for root in scene.roots().iter().rev() {
            self.stack.push((*root, DMat4::IDENTITY, true, false));
        }
        while let Some((key, parent_world, parent_visible, parent_changed)) = self.stack.pop() {
            let Some(node) = scene.node(key) else { continue };
            if !parent_changed && node.subtree_revision <= self.resolved_revision {
                continue; // nothing below here changed: the cached values stand
            }
            let cached = self.world.get(key).copied();
            let changed = parent_changed || node.revision > self.resolved_revision || cached.is_none();
            let (world, visible) = match cached {
                Some(values) if !changed => values,
                _ => {
                    self.recomputed_last += 1;
                    let values = (parent_world * node.local.to_dmat4(), parent_visible && node.is_visible());
                    self.world.insert(key, values);
                    values
                }
            };
            for child in node.children.iter().rev() {
                self.stack.push((*child, world, visible, changed));
            }
        }
        self.resolved_revision = scene.revision();
    }

    /// Forgets every cached matrix (keeping the memory), so the next
    /// resolution recomputes all nodes.
    pub fn invalidate(&mut self) {
        self.scene_id = 0;
    }

    /// Nodes whose world matrix was recomputed by the last resolution.
    pub fn recomputed_last(&self) -> usize {
        self.recomputed_last
    }

    /// The scene revision this table reflects.
    pub fn resolved_revision(&self) -> u64 {
        self.resolved_revision
    }

    /// The world matrix rounded to `f32`.
    pub fn get(&self, key: NodeKey) -> Option<Mat4> {
        self.world.get(key).map(|(m, _)| m.as_mat4())
    }

    /// The world matrix in `f64`, for camera-relative rebasing.
    pub fn get_f64(&self, key: NodeKey) -> Option<DMat4> {
        self.world.get(key).map(|(m, _)| *m)
    }

    /// True when the node and all its ancestors are visible.
    pub fn is_effectively_visible(&self, key: NodeKey) -> bool {
        self.world.get(key).is_some_and(|(_, v)| *v)
    }
}

#[cfg(test)]
mod tests {
    use glam::{Quat, Vec3};

    use crate::{NodeFlags, Scene, Transform};

    #[test]
    fn children_compose_with_their_parents() {
        let mut scene = Scene::new();
        let parent = scene.add_node(
            "parent",
            Transform::from_translation(Vec3::new(10.0, 0.0, 0.0))
                .with_rotation(Quat::from_rotation_y(90f32.to_radians())),
        );
        let child = scene.add_child(parent, "child", Transform::from_translation(Vec3::new(0.0, 0.0, -1.0))).unwrap();
        let mut world = super::WorldTransforms::new();
        scene.resolve_world_transforms(&mut world);
        let p = world.get(child).unwrap().transform_point3(Vec3::ZERO);
        assert!((p - Vec3::new(9.0, 0.0, 0.0)).length() < 1e-5, "{p}");
    }

    #[test]
    fn unchanged_subtrees_cost_nothing_and_edits_recompute_only_what_they_move() {
        let mut scene = Scene::new();
        let a = scene.add_node("a", Transform::IDENTITY);
        let a1 = scene.add_child(a, "a1", Transform::from_translation(Vec3::X)).unwrap();
        let a2 = scene.add_child(a1, "a2", Transform::from_translation(Vec3::X)).unwrap();
        let b = scene.add_node("b", Transform::IDENTITY);
        let b1 = scene.add_child(b, "b1", Transform::IDENTITY).unwrap();
        let mut world = super::WorldTransforms::new();
        scene.resolve_world_transforms(&mut world);
        assert_eq!(world.recomputed_last(), 5);

        scene.resolve_world_transforms(&mut world);
        assert_eq!(world.recomputed_last(), 0, "nothing changed");

        // Moving a1 recomputes a1 and its child a2, not a, b or b1.
        scene.set_local_transform(a1, Transform::from_translation(Vec3::Y)).unwrap();
        scene.resolve_world_transforms(&mut world);
        assert_eq!(world.recomputed_last(), 2);
        assert_eq!(world.get(a2).unwrap().w_axis.truncate(), Vec3::new(1.0, 1.0, 0.0));

        // A leaf edit recomputes the leaf only.
        scene.set_local_transform(b1, Transform::from_translation(Vec3::Z)).unwrap();
        scene.resolve_world_transforms(&mut world);
        assert_eq!(world.recomputed_last(), 1);
        assert_eq!(world.get(b1).unwrap().w_axis.truncate(), Vec3::Z);

        // Hiding b hides b1 through the incremental path too.
        scene.set_flags(b, NodeFlags::empty()).unwrap();
        scene.resolve_world_transforms(&mut world);
        assert!(!world.is_effectively_visible(b1));

        // Re-parenting a2 under b moves it with its new parent.
        scene.set_parent(a2, Some(b)).unwrap();
        scene.resolve_world_transforms(&mut world);
        assert_eq!(world.get(a2).unwrap().w_axis.truncate(), Vec3::X);
    }

    #[test]
    fn a_table_used_with_another_scene_starts_over() {
        let mut first = Scene::new();
        let key = first.add_node("n", Transform::from_translation(Vec3::X));
        let mut world = super::WorldTransforms::new();
        first.resolve_world_transforms(&mut world);
        let mut second = Scene::new();
        let other = second.add_node("m", Transform::from_translation(Vec3::Y));
        second.resolve_world_transforms(&mut world);
        assert_eq!(world.get(other).unwrap().w_axis.truncate(), Vec3::Y);
        assert_eq!(world.recomputed_last(), 1);
        let _ = key;
    }

    #[test]
    fn hiding_a_parent_hides_its_subtree() {
        let mut scene = Scene::new();
        let parent = scene.add_node("parent", Transform::IDENTITY);
        let child = scene.add_child(parent, "child", Transform::IDENTITY).unwrap();
        scene.set_flags(parent, NodeFlags::empty()).unwrap();
        let mut world = super::WorldTransforms::new();
        scene.resolve_world_transforms(&mut world);
        assert!(!world.is_effectively_visible(child));
    }

    /// A chain of 1000 small offsets under a root 1e6 units away: composed in
    /// f32, each step would round to the 0.0625 spacing of f32 at 1e6 and the
    /// error would reach metres; composed in f64 it is one final rounding.
    #[test]
    fn deep_chains_far_from_the_origin_compose_without_f32_drift() {
        let mut scene = Scene::new();
        let mut node = scene.add_node("far", Transform::from_translation(Vec3::new(1e6, 0.0, 0.0)));
        for i in 0..1000 {
            node = scene
                .add_child(node, format!("step{i}"), Transform::from_translation(Vec3::new(0.1, 0.0, 0.0)))
                .unwrap();
        }
        let mut world = super::WorldTransforms::new();
        scene.resolve_world_transforms(&mut world);
        let x = world.get(node).unwrap().w_axis.x;
        assert!((x as f64 - 1_000_100.0).abs() <= 0.0625, "x = {x}");
    }

    /// `get_f64` hands out the composed matrix before its rounding to f32:
    /// 1e6 + 0.1 rounds to 1000000.125 in f32 (spacing 0.0625), while f64
    /// keeps the sum of the two f32 inputs to its spacing of 1.2e-10 there
    /// (the bound, 1e-9, is 8 such steps).
    #[test]
    fn the_f64_world_matrix_keeps_what_f32_rounding_loses() {
        let mut scene = Scene::new();
        let far = scene.add_node("far", Transform::from_translation(Vec3::new(1e6, 0.0, 0.0)));
        let near = scene.add_child(far, "near", Transform::from_translation(Vec3::new(0.1, 0.0, 0.0))).unwrap();
        let mut world = super::WorldTransforms::new();
        scene.resolve_world_transforms(&mut world);
        let x = world.get_f64(near).unwrap().w_axis.x;
        assert!((x - (1e6 + 0.1f32 as f64)).abs() < 1e-9, "x = {x}");
        assert_eq!(world.get(near).unwrap().w_axis.x, x as f32);
        assert_eq!(world.get_f64(far).unwrap().w_axis.x, 1e6);
    }

    #[test]
    fn visible_nodes_under_visible_parents_are_effectively_visible() {
        let mut scene = Scene::new();
        let parent = scene.add_node("parent", Transform::IDENTITY);
        let child = scene.add_child(parent, "child", Transform::IDENTITY).unwrap();
        let mut world = super::WorldTransforms::new();
        scene.resolve_world_transforms(&mut world);
        assert!(world.is_effectively_visible(parent));
        assert!(world.is_effectively_visible(child));
    }

    /// The table says which revision it reflects: the scene's newest, not a
    /// fixed value (a new scene starts at revision 1; two additions make it 3).
    #[test]
    fn the_resolved_revision_is_the_scenes_revision_at_resolution() {
        let mut scene = Scene::new();
        let a = scene.add_node("a", Transform::IDENTITY);
        scene.add_node("b", Transform::IDENTITY);
        let mut world = super::WorldTransforms::new();
        assert_eq!(world.resolved_revision(), 0, "nothing resolved yet");
        scene.resolve_world_transforms(&mut world);
        assert_eq!(world.resolved_revision(), scene.revision());
        assert_eq!(scene.revision(), 3);
        scene.set_local_transform(a, Transform::from_translation(Vec3::X)).unwrap();
        scene.resolve_world_transforms(&mut world);
        assert_eq!(world.resolved_revision(), 4);
    }

    /// An invalidated table recomputes every node even though the scene did
    /// not change since the last resolution (which would otherwise cost nothing).
    #[test]
    fn invalidating_the_table_recomputes_every_node() {
        let mut scene = Scene::new();
        let a = scene.add_node("a", Transform::IDENTITY);
        scene.add_child(a, "a1", Transform::from_translation(Vec3::X)).unwrap();
        scene.add_node("b", Transform::IDENTITY);
        let mut world = super::WorldTransforms::new();
        scene.resolve_world_transforms(&mut world);
        scene.resolve_world_transforms(&mut world);
        assert_eq!(world.recomputed_last(), 0);
        world.invalidate();
        scene.resolve_world_transforms(&mut world);
        assert_eq!(world.recomputed_last(), 3);
    }

    /// A parent whose own last edit was the one the previous resolution saw
    /// (its revision equal to the resolved one) is up to date: a later edit
    /// of its child recomputes the child alone, not the parent and its other
    /// children.
    #[test]
    fn a_parent_edited_just_before_the_last_resolution_is_not_recomputed_for_its_childs_edit() {
        let mut scene = Scene::new();
        let parent = scene.add_node("parent", Transform::IDENTITY);
        let child = scene.add_child(parent, "child", Transform::IDENTITY).unwrap();
        scene.add_child(parent, "sibling", Transform::IDENTITY).unwrap();
        scene.set_local_transform(parent, Transform::from_translation(Vec3::X)).unwrap();
        let mut world = super::WorldTransforms::new();
        scene.resolve_world_transforms(&mut world);
        assert_eq!(scene.node(parent).unwrap().revision(), world.resolved_revision());
        scene.set_local_transform(child, Transform::from_translation(Vec3::Y)).unwrap();
        scene.resolve_world_transforms(&mut world);
        assert_eq!(world.recomputed_last(), 1);
        assert_eq!(world.get(child).unwrap().w_axis.truncate(), Vec3::new(1.0, 1.0, 0.0));
    }
}
