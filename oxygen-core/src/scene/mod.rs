//! The scene: a node table with hierarchy, flags and attachments.
//!
//! Nodes live in a [`slotmap`], so a [`NodeKey`] stays valid (and stale keys
//! are detected) while other nodes come and go. A node carries a local
//! [`Transform`]; world matrices are resolved from the hierarchy once per
//! frame into a [`WorldTransforms`] table by ScenePrep's frame phase — the
//! scene itself is never mutated by rendering, so `render_frame(&scene)`
//! borrows it immutably.
//!
//! Geometry and materials are shared assets referenced by handle from any
//! number of renderable nodes.

pub mod delta;
mod node;
mod world;

pub use node::{LodLevel, Node, NodeFlags, Renderable, Skin, Transform};
pub use world::WorldTransforms;

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use slotmap::{Key, SlotMap, new_key_type};
use thiserror::Error;

use crate::{Camera, Geometry, Light, Material, TextureImage};

new_key_type! {
    /// A node in the [`Scene`]; carries a generation, so a key of a removed
    /// node is detected rather than aliasing a new one.
    pub struct NodeKey;
    /// A geometry asset in the [`Scene`].
    pub struct GeometryHandle;
    /// A material asset in the [`Scene`].
    pub struct MaterialHandle;
    /// A texture asset in the [`Scene`].
    pub struct TextureHandle;
}

/// The stable numeric id of a node (its slot index), used for deterministic
/// tie-breaks and in dumps.
pub fn node_index(key: NodeKey) -> u32 {
    (key.data().as_ffi() & 0xffff_ffff) as u32
}

/// The stable numeric id of a material (its slot index).
pub fn material_index(handle: MaterialHandle) -> u32 {
    (handle.data().as_ffi() & 0xffff_ffff) as u32
}

/// The stable numeric id of a texture (its slot index).
pub fn texture_index(handle: TextureHandle) -> u32 {
    (handle.data().as_ffi() & 0xffff_ffff) as u32
}

/// The stable numeric id of a geometry (its slot index).
pub fn geometry_index(handle: GeometryHandle) -> u32 {
    (handle.data().as_ffi() & 0xffff_ffff) as u32
}

/// A scene edit that refers to something that is not there or does not fit.
#[derive(Debug, Error, PartialEq)]
pub enum SceneError {
    /// The node key is stale or from another scene.
    #[error("node {0:?} does not exist in this scene")]
    NoSuchNode(NodeKey),
    /// The geometry handle is stale or from another scene.
    #[error("geometry {0:?} does not exist in this scene")]
    NoSuchGeometry(GeometryHandle),
    /// The material handle is stale or from another scene.
    #[error("material {0:?} does not exist in this scene")]
    NoSuchMaterial(MaterialHandle),
    /// A renderable must name one material per submesh.
    #[error("renderable on node '{node}' gives {given} materials for {submeshes} submeshes of geometry '{geometry}'")]
    MaterialCountMismatch {
        /// Node name.
        node: String,
        /// Geometry name.
        geometry: String,
        /// Materials given.
        given: usize,
        /// Submeshes in the geometry.
        submeshes: usize,
    },
    /// A skin that does not fit its node.
    #[error("skin of node '{node}': {reason}")]
    BadSkin {
        /// Node name.
        node: String,
        /// What is wrong.
        reason: String,
    },
    /// A level of detail that does not fit its node.
    #[error("LOD of node '{node}': {reason}")]
    BadLod {
        /// Node name.
        node: String,
        /// What is wrong.
        reason: String,
    },
    /// Re-parenting would make a node its own ancestor.
    #[error("making {child:?} a child of {parent:?} would create a cycle")]
    Cycle {
        /// The node being moved.
        child: NodeKey,
        /// The requested parent.
        parent: NodeKey,
    },
}

/// The scene node table and its assets.
///
/// Every edit bumps a revision counter; a node records the revision of its
/// last own edit and the newest revision anywhere in its subtree. This is the
/// dirty-flag scheme that lets world-transform resolution skip unchanged
/// subtrees without visiting them, and ScenePrep skip the whole frame phase
/// when nothing changed, while rendering still borrows the scene immutably.
pub struct Scene {
    id: u64,
    revision: u64,
    /// The revision of the newest edit of a scene-wide asset (a geometry,
    /// material or texture), which no node's revision records.
    assets_revision: u64,
    nodes: SlotMap<NodeKey, Node>,
    roots: Vec<NodeKey>,
    geometries: SlotMap<GeometryHandle, Arc<Geometry>>,
    materials: SlotMap<MaterialHandle, Material>,
    textures: SlotMap<TextureHandle, Arc<TextureImage>>,
    /// What a replica must replay to give its nodes and assets the same
    /// slots: see [`delta`].
    journal: delta::Journal,
}

impl Default for Scene {
    fn default() -> Self {
        static NEXT_SCENE_ID: AtomicU64 = AtomicU64::new(1);
        Scene {
            id: NEXT_SCENE_ID.fetch_add(1, Ordering::Relaxed),
            revision: 1,
            assets_revision: 1,
            nodes: SlotMap::with_key(),
            roots: Vec::new(),
            geometries: SlotMap::with_key(),
            materials: SlotMap::with_key(),
            textures: SlotMap::with_key(),
            journal: delta::Journal::default(),
        }
    }
}

impl Scene {
    /// An empty scene.
    pub fn new() -> Self {
        Self::default()
    }

    /// A process-unique id, so caches keyed on a scene notice another scene.
    pub fn id(&self) -> u64 {
        self.id
    }

    /// The revision of the newest edit (any method taking `&mut self`).
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// The revision of the newest edit of a scene-wide asset (a geometry,
    /// material or texture added, a material replaced): what no node's own
    /// revision ([`Node::revision`]) records.
    pub fn assets_revision(&self) -> u64 {
        self.assets_revision
    }

    /// Records an edit of a scene-wide asset.
    fn touch_assets(&mut self) {
        self.revision += 1;
        self.assets_revision = self.revision;
    }

    /// Records an edit of `key` (its transform, flags, parent or
    /// attachments): the node and every ancestor learn that their subtree changed.
    fn touch(&mut self, key: NodeKey) {
        self.revision += 1;
        let revision = self.revision;
        if let Some(node) = self.nodes.get_mut(key) {
            node.revision = revision;
        }
        let mut cursor = Some(key);
        while let Some(k) = cursor {
            let Some(node) = self.nodes.get_mut(k) else { break };
            node.subtree_revision = revision;
            cursor = node.parent;
        }
    }

    /// Adds a geometry asset.
    pub fn add_geometry(&mut self, geometry: Geometry) -> GeometryHandle {
        self.touch_assets();
        let handle = self.geometries.insert(Arc::new(geometry));
        self.journal.record(self.revision, delta::Event::GeometryAdded(geometry_index(handle)));
        handle
    }

    /// Adds a geometry a replica received (shared with its cache).
    pub(crate) fn add_geometry_shared(&mut self, geometry: Arc<Geometry>) -> GeometryHandle {
        self.touch_assets();
        let handle = self.geometries.insert(geometry);
        self.journal.record(self.revision, delta::Event::GeometryAdded(geometry_index(handle)));
        handle
    }

    /// Adds a texture a replica received (shared with its cache).
    pub(crate) fn add_texture_shared(&mut self, texture: Arc<TextureImage>) -> TextureHandle {
        self.touch_assets();
        let handle = self.textures.insert(texture);
        self.journal.record(self.revision, delta::Event::TextureAdded(texture_index(handle)));
        handle
    }

    /// Adds a material asset (sanitized: NaN and out-of-range values fixed).
    pub fn add_material(&mut self, material: Material) -> MaterialHandle {
        self.touch_assets();
        let handle = self.materials.insert(material.sanitized());
        self.journal.record(self.revision, delta::Event::MaterialAdded(material_index(handle)));
        handle
    }

    /// Replaces a material (sanitized like [`Scene::add_material`]); every
    /// draw using it shows the new one from the next frame.
    pub fn set_material(&mut self, handle: MaterialHandle, material: Material) -> Result<(), SceneError> {
        let slot = self.materials.get_mut(handle).ok_or(SceneError::NoSuchMaterial(handle))?;
        *slot = material.sanitized();
        self.touch_assets();
        self.journal.record(self.revision, delta::Event::MaterialSet(material_index(handle)));
        Ok(())
    }

    /// Adds a texture asset.
    pub fn add_texture(&mut self, texture: TextureImage) -> TextureHandle {
        self.touch_assets();
        let handle = self.textures.insert(Arc::new(texture));
        self.journal.record(self.revision, delta::Event::TextureAdded(texture_index(handle)));
        handle
    }

    /// A texture by handle.
    pub fn texture(&self, handle: TextureHandle) -> Option<&Arc<TextureImage>> {
        self.textures.get(handle)
    }

    /// A geometry by handle.
    pub fn geometry(&self, handle: GeometryHandle) -> Option<&Arc<Geometry>> {
        self.geometries.get(handle)
    }

    /// A material by handle.
    pub fn material(&self, handle: MaterialHandle) -> Option<&Material> {
        self.materials.get(handle)
    }

    /// Every material with its handle, in stable slot order.
    pub fn materials(&self) -> impl Iterator<Item = (MaterialHandle, &Material)> {
        self.materials.iter()
    }

    /// Adds a root node with a local transform; visible and shadow-casting.
    pub fn add_node(&mut self, name: impl Into<String>, local: Transform) -> NodeKey {
        let key = self.nodes.insert(Node::new(name.into(), None, local));
        self.roots.push(key);
        self.touch(key);
        self.journal.node_inserted(self.revision, node_index(key));
        key
    }

    /// Adds a node under `parent`.
    pub fn add_child(
        &mut self,
        parent: NodeKey,
        name: impl Into<String>,
        local: Transform,
    ) -> Result<NodeKey, SceneError> {
        if !self.nodes.contains_key(parent) {
            return Err(SceneError::NoSuchNode(parent));
        }
        let key = self.nodes.insert(Node::new(name.into(), Some(parent), local));
        self.nodes[parent].children.push(key);
        self.touch(key);
        self.journal.node_inserted(self.revision, node_index(key));
        Ok(key)
    }

    /// Removes a node and its whole subtree.
    pub fn remove_node(&mut self, key: NodeKey) -> Result<(), SceneError> {
        let node = self.nodes.get(key).ok_or(SceneError::NoSuchNode(key))?;
        let parent = node.parent;
        match parent {
            Some(p) => self.nodes[p].children.retain(|c| *c != key),
            None => self.roots.retain(|r| *r != key),
        }
        match parent {
            Some(p) => self.touch(p),
            None => self.revision += 1,
        }
        let mut stack = vec![key];
        while let Some(k) = stack.pop() {
            if let Some(n) = self.nodes.remove(k) {
                self.journal.node_removed(self.revision, node_index(k));
                stack.extend(n.children);
            }
        }
        Ok(())
    }

    /// Moves `child` under `parent` (or to the roots with `None`).
    pub fn set_parent(&mut self, child: NodeKey, parent: Option<NodeKey>) -> Result<(), SceneError> {
        let old = self.nodes.get(child).ok_or(SceneError::NoSuchNode(child))?.parent;
        if let Some(p) = parent {
            let mut cursor = Some(p);
            while let Some(c) = cursor {
                if c == child {
                    return Err(SceneError::Cycle { child, parent: p });
                }
                cursor = self.nodes.get(c).ok_or(SceneError::NoSuchNode(c))?.parent;
            }
        }
        match old {
            Some(o) => self.nodes[o].children.retain(|c| *c != child),
            None => self.roots.retain(|r| *r != child),
        }
        match parent {
            Some(p) => self.nodes[p].children.push(child),
            None => self.roots.push(child),
        }
        self.nodes[child].parent = parent;
        self.touch(child);
        Ok(())
    }

    /// Moves each `(child, parent)` of `moves` under its parent (or to the
    /// roots with `None`) as one edit: every child leaves its place first,
    /// then each joins its new one in the order given. The result is what
    /// [`Scene::set_parent`] one move at a time gives when no step passes
    /// through a cycle, in time linear in the nodes and lists touched (a
    /// replica's snapshot moves every node). Refused, with nothing changed,
    /// when a node is missing or the final hierarchy has a cycle.
    pub(crate) fn reparent_many(&mut self, moves: &[(NodeKey, Option<NodeKey>)]) -> Result<(), SceneError> {
        use std::collections::{HashMap, HashSet};
        for &(child, parent) in moves {
            for key in std::iter::once(child).chain(parent) {
                if !self.nodes.contains_key(key) {
                    return Err(SceneError::NoSuchNode(key));
                }
            }
        }
        // The last move of a node wins, as it would one at a time.
        let final_parent: HashMap<NodeKey, Option<NodeKey>> = moves.iter().copied().collect();
        let parent_of = |k: NodeKey| final_parent.get(&k).copied().unwrap_or_else(|| self.nodes[k].parent);
        // Every moved node's chain must reach a root: each node is walked
        // once (a chain stops at a node already known to reach one).
        let mut reaches_root: HashSet<NodeKey> = HashSet::new();
        for &(child, _) in moves {
            let mut path = Vec::new();
            let mut on_path = HashSet::new();
            let mut cursor = Some(child);
            while let Some(k) = cursor {
                if reaches_root.contains(&k) {
                    break;
                }
                if !on_path.insert(k) {
                    let parent = parent_of(k).unwrap_or(k);
                    return Err(SceneError::Cycle { child: k, parent });
                }
                path.push(k);
                cursor = parent_of(k);
            }
            reaches_root.extend(path);
        }
        let moved: HashSet<NodeKey> = final_parent.keys().copied().collect();
        let old_parents: HashSet<Option<NodeKey>> = moved.iter().map(|k| self.nodes[*k].parent).collect();
        for old in old_parents {
            match old {
                Some(p) => self.nodes[p].children.retain(|c| !moved.contains(c)),
                None => self.roots.retain(|r| !moved.contains(r)),
            }
        }
        let mut placed = HashSet::new();
        for &(child, _) in moves {
            if !placed.insert(child) {
                continue;
            }
            let parent = final_parent[&child];
            match parent {
                Some(p) => self.nodes[p].children.push(child),
                None => self.roots.push(child),
            }
            self.nodes[child].parent = parent;
        }
        for &(child, _) in moves {
            self.touch(child);
        }
        Ok(())
    }

    /// A node by key.
    pub fn node(&self, key: NodeKey) -> Option<&Node> {
        self.nodes.get(key)
    }

    fn node_mut(&mut self, key: NodeKey) -> Result<&mut Node, SceneError> {
        self.nodes.get_mut(key).ok_or(SceneError::NoSuchNode(key))
    }

    /// Every node with its key, in stable slot order.
    pub fn nodes(&self) -> impl Iterator<Item = (NodeKey, &Node)> {
        self.nodes.iter()
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Root nodes in the order they were added or moved to the roots (on a
    /// replica built from scene deltas: the same roots, not necessarily in
    /// the same order, as [`Node::children`] says).
    pub fn roots(&self) -> &[NodeKey] {
        &self.roots
    }

    /// Replaces a node's local transform.
    pub fn set_local_transform(&mut self, key: NodeKey, local: Transform) -> Result<(), SceneError> {
        self.node_mut(key)?.local = local;
        self.touch(key);
        Ok(())
    }

    /// Replaces a node's flags.
    pub fn set_flags(&mut self, key: NodeKey, flags: NodeFlags) -> Result<(), SceneError> {
        self.node_mut(key)?.flags = flags;
        self.touch(key);
        Ok(())
    }

    /// Attaches a renderable; checks the handles and the material count.
    pub fn set_renderable(&mut self, key: NodeKey, renderable: Renderable) -> Result<(), SceneError> {
        let geometry =
            self.geometries.get(renderable.geometry).ok_or(SceneError::NoSuchGeometry(renderable.geometry))?;
        if let Some(m) = renderable.materials.iter().find(|m| !self.materials.contains_key(**m)) {
            return Err(SceneError::NoSuchMaterial(*m));
        }
        let node = self.nodes.get(key).ok_or(SceneError::NoSuchNode(key))?;
        if renderable.materials.len() != geometry.submeshes().len() {
            return Err(SceneError::MaterialCountMismatch {
                node: node.name.clone(),
                geometry: geometry.name().to_owned(),
                given: renderable.materials.len(),
                submeshes: geometry.submeshes().len(),
            });
        }
        self.node_mut(key)?.renderable = Some(renderable);
        self.touch(key);
        Ok(())
    }

    /// Makes a node's renderable follow `skin` (`None`: rigid again). The
    /// joints must be nodes of this scene, one finite inverse bind matrix
    /// each. Only a skinned geometry ([`Geometry::with_skin_weights`](crate::Geometry::with_skin_weights))
    /// moves with it; joint indices past the skin's joints are refused when
    /// the renderable is drawn (the frame skips it with a reason).
    pub fn set_skin(&mut self, key: NodeKey, skin: Option<Skin>) -> Result<(), SceneError> {
        let name = self.nodes.get(key).ok_or(SceneError::NoSuchNode(key))?.name.clone();
        if let Some(skin) = &skin {
            let bad = |reason: String| SceneError::BadSkin { node: name.clone(), reason };
            if skin.joints.len() != skin.inverse_bind_matrices.len() {
                return Err(bad(format!(
                    "{} joints but {} inverse bind matrices",
                    skin.joints.len(),
                    skin.inverse_bind_matrices.len()
                )));
            }
            if skin.joints.is_empty() || skin.joints.len() > crate::geometry::MAX_JOINTS {
                return Err(bad(format!("{} joints (1 to {})", skin.joints.len(), crate::geometry::MAX_JOINTS)));
            }
            if let Some(i) = skin.joints.iter().position(|j| !self.nodes.contains_key(*j)) {
                return Err(bad(format!("joint {i} is not a node of this scene")));
            }
            if let Some(i) = skin.inverse_bind_matrices.iter().position(|m| !m.is_finite()) {
                return Err(bad(format!("inverse bind matrix {i} is not finite")));
            }
        }
        self.node_mut(key)?.skin = skin.map(std::sync::Arc::new);
        self.touch(key);
        Ok(())
    }

    /// Sets the weights of a node's morph targets (target order; a
    /// non-finite weight counts as 0, weights past the geometry's targets
    /// are ignored).
    pub fn set_morph_weights(&mut self, key: NodeKey, weights: Vec<f32>) -> Result<(), SceneError> {
        let node = self.node_mut(key)?;
        node.morph_weights = weights.into_iter().map(|w| if w.is_finite() { w } else { 0.0 }).collect();
        self.touch(key);
        Ok(())
    }

    /// Sets the node's semantic class, the value segmentation images show
    /// for the pixels it draws (0, the default, is the class of nothing in
    /// particular). The GPU's semantic label plane carries it, so this is
    /// an edit like any other: the next frame recollects the node.
    pub fn set_semantic_class(&mut self, key: NodeKey, class: u32) -> Result<(), SceneError> {
        let node = self.node_mut(key)?;
        if node.semantic_class != class {
            node.semantic_class = class;
            self.touch(key);
        }
        Ok(())
    }

    /// The node with stable id `index` ([`node_index`]): what an instance
    /// label names.
    pub fn node_at_index(&self, index: u32) -> Option<NodeKey> {
        self.nodes.keys().find(|k| node_index(*k) == index)
    }

    /// Gives a renderable node coarser meshes for when it is small on screen
    /// (sorted by decreasing `below_screen_fraction`; empty removes them).
    pub fn set_lods(&mut self, key: NodeKey, mut lods: Vec<LodLevel>) -> Result<(), SceneError> {
        let node = self.nodes.get(key).ok_or(SceneError::NoSuchNode(key))?;
        let base = node.renderable.as_ref().ok_or_else(|| SceneError::BadLod {
            node: node.name.clone(),
            reason: "the node has no renderable".into(),
        })?;
        let submeshes = self.geometries.get(base.geometry).map_or(0, |g| g.submeshes().len());
        for lod in &lods {
            let geometry = self.geometries.get(lod.geometry).ok_or(SceneError::NoSuchGeometry(lod.geometry))?;
            if geometry.submeshes().len() != submeshes {
                return Err(SceneError::BadLod {
                    node: node.name.clone(),
                    reason: format!(
                        "LOD '{}' has {} submeshes, the base mesh {submeshes}",
                        geometry.name(),
                        geometry.submeshes().len()
                    ),
                });
            }
            if !(lod.below_screen_fraction > 0.0 && lod.below_screen_fraction.is_finite()) {
                return Err(SceneError::BadLod {
                    node: node.name.clone(),
                    reason: format!("screen fraction {} is not a positive finite number", lod.below_screen_fraction),
                });
            }
        }
        lods.sort_by(|a, b| b.below_screen_fraction.total_cmp(&a.below_screen_fraction));
        self.node_mut(key)?.lods = lods;
        self.touch(key);
        Ok(())
    }

    /// Attaches (or with `None` removes) a light.
    pub fn set_light(&mut self, key: NodeKey, light: Option<Light>) -> Result<(), SceneError> {
        self.node_mut(key)?.light = light;
        self.touch(key);
        Ok(())
    }

    /// Attaches (or removes) a camera.
    pub fn set_camera(&mut self, key: NodeKey, camera: Option<Camera>) -> Result<(), SceneError> {
        self.node_mut(key)?.camera = camera;
        self.touch(key);
        Ok(())
    }

    /// The world matrix of one node, composed (in `f64`) up its parent
    /// chain; for resolvers that follow a node, without a whole-scene pass.
    pub fn world_transform(&self, key: NodeKey) -> Option<glam::DMat4> {
        let mut node = self.nodes.get(key)?;
        let mut world = node.local.to_dmat4();
        while let Some(parent) = node.parent {
            node = self.nodes.get(parent)?;
            world = node.local.to_dmat4() * world;
        }
        Some(world)
    }

    /// True when the node and all its ancestors are visible.
    pub fn is_effectively_visible(&self, key: NodeKey) -> bool {
        let mut cursor = Some(key);
        while let Some(k) = cursor {
            match self.nodes.get(k) {
                Some(node) if node.is_visible() => cursor = node.parent,
                _ => return false,
            }
        }
        true
    }

    /// Brings `out` up to date with every node's world matrix. Subtrees
    /// untouched since `out` was last resolved against this scene are not
    /// visited at all. Composition is done in `f64`, so deep hierarchies and
    /// large offsets lose no precision before the final rounding to `f32`.
    pub fn resolve_world_transforms(&self, out: &mut WorldTransforms) {
        out.resolve(self);
    }
}

#[cfg(test)]
mod tests {
    use glam::{DVec3, Mat4, Vec3, Vec4};

    use super::*;
    use crate::{MAX_JOINTS, Submesh};

    /// A key that named a node of `scene` once and names none now.
    fn stale_key(scene: &mut Scene) -> NodeKey {
        let key = scene.add_node("gone", Transform::IDENTITY);
        scene.remove_node(key).unwrap();
        key
    }

    /// The cube cut into two submeshes of three faces each.
    fn two_part_cube() -> Geometry {
        let cube = Geometry::cube(1.0);
        let halves = vec![Submesh { first_index: 0, index_count: 18 }, Submesh { first_index: 18, index_count: 18 }];
        Geometry::new("two-part", cube.vertices().to_vec(), cube.indices().to_vec(), halves).unwrap()
    }

    #[test]
    fn node_ids_are_dense_in_insertion_order_and_name_their_node() {
        let mut scene = Scene::new();
        let keys: Vec<NodeKey> = (0..3).map(|i| scene.add_node(format!("n{i}"), Transform::IDENTITY)).collect();
        let ids: Vec<u32> = keys.iter().map(|k| node_index(*k)).collect();
        // Slot indices of a fresh table count up from the first one.
        assert_eq!(ids, [ids[0], ids[0] + 1, ids[0] + 2]);
        for (key, id) in keys.iter().zip(&ids) {
            assert_eq!(scene.node_at_index(*id), Some(*key));
        }
        assert_eq!(scene.node_at_index(ids[2] + 1), None);
        scene.remove_node(keys[1]).unwrap();
        assert_eq!(scene.node_at_index(ids[1]), None, "a removed node's id names nothing");
        assert_eq!(scene.node_at_index(ids[2]), Some(keys[2]));
    }

    #[test]
    fn asset_ids_are_dense_per_kind() {
        let mut scene = Scene::new();
        let g = [scene.add_geometry(Geometry::cube(1.0)), scene.add_geometry(Geometry::quad(1.0))];
        let m = [
            scene.add_material(Material::opaque("a", Vec4::ONE)),
            scene.add_material(Material::opaque("b", Vec4::ONE)),
        ];
        let t = [
            scene.add_texture(TextureImage::checker("a", 4, 2, [0; 4], [255; 4])),
            scene.add_texture(TextureImage::checker("b", 4, 2, [0; 4], [255; 4])),
        ];
        assert_eq!(geometry_index(g[1]), geometry_index(g[0]) + 1);
        assert_eq!(material_index(m[1]), material_index(m[0]) + 1);
        assert_eq!(texture_index(t[1]), texture_index(t[0]) + 1);
    }

    #[test]
    fn added_assets_are_what_their_handles_return_and_each_add_is_an_edit() {
        let mut scene = Scene::new();
        let mut last = scene.revision();
        let mut edited = |scene: &Scene| {
            assert!(scene.revision() > last, "revision {} after {last}", scene.revision());
            assert_eq!(scene.assets_revision(), scene.revision());
            last = scene.revision();
        };

        let cube = scene.add_geometry(Geometry::cube(2.0));
        edited(&scene);
        assert_eq!(scene.geometry(cube).map(|g| g.as_ref()), Some(&Geometry::cube(2.0)));

        let mut rough = Material::opaque("rough", Vec4::new(0.2, 0.4, 0.6, 1.0));
        rough.metallic = f32::NAN;
        let first = scene.add_material(rough.clone());
        edited(&scene);
        let second = scene.add_material(Material::opaque("second", Vec4::ONE));
        edited(&scene);
        assert_eq!(scene.material(first), Some(&rough.sanitized()), "stored sanitized");
        assert_eq!(scene.material(first).unwrap().metallic, 0.0);
        let listed: Vec<(MaterialHandle, &str)> = scene.materials().map(|(h, m)| (h, m.name.as_str())).collect();
        assert_eq!(listed, [(first, "rough"), (second, "second")]);

        let checker = TextureImage::checker("checker", 8, 2, [0, 0, 0, 255], [255; 4]);
        let texture = scene.add_texture(checker.clone());
        edited(&scene);
        assert_eq!(scene.texture(texture).map(|t| t.as_ref()), Some(&checker));

        // The null handle names no asset.
        assert!(scene.geometry(GeometryHandle::default()).is_none());
        assert!(scene.material(MaterialHandle::default()).is_none());
        assert!(scene.texture(TextureHandle::default()).is_none());
    }

    #[test]
    fn a_replaced_material_is_stored_sanitized_and_an_unknown_handle_is_refused() {
        let mut scene = Scene::new();
        let handle = scene.add_material(Material::opaque("old", Vec4::ONE));
        let before = scene.revision();
        let mut new = Material::opaque("new", Vec4::new(2.0, 0.5, 0.5, 1.0));
        new.roughness = f32::INFINITY;
        scene.set_material(handle, new.clone()).unwrap();
        assert_eq!(scene.material(handle), Some(&new.sanitized()));
        assert_eq!(scene.material(handle).unwrap().base_color.x, 1.0, "clamped");
        assert!(scene.revision() > before);
        assert_eq!(scene.assets_revision(), scene.revision());

        let unknown = MaterialHandle::default();
        assert_eq!(scene.set_material(unknown, new), Err(SceneError::NoSuchMaterial(unknown)));
    }

    #[test]
    fn removing_a_node_takes_its_subtree_and_leaves_its_siblings() {
        let mut scene = Scene::new();
        let r1 = scene.add_node("r1", Transform::IDENTITY);
        let r2 = scene.add_node("r2", Transform::IDENTITY);
        let r3 = scene.add_node("r3", Transform::IDENTITY);
        let c1 = scene.add_child(r1, "c1", Transform::IDENTITY).unwrap();
        let c2 = scene.add_child(r1, "c2", Transform::IDENTITY).unwrap();
        let g = scene.add_child(c1, "g", Transform::IDENTITY).unwrap();
        assert_eq!(scene.node_count(), 6);

        let before = scene.revision();
        scene.remove_node(c1).unwrap();
        assert!(scene.revision() > before);
        assert_eq!(scene.node(r1).unwrap().children, [c2]);
        assert!(scene.node(c1).is_none() && scene.node(g).is_none(), "the subtree goes too");

        let before = scene.revision();
        scene.remove_node(r2).unwrap();
        assert!(scene.revision() > before, "removing a root is an edit too");
        assert_eq!(scene.roots(), [r1, r3]);

        assert_eq!(scene.node_count(), 3);
        let left: Vec<(NodeKey, &str)> = scene.nodes().map(|(k, n)| (k, n.name.as_str())).collect();
        assert_eq!(left, [(r1, "r1"), (r3, "r3"), (c2, "c2")]);
        assert_eq!(scene.remove_node(c1), Err(SceneError::NoSuchNode(c1)));
    }

    #[test]
    fn reparenting_moves_a_node_out_of_its_old_place_only() {
        let mut scene = Scene::new();
        let a = scene.add_node("a", Transform::IDENTITY);
        let b = scene.add_node("b", Transform::IDENTITY);
        let c = scene.add_node("c", Transform::IDENTITY);
        let a1 = scene.add_child(a, "a1", Transform::IDENTITY).unwrap();
        let a2 = scene.add_child(a, "a2", Transform::IDENTITY).unwrap();

        scene.set_parent(a1, Some(b)).unwrap();
        assert_eq!(scene.node(a).unwrap().children, [a2]);
        assert_eq!(scene.node(b).unwrap().children, [a1]);
        assert_eq!(scene.node(a1).unwrap().parent, Some(b));

        scene.set_parent(c, Some(a)).unwrap();
        assert_eq!(scene.roots(), [a, b]);
        assert_eq!(scene.node(a).unwrap().children, [a2, c]);

        scene.set_parent(a1, None).unwrap();
        assert_eq!(scene.roots(), [a, b, a1]);
        assert!(scene.node(b).unwrap().children.is_empty());

        assert_eq!(scene.set_parent(a, Some(c)), Err(SceneError::Cycle { child: a, parent: c }));
    }

    #[test]
    fn a_renderable_names_live_assets_and_one_material_per_submesh() {
        let mut scene = Scene::new();
        let geometry = scene.add_geometry(two_part_cube());
        let m1 = scene.add_material(Material::opaque("m1", Vec4::ONE));
        let m2 = scene.add_material(Material::opaque("m2", Vec4::ONE));
        let node = scene.add_node("box", Transform::IDENTITY);
        let good = Renderable { geometry, materials: vec![m1, m2] };
        let before = scene.revision();
        scene.set_renderable(node, good.clone()).unwrap();
        assert_eq!(scene.node(node).unwrap().renderable, Some(good.clone()));
        assert!(scene.node(node).unwrap().revision() > before);

        let unknown_material = MaterialHandle::default();
        let refused = |scene: &mut Scene, renderable: Renderable| scene.set_renderable(node, renderable).unwrap_err();
        assert_eq!(
            refused(&mut scene, Renderable { geometry, materials: vec![m1, unknown_material] }),
            SceneError::NoSuchMaterial(unknown_material)
        );
        assert_eq!(
            refused(&mut scene, Renderable { geometry: GeometryHandle::default(), materials: vec![m1, m2] }),
            SceneError::NoSuchGeometry(GeometryHandle::default())
        );
        assert_eq!(
            refused(&mut scene, Renderable { geometry, materials: vec![m1] }),
            SceneError::MaterialCountMismatch {
                node: "box".into(),
                geometry: "two-part".into(),
                given: 1,
                submeshes: 2
            }
        );
        assert_eq!(scene.node(node).unwrap().renderable, Some(good.clone()), "a refused edit changes nothing");
        let stale = stale_key(&mut scene);
        assert_eq!(scene.set_renderable(stale, good), Err(SceneError::NoSuchNode(stale)));
    }

    #[test]
    fn a_skin_needs_one_finite_bind_matrix_per_joint_of_this_scene() {
        let mut scene = Scene::new();
        let mesh = scene.add_node("mesh", Transform::IDENTITY);
        let j1 = scene.add_node("j1", Transform::IDENTITY);
        let j2 = scene.add_child(j1, "j2", Transform::IDENTITY).unwrap();
        let stale = stale_key(&mut scene);
        let skin = |joints: Vec<NodeKey>, matrices: Vec<Mat4>| Skin { joints, inverse_bind_matrices: matrices };
        let reason = |scene: &mut Scene, skin: Skin| match scene.set_skin(mesh, Some(skin)) {
            Err(SceneError::BadSkin { node, reason }) => {
                assert_eq!(node, "mesh");
                reason
            }
            other => panic!("expected BadSkin, got {other:?}"),
        };

        let good = skin(vec![j1, j2], vec![Mat4::IDENTITY, Mat4::from_translation(Vec3::Y)]);
        scene.set_skin(mesh, Some(good.clone())).unwrap();
        assert_eq!(scene.node(mesh).unwrap().skin.as_deref(), Some(&good));

        assert_eq!(
            reason(&mut scene, skin(vec![j1, j2], vec![Mat4::IDENTITY])),
            "2 joints but 1 inverse bind matrices"
        );
        assert_eq!(reason(&mut scene, skin(vec![], vec![])), format!("0 joints (1 to {MAX_JOINTS})"));
        assert_eq!(
            reason(&mut scene, skin(vec![j1, stale], vec![Mat4::IDENTITY; 2])),
            "joint 1 is not a node of this scene"
        );
        let not_finite = Mat4::from_translation(Vec3::new(0.0, f32::NAN, 0.0));
        assert_eq!(
            reason(&mut scene, skin(vec![j1, j2], vec![Mat4::IDENTITY, not_finite])),
            "inverse bind matrix 1 is not finite"
        );
        // The joint count is bounded by what a skinned vertex can index:
        // MAX_JOINTS itself fits, one more does not.
        let most = skin(vec![j1; MAX_JOINTS], vec![Mat4::IDENTITY; MAX_JOINTS]);
        scene.set_skin(mesh, Some(most)).unwrap();
        assert_eq!(scene.node(mesh).unwrap().skin.as_ref().unwrap().joints.len(), MAX_JOINTS);
        assert_eq!(
            reason(&mut scene, skin(vec![j1; MAX_JOINTS + 1], vec![Mat4::IDENTITY; MAX_JOINTS + 1])),
            format!("{} joints (1 to {MAX_JOINTS})", MAX_JOINTS + 1)
        );

        scene.set_skin(mesh, None).unwrap();
        assert!(scene.node(mesh).unwrap().skin.is_none(), "None makes the node rigid again");
        assert_eq!(scene.set_skin(stale, Some(good)), Err(SceneError::NoSuchNode(stale)));
    }

    #[test]
    fn morph_weights_and_semantic_classes_are_set_on_live_nodes_only() {
        let mut scene = Scene::new();
        let node = scene.add_node("blob", Transform::IDENTITY);
        scene.set_morph_weights(node, vec![0.5, f32::NAN, f32::NEG_INFINITY, 0.25]).unwrap();
        assert_eq!(scene.node(node).unwrap().morph_weights, [0.5, 0.0, 0.0, 0.25]);

        let before = scene.revision();
        scene.set_semantic_class(node, 7).unwrap();
        assert_eq!(scene.node(node).unwrap().semantic_class, 7);
        assert!(scene.revision() > before);
        let before = scene.revision();
        scene.set_semantic_class(node, 7).unwrap();
        assert_eq!(scene.revision(), before, "the same class again is no edit");

        let stale = stale_key(&mut scene);
        assert_eq!(scene.set_morph_weights(stale, vec![1.0]), Err(SceneError::NoSuchNode(stale)));
        assert_eq!(scene.set_semantic_class(stale, 3), Err(SceneError::NoSuchNode(stale)));
    }

    #[test]
    fn lods_are_sorted_coarsest_last_and_refused_with_a_reason() {
        let mut scene = Scene::new();
        let base = scene.add_geometry(Geometry::cube(1.0));
        let mid = scene.add_geometry(Geometry::cube(1.0));
        let coarse = scene.add_geometry(Geometry::quad(1.0));
        let split = scene.add_geometry(two_part_cube());
        let material = scene.add_material(Material::opaque("m", Vec4::ONE));
        let node = scene.add_node("lodded", Transform::IDENTITY);
        let bare = scene.add_node("bare", Transform::IDENTITY);
        scene.set_renderable(node, Renderable { geometry: base, materials: vec![material] }).unwrap();
        let lod = |geometry, below_screen_fraction| LodLevel { geometry, below_screen_fraction };

        scene.set_lods(node, vec![lod(coarse, 0.1), lod(mid, 0.5)]).unwrap();
        assert_eq!(scene.node(node).unwrap().lods, [lod(mid, 0.5), lod(coarse, 0.1)]);

        let reason = |scene: &mut Scene, key: NodeKey, lods: Vec<LodLevel>| match scene.set_lods(key, lods) {
            Err(SceneError::BadLod { reason, .. }) => reason,
            other => panic!("expected BadLod, got {other:?}"),
        };
        for fraction in [0.0, -0.5, f32::INFINITY, f32::NAN] {
            let why = reason(&mut scene, node, vec![lod(mid, fraction)]);
            assert_eq!(why, format!("screen fraction {fraction} is not a positive finite number"));
        }
        assert_eq!(reason(&mut scene, node, vec![lod(split, 0.5)]), "LOD 'two-part' has 2 submeshes, the base mesh 1");
        assert_eq!(reason(&mut scene, bare, vec![lod(mid, 0.5)]), "the node has no renderable");
        let unknown = GeometryHandle::default();
        assert_eq!(scene.set_lods(node, vec![lod(unknown, 0.5)]), Err(SceneError::NoSuchGeometry(unknown)));
        assert_eq!(scene.node(node).unwrap().lods.len(), 2, "refused edits change nothing");

        scene.set_lods(node, Vec::new()).unwrap();
        assert!(scene.node(node).unwrap().lods.is_empty(), "an empty list removes them");
        let stale = stale_key(&mut scene);
        assert_eq!(scene.set_lods(stale, Vec::new()), Err(SceneError::NoSuchNode(stale)));
    }

    #[test]
    fn lights_and_cameras_attach_to_live_nodes_and_come_off_with_none() {
        let mut scene = Scene::new();
        let node = scene.add_node("rig", Transform::IDENTITY);
        let light = Light::point(40.0, Some(10.0));
        let camera = Camera::perspective(1.0, 0.1, Some(100.0));
        scene.set_light(node, Some(light.clone())).unwrap();
        scene.set_camera(node, Some(camera)).unwrap();
        assert_eq!(scene.node(node).unwrap().light, Some(light.clone()));
        assert_eq!(scene.node(node).unwrap().camera, Some(camera));
        scene.set_light(node, None).unwrap();
        scene.set_camera(node, None).unwrap();
        assert!(scene.node(node).unwrap().light.is_none() && scene.node(node).unwrap().camera.is_none());

        let stale = stale_key(&mut scene);
        assert_eq!(scene.set_light(stale, Some(light)), Err(SceneError::NoSuchNode(stale)));
        assert_eq!(scene.set_camera(stale, Some(camera)), Err(SceneError::NoSuchNode(stale)));
    }

    #[test]
    fn a_world_transform_composes_the_parent_chain() {
        let mut scene = Scene::new();
        let parent = scene.add_node("parent", Transform::from_translation(Vec3::X * 10.0).with_scale(Vec3::splat(2.0)));
        let child = scene.add_child(parent, "child", Transform::from_translation(Vec3::Y)).unwrap();
        let world = scene.world_transform(child).unwrap();
        // Parent after child: the child's offset is scaled, then moved.
        assert_eq!(world.transform_point3(DVec3::ZERO), DVec3::new(10.0, 2.0, 0.0));
        assert_eq!(world.transform_vector3(DVec3::Z), DVec3::new(0.0, 0.0, 2.0));
        let stale = stale_key(&mut scene);
        assert!(scene.world_transform(stale).is_none());
    }

    #[test]
    fn a_node_is_visible_only_when_it_and_every_ancestor_are() {
        let mut scene = Scene::new();
        let root = scene.add_node("root", Transform::IDENTITY);
        let middle = scene.add_child(root, "middle", Transform::IDENTITY).unwrap();
        let leaf = scene.add_child(middle, "leaf", Transform::IDENTITY).unwrap();
        assert!(scene.is_effectively_visible(leaf));
        scene.set_flags(middle, NodeFlags::CASTS_SHADOWS).unwrap();
        assert!(!scene.is_effectively_visible(leaf), "a hidden parent hides its subtree");
        assert!(!scene.is_effectively_visible(middle));
        assert!(scene.is_effectively_visible(root));
        let stale = stale_key(&mut scene);
        assert!(!scene.is_effectively_visible(stale));
    }
}
