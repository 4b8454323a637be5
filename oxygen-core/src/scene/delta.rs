//! Scene deltas: what changed in a [`Scene`] since a revision, as data that
//! a replica elsewhere (another GPU, another process, another machine)
//! applies to stay in step.
//!
//! A replica must not only hold the same nodes and assets: their slot
//! indices are the ids the frame shows (a node's index is its instance
//! label and breaks ties in the draw order), so the replica must give every
//! node and asset the same slot. Slot maps hand slots out deterministically
//! (a new slot, or the most recently freed one), so a replica that performs
//! the same insertions and removals in the same order gets the same slots.
//! The scene therefore keeps a **journal** of those structural events (a
//! node added or removed, an asset added, a material replaced), and a
//! delta is:
//!
//! * the structural events since the base revision, in order
//!   ([`DeltaOp`]);
//! * the final state of every node edited since then ([`NodeRecord`],
//!   parents by index; children lists follow from the parents);
//! * the content of the assets those events name that this stream has not
//!   sent yet, by [`AssetHash`] (BLAKE3 of the asset's encoding): an asset
//!   travels once per stream, and a replica keeps what it received.
//!
//! From revision 0 (or from one the journal no longer reaches, see
//! [`Scene::trim_journal`]) the delta is a **snapshot**: it rebuilds the
//! slot layout from nothing (every node slot made, the vacant ones freed in
//! the order that leaves the same free list) and carries every node.
//!
//! Deltas are plain data, encoded with `postcard` ([`SceneDelta::encode`])
//! behind a format number; [`SceneReplica::apply`] validates everything it
//! is given (asset contents against their hashes and through the same
//! constructors the scene uses, every index against the replica) and
//! answers a bad or out-of-step delta with a [`DeltaError`], never a panic.

use std::collections::{HashMap, HashSet};
use std::sync::{Arc, Mutex};

use serde::{Deserialize, Serialize};
use slotmap::{Key, KeyData};
use thiserror::Error;

use super::{
    GeometryHandle, LodLevel, MaterialHandle, Node, NodeFlags, NodeKey, Renderable, Scene, SceneError, Skin,
    TextureHandle, Transform, geometry_index, material_index, node_index, texture_index,
};
use crate::{
    Camera, ColorSpace, Geometry, GeometryError, Light, Material, MorphTarget, Sampling, SkinWeights, Submesh,
    TextureError, TextureImage, Vertex, VertexAttributes,
};

/// The encoding's format number: a decoder refuses any other.
pub const DELTA_FORMAT: u32 = 1;

/// Journal events kept before the oldest half is dropped (deltas from
/// before the drop become snapshots): 16 bytes each, 16 MiB at most.
const MAX_JOURNAL_EVENTS: usize = 1 << 20;

/// A structural edit, as the journal keeps it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Event {
    NodeAdded(u32),
    NodeRemoved(u32),
    GeometryAdded(u32),
    TextureAdded(u32),
    MaterialAdded(u32),
    MaterialSet(u32),
}

/// Which asset table an index is in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum AssetKind {
    Geometry,
    Texture,
}

/// The structural events of a scene and what its node slot map's free list
/// holds (mirrored: the slot map does not show it).
#[derive(Debug)]
pub(crate) struct Journal {
    events: Vec<(u64, Event)>,
    /// A delta from a revision before this one cannot be made from the
    /// events (they were trimmed): it is a snapshot.
    floor: u64,
    /// Node slots made so far (slot 0 is the slot map's sentinel).
    node_slots: u32,
    /// Vacant node slots, the most recently freed last.
    free_nodes: Vec<u32>,
    /// Asset hashes, computed when an asset is first sent.
    hashes: Mutex<HashMap<(AssetKind, u32), AssetHash>>,
}

impl Default for Journal {
    fn default() -> Self {
        Journal { events: Vec::new(), floor: 0, node_slots: 1, free_nodes: Vec::new(), hashes: Mutex::default() }
    }
}

impl Journal {
    pub(crate) fn record(&mut self, revision: u64, event: Event) {
        if self.events.len() >= MAX_JOURNAL_EVENTS {
            // Drop the older half, and with it every event of the last
            // dropped revision (one edit may record several: a subtree's
            // removals), so that a delta from the floor misses none.
            let floor = self.events[self.events.len() / 2].0;
            let dropped = self.events.partition_point(|(r, _)| *r <= floor);
            self.floor = self.floor.max(floor);
            self.events.drain(..dropped);
        }
        self.events.push((revision, event));
    }

    /// A node took slot `index`: the free list's last, or a new slot.
    pub(crate) fn node_inserted(&mut self, revision: u64, index: u32) {
        if self.free_nodes.last() == Some(&index) {
            self.free_nodes.pop();
        } else {
            self.node_slots = self.node_slots.max(index + 1);
        }
        self.record(revision, Event::NodeAdded(index));
    }

    pub(crate) fn node_removed(&mut self, revision: u64, index: u32) {
        self.free_nodes.push(index);
        self.record(revision, Event::NodeRemoved(index));
    }

    fn hashes(&self) -> std::sync::MutexGuard<'_, HashMap<(AssetKind, u32), AssetHash>> {
        self.hashes.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// An asset's content hash: BLAKE3 of its encoded record.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct AssetHash(pub [u8; 32]);

impl AssetHash {
    fn of(bytes: &[u8]) -> Self {
        AssetHash(*blake3::hash(bytes).as_bytes())
    }
}

impl std::fmt::Display for AssetHash {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0[..8].iter().try_for_each(|b| write!(f, "{b:02x}"))
    }
}

/// A geometry's content, as a delta carries it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GeometryRecord {
    /// Its name.
    pub name: String,
    /// Vertices.
    pub vertices: Vec<Vertex>,
    /// Indices.
    pub indices: Vec<u32>,
    /// Submesh ranges.
    pub submeshes: Vec<Submesh>,
    /// Vertex colours and second UVs, if any.
    pub attributes: Option<Vec<VertexAttributes>>,
    /// Skin weights, if any.
    pub skin: Option<Vec<SkinWeights>>,
    /// Morph targets.
    pub morph_targets: Vec<MorphTarget>,
}

impl GeometryRecord {
    fn of(geometry: &Geometry) -> Self {
        GeometryRecord {
            name: geometry.name().to_owned(),
            vertices: geometry.vertices().to_vec(),
            indices: geometry.indices().to_vec(),
            submeshes: geometry.submeshes().to_vec(),
            attributes: geometry.attributes().map(<[_]>::to_vec),
            skin: geometry.skin_weights().map(<[_]>::to_vec),
            morph_targets: geometry.morph_targets().to_vec(),
        }
    }

    /// Through the constructors the scene's own geometry went through.
    fn build(self) -> Result<Geometry, GeometryError> {
        let mut geometry = Geometry::new(self.name, self.vertices, self.indices, self.submeshes)?;
        if let Some(attributes) = self.attributes {
            geometry = geometry.with_attributes(attributes)?;
        }
        if let Some(skin) = self.skin {
            geometry = geometry.with_skin_weights(skin)?;
        }
        if !self.morph_targets.is_empty() {
            geometry = geometry.with_morph_targets(self.morph_targets)?;
        }
        Ok(geometry)
    }
}

/// A texture's content, as a delta carries it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TextureRecord {
    /// Its name.
    pub name: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// How its values are encoded.
    pub color_space: ColorSpace,
    /// How it is sampled.
    pub sampling: Sampling,
    /// Tightly packed RGBA8 rows.
    pub pixels: Vec<u8>,
}

impl TextureRecord {
    fn of(texture: &TextureImage) -> Self {
        TextureRecord {
            name: texture.name().to_owned(),
            width: texture.width(),
            height: texture.height(),
            color_space: texture.color_space(),
            sampling: texture.sampling(),
            pixels: texture.pixels().to_vec(),
        }
    }

    fn build(self) -> Result<TextureImage, TextureError> {
        Ok(TextureImage::new(self.name, self.width, self.height, self.color_space, self.pixels)?
            .with_sampling(self.sampling))
    }
}

/// An asset's content.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum AssetBody {
    /// A geometry.
    Geometry(GeometryRecord),
    /// A texture.
    Texture(TextureRecord),
}

/// A structural edit, replayed in order so that the replica's slots are the
/// source's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum DeltaOp {
    /// A node took slot `index` (its state follows in the delta's nodes).
    AddNode {
        /// Its slot.
        index: u32,
    },
    /// The node in slot `index` was removed (a removed subtree is one op
    /// per node, in the order they were freed).
    RemoveNode {
        /// Its slot.
        index: u32,
    },
    /// A geometry took slot `index`.
    AddGeometry {
        /// Its slot.
        index: u32,
        /// Its content, in this delta or an earlier one of the stream.
        hash: AssetHash,
    },
    /// A texture took slot `index`.
    AddTexture {
        /// Its slot.
        index: u32,
        /// Its content, in this delta or an earlier one of the stream.
        hash: AssetHash,
    },
    /// A material took slot `index`.
    AddMaterial {
        /// Its slot.
        index: u32,
        /// Its value (as the source holds it now).
        material: Material,
    },
    /// The material in slot `index` was replaced.
    SetMaterial {
        /// Its slot.
        index: u32,
        /// Its new value.
        material: Material,
    },
}

/// A renderable, by slot indices.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderableRecord {
    /// The geometry's slot.
    pub geometry: u32,
    /// One material slot per submesh.
    pub materials: Vec<u32>,
}

/// A level of detail, by slot index.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LodRecord {
    /// The geometry's slot.
    pub geometry: u32,
    /// See [`LodLevel::below_screen_fraction`].
    pub below_screen_fraction: f32,
}

/// A skin, by node slots.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SkinRecord {
    /// The joints' node slots; `None` for a joint node removed since the
    /// skin was set (the source's key is stale, and so is the replica's).
    pub joints: Vec<Option<u32>>,
    /// One inverse bind matrix per joint.
    pub inverse_bind_matrices: Vec<glam::Mat4>,
}

/// A node's whole state (what a [`Node`] holds, references by slot index).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NodeRecord {
    /// Its slot.
    pub index: u32,
    /// Name.
    pub name: String,
    /// The parent's slot; `None` for a root.
    pub parent: Option<u32>,
    /// Local transform.
    pub local: Transform,
    /// Flags.
    pub flags: NodeFlags,
    /// Renderable.
    pub renderable: Option<RenderableRecord>,
    /// Light.
    pub light: Option<Light>,
    /// Camera.
    pub camera: Option<Camera>,
    /// Levels of detail, finest first.
    pub lods: Vec<LodRecord>,
    /// Skin.
    pub skin: Option<SkinRecord>,
    /// Morph target weights.
    pub morph_weights: Vec<f32>,
    /// Semantic class.
    pub semantic_class: u32,
}

impl NodeRecord {
    fn of(scene: &Scene, index: u32, node: &Node) -> Self {
        NodeRecord {
            index,
            name: node.name.clone(),
            parent: node.parent.map(node_index),
            local: node.local,
            flags: node.flags,
            renderable: node.renderable.as_ref().map(|r| RenderableRecord {
                geometry: geometry_index(r.geometry),
                materials: r.materials.iter().map(|m| material_index(*m)).collect(),
            }),
            light: node.light.clone(),
            camera: node.camera,
            lods: node
                .lods
                .iter()
                .map(|l| LodRecord {
                    geometry: geometry_index(l.geometry),
                    below_screen_fraction: l.below_screen_fraction,
                })
                .collect(),
            skin: node.skin.as_ref().map(|s| SkinRecord {
                joints: s.joints.iter().map(|j| scene.nodes.contains_key(*j).then(|| node_index(*j))).collect(),
                inverse_bind_matrices: s.inverse_bind_matrices.clone(),
            }),
            morph_weights: node.morph_weights.clone(),
            semantic_class: node.semantic_class,
        }
    }
}

/// What changed in a scene between two of its revisions (see the module
/// docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneDelta {
    /// [`DELTA_FORMAT`] when made.
    pub format: u32,
    /// The source revision it applies to; 0 for a snapshot, which applies
    /// to an empty replica (a replica in any state is emptied first).
    pub base: u64,
    /// The source revision it brings a replica to.
    pub revision: u64,
    /// Contents of assets the ops name that the stream had not sent.
    pub assets: Vec<(AssetHash, AssetBody)>,
    /// Structural edits, in order.
    pub ops: Vec<DeltaOp>,
    /// The state of every node added or edited since `base`, in slot order.
    pub nodes: Vec<NodeRecord>,
}

/// Why a delta could not be decoded or applied.
#[derive(Debug, Error, PartialEq)]
pub enum DeltaError {
    /// The bytes are not a delta of this format.
    #[error("not a scene delta of format {DELTA_FORMAT}: {0}")]
    Format(String),
    /// The delta starts from another revision than the replica holds.
    #[error("the delta applies to revision {base}, the replica holds {held:?}")]
    OutOfStep {
        /// The delta's base.
        base: u64,
        /// The replica's revision (`None` after a failed apply).
        held: Option<u64>,
    },
    /// An op names an asset whose content neither this delta nor an
    /// earlier one carried.
    #[error("asset {0} was never sent")]
    MissingAsset(AssetHash),
    /// An asset's content does not hash to the hash it came with.
    #[error("asset {0}: content does not match its hash")]
    HashMismatch(AssetHash),
    /// An asset's content is not a valid asset.
    #[error("asset {hash}: {reason}")]
    BadAsset {
        /// The asset.
        hash: AssetHash,
        /// What its constructor refused.
        reason: String,
    },
    /// An op or record names a slot the replica does not have, or a slot
    /// came out other than the source's.
    #[error("{0}")]
    BadSlot(String),
    /// A node record the scene refuses (a cycle, a skin or LOD that does
    /// not fit).
    #[error("node {index}: {source}")]
    BadNode {
        /// The node's slot.
        index: u32,
        /// What the scene refused.
        source: SceneError,
    },
}

impl SceneDelta {
    /// The delta as bytes (`postcard`).
    pub fn encode(&self) -> Vec<u8> {
        // Encoding plain data into a Vec cannot fail.
        postcard::to_stdvec(self).unwrap_or_default()
    }

    /// A delta from bytes; refuses other formats and malformed bytes.
    pub fn decode(bytes: &[u8]) -> Result<Self, DeltaError> {
        let delta: SceneDelta = postcard::from_bytes(bytes).map_err(|e| DeltaError::Format(e.to_string()))?;
        if delta.format != DELTA_FORMAT {
            return Err(DeltaError::Format(format!("format {}", delta.format)));
        }
        Ok(delta)
    }

    /// Whether it is a snapshot (applies to an empty replica).
    pub fn is_snapshot(&self) -> bool {
        self.base == 0
    }
}

/// The sending side of a stream of deltas to one replica (or to many that
/// receive the same deltas in the same order): the revision it is at and
/// the assets it has sent.
#[derive(Debug, Default)]
pub struct DeltaStream {
    revision: u64,
    sent: HashSet<AssetHash>,
    /// The scene the last delta came from: another scene gets a snapshot.
    scene: Option<u64>,
}

impl DeltaStream {
    /// A stream whose first delta is a snapshot.
    pub fn new() -> Self {
        Self::default()
    }

    /// The source revision the last delta brought the receivers to (0
    /// before the first).
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// The next delta: what changed in `scene` since the last one (a
    /// snapshot first, and whenever the scene's journal no longer reaches
    /// back to the last one). Assets already sent on this stream travel by
    /// hash alone.
    pub fn next(&mut self, scene: &Scene) -> SceneDelta {
        if self.scene != Some(scene.id()) {
            self.revision = 0;
            self.scene = Some(scene.id());
        }
        let delta = scene.delta_since(self.revision, &mut self.sent);
        self.revision = delta.revision;
        delta
    }

    /// Makes the next delta a snapshot (a receiver was reset); assets
    /// already sent still travel by hash, since receivers keep them.
    pub fn restart(&mut self) {
        self.revision = 0;
    }
}

impl Scene {
    /// What changed since source revision `base` (see the module docs);
    /// assets whose hash is in `sent` travel by hash alone, and the others
    /// are added to it. A snapshot when `base` is 0, older than the journal
    /// reaches or newer than the scene.
    pub fn delta_since(&self, base: u64, sent: &mut HashSet<AssetHash>) -> SceneDelta {
        let _span = tracing::info_span!("scene_delta", base, revision = self.revision).entered();
        let snapshot = base == 0 || base < self.journal.floor || base > self.revision;
        let mut delta = SceneDelta {
            format: DELTA_FORMAT,
            base: if snapshot { 0 } else { base },
            revision: self.revision,
            assets: Vec::new(),
            ops: Vec::new(),
            nodes: Vec::new(),
        };
        if snapshot {
            // Every slot ever made, then the vacant ones freed so that the
            // last freed is the free list's head, as here.
            delta.ops.extend((1..self.journal.node_slots).map(|index| DeltaOp::AddNode { index }));
            delta.ops.extend(self.journal.free_nodes.iter().map(|&index| DeltaOp::RemoveNode { index }));
            for (handle, _) in self.geometries.iter() {
                delta.ops.push(self.geometry_op(geometry_index(handle), sent, &mut delta.assets));
            }
            for (handle, _) in self.textures.iter() {
                delta.ops.push(self.texture_op(texture_index(handle), sent, &mut delta.assets));
            }
            for (handle, material) in self.materials.iter() {
                delta.ops.push(DeltaOp::AddMaterial { index: material_index(handle), material: material.clone() });
            }
            delta.nodes = self.nodes.iter().map(|(key, node)| NodeRecord::of(self, node_index(key), node)).collect();
            return delta;
        }
        let first = self.journal.events.partition_point(|(revision, _)| *revision <= base);
        for &(_, event) in &self.journal.events[first..] {
            let op = match event {
                Event::NodeAdded(index) => DeltaOp::AddNode { index },
                Event::NodeRemoved(index) => DeltaOp::RemoveNode { index },
                Event::GeometryAdded(index) => self.geometry_op(index, sent, &mut delta.assets),
                Event::TextureAdded(index) => self.texture_op(index, sent, &mut delta.assets),
                // The material as it is now: a later replacement in the
                // window sends it again, harmlessly.
                Event::MaterialAdded(index) | Event::MaterialSet(index) => {
                    let material =
                        self.material_at(index).cloned().unwrap_or_else(|| Material::opaque("", glam::Vec4::ONE));
                    match event {
                        Event::MaterialAdded(_) => DeltaOp::AddMaterial { index, material },
                        _ => DeltaOp::SetMaterial { index, material },
                    }
                }
            };
            delta.ops.push(op);
        }
        // Slots are per table: only the order within one table matters.
        // Nodes, geometries, textures, then materials, so that a material
        // names only textures already there (one added after it in the
        // window, and set into it, would otherwise come too late).
        delta.ops.sort_by_key(|op| match op {
            DeltaOp::AddNode { .. } | DeltaOp::RemoveNode { .. } => 0,
            DeltaOp::AddGeometry { .. } => 1,
            DeltaOp::AddTexture { .. } => 2,
            DeltaOp::AddMaterial { .. } | DeltaOp::SetMaterial { .. } => 3,
        });
        delta.nodes = self
            .nodes
            .iter()
            .filter(|(_, node)| node.revision > base)
            .map(|(key, node)| NodeRecord::of(self, node_index(key), node))
            .collect();
        delta
    }

    /// Drops the journal's events up to `revision`: deltas from before it
    /// become snapshots. Call when every replica is past it (the journal
    /// also drops its older half by itself past a million events).
    pub fn trim_journal(&mut self, revision: u64) {
        let revision = revision.min(self.revision);
        let keep = self.journal.events.partition_point(|(r, _)| *r <= revision);
        self.journal.events.drain(..keep);
        self.journal.floor = self.journal.floor.max(revision);
    }

    fn material_at(&self, index: u32) -> Option<&Material> {
        self.materials.get(asset_key::<MaterialHandle>(index))
    }

    fn geometry_op(
        &self,
        index: u32,
        sent: &mut HashSet<AssetHash>,
        assets: &mut Vec<(AssetHash, AssetBody)>,
    ) -> DeltaOp {
        let handle = asset_key::<GeometryHandle>(index);
        let hash = self.asset_hash(AssetKind::Geometry, index, sent, assets, || {
            self.geometries.get(handle).map(|g| AssetBody::Geometry(GeometryRecord::of(g)))
        });
        DeltaOp::AddGeometry { index, hash }
    }

    fn texture_op(
        &self,
        index: u32,
        sent: &mut HashSet<AssetHash>,
        assets: &mut Vec<(AssetHash, AssetBody)>,
    ) -> DeltaOp {
        let handle = asset_key::<TextureHandle>(index);
        let hash = self.asset_hash(AssetKind::Texture, index, sent, assets, || {
            self.textures.get(handle).map(|t| AssetBody::Texture(TextureRecord::of(t)))
        });
        DeltaOp::AddTexture { index, hash }
    }

    /// The asset's hash (computed once per scene), its body added to
    /// `assets` when the stream has not sent it.
    fn asset_hash(
        &self,
        kind: AssetKind,
        index: u32,
        sent: &mut HashSet<AssetHash>,
        assets: &mut Vec<(AssetHash, AssetBody)>,
        body: impl FnOnce() -> Option<AssetBody>,
    ) -> AssetHash {
        let known = self.journal.hashes().get(&(kind, index)).copied();
        if let Some(hash) = known
            && sent.contains(&hash)
        {
            return hash;
        }
        // Assets are never removed or replaced, so the body exists.
        let Some(body) = body() else { return AssetHash([0; 32]) };
        let hash = known.unwrap_or_else(|| {
            let hash = AssetHash::of(&encode_body(&body));
            self.journal.hashes().insert((kind, index), hash);
            hash
        });
        if sent.insert(hash) {
            assets.push((hash, body));
        }
        hash
    }
}

fn encode_body(body: &AssetBody) -> Vec<u8> {
    postcard::to_stdvec(body).unwrap_or_default()
}

/// A scene kept in step with another by its deltas.
#[derive(Default)]
pub struct SceneReplica {
    scene: Scene,
    /// The source revision held; `None` before the first delta and after
    /// a failed apply (only a snapshot applies then).
    revision: Option<u64>,
    geometries: HashMap<AssetHash, Arc<Geometry>>,
    textures: HashMap<AssetHash, Arc<TextureImage>>,
    /// The replica's node keys by slot.
    node_keys: HashMap<u32, NodeKey>,
}

impl SceneReplica {
    /// An empty replica: its first delta must be a snapshot.
    pub fn new() -> Self {
        Self::default()
    }

    /// The replicated scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The source revision the replica holds (`None` before its first
    /// snapshot and after a failed apply).
    pub fn revision(&self) -> Option<u64> {
        self.revision
    }

    /// Applies `delta`: a snapshot to any state, any other delta only to
    /// the revision it starts from. On an error the replica waits for a
    /// snapshot ([`SceneReplica::revision`] is `None`); assets received
    /// stay known.
    pub fn apply(&mut self, delta: &SceneDelta) -> Result<(), DeltaError> {
        let _span = tracing::info_span!("apply_scene_delta", base = delta.base, revision = delta.revision).entered();
        if delta.format != DELTA_FORMAT {
            return Err(DeltaError::Format(format!("format {}", delta.format)));
        }
        if !delta.is_snapshot() && self.revision != Some(delta.base) {
            return Err(DeltaError::OutOfStep { base: delta.base, held: self.revision });
        }
        self.revision = None;
        for (hash, body) in &delta.assets {
            if AssetHash::of(&encode_body(body)) != *hash {
                return Err(DeltaError::HashMismatch(*hash));
            }
            let bad = |reason: String| DeltaError::BadAsset { hash: *hash, reason };
            match body.clone() {
                AssetBody::Geometry(record) => {
                    let geometry = record.build().map_err(|e| bad(e.to_string()))?;
                    self.geometries.insert(*hash, Arc::new(geometry));
                }
                AssetBody::Texture(record) => {
                    let texture = record.build().map_err(|e| bad(e.to_string()))?;
                    self.textures.insert(*hash, Arc::new(texture));
                }
            }
        }
        if delta.is_snapshot() {
            self.scene = Scene::new();
            self.node_keys.clear();
        }
        for op in &delta.ops {
            self.apply_op(op)?;
        }
        let keys = std::mem::take(&mut self.node_keys);
        let result = self.apply_nodes(delta, &keys);
        self.node_keys = keys;
        result?;
        self.revision = Some(delta.revision);
        Ok(())
    }

    fn apply_nodes(&mut self, delta: &SceneDelta, keys: &HashMap<u32, NodeKey>) -> Result<(), DeltaError> {
        let key_of =
            |index: u32| keys.get(&index).copied().ok_or_else(|| DeltaError::BadSlot(format!("no node {index}")));
        for record in &delta.nodes {
            let key = key_of(record.index)?;
            self.apply_node(key, record, &key_of).map_err(|e| match e {
                Applied::Scene(source) => DeltaError::BadNode { index: record.index, source },
                Applied::Delta(e) => e,
            })?;
        }
        // Parents last, all at once: applied one by one, final parents
        // could pass through a cycle that the final state does not have,
        // and a snapshot's every node would walk the roots' list.
        let moves = delta
            .nodes
            .iter()
            .map(|record| Ok((key_of(record.index)?, record.parent.map(key_of).transpose()?)))
            .collect::<Result<Vec<_>, DeltaError>>()?;
        self.scene.reparent_many(&moves).map_err(|source| {
            let index = match &source {
                SceneError::Cycle { child, .. } | SceneError::NoSuchNode(child) => node_index(*child),
                _ => 0,
            };
            DeltaError::BadNode { index, source }
        })
    }

    fn apply_op(&mut self, op: &DeltaOp) -> Result<(), DeltaError> {
        let scene = &mut self.scene;
        let wrong = |what: &str, want: u32, got: u32| {
            DeltaError::BadSlot(format!("{what} took slot {got}, the source's took {want}"))
        };
        match op {
            DeltaOp::AddNode { index } => {
                let key = scene.nodes.insert(Node::new(String::new(), None, Transform::IDENTITY));
                scene.roots.push(key);
                scene.touch(key);
                scene.journal.node_inserted(scene.revision, node_index(key));
                if node_index(key) != *index {
                    return Err(wrong("a node", *index, node_index(key)));
                }
                self.node_keys.insert(*index, key);
            }
            DeltaOp::RemoveNode { index } => {
                let key = self
                    .node_keys
                    .remove(index)
                    .ok_or_else(|| DeltaError::BadSlot(format!("no node {index} to remove")))?;
                // One node at a time, as the source freed them: its
                // children become roots until their own op or record.
                let Some(node) = scene.nodes.remove(key) else { return Ok(()) };
                match node.parent {
                    Some(p) => {
                        if let Some(parent) = scene.nodes.get_mut(p) {
                            parent.children.retain(|c| *c != key);
                        }
                    }
                    None => scene.roots.retain(|r| *r != key),
                }
                for child in node.children {
                    if let Some(c) = scene.nodes.get_mut(child) {
                        c.parent = None;
                        scene.roots.push(child);
                    }
                }
                scene.revision += 1;
                scene.journal.node_removed(scene.revision, *index);
            }
            DeltaOp::AddGeometry { index, hash } => {
                let geometry = self.geometries.get(hash).ok_or(DeltaError::MissingAsset(*hash))?;
                let handle = scene.add_geometry_shared(Arc::clone(geometry));
                if geometry_index(handle) != *index {
                    return Err(wrong("a geometry", *index, geometry_index(handle)));
                }
                scene.journal.hashes().insert((AssetKind::Geometry, *index), *hash);
            }
            DeltaOp::AddTexture { index, hash } => {
                let texture = self.textures.get(hash).ok_or(DeltaError::MissingAsset(*hash))?;
                let handle = scene.add_texture_shared(Arc::clone(texture));
                if texture_index(handle) != *index {
                    return Err(wrong("a texture", *index, texture_index(handle)));
                }
                scene.journal.hashes().insert((AssetKind::Texture, *index), *hash);
            }
            DeltaOp::AddMaterial { index, material } => {
                check_textures(scene, material)?;
                let handle = scene.add_material(material.clone());
                if material_index(handle) != *index {
                    return Err(wrong("a material", *index, material_index(handle)));
                }
            }
            DeltaOp::SetMaterial { index, material } => {
                check_textures(scene, material)?;
                let handle = asset_key::<MaterialHandle>(*index);
                scene.set_material(handle, material.clone()).map_err(|e| DeltaError::BadSlot(e.to_string()))?;
            }
        }
        Ok(())
    }

    fn apply_node(
        &mut self,
        key: NodeKey,
        record: &NodeRecord,
        key_of: &dyn Fn(u32) -> Result<NodeKey, DeltaError>,
    ) -> Result<(), Applied> {
        let scene = &mut self.scene;
        let geometry = |index: u32| {
            let handle = asset_key::<GeometryHandle>(index);
            match scene.geometries.contains_key(handle) {
                true => Ok(handle),
                false => Err(Applied::Delta(DeltaError::BadSlot(format!("no geometry {index}")))),
            }
        };
        let renderable = match &record.renderable {
            Some(r) => {
                let materials = r
                    .materials
                    .iter()
                    .map(|m| {
                        let handle = asset_key::<MaterialHandle>(*m);
                        match scene.materials.contains_key(handle) {
                            true => Ok(handle),
                            false => Err(Applied::Delta(DeltaError::BadSlot(format!("no material {m}")))),
                        }
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                Some(Renderable { geometry: geometry(r.geometry)?, materials })
            }
            None => None,
        };
        let lods = record
            .lods
            .iter()
            .map(|l| Ok(LodLevel { geometry: geometry(l.geometry)?, below_screen_fraction: l.below_screen_fraction }))
            .collect::<Result<Vec<_>, Applied>>()?;
        // A joint removed at the source is a key that names nothing here
        // too (the null key).
        let skin = match &record.skin {
            Some(s) => Some(Skin {
                joints: s
                    .joints
                    .iter()
                    .map(|j| j.map_or(Ok(NodeKey::null()), key_of))
                    .collect::<Result<_, _>>()
                    .map_err(Applied::Delta)?,
                inverse_bind_matrices: s.inverse_bind_matrices.clone(),
            }),
            None => None,
        };
        if let Some(node) = scene.nodes.get_mut(key) {
            node.name.clone_from(&record.name);
        }
        scene.set_local_transform(key, record.local)?;
        scene.set_flags(key, record.flags)?;
        match renderable {
            Some(renderable) => scene.set_renderable(key, renderable)?,
            None => {
                if let Some(node) = scene.nodes.get_mut(key) {
                    node.renderable = None;
                }
            }
        }
        // As the source holds them: the source checks LODs against the
        // renderable when they are set, not when the renderable changes
        // later, so a replica must not check them again.
        if let Some(node) = scene.nodes.get_mut(key) {
            node.lods = lods;
        }
        match skin {
            // The scene refuses a skin whose joints are not all there; one
            // whose joints went away since it was set is what the source
            // holds, so it is checked as `set_skin` would and set as is.
            Some(skin) if skin.joints.iter().any(|j| j.is_null()) => {
                let live: Vec<NodeKey> = skin.joints.iter().map(|j| if j.is_null() { key } else { *j }).collect();
                scene.set_skin(key, Some(Skin { joints: live, ..skin.clone() }))?;
                if let Some(node) = scene.nodes.get_mut(key) {
                    node.skin = Some(Arc::new(skin));
                }
            }
            skin => scene.set_skin(key, skin)?,
        }
        scene.set_light(key, record.light.clone())?;
        scene.set_camera(key, record.camera)?;
        scene.set_morph_weights(key, record.morph_weights.clone())?;
        scene.set_semantic_class(key, record.semantic_class)?;
        Ok(())
    }
}

/// A node record's failure: the scene's refusal or a bad slot.
enum Applied {
    Scene(SceneError),
    Delta(DeltaError),
}

impl From<SceneError> for Applied {
    fn from(e: SceneError) -> Self {
        Applied::Scene(e)
    }
}

/// Every texture `material` names must be in `scene`.
fn check_textures(scene: &Scene, material: &Material) -> Result<(), DeltaError> {
    let textures = [
        material.base_color_texture,
        material.metallic_roughness_texture,
        material.normal_texture,
        material.emissive_texture,
        material.occlusion_texture,
    ];
    for texture in textures.into_iter().flatten() {
        if scene.texture(texture).is_none() {
            return Err(DeltaError::BadSlot(format!("material {} names a texture the replica lacks", material.name)));
        }
    }
    Ok(())
}

/// Where two scenes differ, as a replica test asks: their snapshots
/// compared (slots, free lists, assets by hash, materials and every node's
/// state); `None` when they hold the same.
pub fn scene_difference(a: &Scene, b: &Scene) -> Option<String> {
    let (x, y) = (a.delta_since(0, &mut HashSet::new()), b.delta_since(0, &mut HashSet::new()));
    if x.ops != y.ops {
        let first = x.ops.iter().zip(&y.ops).position(|(p, q)| p != q);
        return Some(format!(
            "slots or assets differ: {} and {} ops, first difference at {first:?}: {:?} / {:?}",
            x.ops.len(),
            y.ops.len(),
            first.and_then(|i| x.ops.get(i)),
            first.and_then(|i| y.ops.get(i))
        ));
    }
    if x.nodes != y.nodes {
        let first = x.nodes.iter().zip(&y.nodes).find(|(p, q)| p != q);
        return Some(format!("nodes differ ({} and {}): {first:?}", x.nodes.len(), y.nodes.len()));
    }
    None
}

/// The key of asset slot `index`: assets are never removed, so every
/// asset slot keeps the version a new slot gets (1).
fn asset_key<K: Key + From<KeyData>>(index: u32) -> K {
    K::from(KeyData::from_ffi(u64::from(index) | (1 << 32)))
}

#[cfg(test)]
mod tests {
    use glam::{Vec2, Vec3, Vec4};

    use super::*;
    use crate::{Filter, Wrap};

    /// The delta as a receiver gets it: encoded, decoded, applied.
    fn send(stream: &mut DeltaStream, scene: &Scene, replica: &mut SceneReplica) -> SceneDelta {
        let delta = SceneDelta::decode(&stream.next(scene).encode()).unwrap();
        replica.apply(&delta).unwrap();
        delta
    }

    /// The hierarchy by slot index: the roots, and every node's children,
    /// each as a set (a replica rebuilds lists from the records' parents,
    /// so only membership is the source's).
    fn hierarchy(scene: &Scene) -> (Vec<u32>, Vec<(u32, Vec<u32>)>) {
        let sorted = |keys: &[NodeKey]| {
            let mut indices: Vec<u32> = keys.iter().map(|k| node_index(*k)).collect();
            indices.sort_unstable();
            indices
        };
        let mut children: Vec<(u32, Vec<u32>)> =
            scene.nodes().map(|(key, node)| (node_index(key), sorted(&node.children))).collect();
        children.sort_unstable();
        (sorted(scene.roots()), children)
    }

    /// Three events per revision, 2^20 in all: the journal is full. The
    /// next event drops the older half, cut after the whole revision the
    /// middle event (number 2^19, revision 174763, whose events are 524286
    /// to 524288) belongs to, so a delta from that floor misses none.
    #[test]
    fn a_full_journal_drops_its_older_half_up_to_a_whole_revision() {
        let mut journal = Journal::default();
        for i in 0..MAX_JOURNAL_EVENTS as u64 {
            journal.record(i / 3 + 1, Event::NodeAdded(i as u32));
        }
        assert_eq!(journal.events.len(), MAX_JOURNAL_EVENTS, "nothing dropped before it is full");
        journal.record(349_527, Event::NodeRemoved(1));
        assert_eq!(journal.floor, 174_763);
        assert_eq!(journal.events.first(), Some(&(174_764, Event::NodeAdded(524_289))));
        assert_eq!(journal.events.len(), MAX_JOURNAL_EVENTS - 524_289 + 1);
        assert_eq!(journal.events.last(), Some(&(349_527, Event::NodeRemoved(1))));
    }

    /// Trimming frees the events a delta can no longer need, and makes a
    /// delta from before the cut a snapshot.
    #[test]
    fn trimming_the_journal_drops_the_events_up_to_the_revision() {
        let mut scene = Scene::new();
        let a = scene.add_node("a", Transform::IDENTITY);
        let cut = scene.revision();
        scene.add_node("b", Transform::IDENTITY);
        scene.remove_node(a).unwrap();
        scene.trim_journal(cut);
        let kept: Vec<Event> = scene.journal.events.iter().map(|(_, e)| *e).collect();
        assert_eq!(kept, [Event::NodeAdded(2), Event::NodeRemoved(1)]);
        assert!(scene.delta_since(cut - 1, &mut HashSet::new()).is_snapshot());
    }

    /// A delta from exactly the trimmed revision still has every event it
    /// needs (those after the cut): a plain delta, not a snapshot.
    #[test]
    fn a_delta_from_the_journals_floor_is_not_a_snapshot() {
        let mut scene = Scene::new();
        let (mut stream, mut replica) = (DeltaStream::new(), SceneReplica::new());
        scene.add_node("a", Transform::IDENTITY);
        send(&mut stream, &scene, &mut replica);
        scene.trim_journal(stream.revision());
        scene.add_node("b", Transform::IDENTITY);
        let delta = send(&mut stream, &scene, &mut replica);
        assert!(!delta.is_snapshot());
        assert_eq!(delta.ops, [DeltaOp::AddNode { index: 2 }]);
        assert_eq!(scene_difference(&scene, replica.scene()), None);
    }

    /// From the scene's own revision nothing changed: an empty delta. From
    /// a revision the scene has not reached (a replica of something else)
    /// only a snapshot can help.
    #[test]
    fn a_delta_from_now_is_empty_and_one_from_the_future_is_a_snapshot() {
        let mut scene = Scene::new();
        scene.add_node("a", Transform::IDENTITY);
        let now = scene.delta_since(scene.revision(), &mut HashSet::new());
        assert!(!now.is_snapshot());
        assert_eq!((now.base, now.revision), (scene.revision(), scene.revision()));
        assert!(now.ops.is_empty() && now.nodes.is_empty(), "{now:?}");
        let future = scene.delta_since(scene.revision() + 5, &mut HashSet::new());
        assert!(future.is_snapshot());
        assert_eq!(future.nodes.len(), 1);
    }

    /// A node whose last edit is the base revision itself is already on the
    /// replica: only nodes edited after the base travel.
    #[test]
    fn a_delta_carries_only_the_nodes_edited_after_its_base() {
        let mut scene = Scene::new();
        let a = scene.add_node("a", Transform::IDENTITY);
        scene.add_node("b", Transform::IDENTITY);
        let base = scene.revision();
        scene.set_local_transform(a, Transform::from_translation(Vec3::X)).unwrap();
        let delta = scene.delta_since(base, &mut HashSet::new());
        let indices: Vec<u32> = delta.nodes.iter().map(|n| n.index).collect();
        assert_eq!(indices, [node_index(a)]);
    }

    #[test]
    fn a_stream_is_at_the_revision_of_its_last_delta() {
        let mut scene = Scene::new();
        let mut stream = DeltaStream::new();
        assert_eq!(stream.revision(), 0);
        scene.add_node("a", Transform::IDENTITY);
        scene.add_node("b", Transform::IDENTITY);
        stream.next(&scene);
        assert_eq!(stream.revision(), scene.revision());
        assert_eq!(stream.revision(), 3);
    }

    /// A stream moved to another scene sends a snapshot, even when the
    /// other scene's revision is past the stream's (a delta from the
    /// stream's revision would then look possible, and be wrong).
    #[test]
    fn another_scene_on_a_stream_gets_a_snapshot_whatever_its_revision() {
        let (mut stream, mut replica) = (DeltaStream::new(), SceneReplica::new());
        let mut first = Scene::new();
        first.add_node("a", Transform::IDENTITY);
        send(&mut stream, &first, &mut replica);
        let mut second = Scene::new();
        for i in 0..5 {
            second.add_node(format!("n{i}"), Transform::from_translation(Vec3::X * i as f32));
        }
        assert!(second.revision() > stream.revision());
        let delta = send(&mut stream, &second, &mut replica);
        assert!(delta.is_snapshot());
        assert_eq!(scene_difference(&second, replica.scene()), None);
    }

    /// After a restart (a receiver was reset) the next delta is a snapshot;
    /// the receivers keep the assets, so those travel by hash only.
    #[test]
    fn a_restarted_stream_sends_a_snapshot_without_the_asset_bodies_sent_before() {
        let mut scene = Scene::new();
        let cube = scene.add_geometry(Geometry::cube(1.0));
        let material = scene.add_material(Material::opaque("m", Vec4::ONE));
        let node = scene.add_node("n", Transform::IDENTITY);
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![material] }).unwrap();
        let (mut stream, mut replica) = (DeltaStream::new(), SceneReplica::new());
        assert_eq!(send(&mut stream, &scene, &mut replica).assets.len(), 1);
        stream.restart();
        let again = send(&mut stream, &scene, &mut replica);
        assert!(again.is_snapshot());
        assert!(again.assets.is_empty(), "{} bodies sent again", again.assets.len());
        assert!(
            again
                .ops
                .iter()
                .any(|op| matches!(op, DeltaOp::AddGeometry { index, .. } if *index == geometry_index(cube)))
        );
        assert_eq!(scene_difference(&scene, replica.scene()), None);
    }

    /// A replica's assets are rebuilt from their records: the same values
    /// as the source's (morph targets and vertex attributes included;
    /// `scene_difference` compares assets by hash alone).
    #[test]
    fn a_replicas_geometries_and_textures_equal_the_sources() {
        let mut scene = Scene::new();
        let cube = Geometry::cube(1.0);
        let n = cube.vertices().len();
        let target = MorphTarget { positions: vec![Vec3::Y * 0.25; n], normals: None };
        let attributes = vec![VertexAttributes::new(Vec4::new(0.5, 0.25, 1.0, 1.0), Vec2::new(0.5, 0.5)); n];
        let morphing = scene.add_geometry(cube.clone().with_morph_targets(vec![target]).unwrap());
        let coloured = scene.add_geometry(cube.with_attributes(attributes).unwrap());
        let pixels = (0..2 * 3 * 4).map(|i| (i * 29 % 256) as u8).collect();
        let texture = TextureImage::new("t", 2, 3, ColorSpace::Linear, pixels)
            .unwrap()
            .with_sampling(Sampling::new(Wrap::ClampToEdge, Filter::Nearest));
        let texture = scene.add_texture(texture);
        let mut replica = SceneReplica::new();
        send(&mut DeltaStream::new(), &scene, &mut replica);
        for geometry in [morphing, coloured] {
            assert_eq!(**replica.scene().geometry(geometry).unwrap(), **scene.geometry(geometry).unwrap());
        }
        assert_eq!(replica.scene().geometry(morphing).unwrap().morph_targets().len(), 1);
        assert_eq!(**replica.scene().texture(texture).unwrap(), **scene.texture(texture).unwrap());
    }

    /// Removals are replayed one node at a time: the removed node leaves
    /// its parent's children (or the roots), the others stay.
    #[test]
    fn a_replica_keeps_the_sources_roots_and_children_through_removals() {
        let mut scene = Scene::new();
        let parent = scene.add_node("parent", Transform::IDENTITY);
        let children: Vec<NodeKey> =
            (0..3).map(|i| scene.add_child(parent, format!("c{i}"), Transform::IDENTITY).unwrap()).collect();
        let roots: Vec<NodeKey> = (0..3).map(|i| scene.add_node(format!("r{i}"), Transform::IDENTITY)).collect();
        let (mut stream, mut replica) = (DeltaStream::new(), SceneReplica::new());
        send(&mut stream, &scene, &mut replica);
        scene.remove_node(children[1]).unwrap();
        scene.remove_node(roots[1]).unwrap();
        send(&mut stream, &scene, &mut replica);
        assert_eq!(hierarchy(replica.scene()), hierarchy(&scene));
        let (root_indices, _) = hierarchy(&scene);
        assert_eq!(root_indices, [parent, roots[0], roots[2]].map(node_index));
    }

    /// Caches keyed on a scene's revision (world transforms, ScenePrep's)
    /// must see a replica change: a delta that only removes a root still
    /// moves the replica's revision forward.
    #[test]
    fn a_replicas_revision_advances_when_a_delta_only_removes_a_node() {
        let mut scene = Scene::new();
        scene.add_node("kept", Transform::IDENTITY);
        let removed = scene.add_node("removed", Transform::IDENTITY);
        let (mut stream, mut replica) = (DeltaStream::new(), SceneReplica::new());
        send(&mut stream, &scene, &mut replica);
        let before = replica.scene().revision();
        scene.remove_node(removed).unwrap();
        let delta = send(&mut stream, &scene, &mut replica);
        assert!(delta.nodes.is_empty(), "{delta:?}");
        assert!(replica.scene().revision() > before, "{} after {before}", replica.scene().revision());
    }

    /// Two records that make each other's parent: refused, naming a node of
    /// the cycle.
    #[test]
    fn a_delta_whose_parents_make_a_cycle_is_refused_naming_a_node_of_it() {
        let mut scene = Scene::new();
        let a = node_index(scene.add_node("a", Transform::IDENTITY));
        let b = node_index(scene.add_node("b", Transform::IDENTITY));
        let mut delta = scene.delta_since(0, &mut HashSet::new());
        for record in &mut delta.nodes {
            record.parent = Some(if record.index == a { b } else { a });
        }
        match SceneReplica::new().apply(&delta) {
            Err(DeltaError::BadNode { index, source: SceneError::Cycle { .. } }) => {
                assert!(index == a || index == b, "node {index} named, the cycle is {a} and {b}")
            }
            other => panic!("{other:?}"),
        }
    }

    /// A material op naming a texture slot the replica has not got is
    /// refused (the material would render with a texture that is not there).
    #[test]
    fn a_material_naming_a_texture_the_replica_lacks_is_refused() {
        let mut scene = Scene::new();
        scene.add_material(Material::opaque("dangling", Vec4::ONE));
        let mut delta = scene.delta_since(0, &mut HashSet::new());
        let Some(DeltaOp::AddMaterial { material, .. }) = delta.ops.last_mut() else { panic!("{:?}", delta.ops) };
        material.normal_texture = Some(asset_key::<TextureHandle>(5));
        let refused = SceneReplica::new().apply(&delta);
        assert_eq!(refused, Err(DeltaError::BadSlot("material dangling names a texture the replica lacks".into())));
    }

    /// Hashes print as their first eight bytes in hex: enough to tell
    /// assets apart in a message.
    #[test]
    fn a_delta_naming_an_asset_never_sent_is_refused_naming_its_hash() {
        let mut bytes = [0xff; 32];
        bytes[..8].copy_from_slice(&[0x01, 0x23, 0x45, 0x67, 0x89, 0xab, 0xcd, 0xef]);
        let hash = AssetHash(bytes);
        assert_eq!(hash.to_string(), "0123456789abcdef");
        let mut scene = Scene::new();
        scene.add_geometry(Geometry::cube(1.0));
        let mut delta = scene.delta_since(0, &mut HashSet::new());
        delta.assets.clear();
        delta.ops = vec![DeltaOp::AddGeometry { index: 1, hash }];
        let refused = SceneReplica::new().apply(&delta).unwrap_err();
        assert_eq!(refused.to_string(), "asset 0123456789abcdef was never sent");
    }

    /// `scene_difference` (what replica tests rest on) finds a difference
    /// and says where: the first op, or the first node record, that differs.
    #[test]
    fn scene_difference_names_the_first_op_or_node_that_differs() {
        let scene = |name: &str, color: Vec4| {
            let mut scene = Scene::new();
            scene.add_node("x", Transform::IDENTITY);
            scene.add_node(name, Transform::IDENTITY);
            scene.add_material(Material::opaque("m", color));
            scene
        };
        let source = scene("y", Vec4::ONE);
        assert_eq!(scene_difference(&source, &scene("y", Vec4::ONE)), None);
        // Ops: two nodes, then the material.
        let other_material = scene_difference(&source, &scene("y", Vec4::ZERO)).unwrap();
        assert!(other_material.contains("first difference at Some(2)"), "{other_material}");
        let renamed = scene_difference(&source, &scene("renamed", Vec4::ONE)).unwrap();
        assert!(renamed.starts_with("nodes differ") && renamed.contains("\"renamed\""), "{renamed}");
    }
}
