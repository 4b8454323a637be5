//! Materials, textures and images.
//!
//! A material's texture references are checked (texture, image and sampler
//! indices in range, enums known) before its textures are loaded. An image's
//! bytes come through [`super::source`] (confined URIs, `data:` URIs, buffer
//! views); only PNG and JPEG are decoded, after their dimensions are read
//! from the header and checked against the limits, so a small file that
//! claims a huge picture is refused before the decoder allocates.

use std::borrow::Cow;
use std::collections::HashMap;
use std::io::Cursor;

use glam::Vec2;
use glam::{Vec3, Vec4};
use gltf::json;
use gltf::json::validation::Checked;
use oxygen_core::{
    AlphaMode, ColorSpace, Filter, Material, MaterialHandle, MaterialUvs, Sampling, Scene, TextureHandle, TextureImage,
    UvTransform, Wrap,
};

use super::limits::{Budget, check};
use super::source::{AssetRootRef, UriError};
use super::{GltfErrorKind, LimitExceeded};

/// Materials and textures of one import, each created once.
pub(crate) struct MaterialImporter<'a> {
    pub(crate) root: &'a json::Root,
    pub(crate) buffers: &'a [Cow<'a, [u8]>],
    pub(crate) folder: AssetRootRef<'a>,
    textures: HashMap<(usize, bool), TextureHandle>,
    materials: HashMap<Option<usize>, MaterialHandle>,
    /// Decoded RGBA8 pixels per image index, shared by its sRGB and linear uses.
    images: HashMap<usize, (u32, u32, Vec<u8>)>,
}

impl<'a> MaterialImporter<'a> {
    pub(crate) fn new(root: &'a json::Root, buffers: &'a [Cow<'a, [u8]>], folder: AssetRootRef<'a>) -> Self {
        MaterialImporter {
            root,
            buffers,
            folder,
            textures: HashMap::new(),
            materials: HashMap::new(),
            images: HashMap::new(),
        }
    }

    /// The scene material for glTF material `index` (`None`: the default).
    pub(crate) fn material(
        &mut self,
        scene: &mut Scene,
        index: Option<usize>,
        budget: &mut Budget,
        warnings: &mut Vec<String>,
    ) -> Result<MaterialHandle, GltfErrorKind> {
        if let Some(h) = self.materials.get(&index) {
            return Ok(*h);
        }
        let default = json::Material::default();
        let m = match index {
            Some(i) => self
                .root
                .materials
                .get(i)
                .ok_or_else(|| GltfErrorKind::Invalid(format!("material {i} does not exist")))?,
            None => &default,
        };
        let label = index.map_or_else(|| "the default material".to_owned(), |i| format!("material {i}"));
        let pbr = &m.pbr_metallic_roughness;
        let mut texture = |this: &mut Self, info: Option<TextureRef>, space, what: &str| {
            let Some(info) = info else { return Ok((None, UvTransform::IDENTITY)) };
            let uv = uv_transform(&info, &label, what, warnings);
            this.texture(scene, info.index.value(), space, budget).map(|t| (Some(t), uv))
        };
        let info = |t: &json::texture::Info| TextureRef {
            index: t.index,
            tex_coord: t.tex_coord,
            transform: t.extensions.as_ref().and_then(|e| e.texture_transform.clone()),
        };
        let (base_color_texture, base_color_uv) =
            texture(self, pbr.base_color_texture.as_ref().map(info), ColorSpace::Srgb, "base-colour")?;
        let (metallic_roughness_texture, metallic_roughness_uv) =
            texture(self, pbr.metallic_roughness_texture.as_ref().map(info), ColorSpace::Linear, "metallic-roughness")?;
        let normal = m.normal_texture.as_ref().map(|t| TextureRef {
            index: t.index,
            tex_coord: t.tex_coord,
            transform: t.extensions.as_ref().and_then(|e| transform_in(e.others.get("KHR_texture_transform"))),
        });
        let (normal_texture, normal_uv) = texture(self, normal, ColorSpace::Linear, "normal")?;
        let (emissive_texture, emissive_uv) =
            texture(self, m.emissive_texture.as_ref().map(info), ColorSpace::Srgb, "emissive")?;
        let occlusion = m.occlusion_texture.as_ref().map(|t| TextureRef {
            index: t.index,
            tex_coord: t.tex_coord,
            transform: t.extensions.as_ref().and_then(|e| transform_in(e.others.get("KHR_texture_transform"))),
        });
        let (occlusion_texture, occlusion_uv) = texture(self, occlusion, ColorSpace::Linear, "occlusion")?;
        let uvs = MaterialUvs {
            base_color: base_color_uv,
            metallic_roughness: metallic_roughness_uv,
            normal: normal_uv,
            emissive: emissive_uv,
            occlusion: occlusion_uv,
        };
        let unlit = m.extensions.as_ref().is_some_and(|e| e.unlit.is_some());
        let alpha_mode = match m.alpha_mode {
            Checked::Valid(json::material::AlphaMode::Opaque) => AlphaMode::Opaque,
            Checked::Valid(json::material::AlphaMode::Mask) => {
                AlphaMode::Mask { cutoff: m.alpha_cutoff.map_or(0.5, |c| c.0) }
            }
            Checked::Valid(json::material::AlphaMode::Blend) => AlphaMode::Blend,
            Checked::Invalid => return Err(GltfErrorKind::Invalid(format!("{label}: unknown alphaMode"))),
        };
        let strength =
            m.extensions.as_ref().and_then(|e| e.emissive_strength.as_ref()).map_or(1.0, |s| s.emissive_strength.0);
        let material = Material {
            name: m.name.clone().unwrap_or_else(|| format!("material {index:?}")),
            base_color: Vec4::from(pbr.base_color_factor.0),
            base_color_texture,
            metallic_roughness_texture,
            normal_texture,
            normal_scale: m.normal_texture.as_ref().map_or(1.0, |n| n.scale),
            emissive: Vec3::from(m.emissive_factor.0) * strength,
            emissive_texture,
            occlusion_texture,
            occlusion_strength: m.occlusion_texture.as_ref().map_or(1.0, |o| o.strength.0),
            metallic: pbr.metallic_factor.0,
            roughness: pbr.roughness_factor.0,
            alpha_mode,
            double_sided: m.double_sided,
            uvs,
            unlit,
        };
        warn_non_finite(&material, &label, warnings);
        let handle = scene.add_material(material);
        self.materials.insert(index, handle);
        Ok(handle)
    }

    fn texture(
        &mut self,
        scene: &mut Scene,
        index: usize,
        color_space: ColorSpace,
        budget: &mut Budget,
    ) -> Result<TextureHandle, GltfErrorKind> {
        let key = (index, color_space == ColorSpace::Srgb);
        if let Some(h) = self.textures.get(&key) {
            return Ok(*h);
        }
        let root = self.root;
        let t = root
            .textures
            .get(index)
            .ok_or_else(|| GltfErrorKind::Invalid(format!("texture {index} does not exist")))?;
        let sampling = match t.sampler {
            None => Sampling::default(),
            Some(s) => {
                let s = s.value();
                let sampler = root
                    .samplers
                    .get(s)
                    .ok_or_else(|| GltfErrorKind::Invalid(format!("texture {index}: sampler {s} does not exist")))?;
                let wrap = |w: Checked<json::texture::WrappingMode>, axis: &str| match w {
                    Checked::Valid(json::texture::WrappingMode::ClampToEdge) => Ok(Wrap::ClampToEdge),
                    Checked::Valid(json::texture::WrappingMode::MirroredRepeat) => Ok(Wrap::MirroredRepeat),
                    Checked::Valid(json::texture::WrappingMode::Repeat) => Ok(Wrap::Repeat),
                    Checked::Invalid => Err(GltfErrorKind::Invalid(format!("sampler {s}: unknown {axis}"))),
                };
                let (wrap_s, wrap_t) = (wrap(sampler.wrap_s, "wrapS")?, wrap(sampler.wrap_t, "wrapT")?);
                let filter = match sampler.mag_filter {
                    Some(Checked::Valid(json::texture::MagFilter::Nearest)) => Filter::Nearest,
                    Some(Checked::Valid(json::texture::MagFilter::Linear)) | None => Filter::Linear,
                    Some(Checked::Invalid) => {
                        return Err(GltfErrorKind::Invalid(format!("sampler {s}: unknown magFilter")));
                    }
                };
                Sampling { wrap_u: wrap_s, wrap_v: wrap_t, filter }
            }
        };
        let source = t.source.value();
        let (width, height, pixels) = self.image(source, budget)?;
        let name = t.name.clone().unwrap_or_else(|| format!("texture {index}"));
        // The texture's own copy of the image's texels, charged before it is made.
        budget
            .spend_bytes(pixels.len() as u64)
            .map_err(|e| GltfErrorKind::Limit { context: format!("texture {index}"), source: e })?;
        let pixels = pixels.to_vec();
        let image = TextureImage::new(name, width, height, color_space, pixels)
            .map_err(|e| GltfErrorKind::Invalid(format!("image {source}: {e}")))?
            .with_sampling(sampling);
        let handle = scene.add_texture(image);
        self.textures.insert(key, handle);
        Ok(handle)
    }

    /// The RGBA8 pixels of image `index`, decoded once.
    fn image(&mut self, index: usize, budget: &mut Budget) -> Result<(u32, u32, &[u8]), GltfErrorKind> {
        if self.images.contains_key(&index) {
            let (w, h, pixels) = &self.images[&index];
            return Ok((*w, *h, pixels));
        }
        let image = self
            .root
            .images
            .get(index)
            .ok_or_else(|| GltfErrorKind::Invalid(format!("image {index} does not exist")))?;
        let cap = budget.limits.max_image_file_bytes;
        let bytes: Cow<'_, [u8]> = match (&image.uri, image.buffer_view) {
            (Some(uri), _) => Cow::Owned(self.folder.read(uri, None, cap).map_err(|source| match source {
                // An image too large is a limit, wherever its bytes are.
                UriError::TooLarge { bytes, max } => GltfErrorKind::Limit {
                    context: format!("image {index}"),
                    source: LimitExceeded { limit: "max_image_file_bytes", value: bytes, max },
                },
                source => GltfErrorKind::Uri { what: format!("image {index}"), uri: uri.clone(), source },
            })?),
            (None, Some(view)) => {
                let vi = view.value();
                let v =
                    self.root.buffer_views.get(vi).ok_or_else(|| {
                        GltfErrorKind::Invalid(format!("image {index}: buffer view {vi} does not exist"))
                    })?;
                let buffer = self.buffers.get(v.buffer.value()).ok_or_else(|| {
                    GltfErrorKind::Invalid(format!("image {index}: buffer {} does not exist", v.buffer.value()))
                })?;
                let start = v.byte_offset.map_or(0, |o| o.0);
                let slice = start
                    .checked_add(v.byte_length.0)
                    .filter(|end| *end <= buffer.len() as u64)
                    .map(|end| &buffer[start as usize..end as usize])
                    .ok_or_else(|| {
                        GltfErrorKind::Invalid(format!("image {index}: buffer view {vi} lies outside its buffer"))
                    })?;
                check("max_image_file_bytes", slice.len() as u64, cap)
                    .map_err(|e| GltfErrorKind::Limit { context: format!("image {index}"), source: e })?;
                Cow::Borrowed(slice)
            }
            (None, None) => {
                return Err(GltfErrorKind::Invalid(format!("image {index} has neither a uri nor a bufferView")));
            }
        };
        let decoded = decode(&bytes, budget).map_err(|e| match e {
            DecodeError::Limit(source) => GltfErrorKind::Limit { context: format!("image {index}"), source },
            DecodeError::Bad(what) => GltfErrorKind::Invalid(format!("image {index}: {what}")),
        })?;
        let (w, h, pixels) = self.images.entry(index).or_insert(decoded);
        Ok((*w, *h, pixels))
    }
}

/// A material's reference to a texture: which texture, which coordinate
/// set, and its `KHR_texture_transform` when it has one.
struct TextureRef {
    index: json::Index<json::Texture>,
    tex_coord: u32,
    transform: Option<json::extensions::texture::TextureTransform>,
}

/// `KHR_texture_transform` from an extension map that gltf-json keeps as
/// raw JSON (normal and occlusion textures); an unreadable one is ignored
/// like any unknown extension data.
fn transform_in(value: Option<&json::Value>) -> Option<json::extensions::texture::TextureTransform> {
    json::deserialize::from_value(value?.clone()).ok()
}

/// The coordinate set and transform of one texture reference. glTF
/// defines sets 0 and 1 for every texture; a later set (2 and up) is read
/// as set 0 with a warning, since Oxygen keeps two.
fn uv_transform(info: &TextureRef, label: &str, what: &str, warnings: &mut Vec<String>) -> UvTransform {
    let mut uv = UvTransform::IDENTITY;
    let mut set = info.tex_coord;
    if let Some(t) = &info.transform {
        uv.offset = Vec2::from(t.offset.0);
        uv.rotation = t.rotation.0;
        uv.scale = Vec2::from(t.scale.0);
        // The extension's texCoord overrides the texture info's.
        set = t.tex_coord.unwrap_or(set);
        if !(uv.offset.is_finite() && uv.rotation.is_finite() && uv.scale.is_finite()) {
            warnings.push(format!("{label}: the {what} texture's transform is not finite; ignored"));
            uv = UvTransform::IDENTITY;
        }
    }
    if set > 1 {
        warnings.push(format!("{label}: the {what} texture uses texcoord set {set}; set 0 is used (Oxygen keeps two)"));
        set = 0;
    }
    uv.uv_set = set;
    uv
}

enum DecodeError {
    Limit(super::LimitExceeded),
    Bad(String),
}

/// Decodes a PNG or JPEG to RGBA8 after checking its header's dimensions
/// against the limits and charging its texels to the budget, so that a small
/// file claiming a large picture is refused before the decoder allocates.
fn decode(bytes: &[u8], budget: &mut Budget) -> Result<(u32, u32, Vec<u8>), DecodeError> {
    let max_dimension = budget.limits.max_texture_dimension;
    let format = image::guess_format(bytes).map_err(|_| DecodeError::Bad("not a PNG or JPEG image".into()))?;
    if !matches!(format, image::ImageFormat::Png | image::ImageFormat::Jpeg) {
        return Err(DecodeError::Bad(format!("{format:?} images are not supported (PNG and JPEG are)")));
    }
    let reader = || image::ImageReader::with_format(Cursor::new(bytes), format);
    let (width, height) = reader().into_dimensions().map_err(|e| DecodeError::Bad(e.to_string()))?;
    check("max_texture_dimension", u64::from(width.max(height)), u64::from(max_dimension))
        .map_err(DecodeError::Limit)?;
    // The RGBA8 texels kept (4 bytes each) are charged; the decoder's own
    // buffer (up to 16-bit RGBA, 8 bytes a texel) must fit beside them for
    // as long as it lives.
    let texels = u64::from(width) * u64::from(height);
    budget.spend_bytes(texels * 4).map_err(DecodeError::Limit)?;
    budget.afford(texels * 8).map_err(DecodeError::Limit)?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(max_dimension);
    limits.max_image_height = Some(max_dimension);
    // The decoder's own buffer (up to 16-bit RGBA) plus our RGBA8 copy.
    limits.max_alloc = Some(u64::from(width) * u64::from(height) * 12 + (1 << 20));
    let mut reader = reader();
    reader.limits(limits);
    let decoded = reader.decode().map_err(|e| DecodeError::Bad(e.to_string()))?;
    let rgba = decoded.into_rgba8();
    Ok((rgba.width(), rgba.height(), rgba.into_raw()))
}

/// Names the material's non-finite factors in a warning. The replacement
/// itself is [`Material::sanitized`], which [`Scene::add_material`] applies
/// to every material, imported or not.
fn warn_non_finite(m: &Material, label: &str, warnings: &mut Vec<String>) {
    let cutoff = match m.alpha_mode {
        AlphaMode::Mask { cutoff } => cutoff,
        _ => 0.5,
    };
    let fields = [
        ("baseColorFactor", m.base_color.is_finite()),
        ("emissive", m.emissive.is_finite()),
        ("metallicFactor", m.metallic.is_finite()),
        ("roughnessFactor", m.roughness.is_finite()),
        ("normalTexture.scale", m.normal_scale.is_finite()),
        ("occlusionTexture.strength", m.occlusion_strength.is_finite()),
        ("alphaCutoff", cutoff.is_finite()),
    ];
    let bad: Vec<&str> = fields.iter().filter(|(_, finite)| !finite).map(|(name, _)| *name).collect();
    if !bad.is_empty() {
        warnings.push(format!("{label}: non-finite {} replaced by defaults", bad.join(", ")));
    }
}

#[cfg(test)]
mod tests {
    use super::super::ImportLimits;
    use super::*;

    /// A transform whose every field differs from the extension's defaults
    /// (offset 0, rotation 0, scale 1, no texCoord), so a default one does
    /// not read back the same.
    fn raw_transform() -> json::Value {
        serde_json::json!({"offset": [0.5, -0.25], "rotation": 0.3, "scale": [2.0, 3.0], "texCoord": 1})
    }

    /// Normal and occlusion textures keep `KHR_texture_transform` as raw
    /// JSON: a readable one is read field by field, an absent or unreadable
    /// one is no transform.
    #[test]
    fn a_raw_texture_transform_is_read_field_by_field_and_an_unreadable_one_is_ignored() {
        let t = transform_in(Some(&raw_transform())).expect("a well-formed transform is read");
        assert_eq!(t.offset.0, [0.5, -0.25]);
        assert_eq!(t.rotation.0, 0.3);
        assert_eq!(t.scale.0, [2.0, 3.0]);
        assert_eq!(t.tex_coord, Some(1));
        assert!(transform_in(None).is_none());
        assert!(transform_in(Some(&serde_json::json!({"rotation": "a quarter turn"}))).is_none());
    }

    /// The texture's transform reaches its `UvTransform`, the extension's
    /// texCoord (1) overriding the texture info's (0); none of it is the
    /// identity a default `UvTransform` is.
    #[test]
    fn a_texture_transform_and_its_tex_coord_become_the_uv_transform() {
        let transform = json::deserialize::from_value(raw_transform()).expect("the transform deserializes");
        let info = TextureRef { index: json::Index::new(0), tex_coord: 0, transform: Some(transform) };
        let mut warnings = Vec::new();
        let uv = uv_transform(&info, "material 0", "normal", &mut warnings);
        let expected =
            UvTransform { uv_set: 1, offset: Vec2::new(0.5, -0.25), rotation: 0.3, scale: Vec2::new(2.0, 3.0) };
        assert_eq!(uv, expected);
        assert!(warnings.is_empty(), "{warnings:?}");
    }

    /// A transform with any one field not finite (1e39 reads as infinity) is
    /// dropped whole with a warning, the others finite: one test per field
    /// tells `a && b && c` from `a || b && c` and `a && (b || c)`. The
    /// extension's texCoord is still used.
    #[test]
    fn a_texture_transform_with_any_one_field_not_finite_is_ignored_with_a_warning() {
        for (field, value) in [("offset", "[1e39, 0.5]"), ("rotation", "1e39"), ("scale", "[2.0, 1e39]")] {
            let mut fields = raw_transform();
            fields[field] = json::deserialize::from_str(value).expect("a JSON value");
            let transform = json::deserialize::from_value(fields).expect("the transform deserializes");
            let info = TextureRef { index: json::Index::new(0), tex_coord: 0, transform: Some(transform) };
            let mut warnings = Vec::new();
            let uv = uv_transform(&info, "material 0", "normal", &mut warnings);
            assert_eq!(uv, UvTransform { uv_set: 1, ..UvTransform::IDENTITY }, "{field}");
            assert_eq!(warnings, ["material 0: the normal texture's transform is not finite; ignored"], "{field}");
        }
    }

    /// Sets 0 and 1 are kept without a warning; 2 and up (2 is the boundary
    /// a `>=` or `==` in place of `>` moves) read set 0 with a warning.
    #[test]
    fn texcoord_sets_0_and_1_are_kept_and_a_later_set_reads_set_0_with_a_warning() {
        for (tex_coord, expected_set, warned) in [(0, 0, false), (1, 1, false), (2, 0, true), (5, 0, true)] {
            let info = TextureRef { index: json::Index::new(0), tex_coord, transform: None };
            let mut warnings = Vec::new();
            let uv = uv_transform(&info, "material 0", "emissive", &mut warnings);
            assert_eq!(uv, UvTransform { uv_set: expected_set, ..UvTransform::IDENTITY }, "texCoord {tex_coord}");
            let expected_warning = format!(
                "material 0: the emissive texture uses texcoord set {tex_coord}; set 0 is used (Oxygen keeps two)"
            );
            assert_eq!(warnings, if warned { vec![expected_warning] } else { vec![] }, "texCoord {tex_coord}");
        }
    }

    /// A PNG of `width` × `height` texels.
    fn png(width: u32, height: u32) -> Vec<u8> {
        let mut bytes = Cursor::new(Vec::new());
        image::RgbaImage::new(width, height).write_to(&mut bytes, image::ImageFormat::Png).expect("the PNG encodes");
        bytes.into_inner()
    }

    /// The RGBA8 texels kept are charged at 4 bytes each: 3 × 2 texels are
    /// 24 bytes, where `6 + 4` or `6 / 4` would charge 10 or 1.
    #[test]
    fn a_decoded_image_charges_four_bytes_a_texel_to_the_budget() {
        let mut budget = Budget::new(ImportLimits::default());
        let Ok((width, height, pixels)) = decode(&png(3, 2), &mut budget) else { panic!("the PNG decodes") };
        assert_eq!((width, height, pixels.len()), (3, 2, 24));
        assert_eq!(budget.total_bytes(), 24);
    }

    /// Beside the 4 bytes a texel kept, the decoder's buffer (8 bytes a
    /// texel) must fit for a moment: 3 × 2 texels need 24 + 48 bytes, so a
    /// total of 72 decodes and 71 is refused naming the 72, where a `+` or
    /// `/` in place of the `*` would ask for far less.
    #[test]
    fn a_decoders_buffer_of_eight_bytes_a_texel_must_fit_beside_the_texels_kept() {
        let budget = |max_total_bytes| Budget::new(ImportLimits { max_total_bytes, ..ImportLimits::default() });
        assert!(decode(&png(3, 2), &mut budget(72)).is_ok(), "72 bytes are enough");
        let Err(DecodeError::Limit(refused)) = decode(&png(3, 2), &mut budget(71)) else {
            panic!("71 bytes are too few")
        };
        assert_eq!(refused, LimitExceeded { limit: "max_total_bytes", value: 72, max: 71 });
    }

    /// A finite material gets no warning; each non-finite factor alone is
    /// named in one warning, and two at once in the same one.
    #[test]
    fn non_finite_factors_are_named_in_one_warning_and_a_finite_material_gets_none() {
        type Edit = fn(&mut Material);
        let warned = |edit: Edit| {
            let mut material = Material::opaque("m", Vec4::ONE);
            edit(&mut material);
            let mut warnings = Vec::new();
            warn_non_finite(&material, "material 3", &mut warnings);
            warnings
        };
        assert!(warned(|_| {}).is_empty(), "a finite material");
        let cases: [(&str, Edit); 7] = [
            ("baseColorFactor", |m| m.base_color.y = f32::NAN),
            ("emissive", |m| m.emissive.z = f32::INFINITY),
            ("metallicFactor", |m| m.metallic = f32::NAN),
            ("roughnessFactor", |m| m.roughness = f32::NEG_INFINITY),
            ("normalTexture.scale", |m| m.normal_scale = f32::NAN),
            ("occlusionTexture.strength", |m| m.occlusion_strength = f32::INFINITY),
            ("alphaCutoff", |m| m.alpha_mode = AlphaMode::Mask { cutoff: f32::NAN }),
        ];
        for (name, edit) in cases {
            assert_eq!(warned(edit), [format!("material 3: non-finite {name} replaced by defaults")]);
        }
        let both = warned(|m| {
            m.metallic = f32::NAN;
            m.alpha_mode = AlphaMode::Mask { cutoff: f32::INFINITY };
        });
        assert_eq!(both, ["material 3: non-finite metallicFactor, alphaCutoff replaced by defaults"]);
    }
}
