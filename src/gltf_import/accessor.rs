//! Accessors, validated before any byte is read.
//!
//! [`validate`] checks one accessor against the glTF 2.0 tables for the
//! semantic it is used as (component type, element type, `normalized`), and
//! checks that every byte it will read lies inside its buffer view and
//! buffer, sparse substitution included. What it returns, an
//! [`AccessorView`], can then be read without any further failure except
//! for values the file holds (non-finite floats, sparse indices out of
//! order), which are errors too. Nothing here indexes past a slice or
//! panics: every offset is computed with checked arithmetic.

use std::borrow::Cow;

use gltf::json;
use gltf::json::accessor::{ComponentType, Type};
use gltf::json::validation::Checked;

/// What an accessor is used as; each use allows different types.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Semantic {
    Position,
    Normal,
    Tangent,
    TexCoord,
    Color,
    Joints,
    Weights,
    Indices,
    /// Keyframe times.
    AnimationInput,
    /// Keyframe translations and scales.
    AnimationVector,
    /// Keyframe rotations.
    AnimationRotation,
    /// A skin's inverse bind matrices.
    InverseBindMatrices,
    /// Keyframe morph-target weights.
    AnimationWeights,
}

impl Semantic {
    /// The glTF 2.0 table (3.7.2.1 and 3.7.2.2): element types and
    /// component types allowed, and whether integer components must be
    /// normalized; with `quantized` (the file uses `KHR_mesh_quantization`)
    /// also that extension's 8- and 16-bit positions, normals, tangents and
    /// texture coordinates.
    fn allows(self, ty: Type, component: ComponentType, normalized: bool, quantized: bool) -> bool {
        use ComponentType::{F32, I8, I16, U8, U16, U32};
        let float = component == F32 && !normalized;
        let unorm = matches!(component, U8 | U16) && normalized;
        let small = matches!(component, I8 | U8 | I16 | U16);
        let snorm = matches!(component, I8 | I16) && normalized;
        match self {
            Semantic::Position => ty == Type::Vec3 && (float || (quantized && small)),
            Semantic::Normal => ty == Type::Vec3 && (float || (quantized && snorm)),
            Semantic::Tangent => ty == Type::Vec4 && (float || (quantized && snorm)),
            Semantic::TexCoord => ty == Type::Vec2 && (float || unorm || (quantized && small)),
            Semantic::Color => matches!(ty, Type::Vec3 | Type::Vec4) && (float || unorm),
            Semantic::Joints => ty == Type::Vec4 && matches!(component, U8 | U16) && !normalized,
            Semantic::Weights => ty == Type::Vec4 && (float || unorm),
            Semantic::Indices => ty == Type::Scalar && matches!(component, U8 | U16 | U32) && !normalized,
            // glTF 2.0 3.11: times are floats; translations and scales
            // float VEC3; rotations float or normalized-integer VEC4.
            Semantic::AnimationInput => ty == Type::Scalar && float,
            Semantic::AnimationVector => ty == Type::Vec3 && float,
            Semantic::AnimationRotation => ty == Type::Vec4 && (float || unorm || snorm),
            Semantic::InverseBindMatrices => ty == Type::Mat4 && float,
            Semantic::AnimationWeights => ty == Type::Scalar && (float || unorm || snorm),
        }
    }
}

fn component_size(c: ComponentType) -> u64 {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

fn type_components(t: Type) -> u64 {
    match t {
        Type::Scalar => 1,
        Type::Vec2 => 2,
        Type::Vec3 => 3,
        Type::Vec4 | Type::Mat2 => 4,
        Type::Mat3 => 9,
        Type::Mat4 => 16,
    }
}

/// Bytes one element occupies; matrix columns start on 4-byte boundaries.
fn element_size(t: Type, c: ComponentType) -> u64 {
    let size = component_size(c);
    let (columns, rows) = match t {
        Type::Mat2 => (2, 2),
        Type::Mat3 => (3, 3),
        Type::Mat4 => (4, 4),
        _ => return type_components(t) * size,
    };
    columns * (rows * size).next_multiple_of(4)
}

/// A strided run of elements inside one buffer.
#[derive(Clone, Copy, Debug)]
struct Strided<'a> {
    bytes: &'a [u8],
    stride: usize,
}

/// Sparse substitution: `values[i]` replaces element `indices[i]`.
#[derive(Clone, Copy, Debug)]
struct Sparse<'a> {
    count: usize,
    indices: &'a [u8],
    index_component: ComponentType,
    values: &'a [u8],
}

/// An accessor whose every byte range has been checked.
#[derive(Clone, Copy, Debug)]
pub(crate) struct AccessorView<'a> {
    /// The accessor's index, for messages.
    pub(crate) index: usize,
    /// Elements.
    pub(crate) count: usize,
    /// Components per element (1 to 4 for the semantics read here).
    pub(crate) components: usize,
    component: ComponentType,
    normalized: bool,
    element_size: usize,
    /// `None`: no buffer view, every element is zero before sparse values.
    base: Option<Strided<'a>>,
    sparse: Option<Sparse<'a>>,
}

/// The byte slice `[offset, offset + length)` of `view`, checked against the
/// view and its buffer.
fn view_bytes<'a>(
    root: &json::Root,
    buffers: &'a [Cow<'_, [u8]>],
    view: json::Index<json::buffer::View>,
) -> Result<(&'a [u8], Option<usize>), String> {
    let vi = view.value();
    let v = root.buffer_views.get(vi).ok_or_else(|| format!("buffer view {vi} does not exist"))?;
    let bi = v.buffer.value();
    let buffer = buffers.get(bi).ok_or_else(|| format!("buffer view {vi}: buffer {bi} does not exist"))?;
    let start = v.byte_offset.map_or(0, |o| o.0);
    let end = start.checked_add(v.byte_length.0).filter(|end| *end <= buffer.len() as u64).ok_or_else(|| {
        format!(
            "buffer view {vi}: bytes {start}..+{} lie outside buffer {bi} ({} bytes)",
            v.byte_length.0,
            buffer.len()
        )
    })?;
    let stride = v.byte_stride.map(|s| s.0);
    Ok((&buffer[start as usize..end as usize], stride))
}

/// Validates accessor `index` for use as `semantic`.
pub(crate) fn validate<'a>(
    root: &json::Root,
    buffers: &'a [Cow<'_, [u8]>],
    index: usize,
    semantic: Semantic,
) -> Result<AccessorView<'a>, String> {
    let a = root.accessors.get(index).ok_or_else(|| format!("accessor {index} does not exist"))?;
    let Checked::Valid(json::accessor::GenericComponentType(component)) = a.component_type else {
        return Err(format!("accessor {index}: unknown componentType"));
    };
    let Checked::Valid(ty) = a.type_ else {
        return Err(format!("accessor {index}: unknown type"));
    };
    let quantized = root.extensions_used.iter().chain(&root.extensions_required).any(|e| e == "KHR_mesh_quantization");
    if !semantic.allows(ty, component, a.normalized, quantized) {
        return Err(format!(
            "accessor {index}: {ty:?} of {component:?}{} is not allowed for {semantic:?}",
            if a.normalized { " (normalized)" } else { "" }
        ));
    }
    let count = a.count.0;
    if count == 0 {
        return Err(format!("accessor {index}: count is 0"));
    }
    let element = element_size(ty, component);
    let base = match a.buffer_view {
        Some(view) => {
            let (bytes, stride) = view_bytes(root, buffers, view).map_err(|e| format!("accessor {index}: {e}"))?;
            let stride = stride.map_or(element, |s| s as u64);
            if stride < element {
                return Err(format!(
                    "accessor {index}: byteStride {stride} is smaller than an element ({element} bytes)"
                ));
            }
            let offset = a.byte_offset.map_or(0, |o| o.0);
            let end = (count - 1)
                .checked_mul(stride)
                .and_then(|last| last.checked_add(offset))
                .and_then(|last| last.checked_add(element))
                .filter(|end| *end <= bytes.len() as u64);
            let Some(end) = end else {
                return Err(format!(
                    "accessor {index}: {count} elements of {element} bytes (stride {stride}) from offset {offset} do \
                         not fit its buffer view ({} bytes)",
                    bytes.len()
                ));
            };
            Some(Strided { bytes: &bytes[offset as usize..end as usize], stride: stride as usize })
        }
        None => None,
    };
    let sparse = match &a.sparse {
        None => None,
        Some(s) => {
            let sparse_count = s.count.0;
            if sparse_count == 0 || sparse_count > count {
                return Err(format!("accessor {index}: sparse count {sparse_count} is not in 1..={count}"));
            }
            let Checked::Valid(json::accessor::IndexComponentType(index_component)) = s.indices.component_type else {
                return Err(format!("accessor {index}: unknown sparse index componentType"));
            };
            if !matches!(index_component, ComponentType::U8 | ComponentType::U16 | ComponentType::U32) {
                return Err(format!("accessor {index}: sparse indices of {index_component:?}"));
            }
            let slice = |view, offset: u64, size: u64, what: &str| -> Result<&'a [u8], String> {
                let (bytes, _) =
                    view_bytes(root, buffers, view).map_err(|e| format!("accessor {index}: sparse {what}: {e}"))?;
                let end = sparse_count.checked_mul(size).and_then(|n| n.checked_add(offset));
                match end {
                    Some(end) if end <= bytes.len() as u64 => Ok(&bytes[offset as usize..end as usize]),
                    _ => Err(format!("accessor {index}: sparse {what} do not fit their buffer view")),
                }
            };
            let indices =
                slice(s.indices.buffer_view, s.indices.byte_offset.0, component_size(index_component), "indices")?;
            let values = slice(s.values.buffer_view, s.values.byte_offset.0, element, "values")?;
            Some(Sparse { count: sparse_count as usize, indices, index_component, values })
        }
    };
    Ok(AccessorView {
        index,
        count: count as usize,
        components: type_components(ty) as usize,
        component,
        normalized: a.normalized,
        element_size: element as usize,
        base,
        sparse,
    })
}

fn read_component(bytes: &[u8], component: ComponentType, normalized: bool) -> f32 {
    let le2 = |b: &[u8]| [b[0], b[1]];
    let le4 = |b: &[u8]| [b[0], b[1], b[2], b[3]];
    match (component, normalized) {
        (ComponentType::F32, _) => f32::from_le_bytes(le4(bytes)),
        (ComponentType::U8, true) => f32::from(bytes[0]) / 255.0,
        (ComponentType::U8, false) => f32::from(bytes[0]),
        (ComponentType::I8, true) => (f32::from(bytes[0] as i8) / 127.0).max(-1.0),
        (ComponentType::I8, false) => f32::from(bytes[0] as i8),
        (ComponentType::U16, true) => f32::from(u16::from_le_bytes(le2(bytes))) / 65535.0,
        (ComponentType::U16, false) => f32::from(u16::from_le_bytes(le2(bytes))),
        (ComponentType::I16, true) => (f32::from(i16::from_le_bytes(le2(bytes))) / 32767.0).max(-1.0),
        (ComponentType::I16, false) => f32::from(i16::from_le_bytes(le2(bytes))),
        (ComponentType::U32, _) => u32::from_le_bytes(le4(bytes)) as f32,
    }
}

fn read_uint(bytes: &[u8], component: ComponentType) -> u32 {
    match component {
        ComponentType::U8 => u32::from(bytes[0]),
        ComponentType::U16 => u32::from(u16::from_le_bytes([bytes[0], bytes[1]])),
        _ => u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
    }
}

impl AccessorView<'_> {
    /// The bytes of element `i` of the base data (`i < count`, checked by
    /// [`validate`]); `None` where the accessor has no buffer view.
    fn base_element(&self, i: usize) -> Option<&[u8]> {
        self.base.map(|b| &b.bytes[i * b.stride..i * b.stride + self.element_size])
    }

    /// Applies sparse substitution: calls `write(element, bytes)` per entry.
    fn for_each_sparse(&self, mut write: impl FnMut(usize, &[u8])) -> Result<(), String> {
        let Some(s) = self.sparse else { return Ok(()) };
        let isize = component_size(s.index_component) as usize;
        let mut previous: Option<u32> = None;
        for i in 0..s.count {
            let target = read_uint(&s.indices[i * isize..(i + 1) * isize], s.index_component);
            if target as usize >= self.count || previous.is_some_and(|p| target <= p) {
                return Err(format!(
                    "accessor {}: sparse index {target} is out of range or not increasing",
                    self.index
                ));
            }
            previous = Some(target);
            write(target as usize, &s.values[i * self.element_size..(i + 1) * self.element_size]);
        }
        Ok(())
    }

    fn decode_element<const N: usize>(&self, bytes: &[u8]) -> [f32; N] {
        let size = component_size(self.component) as usize;
        let mut out = [0.0; N];
        for (c, slot) in out.iter_mut().enumerate().take(self.components.min(N)) {
            *slot = read_component(&bytes[c * size..(c + 1) * size], self.component, self.normalized);
        }
        out
    }

    /// Reads every element as `N` floats (missing components are 0); a
    /// non-finite value is an error naming the accessor and element.
    pub(crate) fn read_floats<const N: usize>(&self) -> Result<Vec<[f32; N]>, String> {
        let mut out: Vec<[f32; N]> = (0..self.count)
            .map(|i| self.base_element(i).map_or([0.0; N], |bytes| self.decode_element(bytes)))
            .collect();
        let mut sparse = Vec::new();
        self.for_each_sparse(|i, bytes| sparse.push((i, self.decode_element::<N>(bytes))))?;
        for (i, value) in sparse {
            out[i] = value;
        }
        if let Some(bad) = out.iter().position(|v| v.iter().any(|c| !c.is_finite())) {
            return Err(format!("accessor {}: element {bad} is not finite", self.index));
        }
        Ok(out)
    }

    /// Reads a scalar unsigned-integer accessor (indices).
    pub(crate) fn read_indices(&self) -> Result<Vec<u32>, String> {
        let mut out: Vec<u32> =
            (0..self.count).map(|i| self.base_element(i).map_or(0, |b| read_uint(b, self.component))).collect();
        let mut sparse = Vec::new();
        self.for_each_sparse(|i, bytes| sparse.push((i, read_uint(bytes, self.component))))?;
        for (i, value) in sparse {
            out[i] = value;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn root(json: &str) -> json::Root {
        json::deserialize::from_str(json).unwrap()
    }

    const VIEW: &str = r#""buffers":[{"byteLength":24}],"bufferViews":[{"buffer":0,"byteLength":24}]"#;

    #[test]
    fn the_semantic_tables_refuse_what_gltf_forbids() {
        use ComponentType::*;
        assert!(Semantic::Indices.allows(Type::Scalar, U16, false, false));
        for c in [I8, I16, F32] {
            assert!(!Semantic::Indices.allows(Type::Scalar, c, false, false), "{c:?} indices");
        }
        assert!(!Semantic::Indices.allows(Type::Scalar, U16, true, false));
        assert!(!Semantic::TexCoord.allows(Type::Vec2, U32, false, false));
        assert!(!Semantic::TexCoord.allows(Type::Vec2, U8, false, false));
        assert!(Semantic::TexCoord.allows(Type::Vec2, U8, true, false));
        assert!(!Semantic::Position.allows(Type::Vec2, F32, false, false));
        assert!(!Semantic::Position.allows(Type::Vec3, F32, true, false));
        assert!(Semantic::Color.allows(Type::Vec4, U16, true, false));
    }

    #[test]
    fn mesh_quantization_admits_small_integers_only_where_it_says() {
        use ComponentType::*;
        // Without the extension, 16-bit positions are refused ...
        assert!(!Semantic::Position.allows(Type::Vec3, I16, false, false));
        // ... with it, positions of any small integer type, normalized or not.
        for (c, n) in [(I8, false), (U8, true), (I16, true), (U16, false)] {
            assert!(Semantic::Position.allows(Type::Vec3, c, n, true), "{c:?} {n}");
        }
        // Normals and tangents only as signed normalized integers.
        assert!(Semantic::Normal.allows(Type::Vec3, I8, true, true));
        assert!(!Semantic::Normal.allows(Type::Vec3, U8, true, true));
        assert!(!Semantic::Normal.allows(Type::Vec3, I16, false, true));
        assert!(Semantic::Tangent.allows(Type::Vec4, I16, true, true));
        // Texture coordinates as any small integer; never 32-bit integers.
        assert!(Semantic::TexCoord.allows(Type::Vec2, I16, false, true));
        assert!(!Semantic::TexCoord.allows(Type::Vec2, U32, false, true));
        // Indices are untouched by the extension.
        assert!(!Semantic::Indices.allows(Type::Scalar, I16, false, true));
    }

    /// Tangents are VEC4 (the fourth component is the handedness): floats,
    /// or, with the extension only, signed normalized integers and no other.
    #[test]
    fn tangents_are_vec4_floats_or_quantized_signed_normalized_integers() {
        use ComponentType::*;
        assert!(Semantic::Tangent.allows(Type::Vec4, F32, false, false));
        assert!(!Semantic::Tangent.allows(Type::Vec3, F32, false, false));
        assert!(!Semantic::Tangent.allows(Type::Vec3, I16, true, true));
        assert!(Semantic::Tangent.allows(Type::Vec4, I8, true, true));
        assert!(!Semantic::Tangent.allows(Type::Vec4, I16, true, false), "signed normalized without the extension");
        assert!(!Semantic::Tangent.allows(Type::Vec4, U16, true, true), "unsigned normalized");
        assert!(!Semantic::Tangent.allows(Type::Vec4, I16, false, true), "not normalized");
    }

    /// The vertex-colour, joint and weight rows of the table: each needs
    /// both its element type and its component type, so a right type of the
    /// wrong shape, or the right shape of a wrong type, is refused.
    #[test]
    fn colours_joints_and_weights_need_both_their_shape_and_their_component_type() {
        use ComponentType::*;
        // Colours: RGB or RGBA, as floats or unsigned normalized integers.
        assert!(Semantic::Color.allows(Type::Vec3, F32, false, false));
        assert!(!Semantic::Color.allows(Type::Scalar, F32, false, false), "a scalar colour");
        assert!(!Semantic::Color.allows(Type::Vec2, U8, true, false), "a two-channel colour");
        assert!(!Semantic::Color.allows(Type::Vec4, I16, true, false), "signed normalized");
        // Joints: four unsigned integers that index the skin, never normalized.
        assert!(Semantic::Joints.allows(Type::Vec4, U8, false, false));
        assert!(Semantic::Joints.allows(Type::Vec4, U16, false, false));
        assert!(!Semantic::Joints.allows(Type::Vec4, F32, false, false), "float joints");
        assert!(!Semantic::Joints.allows(Type::Vec4, U16, true, false), "normalized joints");
        assert!(!Semantic::Joints.allows(Type::Vec3, U8, false, false), "three joints");
        assert!(!Semantic::Joints.allows(Type::Scalar, U16, true, false));
        // Weights: four, as floats or unsigned normalized integers.
        assert!(Semantic::Weights.allows(Type::Vec4, U8, true, false));
        assert!(!Semantic::Weights.allows(Type::Vec3, F32, false, false), "three weights");
        assert!(!Semantic::Weights.allows(Type::Vec4, U8, false, false), "weights not normalized");
    }

    /// glTF 2.0 3.11's rows for keyframes and skins: times are float
    /// scalars, translations and scales float VEC3, rotations VEC4 and
    /// morph weights scalars (both floats or normalized integers of either
    /// sign), inverse bind matrices float MAT4. A right shape of a wrong
    /// type, or a right type of a wrong shape, is refused.
    #[test]
    fn keyframes_and_inverse_bind_matrices_need_both_their_shape_and_their_component_type() {
        use ComponentType::*;
        assert!(Semantic::AnimationInput.allows(Type::Scalar, F32, false, false));
        assert!(!Semantic::AnimationInput.allows(Type::Vec2, F32, false, false), "two times per keyframe");
        assert!(!Semantic::AnimationInput.allows(Type::Scalar, U16, true, false), "normalized times");

        assert!(Semantic::AnimationVector.allows(Type::Vec3, F32, false, false));
        assert!(!Semantic::AnimationVector.allows(Type::Vec4, F32, false, false), "a four-component translation");
        assert!(!Semantic::AnimationVector.allows(Type::Vec3, I16, true, true), "quantized translations");

        for (c, n) in [(F32, false), (U8, true), (I8, true), (U16, true), (I16, true)] {
            assert!(Semantic::AnimationRotation.allows(Type::Vec4, c, n, false), "{c:?} {n} rotation");
        }
        assert!(!Semantic::AnimationRotation.allows(Type::Vec3, F32, false, false), "a three-component rotation");
        assert!(!Semantic::AnimationRotation.allows(Type::Vec4, U32, false, false), "32-bit integer rotation");
        assert!(!Semantic::AnimationRotation.allows(Type::Vec4, I16, false, false), "rotation not normalized");

        assert!(Semantic::InverseBindMatrices.allows(Type::Mat4, F32, false, false));
        assert!(!Semantic::InverseBindMatrices.allows(Type::Mat3, F32, false, false), "a 3 × 3 matrix");
        assert!(!Semantic::InverseBindMatrices.allows(Type::Vec4, F32, false, false));
        assert!(!Semantic::InverseBindMatrices.allows(Type::Mat4, U8, true, false), "normalized matrices");

        for (c, n) in [(F32, false), (U8, true), (I8, true), (U16, true), (I16, true)] {
            assert!(Semantic::AnimationWeights.allows(Type::Scalar, c, n, false), "{c:?} {n} weight");
        }
        assert!(!Semantic::AnimationWeights.allows(Type::Vec4, F32, false, false), "weights four to a value");
        assert!(!Semantic::AnimationWeights.allows(Type::Scalar, U32, false, false), "32-bit integer weights");
    }

    /// glTF 2.0 3.6.2.4: each column of a matrix starts on a 4-byte
    /// boundary, so a 2 × 2 or 3 × 3 matrix of 1- or 2-byte components
    /// carries padding after each column; a 4 × 4 one never does (four
    /// components of any size fill whole 4-byte words).
    #[test]
    fn matrix_columns_are_padded_to_four_bytes() {
        use ComponentType::*;
        assert_eq!(element_size(Type::Mat2, U8), 8, "two columns of 2 bytes + 2 padding");
        assert_eq!(element_size(Type::Mat2, I16), 8);
        assert_eq!(element_size(Type::Mat3, I8), 12, "three columns of 3 bytes + 1 padding");
        assert_eq!(element_size(Type::Mat3, U16), 24, "three columns of 6 bytes + 2 padding");
        assert_eq!(element_size(Type::Mat3, F32), 36);
        assert_eq!(element_size(Type::Mat4, U8), 16);
        assert_eq!(element_size(Type::Mat4, F32), 64);
        // Vectors are never padded.
        assert_eq!(element_size(Type::Vec3, U8), 3);
        assert_eq!(element_size(Type::Vec3, I16), 6);
    }

    /// `KHR_mesh_quantization` is what admits 16-bit positions, whether the
    /// file lists it as used or as required; another extension, listed the
    /// same way, admits nothing.
    #[test]
    fn only_the_mesh_quantization_extension_admits_quantized_positions() {
        let file = |extensions: &str| {
            root(&format!(
                r#"{{"asset":{{"version":"2.0"}},{extensions}{VIEW},"accessors":[{{"bufferView":0,"componentType":5122,"normalized":true,"count":4,"type":"VEC3"}}]}}"#
            ))
        };
        let buffers = vec![Cow::Owned(vec![0u8; 24])];
        for listed in [
            r#""extensionsUsed":["KHR_mesh_quantization"],"#,
            r#""extensionsRequired":["KHR_mesh_quantization"],"#,
            r#""extensionsUsed":["KHR_materials_unlit","KHR_mesh_quantization"],"#,
        ] {
            let view = validate(&file(listed), &buffers, 0, Semantic::Position);
            assert_eq!(view.map(|v| v.count), Ok(4), "{listed}");
        }
        let others = r#""extensionsUsed":["KHR_materials_unlit"],"extensionsRequired":["KHR_lights_punctual"],"#;
        for listed in ["", others] {
            let err = validate(&file(listed), &buffers, 0, Semantic::Position).map(|v| v.count).unwrap_err();
            assert!(err.contains("not allowed for Position"), "{listed}: {err}");
        }
    }

    /// Interleaved vertex data: a stride longer than an element skips the
    /// bytes between (here 4 of other data after each 12-byte position); a
    /// stride shorter than an element would make elements overlap, and is
    /// refused.
    #[test]
    fn a_stride_may_be_longer_than_an_element_but_not_shorter() {
        let file = |stride: u32| {
            root(&format!(
                r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":32}}],"bufferViews":[{{"buffer":0,"byteLength":32,"byteStride":{stride}}}],
                "accessors":[{{"bufferView":0,"componentType":5126,"count":2,"type":"VEC3"}}]}}"#
            ))
        };
        let mut bytes = Vec::new();
        for v in [1.0f32, 2.0, 3.0, -1.0, 4.0, 5.0, 6.0, -1.0] {
            bytes.extend(v.to_le_bytes());
        }
        let buffers = vec![Cow::Owned(bytes)];
        let values = validate(&file(16), &buffers, 0, Semantic::Position).unwrap().read_floats::<3>().unwrap();
        assert_eq!(values, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        let err = validate(&file(8), &buffers, 0, Semantic::Position).map(|v| v.count).unwrap_err();
        assert!(err.contains("byteStride 8 is smaller than an element (12 bytes)"), "{err}");
    }

    /// A sparse accessor substitutes from 1 up to every one of its elements;
    /// none, or more than it has, is an error naming the counts (the views
    /// here hold enough bytes for three, so only the count can refuse it).
    #[test]
    fn a_sparse_count_is_from_one_to_the_accessors_count() {
        let file = |sparse: u32| {
            root(&format!(
                r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":44}}],"bufferViews":[{{"buffer":0,"byteLength":8}},{{"buffer":0,"byteOffset":8,"byteLength":36}}],
                "accessors":[{{"componentType":5126,"count":2,"type":"VEC3","sparse":{{"count":{sparse},"indices":{{"bufferView":0,"componentType":5123}},"values":{{"bufferView":1}}}}}}]}}"#
            ))
        };
        let mut bytes = Vec::new();
        for i in [0u16, 1, 2, 0] {
            bytes.extend(i.to_le_bytes());
        }
        for v in [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0] {
            bytes.extend(v.to_le_bytes());
        }
        let buffers = vec![Cow::Owned(bytes)];
        let every = validate(&file(2), &buffers, 0, Semantic::Position).unwrap().read_floats::<3>().unwrap();
        assert_eq!(every, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        let one = validate(&file(1), &buffers, 0, Semantic::Position).unwrap().read_floats::<3>().unwrap();
        assert_eq!(one, vec![[1.0, 2.0, 3.0], [0.0; 3]]);
        for sparse in [0, 3] {
            let err = validate(&file(sparse), &buffers, 0, Semantic::Position).map(|v| v.count).unwrap_err();
            assert!(err.contains(&format!("sparse count {sparse} is not in 1..=2")), "{err}");
        }
    }

    /// Sparse indices or values that run past their buffer view are an
    /// error naming which, not a read past the view (the buffer itself is
    /// long enough, so only the view's length can refuse them).
    #[test]
    fn sparse_indices_or_values_past_their_view_are_an_error_naming_which() {
        let file = |index_bytes: u32, value_bytes: u32| {
            root(&format!(
                r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":64}}],"bufferViews":[{{"buffer":0,"byteLength":{index_bytes}}},{{"buffer":0,"byteOffset":8,"byteLength":{value_bytes}}}],
                "accessors":[{{"componentType":5126,"count":2,"type":"VEC3","sparse":{{"count":2,"indices":{{"bufferView":0,"componentType":5123}},"values":{{"bufferView":1}}}}}}]}}"#
            ))
        };
        let mut bytes = vec![0u8; 64];
        bytes[2] = 1; // indices 0 and 1
        let buffers = vec![Cow::Owned(bytes)];
        assert_eq!(validate(&file(4, 24), &buffers, 0, Semantic::Position).map(|v| v.count), Ok(2));
        let err = validate(&file(3, 24), &buffers, 0, Semantic::Position).map(|v| v.count).unwrap_err();
        assert!(err.contains("sparse indices do not fit"), "{err}");
        let err = validate(&file(4, 23), &buffers, 0, Semantic::Position).map(|v| v.count).unwrap_err();
        assert!(err.contains("sparse values do not fit"), "{err}");
    }

    /// The first element of a one-element accessor of `component_type`
    /// (`ty`, `normalized`) holding `bytes`, read as `semantic` in a file
    /// that uses `KHR_mesh_quantization`; missing components read 0.
    fn first_element(component_type: u32, ty: &str, normalized: bool, bytes: &[u8], semantic: Semantic) -> [f32; 4] {
        let n = bytes.len();
        let r = root(&format!(
            r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["KHR_mesh_quantization"],"buffers":[{{"byteLength":{n}}}],"bufferViews":[{{"buffer":0,"byteLength":{n}}}],
            "accessors":[{{"bufferView":0,"componentType":{component_type},"normalized":{normalized},"count":1,"type":"{ty}"}}]}}"#
        ));
        let buffers = vec![Cow::Owned(bytes.to_vec())];
        validate(&r, &buffers, 0, semantic).unwrap().read_floats::<4>().unwrap()[0]
    }

    /// glTF 2.0 3.11 (animation samplers), whose formulas the mesh
    /// quantization extension reuses: an unsigned normalized integer is
    /// `c / max`; a signed one is `max(c / max, -1)`, so both its most
    /// negative values are -1. Integers that are not normalized read as
    /// their value.
    #[test]
    fn integer_components_read_as_gltf_normalizes_them() {
        let rotation = |component_type, bytes: &[u8]| {
            first_element(component_type, "VEC4", true, bytes, Semantic::AnimationRotation)
        };
        assert_eq!(rotation(5121, &[0, 255, 51, 102]), [0.0, 1.0, 0.2, 0.4], "u8");
        assert_eq!(rotation(5120, &[0x80, 0x81, 127, 64]), [-1.0, -1.0, 1.0, 64.0 / 127.0], "i8");
        let u16s: Vec<u8> = [0u16, 65535, 13107, 32768].iter().flat_map(|v| v.to_le_bytes()).collect();
        assert_eq!(rotation(5123, &u16s), [0.0, 1.0, 0.2, 32768.0 / 65535.0], "u16");
        let i16s: Vec<u8> = [i16::MIN, -32767, 32767, 16384].iter().flat_map(|v| v.to_le_bytes()).collect();
        assert_eq!(rotation(5122, &i16s), [-1.0, -1.0, 1.0, 16384.0 / 32767.0], "i16");

        let position =
            |component_type, bytes: &[u8]| first_element(component_type, "VEC3", false, bytes, Semantic::Position);
        assert_eq!(position(5121, &[0, 255, 200]), [0.0, 255.0, 200.0, 0.0], "u8");
        assert_eq!(position(5120, &[0x80, 127, 0xfb]), [-128.0, 127.0, -5.0, 0.0], "i8");
        let u16s: Vec<u8> = [0u16, 65535, 40000].iter().flat_map(|v| v.to_le_bytes()).collect();
        assert_eq!(position(5123, &u16s), [0.0, 65535.0, 40000.0, 0.0], "u16");
        let i16s: Vec<u8> = [i16::MIN, 32767, -5].iter().flat_map(|v| v.to_le_bytes()).collect();
        assert_eq!(position(5122, &i16s), [-32768.0, 32767.0, -5.0, 0.0], "i16");
    }

    #[test]
    fn an_accessor_past_its_buffer_view_is_an_error_naming_it() {
        let r = root(&format!(
            r#"{{"asset":{{"version":"2.0"}},{VIEW},"accessors":[{{"bufferView":0,"byteOffset":4,"componentType":5126,"count":2,"type":"VEC3"}}]}}"#
        ));
        let buffers = vec![Cow::Owned(vec![0u8; 24])];
        let err = validate(&r, &buffers, 0, Semantic::Position).unwrap_err();
        assert!(err.contains("accessor 0") && err.contains("do not fit"), "{err}");
    }

    #[test]
    fn a_buffer_view_past_its_buffer_is_an_error() {
        let r = root(
            r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":8}],"bufferViews":[{"buffer":0,"byteLength":24}],
            "accessors":[{"bufferView":0,"componentType":5126,"count":1,"type":"VEC3"}]}"#,
        );
        let err = validate(&r, &[Cow::Owned(vec![0u8; 8])], 0, Semantic::Position).unwrap_err();
        assert!(err.contains("outside buffer 0"), "{err}");
    }

    #[test]
    fn huge_counts_overflow_into_an_error_not_an_allocation() {
        let r = root(&format!(
            r#"{{"asset":{{"version":"2.0"}},{VIEW},"accessors":[{{"bufferView":0,"componentType":5126,"count":18446744073709551615,"type":"VEC3"}}]}}"#
        ));
        assert!(validate(&r, &[Cow::Owned(vec![0u8; 24])], 0, Semantic::Position).is_err());
    }

    #[test]
    fn sparse_values_replace_zeros_and_non_finite_values_are_refused() {
        let mut bytes = Vec::new();
        bytes.extend(1u16.to_le_bytes()); // sparse index 1
        bytes.extend([0u8; 2]);
        for v in [1.0f32, 2.0, 3.0] {
            bytes.extend(v.to_le_bytes());
        }
        let r = root(
            r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":16}],"bufferViews":[{"buffer":0,"byteLength":4},{"buffer":0,"byteOffset":4,"byteLength":12}],
            "accessors":[{"componentType":5126,"count":2,"type":"VEC3","sparse":{"count":1,"indices":{"bufferView":0,"componentType":5123},"values":{"bufferView":1}}}]}"#,
        );
        let buffers = vec![Cow::Owned(bytes)];
        let values = validate(&r, &buffers, 0, Semantic::Position).unwrap().read_floats::<3>().unwrap();
        assert_eq!(values, vec![[0.0; 3], [1.0, 2.0, 3.0]]);
        let mut nan = buffers[0].to_vec();
        nan[4..8].copy_from_slice(&f32::NAN.to_le_bytes());
        let buffers = vec![Cow::Owned(nan)];
        let err = validate(&r, &buffers, 0, Semantic::Position).unwrap().read_floats::<3>().unwrap_err();
        assert!(err.contains("not finite"), "{err}");
    }
}
