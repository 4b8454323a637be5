//! Nodes: a local transform, flags, and optional attachments.

use bitflags::bitflags;
use glam::{DMat4, DQuat, Mat4, Quat, Vec3};

use super::{GeometryHandle, MaterialHandle, NodeKey};
use crate::{Camera, Light};

bitflags! {
    /// Per-node switches read by ScenePrep.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
    pub struct NodeFlags: u32 {
        /// The node (and what it carries) takes part in rendering.
        const VISIBLE = 1 << 0;
        /// The node's renderable is drawn into shadow views, and its light
        /// may cast shadows.
        const CASTS_SHADOWS = 1 << 1;
    }
}

/// Translation, rotation, scale; composed as `T * R * S`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Transform {
    /// Translation.
    pub translation: Vec3,
    /// Rotation (unit quaternion).
    pub rotation: Quat,
    /// Non-uniform scale; a negative component mirrors.
    pub scale: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Transform::IDENTITY
    }
}

impl Transform {
    /// No translation, rotation or scale.
    pub const IDENTITY: Transform = Transform { translation: Vec3::ZERO, rotation: Quat::IDENTITY, scale: Vec3::ONE };

    /// A pure translation.
    pub fn from_translation(translation: Vec3) -> Self {
        Transform { translation, ..Self::IDENTITY }
    }

    /// This transform with another scale.
    pub fn with_scale(self, scale: Vec3) -> Self {
        Transform { scale, ..self }
    }

    /// This transform with another rotation.
    pub fn with_rotation(self, rotation: Quat) -> Self {
        Transform { rotation, ..self }
    }

    /// The `f32` matrix.
    pub fn to_mat4(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }

    /// The `f64` matrix used for hierarchy composition.
    pub fn to_dmat4(&self) -> DMat4 {
        DMat4::from_scale_rotation_translation(
            self.scale.as_dvec3(),
            DQuat::from_xyzw(
                self.rotation.x as f64,
                self.rotation.y as f64,
                self.rotation.z as f64,
                self.rotation.w as f64,
            ),
            self.translation.as_dvec3(),
        )
    }
}

/// Geometry drawn with one material per submesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Renderable {
    /// The mesh.
    pub geometry: GeometryHandle,
    /// One material per submesh of `geometry`, in submesh order.
    pub materials: Vec<MaterialHandle>,
}

/// How a skinned renderable's vertices follow other nodes: each vertex of
/// its (skinned) geometry is moved by up to four of these joints, joint `i`
/// by `world(joints[i]) × inverse_bind_matrices[i]` (the node's own
/// transform is not applied, as glTF specifies).
#[derive(Clone, Debug, PartialEq)]
pub struct Skin {
    /// The joint nodes, in the order the geometry's joint indices count.
    pub joints: Vec<NodeKey>,
    /// Per joint, the matrix taking the mesh into the joint's bind space.
    pub inverse_bind_matrices: Vec<glam::Mat4>,
}

/// A coarser mesh a renderable switches to when it covers little of the screen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodLevel {
    /// The coarser mesh; same submesh count as the renderable's geometry.
    pub geometry: GeometryHandle,
    /// Used when the bounding sphere's projected diameter is below this
    /// fraction of the viewport height.
    pub below_screen_fraction: f32,
}

/// One entry of the scene's node table.
#[derive(Clone, Debug)]
pub struct Node {
    /// Name for logs, warnings and dumps.
    pub name: String,
    /// Parent, `None` for a root.
    pub parent: Option<NodeKey>,
    /// Children in the order they were added or moved under this node. A
    /// replica built from scene deltas holds the same children, not
    /// necessarily in the same order (a delta re-places every node it
    /// edits); nothing that renders depends on the order.
    pub children: Vec<NodeKey>,
    /// Transform relative to the parent.
    pub local: Transform,
    /// Visibility and shadow flags.
    pub flags: NodeFlags,
    /// What the node draws, if anything.
    pub renderable: Option<Renderable>,
    /// The light it carries, if any.
    pub light: Option<Light>,
    /// The camera it carries, if any.
    pub camera: Option<Camera>,
    /// Coarser meshes of its renderable, by decreasing screen fraction.
    pub lods: Vec<LodLevel>,
    /// The skin its renderable follows ([`Scene::set_skin`](super::Scene::set_skin)).
    pub skin: Option<std::sync::Arc<Skin>>,
    /// Weights of its geometry's morph targets, in target order (missing
    /// ones are 0; [`Scene::set_morph_weights`](super::Scene::set_morph_weights)).
    pub morph_weights: Vec<f32>,
    /// The application's class of the node for segmentation images (0
    /// unless set; [`Scene::set_semantic_class`](super::Scene::set_semantic_class)).
    pub semantic_class: u32,
    /// Scene revision of this node's last own edit.
    pub(crate) revision: u64,
    /// Newest revision of any edit in this node's subtree.
    pub(crate) subtree_revision: u64,
}

impl Node {
    /// The scene revision of this node's last own edit (its transform,
    /// flags, parent, renderable, light, skin, morph weights, class).
    pub fn revision(&self) -> u64 {
        self.revision
    }

    pub(super) fn new(name: String, parent: Option<NodeKey>, local: Transform) -> Self {
        Node {
            name,
            parent,
            children: Vec::new(),
            local,
            flags: NodeFlags::VISIBLE | NodeFlags::CASTS_SHADOWS,
            renderable: None,
            light: None,
            camera: None,
            lods: Vec::new(),
            skin: None,
            morph_weights: Vec::new(),
            semantic_class: 0,
            revision: 0,
            subtree_revision: 0,
        }
    }

    /// True when the node's own VISIBLE flag is set.
    pub fn is_visible(&self) -> bool {
        self.flags.contains(NodeFlags::VISIBLE)
    }
}

#[cfg(test)]
mod tests {
    use glam::{Mat4, Quat, Vec3};

    use super::{Node, NodeFlags, Transform};

    /// `T * R * S`: the point (1, 0, 0) is scaled to (2, 0, 0), turned 90°
    /// about +Y to (0, 0, -2), then moved by (10, 20, 30).
    #[test]
    fn a_transforms_f32_matrix_scales_then_rotates_then_translates() {
        let t = Transform::from_translation(Vec3::new(10.0, 20.0, 30.0))
            .with_rotation(Quat::from_rotation_y(90f32.to_radians()))
            .with_scale(Vec3::new(2.0, 3.0, 4.0));
        let m: Mat4 = t.to_mat4();
        let p = m.transform_point3(Vec3::X);
        assert!((p - Vec3::new(10.0, 20.0, 28.0)).length() < 1e-5, "{p}");
        // The f32 matrix is the f64 one rounded (both built from the same
        // values; 1e-6 covers the rounding of a few units' entries).
        let d = t.to_dmat4().as_mat4();
        assert!(m.abs_diff_eq(d, 1e-6), "{m} against {d}");
    }

    #[test]
    fn a_node_is_visible_by_its_own_flag() {
        let mut node = Node::new("n".into(), None, Transform::IDENTITY);
        assert!(node.is_visible(), "new nodes are visible");
        node.flags = NodeFlags::CASTS_SHADOWS;
        assert!(!node.is_visible());
        node.flags = NodeFlags::VISIBLE;
        assert!(node.is_visible());
    }
}
