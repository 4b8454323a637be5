//! Materials: the metallic-roughness parameters a renderable's submesh uses.

use glam::{Vec2, Vec3, Vec4};

use crate::TextureHandle;

/// How a material's alpha is interpreted; decides the pass class of a draw.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum AlphaMode {
    /// Alpha ignored; drawn in the opaque partitions.
    Opaque,
    /// Alpha-tested: fragments with alpha below `cutoff` are discarded.
    Mask {
        /// Alpha threshold in `[0, 1]`.
        cutoff: f32,
    },
    /// Alpha-blended; drawn back-to-front by the transparent pass.
    Blend,
}

/// Which texture coordinate set a texture reads and how the coordinates are
/// transformed first (glTF `texCoord` and `KHR_texture_transform`):
/// `uv' = translate(offset) · rotate(rotation) · scale(scale) · uv`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct UvTransform {
    /// Texture coordinate set: 0 (`TEXCOORD_0`) or 1 (`TEXCOORD_1`).
    pub uv_set: u32,
    /// Added after rotation and scale.
    pub offset: Vec2,
    /// Radians, counter-clockwise in UV space (glTF's convention).
    pub rotation: f32,
    /// Per-axis scale, applied first.
    pub scale: Vec2,
}

impl Default for UvTransform {
    fn default() -> Self {
        UvTransform::IDENTITY
    }
}

impl UvTransform {
    /// Set 0, untransformed.
    pub const IDENTITY: UvTransform = UvTransform { uv_set: 0, offset: Vec2::ZERO, rotation: 0.0, scale: Vec2::ONE };

    /// The two rows of the 3 × 3 matrix that maps `(u, v, 1)` (the third
    /// row is `(0, 0, 1)`).
    pub fn rows(&self) -> [[f32; 3]; 2] {
        let (sin, cos) = self.rotation.sin_cos();
        [
            [cos * self.scale.x, sin * self.scale.y, self.offset.x],
            [-sin * self.scale.x, cos * self.scale.y, self.offset.y],
        ]
    }

    /// Applies the transform to a coordinate (the CPU twin of the shader's).
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        let [r0, r1] = self.rows();
        Vec2::new(r0[0] * uv.x + r0[1] * uv.y + r0[2], r1[0] * uv.x + r1[1] * uv.y + r1[2])
    }

    /// Non-finite values replaced by the identity's, the set clamped to 0 or 1.
    fn sanitized(self) -> UvTransform {
        let finite_or = |v: Vec2, d: Vec2| if v.is_finite() { v } else { d };
        UvTransform {
            uv_set: self.uv_set.min(1),
            offset: finite_or(self.offset, Vec2::ZERO),
            rotation: if self.rotation.is_finite() { self.rotation } else { 0.0 },
            scale: finite_or(self.scale, Vec2::ONE),
        }
    }
}

/// The [`UvTransform`] of each of a material's five textures.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MaterialUvs {
    /// Of the base-colour texture.
    pub base_color: UvTransform,
    /// Of the metallic-roughness texture.
    pub metallic_roughness: UvTransform,
    /// Of the normal map.
    pub normal: UvTransform,
    /// Of the emissive texture.
    pub emissive: UvTransform,
    /// Of the occlusion texture.
    pub occlusion: UvTransform,
}

impl MaterialUvs {
    /// The five in the order of the GPU record: base colour,
    /// metallic-roughness, normal, emissive, occlusion.
    pub fn in_record_order(&self) -> [UvTransform; 5] {
        [self.base_color, self.metallic_roughness, self.normal, self.emissive, self.occlusion]
    }

    /// Whether every texture reads UV set 0 untransformed (what a material
    /// without `texCoord` or `KHR_texture_transform` has).
    pub fn is_identity(&self) -> bool {
        self.in_record_order().iter().all(|t| *t == UvTransform::IDENTITY)
    }

    fn sanitized(&self) -> MaterialUvs {
        MaterialUvs {
            base_color: self.base_color.sanitized(),
            metallic_roughness: self.metallic_roughness.sanitized(),
            normal: self.normal.sanitized(),
            emissive: self.emissive.sanitized(),
            occlusion: self.occlusion.sanitized(),
        }
    }
}

/// A metallic-roughness material.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Material {
    /// Name for logs and dumps.
    pub name: String,
    /// Linear RGBA base colour factor.
    pub base_color: Vec4,
    /// Base-colour texture (sRGB), multiplied with `base_color`.
    pub base_color_texture: Option<TextureHandle>,
    /// Metallic-roughness texture (linear; roughness in G, metallic in B),
    /// multiplied with the factors.
    pub metallic_roughness_texture: Option<TextureHandle>,
    /// Tangent-space normal map (linear).
    pub normal_texture: Option<TextureHandle>,
    /// Scale of the normal map's X and Y.
    pub normal_scale: f32,
    /// Linear emitted radiance factor.
    pub emissive: Vec3,
    /// Emissive texture (sRGB), multiplied with `emissive`.
    pub emissive_texture: Option<TextureHandle>,
    /// Ambient-occlusion texture (linear, R channel): how much indirect
    /// light (the ambient term and probe reflections) reaches each point.
    pub occlusion_texture: Option<TextureHandle>,
    /// How strongly `occlusion_texture` applies, in `[0, 1]`.
    pub occlusion_strength: f32,
    /// Metallic factor in `[0, 1]`.
    pub metallic: f32,
    /// Perceptual roughness in `[0, 1]`.
    pub roughness: f32,
    /// Alpha handling.
    pub alpha_mode: AlphaMode,
    /// Draw both faces (no back-face culling, normals flipped for back faces).
    pub double_sided: bool,
    /// Texture coordinate set and transform of each texture.
    pub uvs: MaterialUvs,
    /// Unlit (glTF `KHR_materials_unlit`): the base colour (times vertex
    /// colour and texture) is the pixel's radiance; lights, shadows, the
    /// ambient term and reflections are ignored.
    pub unlit: bool,
}

impl Material {
    /// An opaque, single-sided dielectric of the given linear colour.
    pub fn opaque(name: impl Into<String>, base_color: Vec4) -> Self {
        Material {
            name: name.into(),
            base_color,
            base_color_texture: None,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            emissive: Vec3::ZERO,
            emissive_texture: None,
            occlusion_texture: None,
            occlusion_strength: 1.0,
            metallic: 0.0,
            roughness: 0.6,
            alpha_mode: AlphaMode::Opaque,
            double_sided: false,
            uvs: MaterialUvs::default(),
            unlit: false,
        }
    }

    /// Values clamped to their valid ranges and NaN replaced, so that what is
    /// uploaded to the GPU is always meaningful.
    pub fn sanitized(&self) -> Material {
        let fix = |v: f32, default: f32| if v.is_finite() { v.clamp(0.0, 1.0) } else { default };
        let base = self.base_color;
        Material {
            name: self.name.clone(),
            base_color: Vec4::new(fix(base.x, 1.0), fix(base.y, 1.0), fix(base.z, 1.0), fix(base.w, 1.0)),
            base_color_texture: self.base_color_texture,
            metallic_roughness_texture: self.metallic_roughness_texture,
            normal_texture: self.normal_texture,
            normal_scale: if self.normal_scale.is_finite() { self.normal_scale } else { 1.0 },
            emissive: if self.emissive.is_finite() { self.emissive.max(Vec3::ZERO) } else { Vec3::ZERO },
            emissive_texture: self.emissive_texture,
            occlusion_texture: self.occlusion_texture,
            occlusion_strength: fix(self.occlusion_strength, 1.0),
            metallic: fix(self.metallic, 0.0),
            roughness: fix(self.roughness, 1.0),
            alpha_mode: match self.alpha_mode {
                AlphaMode::Mask { cutoff } => AlphaMode::Mask { cutoff: fix(cutoff, 0.5) },
                other => other,
            },
            double_sided: self.double_sided,
            uvs: self.uvs.sanitized(),
            unlit: self.unlit,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// KHR_texture_transform's order, worked out without `rows`: scale,
    /// then rotate (the glTF matrix `[[cos, sin], [-sin, cos]]`), then
    /// offset; the rows are that map.
    #[test]
    fn a_uv_transform_scales_then_rotates_then_offsets() {
        let t = UvTransform { uv_set: 1, offset: Vec2::new(0.25, -0.5), rotation: 0.5, scale: Vec2::new(2.0, 3.0) };
        let (sin, cos) = 0.5f32.sin_cos();
        let scaled = Vec2::new(0.4 * 2.0, 0.7 * 3.0);
        let rotated = Vec2::new(cos * scaled.x + sin * scaled.y, -sin * scaled.x + cos * scaled.y);
        let want = rotated + Vec2::new(0.25, -0.5);
        let got = t.apply(Vec2::new(0.4, 0.7));
        assert!((got - want).abs().max_element() < 1e-6, "{got} against {want}");
        let rows = t.rows();
        let expected = [[cos * 2.0, sin * 3.0, 0.25], [-sin * 2.0, cos * 3.0, -0.5]];
        for (row, want) in rows.iter().zip(expected) {
            for (a, b) in row.iter().zip(want) {
                assert!((a - b).abs() < 1e-6, "{rows:?} against {expected:?}");
            }
        }
        // The identity leaves coordinates where they are.
        assert_eq!(UvTransform::IDENTITY.apply(Vec2::new(0.4, 0.7)), Vec2::new(0.4, 0.7));
    }

    /// Five transforms told apart by their offsets.
    fn distinct_uvs() -> MaterialUvs {
        let t = |x: f32| UvTransform { offset: Vec2::new(x, 0.0), ..UvTransform::IDENTITY };
        MaterialUvs {
            base_color: t(1.0),
            metallic_roughness: t(2.0),
            normal: t(3.0),
            emissive: t(4.0),
            occlusion: t(5.0),
        }
    }

    /// The GPU record reads the five in a fixed order; a swap would put one
    /// texture's transform on another.
    #[test]
    fn the_record_order_is_base_metallic_roughness_normal_emissive_occlusion() {
        let offsets = distinct_uvs().in_record_order().map(|t| t.offset.x);
        assert_eq!(offsets, [1.0, 2.0, 3.0, 4.0, 5.0]);
    }

    #[test]
    fn uvs_are_the_identity_only_when_all_five_are() {
        assert!(MaterialUvs::default().is_identity());
        assert!(!distinct_uvs().is_identity());
        // One texture on set 1 is enough to make the whole not the identity.
        let occlusion_on_set_1 =
            MaterialUvs { occlusion: UvTransform { uv_set: 1, ..UvTransform::IDENTITY }, ..MaterialUvs::default() };
        assert!(!occlusion_on_set_1.is_identity());
    }

    /// Sanitising keeps finite transforms as they are and repairs the rest
    /// field by field: a non-finite offset, rotation or scale becomes the
    /// identity's, a set past 1 becomes 1.
    #[test]
    fn sanitizing_keeps_valid_uv_transforms_and_repairs_broken_ones() {
        let mut material = Material::opaque("m", Vec4::ONE);
        material.uvs = distinct_uvs();
        material.uvs.normal = UvTransform {
            uv_set: 7,
            offset: Vec2::new(f32::NAN, 0.5),
            rotation: f32::INFINITY,
            scale: Vec2::new(2.0, 3.0),
        };
        material.uvs.emissive =
            UvTransform { uv_set: 1, offset: Vec2::new(0.25, 0.5), rotation: 0.5, scale: Vec2::new(1.0, f32::NAN) };
        let uvs = material.sanitized().uvs;
        let mut want = distinct_uvs();
        want.normal = UvTransform { uv_set: 1, offset: Vec2::ZERO, rotation: 0.0, scale: Vec2::new(2.0, 3.0) };
        want.emissive = UvTransform { uv_set: 1, offset: Vec2::new(0.25, 0.5), rotation: 0.5, scale: Vec2::ONE };
        assert_eq!(uvs, want);
    }
}
