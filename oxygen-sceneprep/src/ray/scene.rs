//! The scene as the path-traced reference sees it: a two-level bounding
//! volume hierarchy over the same bindless geometry the raster passes draw.
//!
//! Each mesh gets a bottom-level tree over its triangles once (in its own
//! space, kept while the mesh lives); each time the frame phase recollects
//! the scene, a top-level tree is built over the instances' world boxes.
//! Everything is flattened into three arrays with absolute indices, in the
//! layout `reference_trace.wgsl` reads:
//!
//! ```text
//! nodes:     [ top level ][ mesh A's tree ][ mesh B's tree ] …
//! words:     [ top-level leaf order (instances) ][ A's order (triangles) ] … [ submesh tables ]
//! instances: one RayInstance per drawable renderable
//! ```
//!
//! A submesh table holds, per submesh of the instance, the triangle range it
//! covers and its material id; triangles outside every range are not hit.
//! Vertices and indices are not copied: the shader reads them from the heap
//! at the instance's vertex and index slots, so the tracer and the raster
//! passes see the same bytes. The matrices are the frame's, relative to the
//! render origin like everything else the GPU reads.
//!
//! Skinned and morphed meshes are the exception: the raster deforms them in
//! its vertex shader, which the tracer cannot follow into a tree. Each such
//! instance is posed here on the CPU with the frame's own joint matrices and
//! morph weights (the same arithmetic as `mesh_vertex.wgsl`), expressed in
//! its node's space, and gets a tree of its own over the posed triangles;
//! its posed vertices ([`RayScene::posed_vertices`]) are uploaded by the
//! tracer, and the instance, flagged [`POSED`], points into them.

use std::collections::HashMap;

use glam::{Mat3, Mat4, Vec3};
use oxygen_core::{Aabb, Geometry, Scene, Vertex};
use tracing::info_span;

use super::bvh::{Bvh, BvhNode, triangle_boxes};
use crate::FrameCollection;
use crate::finalize::geometry_cache::GeometryCache;

/// Triangles per bottom-level leaf; instances per top-level leaf.
const MAX_LEAF: u32 = 4;

oxygen_gpu::gpu_struct! {
    /// One instance as the tracer reads it (80 bytes).
    #[derive(Debug, Default, PartialEq)]
    pub struct RayInstance: 80 bytes {
        /// Rows of the inverse world matrix (world → the mesh's own space).
        pub inverse_rows: [[f32; 4]; 3] => "array<vec4<f32>, 3>",
        /// Index into the frame's world and normal matrices.
        pub transform_index: u32,
        /// The mesh's tree's root in `nodes`.
        pub blas_root: u32,
        /// The mesh's first vertex in the vertex domain.
        pub vertex_slot: u32,
        /// The mesh's first index in the index domain.
        pub index_slot: u32,
        /// First word of its submesh table in `words` (3 words per submesh).
        pub submesh_first: u32,
        /// Submeshes in the table.
        pub submesh_count: u32,
        /// The mesh's attribute records (colour, second UV set) in the vertex
        /// domain, [`oxygen_bindless::INVALID_SLOT`] when it has none.
        pub attributes_slot: u32,
        /// [`POSED`] when `vertex_slot` is an offset into
        /// [`RayScene::posed_vertices`] (the tracer rebases it on upload), else 0.
        pub flags: u32,
    }
}

/// [`RayInstance::flags`]: a skinned or morphed instance, posed on the CPU.
pub const POSED: u32 = 1;

const _: () = assert!(std::mem::size_of::<RayInstance>() == 80);

/// The flattened two-level hierarchy.
#[derive(Default)]
pub struct RayScene {
    /// Bottom-level trees by geometry id, with the geometry's index count
    /// (a different mesh under a reused id is rebuilt).
    meshes: HashMap<u32, (usize, Bvh)>,
    nodes: Vec<BvhNode>,
    words: Vec<u32>,
    instances: Vec<RayInstance>,
    tlas_root: Option<u32>,
    generation: u64,
    skipped: u32,
    /// Vertices of the posed instances, one run per instance.
    posed_vertices: Vec<Vertex>,
}

impl RayScene {
    /// Forgets every mesh's tree (another scene's geometry ids name other
    /// meshes); the next rebuild builds them again.
    pub fn forget_meshes(&mut self) {
        self.meshes.clear();
    }

    /// Every node, top level first.
    pub fn nodes(&self) -> &[BvhNode] {
        &self.nodes
    }
    /// Leaf orders, then submesh tables.
    pub fn words(&self) -> &[u32] {
        &self.words
    }
    /// The instances.
    pub fn instances(&self) -> &[RayInstance] {
        &self.instances
    }
    /// The top level's root node, `None` when nothing can be hit.
    pub fn tlas_root(&self) -> Option<u32> {
        self.tlas_root
    }
    /// Bumped by every rebuild: what the tracer restarts its samples on.
    pub fn generation(&self) -> u64 {
        self.generation
    }
    /// Renderables left out of the last rebuild: their world matrix cannot
    /// be inverted (a scale of zero: nothing a ray could hit, unless the
    /// mesh is skinned, whose joints place it: the tracer poses skinned
    /// meshes in their node's space and cannot for such a node), or posing
    /// them gave a non-finite vertex (a degenerate joint matrix).
    pub fn skipped(&self) -> u32 {
        self.skipped
    }
    /// The posed vertices of the skinned and morphed instances, in their
    /// nodes' spaces: the tracer uploads them to the vertex domain and adds
    /// where they land to the [`POSED`] instances' `vertex_slot`.
    pub fn posed_vertices(&self) -> &[Vertex] {
        &self.posed_vertices
    }

    /// Rebuilds from the frame phase's output; every mesh named must have
    /// slots in `geometry` (a renderable whose mesh has none is left out).
    pub(crate) fn rebuild(&mut self, scene: &Scene, frame: &FrameCollection, geometry: &GeometryCache) {
        let _span = info_span!("ray_scene_rebuild", renderables = frame.renderables.len()).entered();
        self.generation += 1;
        self.skipped = 0;
        // Instances and their world boxes.
        let mut instances = Vec::with_capacity(frame.renderables.len());
        let mut world_boxes = Vec::with_capacity(frame.renderables.len());
        let mut tables: Vec<[u32; 3]> = Vec::new();
        let mut used: Vec<u32> = Vec::new();
        self.posed_vertices.clear();
        // Trees over posed instances, by the order they were posed in.
        let mut posed_trees: Vec<Bvh> = Vec::new();
        for entry in &frame.renderables {
            let (Some(slots), Some(mesh)) = (geometry.get(entry.geometry), scene.geometry(entry.geometry)) else {
                continue;
            };
            let Some(world) = frame.transforms.world.get(entry.transform_index as usize).copied() else { continue };
            let determinant = world.determinant();
            if !(determinant.is_finite() && determinant.abs() > f32::MIN_POSITIVE) {
                self.skipped += 1;
                continue;
            }
            let inverse = world.inverse();
            let deformed =
                entry.joint_base != oxygen_bindless::INVALID_SLOT || entry.morph_base != oxygen_bindless::INVALID_SLOT;
            let (bvh, vertex_slot, flags, tree) = if deformed {
                let Some(vertices) = pose(mesh, entry, frame, &world) else {
                    self.skipped += 1;
                    continue;
                };
                let positions: Vec<[f32; 3]> = vertices.iter().map(|v| v.position).collect();
                posed_trees.push(Bvh::build(&triangle_boxes(&positions, mesh.indices()), MAX_LEAF));
                let offset = self.posed_vertices.len() as u32;
                self.posed_vertices.extend_from_slice(&vertices);
                let index = posed_trees.len() - 1;
                (&posed_trees[index], offset, POSED, index as u32)
            } else {
                let index_count = mesh.indices().len();
                let stale = self.meshes.get(&entry.geometry_id).is_none_or(|(count, _)| *count != index_count);
                if stale {
                    let positions: Vec<[f32; 3]> = mesh.vertices().iter().map(|v| v.position).collect();
                    let bvh = Bvh::build(&triangle_boxes(&positions, mesh.indices()), MAX_LEAF);
                    self.meshes.insert(entry.geometry_id, (index_count, bvh));
                }
                let Some((_, bvh)) = self.meshes.get(&entry.geometry_id) else { continue };
                (bvh, slots.vertices.start, 0, entry.geometry_id)
            };
            if bvh.nodes.is_empty() {
                continue;
            }
            let (start, count) = entry.submeshes;
            let submeshes = frame.submeshes.get(start as usize..(start + count) as usize).unwrap_or(&[]);
            let submesh_first = tables.len() as u32;
            tables
                .extend(submeshes.iter().map(|s| [s.first_index / 3, (s.first_index + s.index_count) / 3, s.material]));
            let rows = inverse.transpose().to_cols_array_2d();
            instances.push(RayInstance {
                inverse_rows: [rows[0], rows[1], rows[2]],
                transform_index: entry.transform_index,
                blas_root: tree, // resolved below
                vertex_slot,
                index_slot: slots.index_slot,
                submesh_first,
                submesh_count: submeshes.len() as u32,
                attributes_slot: slots.attributes,
                flags,
            });
            world_boxes.push(transform_box(&world, bvh.bounds()));
            if !deformed && !used.contains(&entry.geometry_id) {
                used.push(entry.geometry_id);
            }
        }
        // Meshes no instance uses any more are dropped.
        self.meshes.retain(|id, _| used.contains(id));

        let top = Bvh::build(&world_boxes, MAX_LEAF);
        self.nodes.clear();
        self.words.clear();
        self.nodes.extend_from_slice(&top.nodes);
        self.words.extend_from_slice(&top.order);
        let mut roots: HashMap<u32, u32> = HashMap::new();
        used.sort_unstable();
        for id in &used {
            let Some((_, bvh)) = self.meshes.get(id) else { continue };
            let (node_base, word_base) = (self.nodes.len() as u32, self.words.len() as u32);
            roots.insert(*id, node_base);
            self.nodes.extend(
                bvh.nodes
                    .iter()
                    .map(|n| BvhNode { first: n.first + if n.count == 0 { node_base } else { word_base }, ..*n }),
            );
            self.words.extend_from_slice(&bvh.order);
        }
        let mut posed_roots = Vec::with_capacity(posed_trees.len());
        for bvh in &posed_trees {
            let (node_base, word_base) = (self.nodes.len() as u32, self.words.len() as u32);
            posed_roots.push(node_base);
            self.nodes.extend(
                bvh.nodes
                    .iter()
                    .map(|n| BvhNode { first: n.first + if n.count == 0 { node_base } else { word_base }, ..*n }),
            );
            self.words.extend_from_slice(&bvh.order);
        }
        let table_base = self.words.len() as u32;
        self.words.extend(tables.iter().flatten());
        for instance in &mut instances {
            instance.blas_root = if instance.flags & POSED != 0 {
                posed_roots.get(instance.blas_root as usize).copied().unwrap_or(0)
            } else {
                roots.get(&instance.blas_root).copied().unwrap_or(0)
            };
            // From an entry of the tables to its first word (3 per entry).
            instance.submesh_first = table_base + instance.submesh_first * 3;
        }
        self.instances = instances;
        self.tlas_root = (!top.nodes.is_empty()).then_some(0);
    }
}

/// The mesh as the raster's vertex shader deforms it this frame, in the
/// space of its node (`world`): morph targets with the weights of the
/// frame's morph header, then the skin with the frame's joint matrices.
/// `None` when the frame lacks the matrices named or a posed vertex is not
/// finite.
fn pose(mesh: &Geometry, entry: &crate::RenderableEntry, frame: &FrameCollection, world: &Mat4) -> Option<Vec<Vertex>> {
    let matrices = &frame.transforms;
    let mut vertices = mesh.vertices().to_vec();
    if entry.morph_base != oxygen_bindless::INVALID_SLOT {
        // [vertex count, target count, w0, w1, ...], 16 floats a matrix.
        let header = |k: usize| -> Option<f32> {
            let m = matrices.world.get(entry.morph_base as usize + k / 16)?;
            Some(m.to_cols_array()[k % 16])
        };
        let targets = header(1)? as usize;
        for (t, target) in mesh.morph_targets().iter().enumerate().take(targets) {
            let w = header(t + 2)?;
            if w == 0.0 {
                continue;
            }
            for (i, v) in vertices.iter_mut().enumerate() {
                let d = target.positions.get(i).copied().unwrap_or(Vec3::ZERO);
                v.position = (Vec3::from(v.position) + w * d).to_array();
                if let Some(normals) = &target.normals {
                    let d = normals.get(i).copied().unwrap_or(Vec3::ZERO);
                    v.normal = (Vec3::from(v.normal) + w * d).to_array();
                }
            }
        }
    }
    if entry.joint_base != oxygen_bindless::INVALID_SLOT {
        let skin = mesh.skin_weights()?;
        // The skin gives world space; the tracer applies the node's world
        // matrix, so the posed mesh goes back through its inverse (normals
        // through its transpose, the inverse of the normal matrix).
        let to_node = world.inverse();
        let normal_to_node = Mat3::from_mat4(*world).transpose();
        for (v, s) in vertices.iter_mut().zip(skin) {
            let (mut position, mut normal) = (Vec3::ZERO, Vec3::ZERO);
            for k in 0..4 {
                let weight = s.weights[k];
                if weight > 0.0 {
                    let joint = entry.joint_base as usize + s.joints[k] as usize;
                    let m = matrices.world.get(joint)?;
                    let n = matrices.normal.get(joint)?;
                    let n = n.matrix();
                    position += weight * m.transform_point3(Vec3::from(v.position));
                    normal += weight * (n * Vec3::from(v.normal));
                }
            }
            v.position = to_node.transform_point3(position).to_array();
            v.normal = (normal_to_node * normal).to_array();
        }
    }
    vertices.iter().all(|v| Vec3::from(v.position).is_finite() && Vec3::from(v.normal).is_finite()).then_some(vertices)
}

/// The box around `local` once `world` has moved it (its eight corners).
fn transform_box(world: &Mat4, local: Aabb) -> Aabb {
    let mut out = Aabb::EMPTY;
    for i in 0..8 {
        let corner = Vec3::new(
            if i & 1 == 0 { local.min.x } else { local.max.x },
            if i & 2 == 0 { local.min.y } else { local.max.y },
            if i & 4 == 0 { local.min.z } else { local.max.z },
        );
        let p = world.transform_point3(corner);
        out.min = out.min.min(p);
        out.max = out.max.max(p);
    }
    // Rounded outward by a few units in the last place, so that f32
    // rounding of the transformed corners never makes the box smaller
    // than what the shader's own transform of the triangles gives.
    let slack = (out.min.abs().max(out.max.abs()) * 4.0 * f32::EPSILON).max(Vec3::splat(f32::MIN_POSITIVE));
    Aabb { min: out.min - slack, max: out.max + slack }
}
