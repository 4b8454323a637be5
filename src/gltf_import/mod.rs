//! glTF 2.0 import into a [`Scene`], safe on untrusted files.
//!
//! What comes in: the chosen scene's node hierarchy with local TRS; meshes
//! (every triangle primitive becomes a submesh of one [`Geometry`](oxygen_core::Geometry), with its
//! own material), with `COLOR_0` (vec3 or vec4; float, normalized u8 or
//! u16) and `TEXCOORD_1` as vertex attributes and `KHR_mesh_quantization`'s
//! 8- and 16-bit positions, normals and texture coordinates;
//! metallic-roughness materials with base-colour, metallic-roughness,
//! normal, emissive and occlusion textures, each with its texture
//! coordinate set and `KHR_texture_transform`, their samplers (wrap mode per
//! axis, filter), alpha mode and cutoff, double-sidedness,
//! `KHR_materials_emissive_strength` and `KHR_materials_unlit`;
//! `KHR_lights_punctual` lights; cameras (as [`GltfCamera`]s an application
//! can register as views); skins (`JOINTS_0`/`WEIGHTS_0`, four joints a
//! vertex, with their joints and inverse bind matrices, identity where the
//! file has none); morph targets (position and normal displacements, at
//! most [`MAX_MORPH_TARGETS`](oxygen_core::MAX_MORPH_TARGETS) a mesh, with
//! the node's or else the mesh's default weights); animations of node
//! translation, rotation, scale and morph weights
//! ([`GltfImport::animations`]). Nodes with a negative scale are imported
//! as they are: ScenePrep flips the winding of mirrored draws.
//!
//! What is left out (never a panic): primitives that are not triangle
//! lists; texture coordinate sets above 1 (a texture naming one reads set
//! 0); morph targets' tangent displacements; a skin whose joints are not
//! all in the imported scene (its mesh stays in its bind pose), a skin on a
//! node without a mesh, and `JOINTS_0` without `WEIGHTS_0` or the reverse;
//! animation channels on nodes outside the imported scene or on the morph
//! weights of a node without targets: each with a warning. Validated but
//! not read, without one: `TANGENT` (tangents are derived per pixel from
//! positions and texture coordinates, so they follow skins and morphs),
//! colour sets above 0, and joint and weight sets above 0 (at most four
//! joints a vertex). Missing normals are generated (area-weighted smooth
//! normals, with a warning); missing texture coordinates are zero.
//!
//! # Untrusted input
//!
//! A file is data written by someone else, so the importer trusts none of
//! it (the threat model is `docs/security.md`):
//!
//! 1. the container and JSON are parsed by Oxygen's own GLB splitter and
//!    `serde_json`, after the file and its JSON are checked against
//!    [`ImportLimits`];
//! 2. every buffer and image URI is resolved by [`source`]: `data:` URIs
//!    decoded, other URIs confined to the scene's folder (or an explicit
//!    [`ImportOptions::asset_root`]), at most `byteLength` bytes read;
//! 3. the node graph is checked to be a forest ([`graph`]) and walked with
//!    an explicit stack;
//! 4. every accessor is validated for its semantic and byte range before it
//!    is read (`accessor`), and vertex, index, texel and byte totals are
//!    charged to a budget before they are allocated.
//!
//! Nothing here calls the `gltf` crate's importer or readers, which trust the
//! file; only its JSON types are used, through indices that are checked.

mod accessor;
mod animation;
pub mod graph;
mod limits;
mod material;
mod mesh;
pub mod source;

use std::borrow::Cow;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Quat, UVec2, Vec3};
use gltf::json;
use gltf::json::validation::Checked;
use oxygen_core::{
    Aabb, Camera, GeometryHandle, Light, LightKind, MaterialHandle, NodeKey, Projection, Renderable, ResolvedView,
    Scene, Transform, ViewContext, ViewError, ViewResolver,
};
use thiserror::Error;
use tracing::{info, info_span, warn};

pub use graph::GraphError;
pub use limits::{ImportLimits, LimitExceeded};
pub use mesh::MeshError;
pub use source::UriError;

use limits::Budget;
use source::{AssetRoot, AssetRootRef};

/// Extensions whose meaning Oxygen implements; a file that *requires* any
/// other is refused, as glTF asks of a loader that does not support it.
pub const SUPPORTED_REQUIRED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_unlit",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
];

/// Why a glTF file could not be imported. Every variant names the file; the
/// ones about one part of it name that part (node, mesh, primitive,
/// accessor, image, URI).
#[derive(Debug, Error)]
pub enum GltfError {
    /// The scene file itself could not be read.
    #[error("{path}: {source}")]
    Load {
        /// The file.
        path: PathBuf,
        /// The reason.
        source: std::io::Error,
    },
    /// The file is not a GLB container or glTF JSON document.
    #[error("{path}: not a glTF file: {reason}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// What the parser said.
        reason: String,
    },
    /// The file asks for more than [`ImportLimits`] allow.
    #[error("{path}: {context}: {source}")]
    Limit {
        /// The file.
        path: PathBuf,
        /// Which part of the file (e.g. "image 3", "the JSON chunk").
        context: String,
        /// The limit, the value and the maximum.
        source: LimitExceeded,
    },
    /// A buffer or image URI was refused or could not be read.
    #[error("{path}: {what} uri '{uri}': {source}")]
    Uri {
        /// The file.
        path: PathBuf,
        /// "buffer N" or "image N".
        what: String,
        /// The URI as written in the file (shortened when long).
        uri: String,
        /// Why.
        source: UriError,
    },
    /// The node graph is not a forest.
    #[error("{path}: {source}")]
    Graph {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the node.
        source: GraphError,
    },
    /// A mesh primitive's accessors are invalid.
    #[error("{path}: {source}")]
    Mesh {
        /// The file.
        path: PathBuf,
        /// Mesh, primitive, accessor and reason.
        source: MeshError,
    },
    /// The file requires an extension Oxygen does not implement.
    #[error("{path}: requires extension {extension}, which Oxygen does not support")]
    UnsupportedExtension {
        /// The file.
        path: PathBuf,
        /// The extension.
        extension: String,
    },
    /// The requested scene does not exist.
    #[error("{path}: no scene {wanted} (the file has {available})")]
    NoSuchScene {
        /// The file.
        path: PathBuf,
        /// What was asked for.
        wanted: String,
        /// The scenes it has.
        available: String,
    },
    /// Some other part of the file is invalid.
    #[error("{path}: {what}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
}

/// An error before the file's path is attached.
#[derive(Debug)]
pub(crate) enum GltfErrorKind {
    Limit { context: String, source: LimitExceeded },
    Uri { what: String, uri: String, source: UriError },
    Mesh(MeshError),
    Invalid(String),
}

impl GltfErrorKind {
    fn at(self, path: &Path) -> GltfError {
        let path = path.to_owned();
        match self {
            GltfErrorKind::Limit { context, source } => GltfError::Limit { path, context, source },
            GltfErrorKind::Uri { what, uri, source } => GltfError::Uri { path, what, uri: shorten(&uri), source },
            GltfErrorKind::Mesh(source) => GltfError::Mesh { path, source },
            GltfErrorKind::Invalid(what) => GltfError::Invalid { path, what },
        }
    }
}

/// A URI fit for a message: `data:` payloads and long names are cut.
fn shorten(uri: &str) -> String {
    const KEEP: usize = 64;
    if uri.len() <= KEEP {
        return uri.to_owned();
    }
    let mut end = KEEP;
    while !uri.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}… ({} bytes)", &uri[..end], uri.len())
}

/// Which of a file's scenes to import.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum SceneChoice {
    /// The file's default scene, or its first.
    #[default]
    Default,
    /// By index.
    Index(usize),
    /// By name.
    Name(String),
}

/// How to import: which scene, within which limits, from which folder.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ImportOptions {
    /// Which of the file's scenes.
    pub scene: SceneChoice,
    /// What the file may make the importer allocate.
    pub limits: ImportLimits,
    /// The folder external URIs must stay inside. `None`: the scene file's
    /// own folder. Naming a parent folder lets scenes share textures kept
    /// beside them; it never lets a URI leave that folder.
    pub asset_root: Option<PathBuf>,
}
/// A camera found in the file, attached to a node.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfCamera {
    /// The camera's (or its node's) name.
    pub name: String,
    /// The node it follows.
    pub node: NodeKey,
    /// Its projection.
    pub camera: Camera,
    /// The aspect ratio the file asks for, if any.
    pub aspect_ratio: Option<f32>,
}

impl GltfCamera {
    /// A resolver that renders through this camera at `viewport` pixels.
    pub fn resolver(&self, viewport: UVec2) -> NodeCameraResolver {
        NodeCameraResolver { node: self.node, camera: self.camera, viewport }
    }
}

/// A view that follows a scene node: its world transform (scale removed) is
/// the camera pose, looking down the node's −Z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeCameraResolver {
    /// The node.
    pub node: NodeKey,
    /// The projection.
    pub camera: Camera,
    /// Target size.
    pub viewport: UVec2,
}

impl ViewResolver for NodeCameraResolver {
    fn resolve(&self, ctx: &ViewContext, scene: &Scene) -> Result<ResolvedView, ViewError> {
        let view_id = ctx.view_id;
        let world = scene
            .world_transform(self.node)
            .ok_or_else(|| ViewError::Other { view: view_id, message: "the camera's node was removed".into() })?;
        let (_, rotation, translation) = world.to_scale_rotation_translation();
        let pose = glam::DMat4::from_rotation_translation(rotation.normalize(), translation);
        let aspect = self.viewport.x as f32 / self.viewport.y.max(1) as f32;
        let projection =
            self.camera.projection_matrix(aspect).map_err(|source| ViewError::Camera { view: view_id, source })?;
        let (near, far) = self.camera.depth_range();
        ResolvedView::new_f64(view_id, pose.inverse(), projection, self.viewport, near, far)
    }
}

/// What an import produced.
#[derive(Debug, Default)]
pub struct GltfImport {
    /// Root nodes added to the scene.
    pub roots: Vec<NodeKey>,
    /// Cameras, in file order.
    pub cameras: Vec<GltfCamera>,
    /// Lights added.
    pub lights: usize,
    /// Renderable nodes added.
    pub renderables: usize,
    /// World-space bounds of every imported renderable with finite bounds,
    /// in f32, rounded outward from [`GltfImport::precise_bounds`].
    pub bounds: Option<Aabb>,
    /// The same bounds in f64: what to frame a camera on when the scene may
    /// sit far from the origin (the f32 corners are whole units off thirty
    /// million units out).
    pub precise_bounds: Option<oxygen_core::DAabb>,
    /// What was skipped or approximated, one line each.
    pub warnings: Vec<String>,
    /// The file's animations, their channels bound to the imported nodes;
    /// [`oxygen_core::Animation::apply`] poses the scene at a time.
    pub animations: Vec<oxygen_core::Animation>,
    /// Bytes the import charged to [`ImportLimits::max_total_bytes`]: the
    /// file, external buffers, the parsed JSON's estimate, decoded texels
    /// (once per image and once per texture made from it), vertices and
    /// indices.
    pub bytes_decoded: u64,
    /// Each imported node the file names, with its name, in the order of
    /// the file's `nodes` array: what [`GltfImport::node`] searches.
    named_nodes: Vec<(usize, String, NodeKey)>,
}

impl GltfImport {
    /// The animation `which` names (an index or a name; `None`: the first),
    /// or an error that lists the file's animations.
    pub fn animation(&self, which: Option<&str>) -> Result<&oxygen_core::Animation, String> {
        let found = match which {
            None => self.animations.first(),
            Some(w) => match w.parse::<usize>() {
                Ok(i) => self.animations.get(i),
                Err(_) => self.animations.iter().find(|a| a.name == w),
            },
        };
        found.ok_or_else(|| {
            let names: Vec<String> =
                self.animations.iter().enumerate().map(|(i, a)| format!("{i} ('{}')", a.name)).collect();
            let has = if names.is_empty() { "none".to_owned() } else { names.join(", ") };
            format!("no animation {}: the file has {has}", which.unwrap_or("at all"))
        })
    }

    /// The imported node the file calls `name`, or `None` if no imported
    /// node has that name.
    ///
    /// glTF does not require names to be unique: with duplicates this is the
    /// first in the file's `nodes` array (see [`GltfImport::nodes_named`] for
    /// all of them). Only names written in the file match, not the
    /// `"node N"` that unnamed nodes are given in the [`Scene`], and only
    /// nodes of the imported scene.
    pub fn node(&self, name: &str) -> Option<NodeKey> {
        self.nodes_named(name).next()
    }

    /// Every imported node the file calls `name`, in the order of the file's
    /// `nodes` array.
    pub fn nodes_named<'a>(&'a self, name: &'a str) -> impl Iterator<Item = NodeKey> + 'a {
        self.named_nodes.iter().filter(move |(_, n, _)| n == name).map(|(_, _, key)| *key)
    }

    /// The first camera in [`GltfImport::cameras`] whose
    /// [`GltfCamera::name`] is `name` (the camera's name in the file, or its
    /// node's when the camera has none).
    pub fn camera(&self, name: &str) -> Option<&GltfCamera> {
        self.cameras.iter().find(|c| c.name == name)
    }
}

/// Imports a `.gltf` or `.glb` file (with its buffers and images) into
/// `scene`, with default [`ImportLimits`] and external files confined to the
/// file's folder.
pub fn import_gltf(scene: &mut Scene, path: impl AsRef<Path>, choice: &SceneChoice) -> Result<GltfImport, GltfError> {
    import_gltf_with(scene, path, &ImportOptions { scene: choice.clone(), ..ImportOptions::default() })
}

/// Imports a `.gltf` or `.glb` file with explicit options.
pub fn import_gltf_with(
    scene: &mut Scene,
    path: impl AsRef<Path>,
    options: &ImportOptions,
) -> Result<GltfImport, GltfError> {
    let path = path.as_ref();
    let _span = info_span!("gltf_import", path = %path.display()).entered();
    let load = |source| GltfError::Load { path: path.to_owned(), source };
    let meta = std::fs::metadata(path).map_err(load)?;
    if !meta.is_file() {
        return Err(load(std::io::Error::other("not a regular file")));
    }
    limits::check("max_file_bytes", meta.len(), options.limits.max_file_bytes).map_err(|source| GltfError::Limit {
        path: path.to_owned(),
        context: "the file".into(),
        source,
    })?;
    let bytes = std::fs::read(path).map_err(load)?;
    let folder = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let root = AssetRoot::new(folder, options.asset_root.as_deref()).map_err(|e| GltfError::Load {
        path: options.asset_root.clone().unwrap_or_else(|| folder.to_owned()),
        source: e,
    })?;
    import_bytes(scene, &bytes, path, AssetRootRef::Folder(&root), options)
}

/// Imports a glTF file held in memory (a `.glb`, or `.gltf` JSON whose
/// buffers and images are `data:` URIs). `name` stands for the file in
/// errors. Any other URI is refused: a file in memory has no folder.
pub fn import_gltf_slice(
    scene: &mut Scene,
    bytes: &[u8],
    name: impl AsRef<Path>,
    options: &ImportOptions,
) -> Result<GltfImport, GltfError> {
    let name = name.as_ref();
    let _span = info_span!("gltf_import", name = %name.display(), bytes = bytes.len()).entered();
    limits::check("max_file_bytes", bytes.len() as u64, options.limits.max_file_bytes)
        .map_err(|source| GltfError::Limit { path: name.to_owned(), context: "the file".into(), source })?;
    import_bytes(scene, bytes, name, AssetRootRef::Memory, options)
}

fn import_bytes(
    scene: &mut Scene,
    bytes: &[u8],
    path: &Path,
    folder: AssetRootRef<'_>,
    options: &ImportOptions,
) -> Result<GltfImport, GltfError> {
    let limit_error =
        |context: &str, source| GltfError::Limit { path: path.to_owned(), context: context.into(), source };
    let mut budget = Budget::new(options.limits);
    budget.spend_bytes(bytes.len() as u64).map_err(|e| limit_error("the file", e))?;

    // 1. Container and JSON.
    let (json_bytes, bin) = if bytes.starts_with(b"glTF") {
        let glb = source::split_glb(bytes).map_err(|reason| GltfError::Parse { path: path.to_owned(), reason })?;
        (glb.json, glb.bin)
    } else {
        (bytes, None)
    };
    limits::check("max_json_bytes", json_bytes.len() as u64, options.limits.max_json_bytes)
        .map_err(|e| limit_error("the JSON", e))?;
    let objects = source::count_json_objects(json_bytes);
    limits::check("max_json_objects", objects, options.limits.max_json_objects)
        .map_err(|e| limit_error("the JSON", e))?;
    // A parsed object is a few hundred bytes at most (a node is the largest).
    budget.spend_bytes(objects.saturating_mul(512)).map_err(|e| limit_error("the parsed JSON", e))?;
    let root: json::Root = json::deserialize::from_slice(json_bytes)
        .map_err(|e| GltfError::Parse { path: path.to_owned(), reason: e.to_string() })?;
    if let Some(extension) =
        root.extensions_required.iter().find(|e| !SUPPORTED_REQUIRED_EXTENSIONS.contains(&e.as_str()))
    {
        return Err(GltfError::UnsupportedExtension { path: path.to_owned(), extension: extension.clone() });
    }
    limits::check("max_nodes", root.nodes.len() as u64, options.limits.max_nodes)
        .map_err(|e| limit_error("the node list", e))?;

    // 2. Node graph and scene choice, before anything is read or added.
    let parents = graph::parents(&root.nodes).map_err(|source| GltfError::Graph { path: path.to_owned(), source })?;
    let scene_index = choose_scene(&root, &options.scene, path)?;
    let roots: Vec<usize> = root.scenes[scene_index].nodes.iter().map(|n| n.value()).collect();
    graph::check_roots(&roots, &parents).map_err(|source| GltfError::Graph { path: path.to_owned(), source })?;

    // 3. Buffers, each exactly its byteLength, charged before it is read.
    let buffers = load_buffers(&root, bin, folder, &mut budget).map_err(|e| e.at(path))?;

    // 4. The walk.
    let mut importer = Importer {
        root: &root,
        buffers: &buffers,
        materials: material::MaterialImporter::new(&root, &buffers, folder),
        meshes: HashMap::new(),
        node_keys: HashMap::new(),
        pending_skins: Vec::new(),
        budget,
        out: GltfImport::default(),
    };
    importer.walk(scene, &roots).map_err(|e| e.at(path))?;
    // The walk visits depth-first; lookups promise the file's order.
    importer.out.named_nodes.sort_unstable_by_key(|(index, _, _)| *index);
    importer.bind_skins(scene).map_err(|e| e.at(path))?;
    importer.out.animations =
        animation::import(&root, &buffers, &importer.node_keys, &mut importer.budget, &mut importer.out.warnings)
            .map_err(|e| e.at(path))?;
    for w in &importer.out.warnings {
        warn!(path = %path.display(), "{w}");
    }
    importer.out.bytes_decoded = importer.budget.total_bytes();
    info!(renderables = importer.out.renderables, bytes = importer.out.bytes_decoded, "glTF imported");
    Ok(importer.out)
}

fn choose_scene(root: &json::Root, choice: &SceneChoice, path: &Path) -> Result<usize, GltfError> {
    let chosen = match choice {
        SceneChoice::Default => match root.scene {
            Some(i) if i.value() < root.scenes.len() => Some(i.value()),
            Some(i) => {
                return Err(GltfError::Invalid {
                    path: path.to_owned(),
                    what: format!("the default scene {} does not exist", i.value()),
                });
            }
            None => (!root.scenes.is_empty()).then_some(0),
        },
        SceneChoice::Index(i) => (*i < root.scenes.len()).then_some(*i),
        SceneChoice::Name(name) => root.scenes.iter().position(|s| s.name.as_deref() == Some(name.as_str())),
    };
    chosen.ok_or_else(|| {
        let available: Vec<String> = root
            .scenes
            .iter()
            .enumerate()
            .map(|(i, s)| format!("{i} ({})", s.name.as_deref().unwrap_or("unnamed")))
            .collect();
        GltfError::NoSuchScene {
            path: path.to_owned(),
            wanted: format!("{choice:?}"),
            available: if available.is_empty() { "none".into() } else { available.join(", ") },
        }
    })
}

fn load_buffers<'a>(
    root: &json::Root,
    bin: Option<&'a [u8]>,
    folder: AssetRootRef<'_>,
    budget: &mut Budget,
) -> Result<Vec<Cow<'a, [u8]>>, GltfErrorKind> {
    let mut buffers = Vec::with_capacity(root.buffers.len());
    for (index, buffer) in root.buffers.iter().enumerate() {
        let need = buffer.byte_length.0;
        let data = match &buffer.uri {
            None => {
                // The GLB binary chunk, which may carry up to 3 bytes of padding.
                let bin = bin.filter(|_| index == 0).ok_or_else(|| {
                    GltfErrorKind::Invalid(format!("buffer {index} has no uri and is not the GLB binary chunk"))
                })?;
                let data = bin.get(..need.min(usize::MAX as u64) as usize).filter(|_| need <= bin.len() as u64);
                Cow::Borrowed(data.ok_or_else(|| {
                    GltfErrorKind::Invalid(format!(
                        "buffer {index}: byteLength {need} is more than the GLB binary chunk's {} bytes",
                        bin.len()
                    ))
                })?)
            }
            Some(uri) => {
                budget
                    .spend_bytes(need)
                    .map_err(|source| GltfErrorKind::Limit { context: format!("buffer {index}"), source })?;
                let bytes = folder.read(uri, Some(need), need.saturating_add(3)).map_err(|source| {
                    GltfErrorKind::Uri { what: format!("buffer {index}"), uri: uri.clone(), source }
                })?;
                Cow::Owned(bytes)
            }
        };
        buffers.push(data);
    }
    Ok(buffers)
}

struct Importer<'a> {
    root: &'a json::Root,
    buffers: &'a [Cow<'a, [u8]>],
    materials: material::MaterialImporter<'a>,
    meshes: HashMap<usize, Option<(GeometryHandle, Vec<MaterialHandle>)>>,
    /// Every imported node by its index in the file (animation targets).
    node_keys: HashMap<usize, NodeKey>,
    /// Skinned mesh nodes and their skin, bound after the walk.
    pending_skins: Vec<(NodeKey, usize, String)>,
    budget: Budget,
    out: GltfImport,
}

impl Importer<'_> {
    /// Adds the chosen scene's trees, parents before children, with an
    /// explicit stack (the graph was checked to be a forest).
    fn walk(&mut self, scene: &mut Scene, roots: &[usize]) -> Result<(), GltfErrorKind> {
        let max_depth = self.budget.limits.max_node_depth;
        let mut stack: Vec<(usize, Option<NodeKey>, glam::DMat4, u32)> =
            roots.iter().rev().map(|r| (*r, None, glam::DMat4::IDENTITY, 1)).collect();
        while let Some((index, parent, parent_world, depth)) = stack.pop() {
            limits::check("max_node_depth", u64::from(depth), u64::from(max_depth))
                .map_err(|source| GltfErrorKind::Limit { context: format!("node {index}"), source })?;
            let (key, world) = self.node(scene, index, parent, parent_world)?;
            if parent.is_none() {
                self.out.roots.push(key);
            }
            let node = &self.root.nodes[index];
            for child in node.children.iter().flatten().rev() {
                stack.push((child.value(), Some(key), world, depth + 1));
            }
        }
        Ok(())
    }

    fn node(
        &mut self,
        scene: &mut Scene,
        index: usize,
        parent: Option<NodeKey>,
        parent_world: glam::DMat4,
    ) -> Result<(NodeKey, glam::DMat4), GltfErrorKind> {
        let root = self.root;
        let node = &root.nodes[index];
        let name = node.name.clone().unwrap_or_else(|| format!("node {index}"));
        let local = local_transform(node);
        if !(local.translation.is_finite() && local.scale.is_finite()) {
            self.out.warnings.push(format!("node '{name}': non-finite transform; it and its children are not drawn"));
        }
        let key = match parent {
            Some(p) => scene.add_child(p, name.clone(), local).map_err(|e| GltfErrorKind::Invalid(e.to_string()))?,
            None => scene.add_node(name.clone(), local),
        };
        let world = parent_world * local.to_dmat4();
        self.node_keys.insert(index, key);
        if let Some(file_name) = &node.name {
            self.out.named_nodes.push((index, file_name.clone(), key));
        }

        if let Some(mesh) = node.mesh
            && let Some((geometry, materials)) = self.mesh(scene, mesh.value())?
        {
            // Morph weights: the node's, else the mesh's defaults.
            let weights =
                node.weights.clone().or_else(|| root.meshes.get(mesh.value()).and_then(|m| m.weights.clone()));
            if let Some(weights) = weights {
                scene.set_morph_weights(key, weights).map_err(|e| GltfErrorKind::Invalid(e.to_string()))?;
            }
            if let Some(g) = scene.geometry(geometry) {
                // In f64: a model placed a million units out keeps its
                // bounds to the millimetre (f32 would round them by units).
                let bounds = oxygen_core::DAabb::transformed(&g.local_aabb(), &world);
                if bounds.is_finite() {
                    let precise = self.out.precise_bounds.map_or(bounds, |b| b.union(bounds));
                    self.out.precise_bounds = Some(precise);
                    self.out.bounds = Some(precise.to_f32_outward());
                } else {
                    self.out.warnings.push(format!("node '{name}': non-finite bounds, left out of the scene bounds"));
                }
            }
            scene
                .set_renderable(key, Renderable { geometry, materials })
                .map_err(|e| GltfErrorKind::Invalid(e.to_string()))?;
            self.out.renderables += 1;
        }
        if let Some(light) = node.extensions.as_ref().and_then(|e| e.khr_lights_punctual.as_ref()) {
            let light = self.light(light.light.value(), &name)?;
            scene.set_light(key, Some(light)).map_err(|e| GltfErrorKind::Invalid(e.to_string()))?;
            self.out.lights += 1;
        }
        if let Some(camera) = node.camera {
            let (camera_value, aspect_ratio, camera_name) = self.camera(camera.value(), &name)?;
            scene.set_camera(key, Some(camera_value)).map_err(|e| GltfErrorKind::Invalid(e.to_string()))?;
            self.out.cameras.push(GltfCamera { name: camera_name, node: key, camera: camera_value, aspect_ratio });
        }
        if let Some(skin) = node.skin {
            if node.mesh.is_some() {
                // Bound once every node exists (joints may come later).
                self.pending_skins.push((key, skin.value(), name.clone()));
            } else {
                self.out.warnings.push(format!("node '{name}': a skin without a mesh is ignored"));
            }
        }
        Ok((key, world))
    }

    /// Gives every skinned mesh node its skin: the joints (imported nodes)
    /// and inverse bind matrices (identity when the file has none). A skin
    /// whose joints are not all in the imported scene leaves its mesh rigid,
    /// with a warning.
    fn bind_skins(&mut self, scene: &mut Scene) -> Result<(), GltfErrorKind> {
        for (node, index, name) in std::mem::take(&mut self.pending_skins) {
            let skin = self
                .root
                .skins
                .get(index)
                .ok_or_else(|| GltfErrorKind::Invalid(format!("node '{name}': skin {index} does not exist")))?;
            // Joints and matrices (64 + 8 bytes a joint) charged before they
            // are built; glTF forbids a joint listed twice, which also bounds
            // a skin by the file's nodes.
            self.budget
                .spend_bytes((skin.joints.len() as u64).saturating_mul(72))
                .map_err(|source| GltfErrorKind::Limit { context: format!("skin {index}"), source })?;
            let mut seen = std::collections::HashSet::with_capacity(skin.joints.len());
            if let Some(twice) = skin.joints.iter().find(|j| !seen.insert(j.value())) {
                return Err(GltfErrorKind::Invalid(format!("skin {index}: joint {} is listed twice", twice.value())));
            }
            let joints: Option<Vec<NodeKey>> =
                skin.joints.iter().map(|j| self.node_keys.get(&j.value()).copied()).collect();
            let Some(joints) = joints else {
                self.out.warnings.push(format!(
                    "node '{name}': skin {index} names joints outside the imported scene; drawn in its bind pose"
                ));
                continue;
            };
            let inverse_bind_matrices = match skin.inverse_bind_matrices {
                None => vec![glam::Mat4::IDENTITY; joints.len()],
                Some(a) => {
                    let view =
                        accessor::validate(self.root, self.buffers, a.value(), accessor::Semantic::InverseBindMatrices)
                            .map_err(|e| GltfErrorKind::Invalid(format!("skin {index}: {e}")))?;
                    if view.count != joints.len() {
                        return Err(GltfErrorKind::Invalid(format!(
                            "skin {index}: {} inverse bind matrices for {} joints",
                            view.count,
                            joints.len()
                        )));
                    }
                    self.budget
                        .spend_bytes(view.count as u64 * 64)
                        .map_err(|source| GltfErrorKind::Limit { context: format!("skin {index}"), source })?;
                    view.read_floats::<16>()
                        .map_err(|e| GltfErrorKind::Invalid(format!("skin {index}: {e}")))?
                        .iter()
                        .map(glam::Mat4::from_cols_array)
                        .collect()
                }
            };
            scene
                .set_skin(node, Some(oxygen_core::Skin { joints, inverse_bind_matrices }))
                .map_err(|e| GltfErrorKind::Invalid(format!("node '{name}': {e}")))?;
        }
        Ok(())
    }

    fn mesh(
        &mut self,
        scene: &mut Scene,
        index: usize,
    ) -> Result<Option<(GeometryHandle, Vec<MaterialHandle>)>, GltfErrorKind> {
        if let Some(done) = self.meshes.get(&index) {
            return Ok(done.clone());
        }
        let built = mesh::build(self.root, self.buffers, index, &mut self.budget, &mut self.out.warnings)?;
        let result = match built {
            mesh::MeshResult::Empty => None,
            mesh::MeshResult::Geometry(geometry, material_indices) => {
                let mut materials = Vec::with_capacity(material_indices.len());
                for m in material_indices {
                    materials.push(self.materials.material(scene, m, &mut self.budget, &mut self.out.warnings)?);
                }
                Some((scene.add_geometry(*geometry), materials))
            }
        };
        self.meshes.insert(index, result.clone());
        Ok(result)
    }

    fn light(&mut self, index: usize, node: &str) -> Result<Light, GltfErrorKind> {
        use json::extensions::scene::khr_lights_punctual::Type;
        let light = self
            .root
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
            .and_then(|l| l.lights.get(index))
            .ok_or_else(|| GltfErrorKind::Invalid(format!("node '{node}': light {index} does not exist")))?;
        let kind = match (light.type_, &light.spot) {
            (Checked::Valid(Type::Directional), _) => LightKind::Directional,
            (Checked::Valid(Type::Point), _) => LightKind::Point { range: light.range },
            (Checked::Valid(Type::Spot), Some(spot)) => LightKind::Spot {
                range: light.range,
                inner_cone: spot.inner_cone_angle,
                outer_cone: spot.outer_cone_angle,
            },
            (Checked::Valid(Type::Spot), None) => {
                return Err(GltfErrorKind::Invalid(format!("light {index}: a spot light without a 'spot' object")));
            }
            (Checked::Invalid, _) => return Err(GltfErrorKind::Invalid(format!("light {index}: unknown type"))),
        };
        // Non-finite values are kept: ScenePrep skips such a light with a
        // warning each frame, as it does for lights built in code.
        Ok(Light { kind, color: Vec3::from(light.color), intensity: light.intensity, ..Light::directional(1.0) })
    }

    fn camera(&mut self, index: usize, node: &str) -> Result<(Camera, Option<f32>, String), GltfErrorKind> {
        use json::camera::Type;
        let camera = self
            .root
            .cameras
            .get(index)
            .ok_or_else(|| GltfErrorKind::Invalid(format!("node '{node}': camera {index} does not exist")))?;
        let missing = |what| GltfErrorKind::Invalid(format!("camera {index}: type {what} without its '{what}' object"));
        let (projection, aspect_ratio) = match camera.type_ {
            Checked::Valid(Type::Perspective) => {
                let p = camera.perspective.as_ref().ok_or_else(|| missing("perspective"))?;
                (Projection::Perspective { fov_y: p.yfov, near: p.znear, far: p.zfar }, p.aspect_ratio)
            }
            Checked::Valid(Type::Orthographic) => {
                let o = camera.orthographic.as_ref().ok_or_else(|| missing("orthographic"))?;
                (Projection::Orthographic { half_height: o.ymag, near: o.znear, far: o.zfar }, Some(o.xmag / o.ymag))
            }
            Checked::Invalid => return Err(GltfErrorKind::Invalid(format!("camera {index}: unknown type"))),
        };
        let camera_value = Camera { projection };
        let name = camera.name.clone().unwrap_or_else(|| node.to_owned());
        // A camera that cannot be resolved is still imported: a view through
        // it is skipped (with a warning in the frame report), not the frame.
        if let Err(e) =
            camera_value.projection_matrix(aspect_ratio.filter(|a| a.is_finite() && *a > 0.0).unwrap_or(1.0))
        {
            self.out.warnings.push(format!("camera '{name}': {e}; views through it will be skipped"));
        }
        let aspect_ratio = aspect_ratio.filter(|a| a.is_finite() && *a > 0.0);
        Ok((camera_value, aspect_ratio, name))
    }
}

/// A node's local transform, from its matrix or its TRS. A rotation that is
/// not a usable quaternion becomes the identity.
fn local_transform(node: &json::Node) -> Transform {
    let (translation, rotation, scale) = match node.matrix {
        Some(m) => {
            let (s, r, t) = glam::Mat4::from_cols_array(&m).to_scale_rotation_translation();
            (t, r, s)
        }
        None => (
            node.translation.map_or(Vec3::ZERO, Vec3::from),
            node.rotation.map_or(Quat::IDENTITY, |r| Quat::from_array(r.0)),
            node.scale.map_or(Vec3::ONE, Vec3::from),
        ),
    };
    Transform {
        translation,
        rotation: if rotation.is_finite() && rotation.length_squared() > 0.0 {
            rotation.normalize()
        } else {
            Quat::IDENTITY
        },
        scale,
    }
}

#[cfg(test)]
mod tests {
    use super::{GltfImport, NodeCameraResolver, shorten};
    use oxygen_core::{Animation, Camera, Scene, Transform, ViewContext, ViewIds, ViewResolver};

    /// An animation is found by its index or by its name, the first one
    /// without either; an unknown one is an error listing them all.
    #[test]
    fn an_animation_is_found_by_index_or_name() {
        let animation = |name: &str| Animation { name: name.to_owned(), channels: Vec::new() };
        let import = GltfImport {
            animations: vec![animation("walk"), animation("run"), animation("jump")],
            ..Default::default()
        };
        assert_eq!(import.animation(None).map(|a| a.name.as_str()), Ok("walk"));
        assert_eq!(import.animation(Some("2")).map(|a| a.name.as_str()), Ok("jump"));
        assert_eq!(import.animation(Some("run")).map(|a| a.name.as_str()), Ok("run"));
        let unknown = import.animation(Some("swim")).unwrap_err();
        assert!(unknown.contains("0 ('walk'), 1 ('run'), 2 ('jump')"), "{unknown}");
    }

    /// A glTF camera renders at the viewport's aspect: through a 200 × 100
    /// viewport its horizontal scale is half its vertical one.
    #[test]
    fn a_node_camera_projects_at_its_viewport_aspect() {
        let mut scene = Scene::new();
        let node = scene.add_node("camera", Transform::IDENTITY);
        let resolver = NodeCameraResolver {
            node,
            camera: Camera::try_perspective(1.0, 0.1, Some(100.0)).unwrap(),
            viewport: glam::UVec2::new(200, 100),
        };
        let context = ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 };
        let view = resolver.resolve(&context, &scene).unwrap();
        let (x, y) = (view.projection.x_axis.x, view.projection.y_axis.y);
        assert!((x * 2.0 - y).abs() < 1e-5 * y, "x scale {x}, y scale {y}");
    }

    /// A URI in an error message: a short one whole; a long one cut to its
    /// first 64 bytes with its length, and never inside a character (a
    /// two-byte `é` across byte 64 is cut before it).
    #[test]
    fn a_long_uri_is_cut_at_a_character_boundary_with_its_length() {
        assert_eq!(shorten("textures/box.png"), "textures/box.png");
        let long = format!("data:image/png;base64,{}", "A".repeat(100));
        assert_eq!(shorten(&long), format!("{}… (122 bytes)", &long[..64]));
        // 63 ASCII bytes, then `é` in bytes 63 and 64: the cut falls back to 63.
        let straddling = format!("{}é{}", "a".repeat(63), "b".repeat(10));
        assert_eq!(shorten(&straddling), format!("{}… (75 bytes)", "a".repeat(63)));
    }
}
