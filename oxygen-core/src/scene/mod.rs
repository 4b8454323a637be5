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

    /// Root nodes in insertion order.
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
