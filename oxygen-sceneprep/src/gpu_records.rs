//! GPU records of the material, light and transform domains, each declared
//! once with `gpu_struct!`: its WGSL twin is generated from the Rust struct
//! (`gpu_records.wgsl` includes them; the shader registry's layout test
//! compares the two through naga).

use std::mem::{offset_of, size_of};

use glam::Mat3;
use oxygen_bindless::{DomainKind, INVALID_SLOT};
use oxygen_core::{AlphaMode, Material, SkinWeights, Vertex, VertexAttributes};
use oxygen_gpu::StructLayout;

/// The WGSL the scene's records share: the include lines of the generated
/// records (`NormalMatrix`, `DrawMetadata`, `MaterialRecord`, the light
/// records, the ray scene's, `VertexRecord`) and `apply_uv_transform`.
pub const GPU_RECORDS_WGSL: &str = include_str!("gpu_records.wgsl");

oxygen_gpu::gpu_struct! {
    /// One record of the vertex domain as shaders read it: eight floats
    /// named for a vertex's position (`px`..`pz`), normal (`nx`..`nz`) and
    /// texture coordinate (`u`, `v`). Scalars, because a `vec3` member would
    /// be 16-byte aligned and break the 32-byte stride. The domain holds
    /// oxygen-core's 32-byte records in this place, which shaders read
    /// through these members: see [`vertex_record_overlays`].
    #[derive(Debug, Default, PartialEq)]
    pub struct VertexRecord: 32 bytes {
        /// Position x.
        pub px: f32,
        /// Position y.
        pub py: f32,
        /// Position z.
        pub pz: f32,
        /// Normal x.
        pub nx: f32,
        /// Normal y.
        pub ny: f32,
        /// Normal z.
        pub nz: f32,
        /// Texture coordinate u.
        pub u: f32,
        /// Texture coordinate v.
        pub v: f32,
    }
}

/// oxygen-core's records of the vertex domain as they lie over
/// [`VertexRecord`]'s members, each Rust field named by the first member it
/// covers, for [`oxygen_gpu::check_overlay`]. The shaders read them through
/// those members (`mesh/mesh_vertex.wgsl`, `reference/trace.wgsl`): a
/// [`Vertex`] (and a morph target's displacement, written as one) as it is
/// named; a [`VertexAttributes`] record's colour as `px`..`nx`, its second
/// UV set as `ny`, `nz`; a [`SkinWeights`] record's joints as `px`..`nx`
/// and its weights as `ny`..`v`.
pub fn vertex_record_overlays() -> [StructLayout; 3] {
    [
        oxygen_gpu::gpu_layout!(Vertex { position => "px", normal => "nx", uv => "u" }),
        oxygen_gpu::gpu_layout!(VertexAttributes { color => "px", uv1 => "ny", reserved => "u" }),
        oxygen_gpu::gpu_layout!(SkinWeights { joints => "px", weights => "ny" }),
    ]
}

oxygen_gpu::gpu_struct! {
    /// A normal matrix as WGSL `mat3x3<f32>` stores it (three columns, each
    /// padded to 16 bytes), with the node's semantic class in the first
    /// column's padding: the labels' semantic plane reads it beside the
    /// matrix the vertex shader reads anyway, at no extra byte.
    #[derive(Debug, Default, PartialEq)]
    pub struct NormalMatrix: 48 bytes {
        /// First column.
        pub x: [f32; 3] => "vec3<f32>",
        /// The semantic class of the node drawn with this matrix
        /// (`Scene::set_semantic_class`); 0 for a joint's matrix.
        pub semantic_class: u32,
        /// Second column.
        pub y: [f32; 3] => "vec3<f32>",
        /// Zero: the second column's padding.
        pub reserved_y: u32,
        /// Third column.
        pub z: [f32; 3] => "vec3<f32>",
        /// Zero: the third column's padding.
        pub reserved_z: u32,
    }
}

impl NormalMatrix {
    /// The matrix of a node of semantic class `semantic_class`.
    pub fn with_class(m: Mat3, semantic_class: u32) -> Self {
        NormalMatrix { semantic_class, ..m.into() }
    }

    /// The matrix, without the class.
    pub fn matrix(&self) -> Mat3 {
        Mat3::from_cols(self.x.into(), self.y.into(), self.z.into())
    }
}

impl From<Mat3> for NormalMatrix {
    fn from(m: Mat3) -> Self {
        NormalMatrix {
            x: m.x_axis.to_array(),
            semantic_class: 0,
            y: m.y_axis.to_array(),
            reserved_y: 0,
            z: m.z_axis.to_array(),
            reserved_z: 0,
        }
    }
}

/// Material flags bits in [`MaterialRecord::flags`].
pub mod material_flags {
    /// Alpha-tested.
    pub const MASKED: u32 = 1 << 0;
    /// Alpha-blended.
    pub const BLEND: u32 = 1 << 1;
    /// Double-sided.
    pub const DOUBLE_SIDED: u32 = 1 << 2;
    /// Unlit (`KHR_materials_unlit`): base colour is the radiance.
    pub const UNLIT: u32 = 1 << 3;
    /// Some texture reads set 1 or has a transform: the shader applies
    /// [`MaterialRecord::uv_transforms`](super::MaterialRecord::uv_transforms);
    /// without it, every texture reads set 0 as is.
    pub const UV_TRANSFORMS: u32 = 1 << 4;
    /// Every flag with its name, the list [`MaterialRecord::wgsl_constants`](super::MaterialRecord::wgsl_constants)
    /// emits; a flag added above belongs here too (a test checks that the
    /// bits are distinct and cover every bit a record can set).
    pub const ALL: [(&str, u32); 5] = [
        ("MASKED", MASKED),
        ("BLEND", BLEND),
        ("DOUBLE_SIDED", DOUBLE_SIDED),
        ("UNLIT", UNLIT),
        ("UV_TRANSFORMS", UV_TRANSFORMS),
    ];
}

/// One `const NAME: u32 = 0x..u;` line.
fn wgsl_constant(name: &str, value: u32) -> String {
    format!("const {name}: u32 = {value:#x}u;\n")
}

oxygen_gpu::gpu_struct! {
    /// A texture's coordinate set and transform as shaders read it (32 bytes):
    /// `uv' = (dot(row0, (u, v, 1)), dot(row1, (u, v, 1)))` of set `uv_set`.
    #[derive(Debug, PartialEq)]
    pub struct UvTransformRecord: 32 bytes {
        /// First row of the affine map.
        pub row0: [f32; 3],
        /// Texture coordinate set, 0 or 1.
        pub uv_set: u32,
        /// Second row of the affine map.
        pub row1: [f32; 3],
        /// Zero.
        pub reserved: u32,
    }
}

impl UvTransformRecord {
    /// The record of a (sanitized) transform.
    pub fn from_transform(t: &oxygen_core::UvTransform) -> Self {
        let [row0, row1] = t.rows();
        UvTransformRecord { row0, uv_set: t.uv_set, row1, reserved: 0 }
    }
}

oxygen_gpu::gpu_struct! {
    /// A material as shaders read it (240 bytes). Texture fields are slots in
    /// the texture-locations domain, [`INVALID_SLOT`] when absent.
    #[derive(Debug, PartialEq)]
    pub struct MaterialRecord: 240 bytes {
        /// Linear RGBA base colour factor.
        pub base_color: [f32; 4],
        /// Linear emissive factor.
        pub emissive: [f32; 3],
        /// Normal-map XY scale.
        pub normal_scale: f32,
        /// Metallic factor.
        pub metallic: f32,
        /// Roughness factor.
        pub roughness: f32,
        /// Alpha cutoff (only read when masked).
        pub alpha_cutoff: f32,
        /// [`material_flags`] bits.
        pub flags: u32,
        /// Base-colour texture slot.
        pub base_color_texture: u32,
        /// Metallic-roughness texture slot.
        pub metallic_roughness_texture: u32,
        /// Normal-map slot.
        pub normal_texture: u32,
        /// Emissive texture slot.
        pub emissive_texture: u32,
        /// Ambient-occlusion texture slot.
        pub occlusion_texture: u32,
        /// Ambient-occlusion strength in `[0, 1]`.
        pub occlusion_strength: f32,
        /// Zero.
        pub reserved: [u32; 2] => "array<u32, 2>",
        /// Coordinate set and transform of each texture, in the order base
        /// colour, metallic-roughness, normal, emissive, occlusion; read only
        /// when `flags` has [`material_flags::UV_TRANSFORMS`].
        pub uv_transforms: [UvTransformRecord; 5] => "array<UvTransformRecord, 5>",
    }
}

impl MaterialRecord {
    /// WGSL `const` declarations of the `material_flags` bits, named
    /// `MATERIAL_` followed by the flag (`MATERIAL_DOUBLE_SIDED`).
    pub fn wgsl_constants() -> String {
        material_flags::ALL.iter().map(|(name, bit)| wgsl_constant(&format!("MATERIAL_{name}"), *bit)).collect()
    }

    /// The record for a (sanitized) material, textures not yet resolved.
    pub fn from_material(m: &Material) -> Self {
        let (alpha_cutoff, mut flags) = match m.alpha_mode {
            AlphaMode::Opaque => (0.0, 0),
            AlphaMode::Mask { cutoff } => (cutoff, material_flags::MASKED),
            AlphaMode::Blend => (0.0, material_flags::BLEND),
        };
        if m.double_sided {
            flags |= material_flags::DOUBLE_SIDED;
        }
        if m.unlit {
            flags |= material_flags::UNLIT;
        }
        if !m.uvs.is_identity() {
            flags |= material_flags::UV_TRANSFORMS;
        }
        let uvs = m.uvs.in_record_order();
        MaterialRecord {
            base_color: m.base_color.to_array(),
            emissive: m.emissive.to_array(),
            normal_scale: m.normal_scale,
            metallic: m.metallic,
            roughness: m.roughness,
            alpha_cutoff,
            flags,
            base_color_texture: INVALID_SLOT,
            metallic_roughness_texture: INVALID_SLOT,
            normal_texture: INVALID_SLOT,
            emissive_texture: INVALID_SLOT,
            occlusion_texture: INVALID_SLOT,
            occlusion_strength: m.occlusion_strength,
            reserved: [0; 2],
            uv_transforms: uvs.map(|t| UvTransformRecord::from_transform(&t)),
        }
    }
}

oxygen_gpu::gpu_struct! {
    /// A directional light as shaders read it (48 bytes).
    #[derive(Debug, PartialEq)]
    pub struct DirectionalLightRecord: 48 bytes {
        /// Unit direction the light travels (world space).
        pub direction: [f32; 3],
        /// Illuminance in lux.
        pub intensity: f32,
        /// Linear RGB colour.
        pub color: [f32; 3],
        /// Bit 0: casts shadows.
        pub flags: u32,
        /// Shadow data slot, [`INVALID_SLOT`] when none.
        pub shadow_slot: u32,
        /// Angular radius of the light's disc in radians (0: a point;
        /// `Light::angular_radius`).
        pub angular_radius: f32,
        /// Zero.
        pub reserved: [u32; 2] => "array<u32, 2>",
    }
}

oxygen_gpu::gpu_struct! {
    /// A point or spot light as shaders read it (80 bytes).
    #[derive(Debug, PartialEq)]
    pub struct PositionalLightRecord: 80 bytes {
        /// World position.
        pub position: [f32; 3],
        /// Cut-off range; 0 means unbounded.
        pub range: f32,
        /// Unit direction of a spot's axis (world space).
        pub direction: [f32; 3],
        /// Luminous intensity in candela.
        pub intensity: f32,
        /// Linear RGB colour.
        pub color: [f32; 3],
        /// 0 point, 1 spot.
        pub kind: u32,
        /// Cosine of the inner cone angle (spot).
        pub cos_inner: f32,
        /// Cosine of the outer cone angle (spot).
        pub cos_outer: f32,
        /// Bit 0: casts shadows.
        pub flags: u32,
        /// First tile of the light's shadow maps in the local-light shadow
        /// atlas (a spot has one tile, a point light six, one per cube face in
        /// `PROBE_FACE_AXES` order); [`INVALID_SLOT`] when it casts none.
        pub shadow_slot: u32,
        /// Radius of the light's sphere in metres (`Light::radius`): 0 is a
        /// point. The reference traces shadows to points of its disc; PCSS
        /// widens the light's shadow penumbrae by it.
        pub radius: f32,
        /// Zero: explicit padding to 16-byte records (scalars: a `vec3`
        /// would align to 16 in WGSL).
        pub pad0: u32,
        /// Zero.
        pub pad1: u32,
        /// Zero.
        pub pad2: u32,
    }
}

/// Tiles of the local-light shadow atlas: a shadow-casting spot takes one, a
/// point light six. Lights that no longer fit are lit unshadowed.
pub const MAX_SHADOW_TILES: u32 = 16;

/// Atlas tiles a positional light of `kind` needs for its shadow.
pub(crate) fn shadow_tiles_for(kind: u32) -> u32 {
    if kind == PositionalLightRecord::POINT { 6 } else { 1 }
}

impl DirectionalLightRecord {
    /// `flags` bit: the light casts shadows.
    pub const CASTS_SHADOWS: u32 = 1 << 0;
}

impl PositionalLightRecord {
    /// `kind` of a point light.
    pub const POINT: u32 = 0;
    /// `kind` of a spot light.
    pub const SPOT: u32 = 1;
    /// `flags` bit: the light casts shadows (the same bit as a directional
    /// light's, so shaders test both with one constant).
    pub const CASTS_SHADOWS: u32 = DirectionalLightRecord::CASTS_SHADOWS;

    /// WGSL `const` declarations of the light records' numbers: the kinds
    /// (`LIGHT_POINT`, `LIGHT_SPOT`) and the `flags` bit `LIGHT_CASTS_SHADOWS`
    /// shared by directional and positional records.
    pub fn wgsl_constants() -> String {
        [("LIGHT_POINT", Self::POINT), ("LIGHT_SPOT", Self::SPOT), ("LIGHT_CASTS_SHADOWS", Self::CASTS_SHADOWS)]
            .iter()
            .map(|(name, value)| wgsl_constant(name, *value))
            .collect()
    }
}

const _: () = {
    assert!(size_of::<NormalMatrix>() as u64 == DomainKind::NormalTransforms.record_size());
    assert!(size_of::<MaterialRecord>() as u64 == DomainKind::Materials.record_size());
    assert!(size_of::<DirectionalLightRecord>() as u64 == DomainKind::DirectionalLights.record_size());
    assert!(size_of::<PositionalLightRecord>() as u64 == DomainKind::PositionalLights.record_size());
    assert!(size_of::<Vertex>() as u64 == DomainKind::Vertices.record_size());
    assert!(size_of::<VertexRecord>() as u64 == DomainKind::Vertices.record_size());
    assert!(offset_of!(MaterialRecord, emissive) == 16);
    assert!(offset_of!(MaterialRecord, metallic) == 32);
    assert!(offset_of!(MaterialRecord, base_color_texture) == 48);
    assert!(offset_of!(MaterialRecord, emissive_texture) == 60);
    assert!(offset_of!(MaterialRecord, occlusion_texture) == 64);
    assert!(offset_of!(MaterialRecord, occlusion_strength) == 68);
    assert!(offset_of!(MaterialRecord, uv_transforms) == 80);
    assert!(size_of::<UvTransformRecord>() == 32);
    assert!(offset_of!(DirectionalLightRecord, color) == 16);
    assert!(offset_of!(DirectionalLightRecord, shadow_slot) == 32);
    assert!(offset_of!(PositionalLightRecord, direction) == 16);
    assert!(offset_of!(PositionalLightRecord, color) == 32);
    assert!(offset_of!(PositionalLightRecord, cos_inner) == 48);
    assert!(offset_of!(PositionalLightRecord, shadow_slot) == 60);
};

#[cfg(test)]
mod tests {
    use super::*;

    fn declares(wgsl: &str, name: &str, value: u32) -> bool {
        wgsl.lines().any(|line| line == format!("const {name}: u32 = {value:#x}u;"))
    }

    #[test]
    fn every_material_flag_is_a_wgsl_constant_with_its_bit() {
        let wgsl = MaterialRecord::wgsl_constants();
        for (name, bit) in material_flags::ALL {
            assert!(declares(&wgsl, &format!("MATERIAL_{name}"), bit), "{name}:\n{wgsl}");
        }
        assert_eq!(wgsl.lines().count(), material_flags::ALL.len());
    }

    /// `ALL` lists each flag once: distinct single bits, and together every
    /// bit `from_material` sets for any alpha mode and sidedness.
    #[test]
    fn the_material_flag_list_is_complete() {
        let union = material_flags::ALL.iter().fold(0, |acc, (_, bit)| {
            assert_eq!(bit.count_ones(), 1);
            assert_eq!(acc & bit, 0, "bit {bit:#x} listed twice");
            acc | bit
        });
        for alpha_mode in [AlphaMode::Opaque, AlphaMode::Mask { cutoff: 0.5 }, AlphaMode::Blend] {
            for double_sided in [false, true] {
                let material = Material { alpha_mode, double_sided, ..Material::opaque("flags", glam::Vec4::ONE) };
                let flags = MaterialRecord::from_material(&material).flags;
                assert_eq!(flags & !union, 0, "{alpha_mode:?} sets an unlisted bit: {flags:#x}");
            }
        }
    }

    /// Each flag is set by its own property and only by it, and adds to the
    /// alpha mode's bit rather than replacing it.
    #[test]
    fn each_material_flag_follows_its_property() {
        use material_flags::*;
        let flags = |m: Material| MaterialRecord::from_material(&m).flags;
        let plain = || Material::opaque("flags", glam::Vec4::ONE);
        let transformed = oxygen_core::MaterialUvs {
            normal: oxygen_core::UvTransform { uv_set: 1, ..oxygen_core::UvTransform::IDENTITY },
            ..Default::default()
        };
        assert_eq!(flags(plain()), 0, "identity UVs need no transform");
        assert_eq!(flags(Material { double_sided: true, ..plain() }), DOUBLE_SIDED);
        assert_eq!(flags(Material { unlit: true, ..plain() }), UNLIT);
        assert_eq!(flags(Material { uvs: transformed, ..plain() }), UV_TRANSFORMS);
        let masked = AlphaMode::Mask { cutoff: 0.5 };
        assert_eq!(flags(Material { alpha_mode: masked, double_sided: true, ..plain() }), MASKED | DOUBLE_SIDED);
        assert_eq!(flags(Material { alpha_mode: masked, unlit: true, ..plain() }), MASKED | UNLIT);
        assert_eq!(flags(Material { alpha_mode: masked, uvs: transformed, ..plain() }), MASKED | UV_TRANSFORMS);
        let everything =
            Material { alpha_mode: AlphaMode::Blend, double_sided: true, unlit: true, uvs: transformed, ..plain() };
        assert_eq!(flags(everything), BLEND | DOUBLE_SIDED | UNLIT | UV_TRANSFORMS);
    }

    #[test]
    fn light_kinds_and_flags_are_wgsl_constants_with_their_values() {
        let wgsl = PositionalLightRecord::wgsl_constants();
        assert!(declares(&wgsl, "LIGHT_POINT", PositionalLightRecord::POINT), "{wgsl}");
        assert!(declares(&wgsl, "LIGHT_SPOT", PositionalLightRecord::SPOT), "{wgsl}");
        assert!(declares(&wgsl, "LIGHT_CASTS_SHADOWS", DirectionalLightRecord::CASTS_SHADOWS), "{wgsl}");
        assert!(declares(&wgsl, "LIGHT_CASTS_SHADOWS", PositionalLightRecord::CASTS_SHADOWS), "{wgsl}");
    }
}
