//! Meshes: every triangle primitive becomes a submesh of one [`Geometry`].
//!
//! Each primitive's accessors are validated ([`super::accessor`]) for the
//! semantic they are used as and their counts compared, and the whole mesh's
//! vertex and index totals are charged to the import's budget; only then are
//! its arrays allocated (once, at their final size) and the accessors read.
//! Index values are checked against the vertex count. Failures name the
//! mesh, the primitive and the accessor.

use std::borrow::Cow;

use glam::{DVec3, Vec2, Vec3, Vec4};
use gltf::json;
use gltf::json::mesh::{Mode, Semantic as JsonSemantic};
use gltf::json::validation::Checked;
use oxygen_core::{Geometry, MorphTarget, SkinWeights, Submesh, Vertex, VertexAttributes};

use super::accessor::{self, Semantic};
use super::limits::Budget;

/// A mesh primitive's failure: which mesh, primitive and accessor.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("mesh {mesh} ('{name}'), primitive {primitive}{}: {what}", accessor.map(|a| format!(", accessor {a}")).unwrap_or_default())]
pub struct MeshError {
    /// The mesh's index.
    pub mesh: usize,
    /// The mesh's name (or "unnamed").
    pub name: String,
    /// The primitive's index within the mesh.
    pub primitive: usize,
    /// The accessor at fault, when one is.
    pub accessor: Option<usize>,
    /// What is wrong.
    pub what: String,
}

/// The outcome of one mesh.
pub(crate) enum MeshResult {
    /// At least one triangle primitive: the geometry and each submesh's
    /// material index (`None` for the default material).
    Geometry(Box<Geometry>, Vec<Option<usize>>),
    /// Nothing drawable (every primitive skipped with a warning).
    Empty,
}

/// Builds mesh `index`. `warnings` collects what was skipped.
pub(crate) fn build(
    root: &json::Root,
    buffers: &[Cow<'_, [u8]>],
    index: usize,
    budget: &mut Budget,
    warnings: &mut Vec<String>,
) -> Result<MeshResult, super::GltfErrorKind> {
    let Some(mesh) = root.meshes.get(index) else {
        return Err(super::GltfErrorKind::Invalid(format!("mesh {index} does not exist")));
    };
    let name = mesh.name.clone().unwrap_or_else(|| "unnamed".to_owned());
    let fail = |primitive: usize, accessor: Option<usize>, what: String| {
        super::GltfErrorKind::Mesh(MeshError { mesh: index, name: name.clone(), primitive, accessor, what })
    };
    // Pass 1: every primitive validated and the whole mesh charged to the
    // budget, before anything is read or allocated for it.
    let mut plans = Vec::new();
    let (mut total_vertices, mut total_indices) = (0usize, 0usize);
    let mut largest_scratch = 0u64;
    for (p, primitive) in mesh.primitives.iter().enumerate() {
        let mode = match primitive.mode {
            Checked::Valid(mode) => mode,
            Checked::Invalid => return Err(fail(p, None, "unknown primitive mode".into())),
        };
        if let Some(material) = primitive.material
            && material.value() >= root.materials.len()
        {
            return Err(fail(p, None, format!("material {} does not exist", material.value())));
        }
        if mode != Mode::Triangles {
            warnings.push(format!("mesh '{name}': skipped a {mode:?} primitive (only triangles)"));
            continue;
        }
        // Every attribute Oxygen knows is validated, read or not, and all of
        // them must agree on the vertex count.
        let mut position = None;
        let mut normal = None;
        let mut texcoord0 = None;
        let mut texcoord1 = None;
        let mut color0 = None;
        let mut joints0 = None;
        let mut weights0 = None;
        let mut count: Option<(usize, usize)> = None;
        for (semantic, accessor_index) in &primitive.attributes {
            let a = accessor_index.value();
            let (use_as, keep) = match semantic {
                Checked::Valid(JsonSemantic::Positions) => (Semantic::Position, Some(&mut position)),
                Checked::Valid(JsonSemantic::Normals) => (Semantic::Normal, Some(&mut normal)),
                Checked::Valid(JsonSemantic::TexCoords(0)) => (Semantic::TexCoord, Some(&mut texcoord0)),
                Checked::Valid(JsonSemantic::TexCoords(1)) => (Semantic::TexCoord, Some(&mut texcoord1)),
                Checked::Valid(JsonSemantic::TexCoords(_)) => (Semantic::TexCoord, None),
                Checked::Valid(JsonSemantic::Tangents) => (Semantic::Tangent, None),
                Checked::Valid(JsonSemantic::Colors(0)) => (Semantic::Color, Some(&mut color0)),
                Checked::Valid(JsonSemantic::Colors(_)) => (Semantic::Color, None),
                Checked::Valid(JsonSemantic::Joints(0)) => (Semantic::Joints, Some(&mut joints0)),
                Checked::Valid(JsonSemantic::Joints(_)) => (Semantic::Joints, None),
                Checked::Valid(JsonSemantic::Weights(0)) => (Semantic::Weights, Some(&mut weights0)),
                Checked::Valid(JsonSemantic::Weights(_)) => (Semantic::Weights, None),
                // Application-specific attributes (`_NAME`) are not read.
                _ => continue,
            };
            let view = accessor::validate(root, buffers, a, use_as).map_err(|e| fail(p, Some(a), e))?;
            match count {
                Some((n, first)) if n != view.count => {
                    return Err(fail(
                        p,
                        Some(a),
                        format!("{use_as:?} has {} elements, accessor {first} has {n}", view.count),
                    ));
                }
                None => count = Some((view.count, a)),
                _ => {}
            }
            if let Some(slot) = keep {
                *slot = Some(view);
            }
        }
        let Some(position) = position else {
            warnings.push(format!("mesh '{name}': skipped a primitive without positions"));
            continue;
        };
        // Morph targets: position and normal displacements, one per vertex.
        let mut targets = Vec::new();
        for target in primitive.targets.iter().flatten() {
            let view = |a: Option<json::Index<json::Accessor>>, use_as| -> Result<_, super::GltfErrorKind> {
                let Some(a) = a else { return Ok(None) };
                let v =
                    accessor::validate(root, buffers, a.value(), use_as).map_err(|e| fail(p, Some(a.value()), e))?;
                if v.count != position.count {
                    let what = format!("a morph target has {} elements for {} vertices", v.count, position.count);
                    return Err(fail(p, Some(a.value()), what));
                }
                Ok(Some(v))
            };
            if target.tangents.is_some() {
                warnings
                    .push(format!("mesh '{name}': morph-target tangent displacements ignored (tangents are derived)"));
            }
            targets.push((view(target.positions, Semantic::Position)?, view(target.normals, Semantic::Normal)?));
        }
        if let Some(first) = plans.first().map(|p: &PrimitivePlan<'_>| p.targets.len())
            && first != targets.len()
        {
            return Err(fail(
                p,
                None,
                format!("{} morph targets where the mesh's first primitive has {first}", targets.len()),
            ));
        }
        if targets.len() > oxygen_core::MAX_MORPH_TARGETS {
            return Err(fail(
                p,
                None,
                format!("{} morph targets (at most {})", targets.len(), oxygen_core::MAX_MORPH_TARGETS),
            ));
        }
        let index_view = match primitive.indices {
            Some(i) => Some(
                accessor::validate(root, buffers, i.value(), Semantic::Indices)
                    .map_err(|e| fail(p, Some(i.value()), e))?,
            ),
            None => None,
        };
        let vertex_count = position.count;
        let index_count = index_view.map_or(vertex_count, |v| v.count);
        if !index_count.is_multiple_of(3) {
            let at = index_view.map_or(position.index, |v| v.index);
            return Err(fail(p, Some(at), format!("{index_count} indices do not make whole triangles")));
        }
        total_vertices = total_vertices
            .checked_add(vertex_count)
            .filter(|t| u32::try_from(*t).is_ok())
            .ok_or_else(|| fail(p, None, "more than 2^32 vertices in one mesh".into()))?;
        total_indices = total_indices
            .checked_add(index_count)
            .filter(|t| u32::try_from(*t).is_ok())
            .ok_or_else(|| fail(p, None, "more than 2^32 indices in one mesh".into()))?;
        // A primitive with a colour or second UV set gives its mesh attribute
        // records (one per vertex, the size of a vertex) for every vertex;
        // one with joints and weights, skin records.
        let extras = color0.is_some() || texcoord1.is_some();
        if joints0.is_some() != weights0.is_some() {
            warnings.push(format!("mesh '{name}': JOINTS_0 without WEIGHTS_0 (or the reverse); not skinned"));
            joints0 = None;
            weights0 = None;
        }
        let skinned = joints0.is_some();
        let vertex_bytes =
            size_of::<Vertex>() as u64 * (1 + u64::from(extras) + u64::from(skinned) + targets.len() as u64);
        budget
            .spend_geometry(vertex_count as u64, index_count as u64, vertex_bytes)
            .map_err(|e| super::GltfErrorKind::Limit { context: format!("mesh {index} ('{name}')"), source: e })?;
        // While a primitive is read, its attributes live in scratch arrays
        // beside the mesh's: positions, normals (and their f64 sums when
        // generated), texture coordinates, its own indices.
        let scratch_per_vertex: u64 = 12
            + 12
            + 8
            + if normal.is_none() { 24 } else { 0 }
            + if extras { 24 } else { 0 }
            + if skinned { 32 } else { 0 };
        let scratch = (vertex_count as u64)
            .saturating_mul(scratch_per_vertex)
            .saturating_add((index_count as u64).saturating_mul(4));
        largest_scratch = largest_scratch.max(scratch);
        plans.push(PrimitivePlan {
            primitive: p,
            position,
            normal,
            texcoord0,
            texcoord1,
            color0,
            joints0,
            weights0,
            targets,
            indices: index_view,
            material: primitive.material.map(|m| m.value()),
        });
    }
    if plans.is_empty() {
        return Ok(MeshResult::Empty);
    }
    budget
        .afford(largest_scratch)
        .map_err(|e| super::GltfErrorKind::Limit { context: format!("mesh {index} ('{name}')"), source: e })?;

    // Pass 2: the mesh's arrays, allocated once at their final size, filled
    // primitive by primitive.
    // Attribute records for the whole mesh when any primitive has colours
    // or a second UV set (the others get white and zero).
    let any_extras = plans.iter().any(|p| p.color0.is_some() || p.texcoord1.is_some());
    let mut attributes: Vec<VertexAttributes> = Vec::with_capacity(if any_extras { total_vertices } else { 0 });
    // Skin records for the whole mesh when any primitive is skinned (the
    // others bound wholly to joint 0).
    let any_skin = plans.iter().any(|p| p.joints0.is_some());
    // Morph targets for the whole mesh (every primitive has as many).
    let target_count = plans.first().map_or(0, |p| p.targets.len());
    let any_morph_normals = plans.iter().any(|p| p.targets.iter().any(|(_, n)| n.is_some()));
    let mut morph: Vec<MorphTarget> = (0..target_count)
        .map(|_| MorphTarget {
            positions: Vec::with_capacity(total_vertices),
            normals: any_morph_normals.then(|| Vec::with_capacity(total_vertices)),
        })
        .collect();
    let mut skin: Vec<SkinWeights> = Vec::with_capacity(if any_skin { total_vertices } else { 0 });
    let mut vertices: Vec<Vertex> = Vec::with_capacity(total_vertices);
    let mut indices: Vec<u32> = Vec::with_capacity(total_indices);
    let mut submeshes = Vec::with_capacity(plans.len());
    let mut materials = Vec::with_capacity(plans.len());
    for plan in plans {
        let p = plan.primitive;
        let vertex_count = plan.position.count;
        // Both fit in u32: their totals were checked in pass 1.
        let base = vertices.len() as u32;
        let first_index = indices.len() as u32;
        let positions: Vec<Vec3> = plan
            .position
            .read_floats::<3>()
            .map_err(|e| fail(p, Some(plan.position.index), e))?
            .into_iter()
            .map(Vec3::from)
            .collect();
        let local_indices: Vec<u32> = match plan.indices {
            Some(view) => {
                let read = view.read_indices().map_err(|e| fail(p, Some(view.index), e))?;
                if let Some(bad) = read.iter().find(|i| **i as usize >= vertex_count) {
                    return Err(fail(p, Some(view.index), format!("index {bad} is past the {vertex_count} vertices")));
                }
                read
            }
            None => (0..vertex_count as u32).collect(),
        };
        let normals: Vec<Vec3> = match plan.normal {
            Some(view) => {
                view.read_floats::<3>().map_err(|e| fail(p, Some(view.index), e))?.into_iter().map(Vec3::from).collect()
            }
            None => {
                warnings.push(format!("mesh '{name}': normals generated"));
                generate_normals(&positions, &local_indices)
            }
        };
        let uvs: Vec<Vec2> = match plan.texcoord0 {
            Some(view) => {
                view.read_floats::<2>().map_err(|e| fail(p, Some(view.index), e))?.into_iter().map(Vec2::from).collect()
            }
            None => vec![Vec2::ZERO; vertex_count],
        };
        vertices.extend(positions.iter().zip(&normals).zip(&uvs).map(|((p, n), uv)| Vertex::new(*p, *n, *uv)));
        if any_extras {
            let colors: Vec<Vec4> = match plan.color0 {
                Some(view) => {
                    let rgb_only = view.components == 3;
                    view.read_floats::<4>()
                        .map_err(|e| fail(p, Some(view.index), e))?
                        .into_iter()
                        .map(|c| if rgb_only { Vec4::new(c[0], c[1], c[2], 1.0) } else { Vec4::from(c) })
                        .collect()
                }
                None => vec![Vec4::ONE; vertex_count],
            };
            let uv1: Vec<Vec2> = match plan.texcoord1 {
                Some(view) => view
                    .read_floats::<2>()
                    .map_err(|e| fail(p, Some(view.index), e))?
                    .into_iter()
                    .map(Vec2::from)
                    .collect(),
                None => vec![Vec2::ZERO; vertex_count],
            };
            attributes.extend(colors.iter().zip(&uv1).map(|(c, uv)| VertexAttributes::new(*c, *uv)));
        }
        for (target, (positions, normals)) in morph.iter_mut().zip(&plan.targets) {
            let read = |v: Option<accessor::AccessorView<'_>>| -> Result<Vec<Vec3>, super::GltfErrorKind> {
                match v {
                    Some(v) => Ok(v
                        .read_floats::<3>()
                        .map_err(|e| fail(p, Some(v.index), e))?
                        .into_iter()
                        .map(Vec3::from)
                        .collect()),
                    None => Ok(vec![Vec3::ZERO; vertex_count]),
                }
            };
            target.positions.extend(read(*positions)?);
            if let Some(out) = &mut target.normals {
                out.extend(read(*normals)?);
            }
        }
        if any_skin {
            match (plan.joints0, plan.weights0) {
                (Some(j), Some(w)) => {
                    let joints = j.read_floats::<4>().map_err(|e| fail(p, Some(j.index), e))?;
                    let weights = w.read_floats::<4>().map_err(|e| fail(p, Some(w.index), e))?;
                    skin.extend(joints.iter().zip(&weights).map(|(j, w)| SkinWeights::new(j.map(|v| v as u32), *w)));
                }
                _ => skin.extend(std::iter::repeat_n(SkinWeights::new([0; 4], [1.0, 0.0, 0.0, 0.0]), vertex_count)),
            }
        }
        submeshes.push(Submesh { first_index, index_count: local_indices.len() as u32 });
        indices.extend(local_indices.iter().map(|i| i + base));
        materials.push(plan.material);
    }
    let invalid = |e| super::GltfErrorKind::Invalid(format!("mesh {index} ('{name}'): {e}"));
    let mut geometry = Geometry::new(name.clone(), vertices, indices, submeshes).map_err(invalid)?;
    if any_extras {
        geometry = geometry.with_attributes(attributes).map_err(invalid)?;
    }
    if any_skin {
        geometry = geometry.with_skin_weights(skin).map_err(invalid)?;
    }
    if target_count > 0 {
        geometry = geometry.with_morph_targets(morph).map_err(invalid)?;
    }
    Ok(MeshResult::Geometry(Box::new(geometry), materials))
}

/// One triangle primitive, validated and charged, waiting to be read.
struct PrimitivePlan<'a> {
    primitive: usize,
    position: accessor::AccessorView<'a>,
    normal: Option<accessor::AccessorView<'a>>,
    texcoord0: Option<accessor::AccessorView<'a>>,
    texcoord1: Option<accessor::AccessorView<'a>>,
    color0: Option<accessor::AccessorView<'a>>,
    joints0: Option<accessor::AccessorView<'a>>,
    weights0: Option<accessor::AccessorView<'a>>,
    /// Per morph target, its position and normal displacements.
    targets: Vec<(Option<accessor::AccessorView<'a>>, Option<accessor::AccessorView<'a>>)>,
    indices: Option<accessor::AccessorView<'a>>,
    material: Option<usize>,
}

/// Area-weighted smooth normals (unit length; +Z where undefined).
fn generate_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut normals = vec![DVec3::ZERO; positions.len()];
    for tri in indices.chunks_exact(3) {
        let [a, b, c] = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
        let n = (positions[b] - positions[a]).as_dvec3().cross((positions[c] - positions[a]).as_dvec3());
        for i in [a, b, c] {
            normals[i] += n;
        }
    }
    normals.into_iter().map(|n| n.as_vec3().try_normalize().unwrap_or(Vec3::Z)).collect()
}

#[cfg(test)]
mod tests {
    use super::super::ImportLimits;
    use super::*;

    /// The one triangle every test imports: accessor 0, `POSITION`.
    const POSITIONS: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    /// Accessor 1, a second UV set: no value is 0, so a set not read
    /// (zeros) never passes for it.
    const UV1: [[f32; 2]; 3] = [[0.25, 0.5], [0.75, 1.0], [0.125, 0.375]];
    /// Accessor 2, RGBA vertex colours: none white, so a colour not read
    /// (white) never passes for one.
    const COLORS: [[f32; 4]; 3] = [[1.0, 0.0, 0.0, 1.0], [0.0, 0.5, 0.0, 0.75], [0.0, 0.0, 0.25, 0.5]];
    /// Where the buffer's spare bytes begin (zeros, room for three VEC4
    /// floats) and where it ends.
    const SPARE: usize = 108;
    const END: usize = SPARE + 48;

    /// The buffer: positions, second UV set, colours, spare zeros.
    fn buffer() -> Vec<u8> {
        let floats = POSITIONS.iter().flatten().chain(UV1.iter().flatten()).chain(COLORS.iter().flatten());
        let mut bytes: Vec<u8> = floats.flat_map(|f| f.to_le_bytes()).collect();
        assert_eq!(bytes.len(), SPARE);
        bytes.resize(END, 0);
        bytes
    }

    /// A file with one mesh, "tri", of one triangle primitive whose
    /// attributes are `POSITION` (accessor 0) and `attributes` (more JSON
    /// members, each `,"NAME":accessor`). Accessors 1 and 2 are [`UV1`] and
    /// [`COLORS`]; `extra`, when not empty, is accessor 3.
    fn document(attributes: &str, extra: &str) -> json::Root {
        let extra = if extra.is_empty() { String::new() } else { format!(",{extra}") };
        json::deserialize::from_str(&format!(
            r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{END}}}],"bufferViews":[{{"buffer":0,"byteLength":{END}}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}},
            {{"bufferView":0,"byteOffset":36,"componentType":5126,"count":3,"type":"VEC2"}},
            {{"bufferView":0,"byteOffset":60,"componentType":5126,"count":3,"type":"VEC4"}}{extra}],
            "meshes":[{{"name":"tri","primitives":[{{"attributes":{{"POSITION":0{attributes}}}}}]}}]}}"#
        ))
        .expect("the test document deserializes")
    }

    /// Accessor JSON over the buffer's one view.
    fn accessor(byte_offset: usize, component_type: u32, count: usize, ty: &str) -> String {
        format!(
            r#"{{"bufferView":0,"byteOffset":{byte_offset},"componentType":{component_type},"count":{count},"type":"{ty}"}}"#
        )
    }

    fn build_mesh(root: &json::Root) -> Result<MeshResult, super::super::GltfErrorKind> {
        let buffers = [Cow::Owned(buffer())];
        build(root, &buffers, 0, &mut Budget::new(ImportLimits::default()), &mut Vec::new())
    }

    /// The mesh's geometry; any failure panics with the error.
    fn geometry(root: &json::Root) -> Geometry {
        match build_mesh(root) {
            Ok(MeshResult::Geometry(geometry, _)) => *geometry,
            Ok(MeshResult::Empty) => panic!("the mesh imported empty"),
            Err(e) => panic!("the mesh failed: {e:?}"),
        }
    }

    /// The mesh's error; an import that succeeds panics naming `case`.
    fn mesh_error(root: &json::Root, case: &str) -> MeshError {
        match build_mesh(root) {
            Err(super::super::GltfErrorKind::Mesh(e)) => e,
            Err(other) => panic!("{case}: not a mesh error: {other:?}"),
            Ok(_) => panic!("{case}: the mesh imported"),
        }
    }

    /// Attributes Oxygen knows but does not read: the name, the accessor
    /// type and component type glTF allows for it, and what the importer
    /// validates it as.
    const UNREAD: [(&str, &str, u32, Semantic); 5] = [
        ("TEXCOORD_2", "VEC2", 5126, Semantic::TexCoord),
        ("TANGENT", "VEC4", 5126, Semantic::Tangent),
        ("COLOR_1", "VEC4", 5126, Semantic::Color),
        ("JOINTS_1", "VEC4", 5123, Semantic::Joints),
        ("WEIGHTS_1", "VEC4", 5126, Semantic::Weights),
    ];

    /// `TEXCOORD_1` becomes every vertex's `uv1` (a texture may name set
    /// 1), with the colour left white; were it only validated, the mesh
    /// would have no attribute records at all.
    #[test]
    fn texcoord_1_is_imported_as_each_vertexs_second_uv_set() {
        let geometry = geometry(&document(r#","TEXCOORD_1":1"#, ""));
        let attributes = geometry.attributes().expect("TEXCOORD_1 gives the mesh attribute records");
        let uv1: Vec<[f32; 2]> = attributes.iter().map(|a| a.uv1).collect();
        assert_eq!(uv1, UV1);
        assert!(attributes.iter().all(|a| a.color == [1.0; 4]), "no COLOR_0: white");
    }

    /// `COLOR_0` becomes every vertex's colour (multiplied into the base
    /// colour), with the second UV set left zero; were it only validated,
    /// the mesh would have no attribute records at all.
    #[test]
    fn color_0_is_imported_as_each_vertexs_colour() {
        let geometry = geometry(&document(r#","COLOR_0":2"#, ""));
        let attributes = geometry.attributes().expect("COLOR_0 gives the mesh attribute records");
        let colors: Vec<[f32; 4]> = attributes.iter().map(|a| a.color).collect();
        assert_eq!(colors, COLORS);
        assert!(attributes.iter().all(|a| a.uv1 == [0.0; 2]), "no TEXCOORD_1: zero");
    }

    /// An attribute Oxygen knows but does not read (a third UV set,
    /// tangents, a second colour, joint or weight set) must still have one
    /// element per vertex: a file whose attributes disagree is malformed,
    /// and fails naming the accessor, rather than being half-imported.
    /// With the right count it imports, and is not read.
    #[test]
    fn an_unread_known_attribute_must_have_as_many_elements_as_positions() {
        for (name, ty, component_type, use_as) in UNREAD {
            let file = |count| document(&format!(r#","{name}":3"#), &accessor(SPARE, component_type, count, ty));
            let geometry = geometry(&file(3));
            assert_eq!(geometry.vertices().len(), 3, "{name}");
            assert!(geometry.attributes().is_none(), "{name} is not read into attribute records");
            assert!(geometry.skin_weights().is_none(), "{name} is not read into skin weights");
            let expected = MeshError {
                mesh: 0,
                name: "tri".into(),
                primitive: 0,
                accessor: Some(3),
                what: format!("{use_as:?} has 2 elements, accessor 0 has 3"),
            };
            assert_eq!(mesh_error(&file(2), &format!("{name} of 2 elements")), expected, "{name}");
        }
    }

    /// An attribute Oxygen knows but does not read is validated as fully as
    /// one it reads: elements past its buffer view, or a type glTF does not
    /// allow for it, fail the import naming the accessor.
    #[test]
    fn an_invalid_unread_known_attribute_fails_the_import() {
        for (name, ty, component_type, _) in UNREAD {
            let file = |extra: String| document(&format!(r#","{name}":3"#), &extra);
            let past = mesh_error(&file(accessor(END, component_type, 3, ty)), &format!("{name} past its view"));
            assert_eq!((past.primitive, past.accessor), (0, Some(3)), "{name}: {past}");
            assert!(past.what.contains("do not fit its buffer view"), "{name}: {past}");
            let scalar = mesh_error(&file(accessor(SPARE, component_type, 3, "SCALAR")), &format!("a SCALAR {name}"));
            assert_eq!((scalar.primitive, scalar.accessor), (0, Some(3)), "{name}: {scalar}");
            assert!(scalar.what.contains("is not allowed for"), "{name}: {scalar}");
        }
    }

    /// An application-specific attribute (`_NAME`) is the application's
    /// business: it is skipped without validation, so even one whose count
    /// disagrees and whose bytes lie past its view does not stop the mesh.
    #[test]
    fn an_application_specific_attribute_is_skipped_unvalidated() {
        let geometry = geometry(&document(r#","_TEMPERATURE":3"#, &accessor(END, 5126, 2, "SCALAR")));
        assert_eq!(geometry.vertices().len(), 3);
        assert!(geometry.attributes().is_none());
    }

    /// A file of one mesh, "two", whose two triangle primitives (both
    /// accessor 0's positions) carry `first` and `second` morph targets
    /// (each accessor 0 as its position displacements).
    fn two_primitives(first: usize, second: usize) -> json::Root {
        let targets = |n: usize| vec![r#"{"POSITION":0}"#; n].join(",");
        json::deserialize::from_str(&format!(
            r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{END}}}],"bufferViews":[{{"buffer":0,"byteLength":{END}}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}}],
            "meshes":[{{"name":"two","primitives":[{{"attributes":{{"POSITION":0}},"targets":[{}]}},
            {{"attributes":{{"POSITION":0}},"targets":[{}]}}]}}]}}"#,
            targets(first),
            targets(second)
        ))
        .expect("the test document deserializes")
    }

    /// The primitives of one mesh share its morph weights, so they must
    /// have as many targets each: the same count imports (both primitives'
    /// vertices), a different one fails naming the primitive that differs.
    #[test]
    fn a_meshs_primitives_must_have_as_many_morph_targets_each() {
        let geometry = geometry(&two_primitives(1, 1));
        assert_eq!(geometry.vertices().len(), 6);
        assert_eq!(geometry.morph_targets().len(), 1);
        let expected = MeshError {
            mesh: 0,
            name: "two".into(),
            primitive: 1,
            accessor: None,
            what: "0 morph targets where the mesh's first primitive has 1".into(),
        };
        assert_eq!(mesh_error(&two_primitives(1, 0), "one target, then none"), expected);
    }

    /// `MAX_MORPH_TARGETS` targets import; one more fails, saying so.
    #[test]
    fn at_most_max_morph_targets_are_imported() {
        let most = oxygen_core::MAX_MORPH_TARGETS;
        let targets = |n: usize| vec![r#"{"POSITION":0}"#; n].join(",");
        let file = |n: usize| {
            let mut root = document("", "");
            let json = format!(r#"{{"attributes":{{"POSITION":0}},"targets":[{}]}}"#, targets(n));
            root.meshes[0].primitives[0] = json::deserialize::from_str(&json).expect("the primitive deserializes");
            root
        };
        assert_eq!(geometry(&file(most)).morph_targets().len(), most);
        let error = mesh_error(&file(most + 1), "one target too many");
        assert_eq!(error.what, format!("{} morph targets (at most {most})", most + 1));
    }

    /// The bytes an import charges to its budget for a mesh's vertices and
    /// indices: one vertex record per vertex, one more with colours or a
    /// second UV set, one more when skinned, one per morph target, and 4
    /// bytes an index (three here: the triangle's implicit ones).
    fn charged_bytes(root: &json::Root) -> u64 {
        let buffers = [Cow::Owned(buffer())];
        let mut budget = Budget::new(ImportLimits::default());
        match build(root, &buffers, 0, &mut budget, &mut Vec::new()) {
            Ok(MeshResult::Geometry(..)) => budget.total_bytes(),
            Ok(MeshResult::Empty) => panic!("the mesh imported empty"),
            Err(e) => panic!("the mesh failed: {e:?}"),
        }
    }

    /// What each kind of record costs the budget, exactly: colours alone
    /// (without a second UV set) make attribute records; a skin (joints
    /// and weights) and two morph targets add theirs.
    #[test]
    fn the_budget_is_charged_a_vertex_record_per_vertex_for_each_kind_of_record() {
        let record = size_of::<Vertex>() as u64;
        let (vertices, indices) = (3u64, 3u64);
        assert_eq!(charged_bytes(&document("", "")), vertices * record + 4 * indices, "positions alone");
        assert_eq!(
            charged_bytes(&document(r#","COLOR_0":2"#, "")),
            vertices * record * 2 + 4 * indices,
            "colours without a second UV set"
        );
        // JOINTS_0 (accessor 3: unsigned shorts over the spare zeros, all
        // joint 0) and WEIGHTS_0 (accessor 4: the colours' floats, each
        // vertex's summing above 0), two targets.
        let mut root = document(
            r#","COLOR_0":2,"JOINTS_0":3,"WEIGHTS_0":4"#,
            &format!("{},{}", accessor(SPARE, 5123, 3, "VEC4"), accessor(60, 5126, 3, "VEC4")),
        );
        root.meshes[0].primitives[0].targets =
            Some(json::deserialize::from_str(r#"[{"POSITION":0},{"POSITION":0}]"#).expect("targets deserialize"));
        assert_eq!(
            charged_bytes(&root),
            vertices * record * (1 + 1 + 1 + 2) + 4 * indices,
            "colours, skin, two targets"
        );
    }

    /// While a primitive is read its attributes live in scratch arrays
    /// beside the mesh's, and the import must afford them on top of what it
    /// has charged: here positions 12, normals 12 and texture coordinates
    /// 8 bytes a vertex, 24 more for generated normals (no `NORMAL`), 24
    /// for colours, 32 for a skin, and 4 an index. A budget that holds
    /// exactly the charge and that scratch imports the mesh; one byte less
    /// refuses it.
    #[test]
    fn a_primitives_scratch_arrays_must_fit_the_budget_beside_its_charge() {
        let mut root = document(
            r#","COLOR_0":2,"JOINTS_0":3,"WEIGHTS_0":4"#,
            &format!("{},{}", accessor(SPARE, 5123, 3, "VEC4"), accessor(60, 5126, 3, "VEC4")),
        );
        root.meshes[0].primitives[0].targets = None;
        let charged = charged_bytes(&root);
        let scratch = 3 * (12 + 12 + 8 + 24 + 24 + 32) + 3 * 4;
        let import = |max_total_bytes: u64| {
            let buffers = [Cow::Owned(buffer())];
            let mut budget = Budget::new(ImportLimits { max_total_bytes, ..ImportLimits::default() });
            build(&root, &buffers, 0, &mut budget, &mut Vec::new())
        };
        assert!(matches!(import(charged + scratch), Ok(MeshResult::Geometry(..))), "charge and scratch fit exactly");
        match import(charged + scratch - 1) {
            Err(super::super::GltfErrorKind::Limit { .. }) => {}
            Err(other) => panic!("a byte short of the scratch: not a limit: {other:?}"),
            Ok(_) => panic!("a byte short of the scratch: the mesh imported"),
        }
    }

    /// `COLOR_0` may be RGB (VEC3) or RGBA (VEC4): an RGB colour has no
    /// alpha, so its vertices must be opaque (alpha 1), not transparent (the
    /// missing fourth component reads as 0); an RGBA colour keeps its own
    /// alpha.
    #[test]
    fn an_rgb_color_0_gets_alpha_1_and_an_rgba_one_keeps_its_alpha() {
        // Accessor 3: the colours' floats read three at a time.
        let rgb = geometry(&document(r#","COLOR_0":3"#, &accessor(60, 5126, 3, "VEC3")));
        let attributes = rgb.attributes().expect("COLOR_0 gives the mesh attribute records");
        let colors: Vec<[f32; 4]> = attributes.iter().map(|a| a.color).collect();
        assert_eq!(colors, [[1.0, 0.0, 0.0, 1.0], [1.0, 0.0, 0.5, 1.0], [0.0, 0.75, 0.0, 1.0]], "RGB: opaque");
        let rgba = geometry(&document(r#","COLOR_0":2"#, ""));
        let alphas: Vec<f32> = rgba.attributes().expect("RGBA colours").iter().map(|a| a.color[3]).collect();
        assert_eq!(alphas, [1.0, 0.75, 0.5], "RGBA: its own alpha");
    }

    /// A mesh's primitives share one vertex and one index array: each
    /// primitive's indices are its own vertices' positions, so they must be
    /// offset by the vertices of the primitives before it, or the second
    /// primitive would draw the first one's triangle.
    #[test]
    fn a_later_primitives_indices_are_offset_past_the_earlier_primitives_vertices() {
        let geometry = geometry(&two_primitives(0, 0));
        assert_eq!(geometry.vertices().len(), 6);
        assert_eq!(geometry.indices(), [0, 1, 2, 3, 4, 5]);
        assert_eq!(
            geometry.submeshes(),
            [Submesh { first_index: 0, index_count: 3 }, Submesh { first_index: 3, index_count: 3 }]
        );
    }

    /// Morph targets are only attached when the mesh has some: a geometry
    /// with morph targets counts its vertices in a float (below 2^24), but a
    /// mesh without any must import at any size the budget allows. Here
    /// 2^24 + 2 vertices (all at the origin: accessors without a buffer
    /// view are zeros) and no targets import.
    #[test]
    fn a_mesh_too_large_to_morph_imports_when_it_has_no_morph_targets() {
        let count = (1usize << 24) + 2;
        assert!(count.is_multiple_of(3));
        let root: json::Root = json::deserialize::from_str(&format!(
            r#"{{"asset":{{"version":"2.0"}},
            "accessors":[{{"componentType":5126,"count":{count},"type":"VEC3"}}],
            "meshes":[{{"name":"big","primitives":[{{"attributes":{{"POSITION":0,"NORMAL":0}}}}]}}]}}"#
        ))
        .expect("the test document deserializes");
        let mut budget = Budget::new(ImportLimits::unlimited());
        match build(&root, &[], 0, &mut budget, &mut Vec::new()) {
            Ok(MeshResult::Geometry(geometry, _)) => {
                assert_eq!(geometry.vertices().len(), count);
                assert!(geometry.morph_targets().is_empty());
            }
            Ok(MeshResult::Empty) => panic!("the mesh imported empty"),
            Err(e) => panic!("the mesh failed: {e:?}"),
        }
    }

    /// A primitive without `NORMAL` gets smooth normals: each vertex's is
    /// the sum of its triangles' normals weighted by their areas, so a
    /// vertex shared by a large horizontal triangle and a small vertical one
    /// leans towards the large one's normal. The triangles lie off the
    /// origin and outside the XY plane, so that edges taken from the wrong
    /// corner, or corners added or divided instead of subtracted, give other
    /// normals.
    #[test]
    fn generated_normals_are_area_weighted_sums_of_the_triangles_normals() {
        // Triangle 0, 1, 2 in the plane y = 2 (area 3, facing +Y); triangle
        // 0, 3, 4 in the plane x = 1 (area 1/2, facing +X).
        let positions: [[f32; 3]; 5] =
            [[1.0, 2.0, 1.0], [1.0, 2.0, 4.0], [3.0, 2.0, 1.0], [1.0, 3.0, 1.0], [1.0, 2.0, 2.0]];
        let indices: [u32; 6] = [0, 1, 2, 0, 3, 4];
        let mut bytes: Vec<u8> = positions.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
        bytes.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
        let root: json::Root = json::deserialize::from_str(&format!(
            r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{len}}}],"bufferViews":[{{"buffer":0,"byteLength":{len}}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":5,"type":"VEC3"}},
            {{"bufferView":0,"byteOffset":60,"componentType":5125,"count":6,"type":"SCALAR"}}],
            "meshes":[{{"name":"bent","primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}]}}"#,
            len = bytes.len()
        ))
        .expect("the test document deserializes");
        let buffers = [Cow::Owned(bytes)];
        let mut warnings = Vec::new();
        let geometry = match build(&root, &buffers, 0, &mut Budget::new(ImportLimits::default()), &mut warnings) {
            Ok(MeshResult::Geometry(geometry, _)) => geometry,
            Ok(MeshResult::Empty) => panic!("the mesh imported empty"),
            Err(e) => panic!("the mesh failed: {e:?}"),
        };
        assert_eq!(warnings, ["mesh 'bent': normals generated"]);
        // The shared vertex: 2 × area 3 of +Y plus 2 × area 1/2 of +X.
        let expected = [Vec3::new(1.0, 6.0, 0.0).normalize(), Vec3::Y, Vec3::Y, Vec3::X, Vec3::X];
        for (i, (vertex, expected)) in geometry.vertices().iter().zip(expected).enumerate() {
            let normal = Vec3::from(vertex.normal);
            assert!((normal - expected).length() < 1e-6, "vertex {i}: normal {normal}, expected {expected}");
        }
    }
}
