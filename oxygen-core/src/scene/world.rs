//! World transforms resolved from the hierarchy once per frame.

use glam::{DMat4, Mat4};
use slotmap::SecondaryMap;

use super::{NodeKey, Scene};

/// Every node's world matrix and its effective visibility for one frame.
///
/// A node is effectively visible when it and all its ancestors are visible:
/// hiding a parent hides its subtree.
#[derive(Default)]
pub struct WorldTransforms {
    world: SecondaryMap<NodeKey, (DMat4, bool)>,
    stack: Vec<(NodeKey, DMat4, bool)>,
}

impl WorldTransforms {
    /// An empty table.
    pub fn new() -> Self {
        Self::default()
    }

    pub(super) fn resolve(&mut self, scene: &Scene) {
        self.world.clear();
        self.stack.clear();
        for root in scene.roots().iter().rev() {
            self.stack.push((*root, DMat4::IDENTITY, true));
        }
        while let Some((key, parent_world, parent_visible)) = self.stack.pop() {
            let Some(node) = scene.node(key) else { continue };
            let world = parent_world * node.local.to_dmat4();
            let visible = parent_visible && node.is_visible();
            self.world.insert(key, (world, visible));
            for child in node.children.iter().rev() {
                self.stack.push((*child, world, visible));
            }
        }
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
}
