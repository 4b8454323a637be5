//! Geometry assets: vertices, indices, submeshes and a local bound.
//!
//! A [`Geometry`] is validated when built, so that later stages (upload, the
//! GPU) never see an index past the end of the vertex array or a NaN position.

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3, Vec4};
use thiserror::Error;

use crate::math::Aabb;

/// One vertex as it is stored in the bindless vertex domain (32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable, serde::Serialize, serde::Deserialize)]
pub struct Vertex {
    /// Object-space position.
    pub position: [f32; 3],
    /// Object-space normal (unit length).
    pub normal: [f32; 3],
    /// Texture coordinate, glTF convention (origin top-left).
    pub uv: [f32; 2],
}

const _: () = assert!(std::mem::size_of::<Vertex>() == 32);

impl Vertex {
    /// A vertex from glam vectors.
    pub fn new(position: Vec3, normal: Vec3, uv: Vec2) -> Self {
        Vertex { position: position.to_array(), normal: normal.to_array(), uv: uv.to_array() }
    }
}

/// A vertex's optional attributes (glTF `COLOR_0` and `TEXCOORD_1`), stored
/// in the vertex domain right after the geometry's vertices, one 32-byte
/// record per vertex, only for geometry that has them: a mesh without
/// vertex colours or a second UV set pays nothing for them.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable, serde::Serialize, serde::Deserialize)]
pub struct VertexAttributes {
    /// Linear RGBA vertex colour, multiplied into the base colour.
    pub color: [f32; 4],
    /// Second texture coordinate set (glTF `TEXCOORD_1`).
    pub uv1: [f32; 2],
    /// Zero.
    pub reserved: [f32; 2],
}

const _: () = assert!(std::mem::size_of::<VertexAttributes>() == std::mem::size_of::<Vertex>());

impl Default for VertexAttributes {
    /// White, second UV set at the origin: what a vertex without them means.
    fn default() -> Self {
        VertexAttributes { color: [1.0; 4], uv1: [0.0; 2], reserved: [0.0; 2] }
    }
}

impl VertexAttributes {
    /// Attributes from glam vectors.
    pub fn new(color: Vec4, uv1: Vec2) -> Self {
        VertexAttributes { color: color.to_array(), uv1: uv1.to_array(), reserved: [0.0; 2] }
    }

    /// Non-finite values replaced (colour by white, UV by zero) and the
    /// colour clamped to `[0, 1]`, so nothing meaningless reaches the GPU.
    fn sanitized(self) -> Self {
        let color = Vec4::from(self.color);
        let color = if color.is_finite() { color.clamp(Vec4::ZERO, Vec4::ONE) } else { Vec4::ONE };
        let uv1 = Vec2::from(self.uv1);
        let uv1 = if uv1.is_finite() { uv1 } else { Vec2::ZERO };
        VertexAttributes::new(color, uv1)
    }
}

/// Joints a skin may have, and one more than the largest joint index a
/// vertex may name: glTF's `JOINTS_0` holds 16-bit indices at most. The cap
/// bounds what a geometry's per-joint bounds cost (a vertex naming joint
/// `j` makes `j + 1` of them), whoever made the geometry: an importer, or
/// a scene delta from another process.
pub const MAX_JOINTS: usize = 1 << 16;

/// A vertex's skin: up to four joints (indices into its node's
/// [`Skin::joints`](crate::scene::Skin::joints)) and their weights, stored in
/// the vertex domain after the geometry's vertices and attribute records
/// (32 bytes; joints as floats, exact below 2^24).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable, serde::Serialize, serde::Deserialize)]
pub struct SkinWeights {
    /// Joint indices (whole numbers).
    pub joints: [f32; 4],
    /// Weights, non-negative, summing to 1.
    pub weights: [f32; 4],
}

const _: () = assert!(std::mem::size_of::<SkinWeights>() == std::mem::size_of::<Vertex>());

impl SkinWeights {
    /// Four joints and weights; the weights are normalised to sum to 1
    /// (negative and non-finite ones count as 0; all zero binds the vertex
    /// to its first joint alone).
    pub fn new(joints: [u32; 4], weights: [f32; 4]) -> Self {
        let weights = weights.map(|w| if w.is_finite() && w > 0.0 { w } else { 0.0 });
        let sum: f32 = weights.iter().sum();
        let weights = if sum > 0.0 { weights.map(|w| w / sum) } else { [1.0, 0.0, 0.0, 0.0] };
        SkinWeights { joints: joints.map(|j| j as f32), weights }
    }

    /// The joints with a weight above zero.
    pub fn influences(&self) -> impl Iterator<Item = u32> + '_ {
        self.joints.iter().zip(&self.weights).filter(|(_, w)| **w > 0.0).map(|(j, _)| *j as u32)
    }
}

/// One morph target: a displacement of every vertex's position and
/// (optionally) normal, blended in with the renderable's weight for it
/// ([`Scene::set_morph_weights`](crate::Scene::set_morph_weights)). Stored
/// in the vertex domain right after the vertices, one record per vertex per
/// target (position delta in the position's place, normal delta in the
/// normal's).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MorphTarget {
    /// Position displacement per vertex.
    pub positions: Vec<Vec3>,
    /// Normal displacement per vertex (`None`: normals do not change).
    pub normals: Option<Vec<Vec3>>,
}

/// Morph targets a geometry may have (each vertex loops over them).
pub const MAX_MORPH_TARGETS: usize = 64;

/// A range of the index array drawn with one material.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Submesh {
    /// First index, relative to the geometry's index array.
    pub first_index: u32,
    /// Number of indices (a multiple of 3).
    pub index_count: u32,
}

/// What was wrong with geometry handed to [`Geometry::new`].
#[derive(Debug, Error, PartialEq)]
pub enum GeometryError {
    /// A vertex has a NaN or infinite position.
    #[error("geometry '{name}': vertex {vertex} has a non-finite position")]
    NonFinitePosition {
        /// Geometry name.
        name: String,
        /// Offending vertex.
        vertex: usize,
    },
    /// An index refers past the vertex array.
    #[error("geometry '{name}': index {position} is {value}, but there are only {vertex_count} vertices")]
    IndexOutOfRange {
        /// Geometry name.
        name: String,
        /// Position in the index array.
        position: usize,
        /// The index value.
        value: u32,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// A submesh reaches past the index array or is not a triangle list.
    #[error(
        "geometry '{name}': submesh {submesh} ({first}..+{count}) is not a triangle range inside {index_count} indices"
    )]
    BadSubmesh {
        /// Geometry name.
        name: String,
        /// Submesh number.
        submesh: usize,
        /// Its first index.
        first: u32,
        /// Its index count.
        count: u32,
        /// Length of the index array.
        index_count: usize,
    },
    /// The indices are not a whole number of triangles.
    #[error("geometry '{name}' has {index_count} indices, not a whole number of triangles")]
    NotTriangles {
        /// Geometry name.
        name: String,
        /// Length of the index array.
        index_count: usize,
    },
    /// There is nothing to draw.
    #[error("geometry '{name}' has no vertices, indices or submeshes")]
    Empty {
        /// Geometry name.
        name: String,
    },
    /// [`Geometry::with_morph_targets`] got targets that do not fit.
    #[error("geometry '{name}': morph targets: {reason}")]
    MorphTargets {
        /// Geometry name.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// [`Geometry::with_skin_weights`] got a different number of records
    /// than there are vertices, or a joint index of [`MAX_JOINTS`] or more.
    #[error("geometry '{name}': {weights} skin records for {vertices} vertices, or a joint index of 65536 or more")]
    SkinWeights {
        /// Geometry name.
        name: String,
        /// Skin records given.
        weights: usize,
        /// Vertices.
        vertices: usize,
    },
    /// [`Geometry::with_attributes`] got a different number of records than
    /// there are vertices.
    #[error("geometry '{name}': {attributes} vertex attribute records for {vertices} vertices")]
    AttributeCount {
        /// Geometry name.
        name: String,
        /// Attribute records given.
        attributes: usize,
        /// Vertices.
        vertices: usize,
    },
    /// More vertices or indices than a `u32` can address.
    #[error("geometry '{name}' is too large for 32-bit indices")]
    TooLarge {
        /// Geometry name.
        name: String,
    },
}

/// An indexed triangle mesh with one or more submeshes.
#[derive(Clone, Debug, PartialEq)]
pub struct Geometry {
    name: String,
    vertices: Vec<Vertex>,
    indices: Vec<u32>,
    submeshes: Vec<Submesh>,
    attributes: Option<Vec<VertexAttributes>>,
    skin: Option<Vec<SkinWeights>>,
    morph_targets: Vec<MorphTarget>,
    /// Per morph target, the bound of its position displacements.
    morph_bounds: Vec<Aabb>,
    /// Per joint, the bound of the vertices it moves (skinned geometry).
    joint_bounds: Vec<Option<Aabb>>,
    local_aabb: Aabb,
}

impl Geometry {
    /// Validates and builds a geometry. Non-finite normals are replaced by +Z
    /// (they only darken a pixel), non-finite positions are an error (they
    /// would poison bounds and culling).
    pub fn new(
        name: impl Into<String>,
        mut vertices: Vec<Vertex>,
        indices: Vec<u32>,
        submeshes: Vec<Submesh>,
    ) -> Result<Self, GeometryError> {
        let name = name.into();
        if vertices.is_empty() || indices.is_empty() || submeshes.is_empty() {
            return Err(GeometryError::Empty { name });
        }
        if u32::try_from(vertices.len()).is_err() || u32::try_from(indices.len()).is_err() {
            return Err(GeometryError::TooLarge { name });
        }
        if !indices.len().is_multiple_of(3) {
            return Err(GeometryError::NotTriangles { name, index_count: indices.len() });
        }
        for (i, v) in vertices.iter_mut().enumerate() {
            if !Vec3::from(v.position).is_finite() {
                return Err(GeometryError::NonFinitePosition { name, vertex: i });
            }
            // A normal already of unit length (within rounding) is kept as
            // given, so that building a geometry from another's vertices
            // (a scene replica) gives the same bits: normalising twice
            // moves some normals by an ulp.
            let n = Vec3::from(v.normal);
            if !(n.is_finite() && (n.length_squared() - 1.0).abs() <= 1e-6) {
                v.normal = n.try_normalize().unwrap_or(Vec3::Z).to_array();
            }
            if !Vec2::from(v.uv).is_finite() {
                v.uv = [0.0, 0.0];
            }
        }
        if let Some((position, &value)) = indices.iter().enumerate().find(|(_, i)| **i as usize >= vertices.len()) {
            return Err(GeometryError::IndexOutOfRange { name, position, value, vertex_count: vertices.len() });
        }
        for (i, s) in submeshes.iter().enumerate() {
            let end = s.first_index as u64 + s.index_count as u64;
            // Whole triangles from a triangle's start: each geometry's
            // triangles are uploaded corner-rotated three indices at a
            // time (deferred shading's triangle table), so a range
            // starting mid-triangle would draw other triangles.
            if s.index_count == 0 || s.index_count % 3 != 0 || s.first_index % 3 != 0 || end > indices.len() as u64 {
                return Err(GeometryError::BadSubmesh {
                    name,
                    submesh: i,
                    first: s.first_index,
                    count: s.index_count,
                    index_count: indices.len(),
                });
            }
        }
        let local_aabb = Aabb::from_points(vertices.iter().map(|v| Vec3::from(v.position)));
        Ok(Geometry {
            name,
            vertices,
            indices,
            submeshes,
            attributes: None,
            skin: None,
            morph_targets: Vec::new(),
            morph_bounds: Vec::new(),
            joint_bounds: Vec::new(),
            local_aabb,
        })
    }

    /// The geometry with per-vertex colours and a second UV set, one record
    /// per vertex (sanitised: non-finite colours become white, non-finite
    /// UVs zero, colours are clamped to `[0, 1]`).
    pub fn with_attributes(mut self, attributes: Vec<VertexAttributes>) -> Result<Self, GeometryError> {
        if attributes.len() != self.vertices.len() {
            return Err(GeometryError::AttributeCount {
                name: self.name,
                attributes: attributes.len(),
                vertices: self.vertices.len(),
            });
        }
        // The vertex domain holds the vertices and their attributes: both
        // together must stay addressable with 32 bits.
        if attributes.len().checked_mul(3).and_then(|n| u32::try_from(n).ok()).is_none() {
            return Err(GeometryError::TooLarge { name: self.name });
        }
        self.attributes = Some(attributes.into_iter().map(VertexAttributes::sanitized).collect());
        Ok(self)
    }

    /// Per-vertex colours and second UV set, when the geometry has them.
    pub fn attributes(&self) -> Option<&[VertexAttributes]> {
        self.attributes.as_deref()
    }

    /// The geometry skinned: one record per vertex (joint indices below
    /// [`MAX_JOINTS`], weights as [`SkinWeights::new`] leaves them). Also computes,
    /// per joint, the bound of the vertices it moves, from which a skinned
    /// renderable's bound in any pose follows ([`Geometry::joint_bounds`]).
    pub fn with_skin_weights(mut self, skin: Vec<SkinWeights>) -> Result<Self, GeometryError> {
        let too_large = skin.iter().any(|s| s.joints.iter().any(|j| !(*j >= 0.0 && *j < MAX_JOINTS as f32)));
        if skin.len() != self.vertices.len() || too_large {
            return Err(GeometryError::SkinWeights {
                name: self.name,
                weights: skin.len(),
                vertices: self.vertices.len(),
            });
        }
        if skin.len().checked_mul(3).and_then(|n| u32::try_from(n).ok()).is_none() {
            return Err(GeometryError::TooLarge { name: self.name });
        }
        let mut bounds: Vec<Option<Aabb>> = Vec::new();
        for (vertex, s) in self.vertices.iter().zip(&skin) {
            let p = Vec3::from(vertex.position);
            for joint in s.influences() {
                let j = joint as usize;
                if bounds.len() <= j {
                    bounds.resize(j + 1, None);
                }
                bounds[j] = Some(match bounds[j] {
                    Some(b) => Aabb::new(b.min.min(p), b.max.max(p)),
                    None => Aabb::new(p, p),
                });
            }
        }
        self.joint_bounds = bounds;
        self.skin = Some(skin);
        Ok(self)
    }

    /// Per-vertex joints and weights, when the geometry is skinned.
    pub fn skin_weights(&self) -> Option<&[SkinWeights]> {
        self.skin.as_deref()
    }

    /// Per joint index, the object-space bound of the vertices that joint
    /// moves (`None` for a joint no vertex uses): a skinned vertex is a
    /// weighted mean of its joints' transforms of it, so it lies inside the
    /// union of each joint's transform of its bound, in every pose.
    pub fn joint_bounds(&self) -> &[Option<Aabb>] {
        &self.joint_bounds
    }

    /// The geometry with morph targets (at most [`MAX_MORPH_TARGETS`], one
    /// displacement per vertex each, finite; at most 2^24 vertices, which
    /// shaders count in a float). The records they take (the vertices,
    /// one block per target, and up to two parallel blocks) then always
    /// fit a `u32` count: see the assertion below.
    pub fn with_morph_targets(mut self, targets: Vec<MorphTarget>) -> Result<Self, GeometryError> {
        let n = self.vertices.len();
        let fail = |name: String, reason: String| Err(GeometryError::MorphTargets { name, reason });
        if targets.len() > MAX_MORPH_TARGETS {
            return fail(self.name, format!("{} targets (at most {MAX_MORPH_TARGETS})", targets.len()));
        }
        if n >= 1 << 24 {
            return fail(self.name, format!("{n} vertices (morphing counts them below 2^24)"));
        }
        for (i, t) in targets.iter().enumerate() {
            let normals_fit = t.normals.as_ref().is_none_or(|v| v.len() == n);
            if t.positions.len() != n || !normals_fit {
                return fail(self.name, format!("target {i} does not have one displacement per vertex"));
            }
            let finite = t.positions.iter().chain(t.normals.iter().flatten()).all(|d| d.is_finite());
            if !finite {
                return fail(self.name, format!("target {i} has a non-finite displacement"));
            }
        }
        self.morph_bounds = targets
            .iter()
            .map(|t| {
                let (min, max) = t.positions.iter().fold((Vec3::ZERO, Vec3::ZERO), |(a, b), d| (a.min(*d), b.max(*d)));
                Aabb::new(min, max)
            })
            .collect();
        self.morph_targets = targets;
        Ok(self)
    }

    /// Its morph targets (empty for most geometry).
    pub fn morph_targets(&self) -> &[MorphTarget] {
        &self.morph_targets
    }

    /// `bound` grown to hold every vertex in it displaced by the targets
    /// with `weights` (missing weights are 0): each target adds its weighted
    /// displacement range, so the result holds the morphed mesh.
    pub fn morphed_bound(&self, bound: Aabb, weights: &[f32]) -> Aabb {
        let (mut min, mut max) = (bound.min, bound.max);
        for (b, w) in self.morph_bounds.iter().zip(weights) {
            let (a, c) = (b.min * *w, b.max * *w);
            min += a.min(c);
            max += a.max(c);
        }
        Aabb::new(min, max)
    }

    /// Records the geometry occupies in the vertex domain: its vertices,
    /// then one block per morph target, then its attribute records and its
    /// skin records when it has them (fits in a `u32`).
    pub fn vertex_domain_records(&self) -> usize {
        self.vertices.len()
            * (1 + self.morph_targets.len() + usize::from(self.attributes.is_some()) + usize::from(self.skin.is_some()))
    }

    /// The vertex-domain records of its morph targets, target by target
    /// (position delta where a vertex has its position, normal delta where
    /// it has its normal).
    pub fn morph_records(&self) -> Vec<Vertex> {
        let mut out = Vec::with_capacity(self.morph_targets.len() * self.vertices.len());
        for t in &self.morph_targets {
            for (i, d) in t.positions.iter().enumerate() {
                let n = t.normals.as_ref().map_or(Vec3::ZERO, |v| v[i]);
                out.push(Vertex::new(*d, n, Vec2::ZERO));
            }
        }
        out
    }

    /// Name for logs and dumps.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Vertex array.
    pub fn vertices(&self) -> &[Vertex] {
        &self.vertices
    }
    /// Index array (triangle list).
    pub fn indices(&self) -> &[u32] {
        &self.indices
    }
    /// Submeshes; a renderable gives one material per submesh.
    pub fn submeshes(&self) -> &[Submesh] {
        &self.submeshes
    }
    /// Object-space bound of every vertex.
    pub fn local_aabb(&self) -> Aabb {
        self.local_aabb
    }

    /// An axis-aligned cube of edge `size` centred at the origin, with flat
    /// normals (24 vertices, one submesh).
    pub fn cube(size: f32) -> Self {
        let h = size * 0.5;
        // (normal, tangent u, tangent v) for the six faces.
        let faces = [
            (Vec3::X, Vec3::NEG_Z, Vec3::Y),
            (Vec3::NEG_X, Vec3::Z, Vec3::Y),
            (Vec3::Y, Vec3::X, Vec3::NEG_Z),
            (Vec3::NEG_Y, Vec3::X, Vec3::Z),
            (Vec3::Z, Vec3::X, Vec3::Y),
            (Vec3::NEG_Z, Vec3::NEG_X, Vec3::Y),
        ];
        let mut vertices = Vec::with_capacity(24);
        let mut indices = Vec::with_capacity(36);
        for (n, u, v) in faces {
            let base = vertices.len() as u32;
            for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let p = (n + u * su + v * sv) * h;
                vertices.push(Vertex::new(p, n, Vec2::new((su + 1.0) * 0.5, (1.0 - sv) * 0.5)));
            }
            indices.extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
        }
        Self::single_submesh("cube", vertices, indices)
    }

    /// A square of edge `size` in the XZ plane facing +Y, centred at the origin.
    pub fn plane(size: f32) -> Self {
        let h = size * 0.5;
        let vertices = [(-h, h), (h, h), (h, -h), (-h, -h)]
            .into_iter()
            .map(|(x, z)| Vertex::new(Vec3::new(x, 0.0, z), Vec3::Y, Vec2::new(x / size + 0.5, z / size + 0.5)))
            .collect();
        Self::single_submesh("plane", vertices, vec![0, 1, 2, 0, 2, 3])
    }

    /// A square of edge `size` in the XY plane facing +Z, centred at the origin.
    pub fn quad(size: f32) -> Self {
        let h = size * 0.5;
        let vertices = [(-h, -h), (h, -h), (h, h), (-h, h)]
            .into_iter()
            .map(|(x, y)| Vertex::new(Vec3::new(x, y, 0.0), Vec3::Z, Vec2::new(x / size + 0.5, 0.5 - y / size)))
            .collect();
        Self::single_submesh("quad", vertices, vec![0, 1, 2, 0, 2, 3])
    }

    /// A UV sphere of `radius` with `segments` around and `rings` from pole
    /// to pole (each at least 3), smooth normals.
    pub fn uv_sphere(radius: f32, segments: u32, rings: u32) -> Self {
        let (segments, rings) = (segments.max(3), rings.max(3));
        let mut vertices = Vec::new();
        for ring in 0..=rings {
            let v = ring as f32 / rings as f32;
            let theta = v * std::f32::consts::PI;
            for segment in 0..=segments {
                let u = segment as f32 / segments as f32;
                let phi = u * std::f32::consts::TAU;
                let n = Vec3::new(theta.sin() * phi.cos(), theta.cos(), -theta.sin() * phi.sin());
                vertices.push(Vertex::new(n * radius, n, Vec2::new(u, v)));
            }
        }
        let mut indices = Vec::new();
        let row = segments + 1;
        for ring in 0..rings {
            for segment in 0..segments {
                let a = ring * row + segment;
                let b = a + row;
                indices.extend_from_slice(&[a, b, a + 1, a + 1, b, b + 1]);
            }
        }
        Self::single_submesh("uv sphere", vertices, indices)
    }

    fn single_submesh(name: &str, vertices: Vec<Vertex>, indices: Vec<u32>) -> Self {
        let submesh = Submesh { first_index: 0, index_count: indices.len() as u32 };
        // Built from constants above; a failure here is a bug in this file.
        Geometry::new(name, vertices, indices, vec![submesh]).expect("procedural geometry is valid")
    }
}

// A morphed mesh's vertex records (its vertices, one block per target and
// up to two parallel blocks of attributes and skin weights) are counted in
// a `u32`: with at most MAX_MORPH_TARGETS targets and 2^24 vertices they
// always fit, so `with_morph_targets` needs no runtime check of it.
const _: () = assert!((MAX_MORPH_TARGETS + 3) * (1 << 24) <= u32::MAX as usize);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_joint_index_past_the_cap_is_refused_before_its_bounds_are_made() {
        let skin = |joint: u32| vec![SkinWeights::new([joint, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]); 24];
        let last = (MAX_JOINTS - 1) as u32;
        let skinned = Geometry::cube(1.0).with_skin_weights(skin(last)).expect("the largest joint index");
        assert_eq!(skinned.joint_bounds().len(), MAX_JOINTS);
        // One more would be accepted up to 2^24 before: 470 MB of bounds
        // from one vertex of a hostile delta or file.
        assert!(Geometry::cube(1.0).with_skin_weights(skin(last + 1)).is_err());
        assert!(Geometry::cube(1.0).with_skin_weights(skin((1 << 24) - 1)).is_err());
    }

    #[test]
    fn cube_faces_wind_counter_clockwise_seen_from_outside() {
        let cube = Geometry::cube(2.0);
        for tri in cube.indices().chunks(3) {
            let p = |i: u32| Vec3::from(cube.vertices()[i as usize].position);
            let n = Vec3::from(cube.vertices()[tri[0] as usize].normal);
            let face_normal = (p(tri[1]) - p(tri[0])).cross(p(tri[2]) - p(tri[0]));
            assert!(face_normal.dot(n) > 0.0);
        }
        assert_eq!(cube.local_aabb(), Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0)));
    }

    #[test]
    fn sphere_triangles_face_outwards() {
        let sphere = Geometry::uv_sphere(2.0, 12, 8);
        for tri in sphere.indices().chunks(3) {
            let p = |i: u32| Vec3::from(sphere.vertices()[i as usize].position);
            let face_normal = (p(tri[1]) - p(tri[0])).cross(p(tri[2]) - p(tri[0]));
            let centroid = (p(tri[0]) + p(tri[1]) + p(tri[2])) / 3.0;
            // Degenerate pole triangles have no area; every other one faces out.
            assert!(face_normal.length() < 1e-6 || face_normal.dot(centroid) > 0.0);
        }
    }

    #[test]
    fn out_of_range_index_is_an_error_naming_the_geometry() {
        let v = vec![Vertex::default(); 3];
        let err = Geometry::new("bad", v, vec![0, 1, 7], vec![Submesh { first_index: 0, index_count: 3 }]);
        assert!(matches!(err, Err(GeometryError::IndexOutOfRange { value: 7, .. })));
        assert!(err.unwrap_err().to_string().contains("'bad'"));
    }

    /// Submeshes are whole triangles from a triangle's start, and the
    /// indices whole triangles: a range starting mid-triangle, or a
    /// leftover index, is refused naming the geometry.
    #[test]
    fn submeshes_and_indices_are_whole_triangles() {
        let v = || vec![Vertex::default(); 3];
        let six = || vec![0, 1, 2, 0, 1, 2];
        let mid = Geometry::new("mid", v(), six(), vec![Submesh { first_index: 1, index_count: 3 }]);
        assert!(matches!(mid, Err(GeometryError::BadSubmesh { first: 1, count: 3, .. })), "{mid:?}");
        let ok = Geometry::new("ok", v(), six(), vec![Submesh { first_index: 3, index_count: 3 }]);
        assert!(ok.is_ok(), "{ok:?}");
        let leftover =
            Geometry::new("leftover", v(), vec![0, 1, 2, 0], vec![Submesh { first_index: 0, index_count: 3 }]);
        let error = leftover.expect_err("four indices").to_string();
        assert!(error.contains("'leftover'") && error.contains("4 indices"), "{error}");
    }

    #[test]
    fn attributes_must_match_the_vertices_and_are_sanitized() {
        let quad = Geometry::quad(1.0);
        let err = quad.clone().with_attributes(vec![VertexAttributes::default(); 3]);
        assert!(matches!(err, Err(GeometryError::AttributeCount { attributes: 3, vertices: 4, .. })));
        let mut attributes = vec![VertexAttributes::new(Vec4::new(0.5, 2.0, -1.0, 1.0), Vec2::new(3.0, 4.0)); 4];
        attributes[1].color[0] = f32::NAN;
        attributes[2].uv1[1] = f32::INFINITY;
        let quad = quad.with_attributes(attributes).unwrap();
        let a = quad.attributes().unwrap();
        assert_eq!(a[0].color, [0.5, 1.0, 0.0, 1.0]);
        assert_eq!(a[1].color, [1.0; 4]);
        assert_eq!(a[2].uv1, [0.0, 0.0]);
        assert_eq!(quad.vertex_domain_records(), 8);
    }

    #[test]
    fn non_finite_position_is_rejected() {
        let mut v = vec![Vertex::default(); 3];
        v[1].position[2] = f32::NAN;
        let err = Geometry::new("nan", v, vec![0, 1, 2], vec![Submesh { first_index: 0, index_count: 3 }]);
        assert!(matches!(err, Err(GeometryError::NonFinitePosition { vertex: 1, .. })));
    }

    fn positions(g: &Geometry) -> Vec<Vec3> {
        g.vertices().iter().map(|v| Vec3::from(v.position)).collect()
    }

    fn uvs(g: &Geometry) -> Vec<Vec2> {
        g.vertices().iter().map(|v| Vec2::from(v.uv)).collect()
    }

    #[test]
    fn cube_corners_sit_half_its_edge_out_on_their_face() {
        // Edge 3 (half 1.5): an edge of 2 would hide a scale applied the
        // wrong way round.
        let cube = Geometry::cube(3.0);
        assert_eq!(cube.name(), "cube");
        assert_eq!(cube.vertices().len(), 24);
        assert_eq!(cube.submeshes(), &[Submesh { first_index: 0, index_count: 36 }]);
        for (face, quad) in cube.vertices().chunks(4).enumerate() {
            let n = Vec3::from(quad[0].normal);
            for v in quad {
                assert_eq!(Vec3::from(v.normal), n, "face {face}");
                assert_eq!(Vec3::from(v.position).abs(), Vec3::splat(1.5), "face {face}");
                assert_eq!(Vec3::from(v.position).dot(n), 1.5, "face {face}");
            }
        }
        // The +X face, corner by corner: its u runs along -Z, its v down Y.
        let expected = [
            Vec3::new(1.5, -1.5, 1.5),
            Vec3::new(1.5, -1.5, -1.5),
            Vec3::new(1.5, 1.5, -1.5),
            Vec3::new(1.5, 1.5, 1.5),
        ];
        assert_eq!(positions(&cube)[..4], expected);
        assert_eq!(cube.indices()[..6], [0, 1, 2, 0, 2, 3]);
        assert_eq!(cube.indices()[30..], [20, 21, 22, 20, 22, 23]);
    }

    #[test]
    fn cube_faces_map_the_whole_texture_unmirrored() {
        let cube = Geometry::cube(3.0);
        for (face, quad) in cube.vertices().chunks(4).enumerate() {
            let uv: Vec<Vec2> = quad.iter().map(|v| Vec2::from(v.uv)).collect();
            // glTF UVs, origin top-left: bottom-left, bottom-right, top-right, top-left.
            assert_eq!(uv, [Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.0)]);
            // Texture right (u) crossed with texture up (-v) is the outward
            // normal on every face: no face shows its texture mirrored.
            let p = |i: usize| Vec3::from(quad[i].position);
            let right = p(1) - p(0);
            let up = p(3) - p(0);
            assert_eq!(right.cross(up).normalize(), Vec3::from(quad[0].normal), "face {face}");
        }
    }

    #[test]
    fn plane_is_a_square_in_xz_facing_up() {
        let plane = Geometry::plane(3.0);
        assert_eq!(plane.name(), "plane");
        assert_eq!(
            positions(&plane),
            [
                Vec3::new(-1.5, 0.0, 1.5),
                Vec3::new(1.5, 0.0, 1.5),
                Vec3::new(1.5, 0.0, -1.5),
                Vec3::new(-1.5, 0.0, -1.5),
            ]
        );
        // Seen from above with -Z up the screen, the texture reads upright.
        assert_eq!(uvs(&plane), [Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.0)]);
        assert!(plane.vertices().iter().all(|v| v.normal == [0.0, 1.0, 0.0]));
        assert_eq!(plane.indices(), &[0, 1, 2, 0, 2, 3]);
        assert_eq!(plane.submeshes(), &[Submesh { first_index: 0, index_count: 6 }]);
        assert_triangles_face(&plane, Vec3::Y);
    }

    /// Every triangle of `geometry` winds counter-clockwise around `normal`.
    fn assert_triangles_face(geometry: &Geometry, normal: Vec3) {
        let p = positions(geometry);
        for tri in geometry.indices().chunks(3) {
            let n = (p[tri[1] as usize] - p[tri[0] as usize]).cross(p[tri[2] as usize] - p[tri[0] as usize]);
            assert!(n.normalize() == normal, "triangle {tri:?} faces {n}");
        }
    }

    #[test]
    fn quad_is_a_square_in_xy_facing_the_viewer() {
        let quad = Geometry::quad(3.0);
        assert_eq!(quad.name(), "quad");
        assert_eq!(
            positions(&quad),
            [
                Vec3::new(-1.5, -1.5, 0.0),
                Vec3::new(1.5, -1.5, 0.0),
                Vec3::new(1.5, 1.5, 0.0),
                Vec3::new(-1.5, 1.5, 0.0),
            ]
        );
        // glTF UVs (origin top-left): the bottom-left corner samples v = 1.
        assert_eq!(uvs(&quad), [Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.0)]);
        assert!(quad.vertices().iter().all(|v| v.normal == [0.0, 0.0, 1.0]));
        assert_eq!(quad.indices(), &[0, 1, 2, 0, 2, 3]);
        assert_eq!(quad.submeshes(), &[Submesh { first_index: 0, index_count: 6 }]);
        assert_triangles_face(&quad, Vec3::Z);
    }

    #[test]
    fn uv_sphere_vertices_lie_on_the_sphere_at_their_grid_angles() {
        let sphere = Geometry::uv_sphere(2.0, 3, 3);
        assert_eq!(sphere.name(), "uv sphere");
        // (3 + 1) rings of (3 + 1) vertices: the seam column repeats the first.
        assert_eq!(sphere.vertices().len(), 16);
        // f32 sin/cos of angles below 2 pi are within 1e-7 or so; 1e-6 is
        // ten ulps of a unit normal.
        let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 1e-6;
        for (i, v) in sphere.vertices().iter().enumerate() {
            let (ring, segment) = (i / 4, i % 4);
            assert_eq!(Vec2::from(v.uv), Vec2::new(segment as f32 / 3.0, ring as f32 / 3.0), "vertex {i}");
            let n = Vec3::from(v.normal);
            assert!((n.length() - 1.0).abs() < 1e-6, "vertex {i}: {n}");
            assert!(close(Vec3::from(v.position), n * 2.0), "vertex {i}");
            // Latitude from the ring: 60 degrees a ring from the +Y pole.
            assert!((n.y - (ring as f32 * std::f32::consts::FRAC_PI_3).cos()).abs() < 1e-6, "vertex {i}: {n}");
        }
        let n = |i: usize| Vec3::from(sphere.vertices()[i].normal);
        assert!(close(n(0), Vec3::Y) && close(n(15), Vec3::NEG_Y));
        let (s, c) = (3f32.sqrt() / 2.0, 0.5);
        // Ring 1, segment 0: longitude 0 is +X.
        assert!(close(n(4), Vec3::new(s, c, 0.0)), "{}", n(4));
        // Ring 2, segment 1: 120 degrees of longitude, turning from +X to -Z.
        assert!(close(n(9), Vec3::new(-s * 0.5, -c, -s * s)), "{}", n(9));
        // The seam column closes the ring where it began.
        assert!(close(n(7), n(4)));
    }

    #[test]
    fn uv_sphere_indices_split_each_grid_cell_in_two() {
        let sphere = Geometry::uv_sphere(1.0, 3, 3);
        // Rows of 4 vertices; cell (ring, segment) with top-left corner a
        // is (a, a + 4, a + 1) and (a + 1, a + 4, a + 5).
        #[rustfmt::skip]
        let expected = [
            0, 4, 1, 1, 4, 5,    1, 5, 2, 2, 5, 6,      2, 6, 3, 3, 6, 7,
            4, 8, 5, 5, 8, 9,    5, 9, 6, 6, 9, 10,     6, 10, 7, 7, 10, 11,
            8, 12, 9, 9, 12, 13, 9, 13, 10, 10, 13, 14, 10, 14, 11, 11, 14, 15,
        ];
        assert_eq!(sphere.indices(), &expected);
        assert_eq!(sphere.submeshes(), &[Submesh { first_index: 0, index_count: 54 }]);
        // Fewer than three segments or rings are raised to three.
        assert_eq!(Geometry::uv_sphere(1.0, 0, 1).indices(), &expected);
    }

    #[test]
    fn skin_weights_are_normalised_and_bad_weights_count_as_zero() {
        let s = SkinWeights::new([4, 5, 6, 7], [2.0, 2.0, 0.0, 0.0]);
        assert_eq!(s.joints, [4.0, 5.0, 6.0, 7.0]);
        assert_eq!(s.weights, [0.5, 0.5, 0.0, 0.0]);
        let s = SkinWeights::new([0, 1, 2, 3], [-1.0, f32::NAN, f32::INFINITY, 3.0]);
        assert_eq!(s.weights, [0.0, 0.0, 0.0, 1.0]);
        // Nothing usable binds the vertex to its first joint.
        let s = SkinWeights::new([9, 1, 2, 3], [0.0, -2.0, f32::NAN, 0.0]);
        assert_eq!(s.weights, [1.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn influences_are_the_joints_with_positive_weight_in_order() {
        let s = SkinWeights::new([3, 7, 9, 2], [0.5, 0.0, 0.5, 0.0]);
        assert_eq!(s.influences().collect::<Vec<_>>(), [3, 9]);
        let s = SkinWeights::new([3, 7, 9, 2], [0.1, 0.2, 0.3, 0.4]);
        assert_eq!(s.influences().collect::<Vec<_>>(), [3, 7, 9, 2]);
        let s = SkinWeights::new([8, 7, 9, 2], [0.0; 4]);
        assert_eq!(s.influences().collect::<Vec<_>>(), [8]);
    }

    #[test]
    fn skin_records_must_match_the_vertices_and_name_valid_joints() {
        let valid = SkinWeights::new([0, 1, 0, 0], [0.5, 0.5, 0.0, 0.0]);
        let quad = Geometry::quad(2.0);
        let err = quad.clone().with_skin_weights(vec![valid; 3]);
        assert!(matches!(err, Err(GeometryError::SkinWeights { weights: 3, vertices: 4, .. })), "{err:?}");
        let skinned = quad.clone().with_skin_weights(vec![valid; 4]).unwrap();
        assert_eq!(skinned.skin_weights(), Some(&[valid; 4][..]));
        assert_eq!(quad.skin_weights(), None);
        assert!(quad.joint_bounds().is_empty());
        // The fields are public: a record built by hand may name a joint
        // that is negative, not a number, or one past the cap.
        for bad in [-1.0, f32::NAN, MAX_JOINTS as f32] {
            let mut skin = vec![valid; 4];
            skin[2].joints[1] = bad;
            let err = quad.clone().with_skin_weights(skin);
            assert!(matches!(err, Err(GeometryError::SkinWeights { weights: 4, vertices: 4, .. })), "{bad}: {err:?}");
        }
    }

    #[test]
    fn joint_bounds_hold_the_vertices_each_joint_moves() {
        // Quad corners: (-1, -1), (1, -1), (1, 1), (-1, 1).
        let skin = vec![
            SkinWeights::new([2, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]),
            SkinWeights::new([0, 2, 0, 0], [0.5, 0.5, 0.0, 0.0]),
            SkinWeights::new([0, 1, 0, 0], [1.0, 0.0, 0.0, 0.0]), // joint 1 named, unweighted
            SkinWeights::new([2, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]),
        ];
        let skinned = Geometry::quad(2.0).with_skin_weights(skin).unwrap();
        assert_eq!(
            skinned.joint_bounds(),
            &[
                Some(Aabb::new(Vec3::new(1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0))),
                None,
                Some(Aabb::new(Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0))),
            ]
        );
    }

    fn target(positions: Vec<Vec3>, normals: Option<Vec<Vec3>>) -> MorphTarget {
        MorphTarget { positions, normals }
    }

    #[test]
    fn morph_targets_need_one_finite_displacement_per_vertex() {
        let quad = Geometry::quad(2.0);
        let four = vec![Vec3::X; 4];
        let refused = |t: MorphTarget| {
            let err = quad.clone().with_morph_targets(vec![t]);
            assert!(matches!(err, Err(GeometryError::MorphTargets { .. })), "{err:?}");
        };
        refused(target(vec![Vec3::X; 3], None));
        refused(target(vec![Vec3::X; 5], Some(four.clone())));
        refused(target(four.clone(), Some(vec![Vec3::X; 3])));
        refused(target(vec![Vec3::X, Vec3::NAN, Vec3::X, Vec3::X], None));
        refused(target(four.clone(), Some(vec![Vec3::X, Vec3::X, Vec3::INFINITY, Vec3::X])));
        let targets = vec![target(four.clone(), None), target(four.clone(), Some(vec![Vec3::Y; 4]))];
        let morphed = quad.with_morph_targets(targets.clone()).unwrap();
        assert_eq!(morphed.morph_targets(), &targets[..]);
    }

    #[test]
    fn at_most_64_morph_targets() {
        let quad = Geometry::quad(2.0);
        let targets = |count: usize| vec![target(vec![Vec3::X; 4], None); count];
        assert_eq!(quad.clone().with_morph_targets(targets(MAX_MORPH_TARGETS)).unwrap().morph_targets().len(), 64);
        let err = quad.clone().with_morph_targets(targets(MAX_MORPH_TARGETS + 1));
        assert!(matches!(err, Err(GeometryError::MorphTargets { .. })), "{err:?}");
        assert!(quad.with_morph_targets(Vec::new()).unwrap().morph_targets().is_empty());
    }

    /// A quad with two targets whose displacement ranges differ per axis
    /// and include the origin only on some axes.
    fn morphed_quad() -> Geometry {
        let a = [Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 0.0, -1.0), Vec3::ZERO];
        let b = [Vec3::new(-2.0, 0.0, 0.0), Vec3::ZERO, Vec3::new(0.0, 0.0, 3.0), Vec3::new(0.0, -0.5, 0.0)];
        let normals = vec![Vec3::Y, Vec3::NEG_Y, Vec3::X, Vec3::ZERO];
        Geometry::quad(2.0)
            .with_morph_targets(vec![target(a.to_vec(), None), target(b.to_vec(), Some(normals))])
            .unwrap()
    }

    #[test]
    fn morphed_bound_adds_each_weighted_displacement_range() {
        let g = morphed_quad();
        let weights = [0.5, -1.0];
        let bound = g.morphed_bound(g.local_aabb(), &weights);
        // 0.5 a spans (0, 0, -0.5)..(0.25, 1, 0); -b spans (0, 0, -3)..(2, 0.5, 0).
        assert_eq!(bound, Aabb::new(Vec3::new(-1.0, -1.0, -3.5), Vec3::new(3.25, 2.5, 0.0)));
        for (i, v) in g.vertices().iter().enumerate() {
            let moved =
                g.morph_targets().iter().zip(weights).fold(Vec3::from(v.position), |p, (t, w)| p + t.positions[i] * w);
            assert!(moved.cmpge(bound.min).all() && moved.cmple(bound.max).all(), "vertex {i} at {moved}");
        }
        // Missing weights are zero; no weights leave the bound as it is.
        let first_only = g.morphed_bound(g.local_aabb(), &[2.0]);
        assert_eq!(first_only, Aabb::new(Vec3::new(-1.0, -1.0, -2.0), Vec3::new(2.0, 5.0, 0.0)));
        assert_eq!(g.morphed_bound(g.local_aabb(), &[]), g.local_aabb());
    }

    #[test]
    fn morph_records_hold_each_targets_deltas_in_vertex_order() {
        let g = morphed_quad();
        let records = g.morph_records();
        assert_eq!(records.len(), 8);
        let t = g.morph_targets();
        for (i, r) in records.iter().enumerate() {
            let (target, vertex) = (&t[i / 4], i % 4);
            assert_eq!(Vec3::from(r.position), target.positions[vertex], "record {i}");
            let normal = target.normals.as_ref().map_or(Vec3::ZERO, |n| n[vertex]);
            assert_eq!(Vec3::from(r.normal), normal, "record {i}");
            assert_eq!(r.uv, [0.0, 0.0]);
        }
        assert_eq!(records[6].normal, [1.0, 0.0, 0.0]);
        assert!(Geometry::quad(1.0).morph_records().is_empty());
    }

    #[test]
    fn vertex_domain_records_count_vertices_targets_attributes_and_skin() {
        let skin = vec![SkinWeights::new([0; 4], [1.0, 0.0, 0.0, 0.0]); 4];
        assert_eq!(Geometry::quad(1.0).vertex_domain_records(), 4);
        assert_eq!(morphed_quad().vertex_domain_records(), 4 * 3);
        assert_eq!(Geometry::quad(1.0).with_skin_weights(skin.clone()).unwrap().vertex_domain_records(), 4 * 2);
        let everything = morphed_quad()
            .with_attributes(vec![VertexAttributes::default(); 4])
            .unwrap()
            .with_skin_weights(skin)
            .unwrap();
        assert_eq!(everything.vertex_domain_records(), 4 * 5);
        let single = Geometry::quad(1.0).with_morph_targets(vec![target(vec![Vec3::X; 4], None)]).unwrap();
        assert_eq!(single.vertex_domain_records(), 4 * 2);
    }
}
