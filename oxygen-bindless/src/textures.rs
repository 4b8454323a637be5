//! Textures addressed by slot, on every backend.
//!
//! A material names its texture by a slot in the `TextureLocations` domain.
//! How a shader turns that slot into texels depends on the path chosen at
//! device creation:
//!
//! * [`TexturePath::BindingArray`]: one `binding_array<texture_2d<f32>, N>`
//!   indexed by the slot (needs texture binding arrays with non-uniform
//!   indexing: Vulkan with descriptor indexing, Metal, DX12);
//! * [`TexturePath::GroupedArrays`]: works wherever `texture_2d_array` does
//!   (GL included). Textures are resampled to one of three square size
//!   classes (64, 512, 2048) and stored as layers of one array per size
//!   class and colour space: six arrays, which with the lighting inputs
//!   stay within GL's 16 sampled textures per shader stage. The slot's
//!   location record says which array and layer (bits 0–23 layer, 24–26
//!   array, 27 nearest, 29–31 wrap). GL pairs each texture with one sampler,
//!   so every array has one (repeat, linear): other wrap modes are applied
//!   to the coordinates in the shader, and nearest filtering is a
//!   `textureLoad` of the texel under the coordinate.
//!
//! Textures sampled with a linear filter get a full mip chain, built on the
//! CPU by 2 × 2 box filtering in linear light (sRGB texels are decoded
//! first), and are sampled trilinearly with the UV derivatives the fragment
//! shader passes in; nearest-filtered textures read level 0 only, so that
//! their hard edges stay hard (on the binding-array path they have no other
//! level). The binding-array path binds a table of six samplers (wrap
//! repeat / clamp / mirror × filter linear / nearest) and the location
//! record carries the sampler's index in bits 29–31.

use std::num::NonZeroU32;

use crate::{Allocation, BindlessError, DomainKind, SlotAllocators};

/// Texture slots a binding array holds.
pub const MAX_TEXTURES: u32 = 256;
const SIZE_CLASSES: [u32; 3] = [64, 512, 2048];
/// Grouped path: one array per size class × colour space.
const GROUPS: usize = SIZE_CLASSES.len() * 2;
/// Grouped path: the repeat-linear sampler (table entry 0).
const GROUPED_SAMPLERS: u32 = 1;
/// Grouped path: location-record bit of nearest-filtered textures.
const NEAREST_BIT: u32 = 1 << 27;

fn group_of(class: usize, srgb: bool) -> usize {
    class * 2 + usize::from(!srgb)
}
fn group_side(g: usize) -> u32 {
    SIZE_CLASSES[g / 2]
}
fn group_is_srgb(g: usize) -> bool {
    g.is_multiple_of(2)
}
/// Every array has its class's full chain (nearest layers use level 0 only).
fn group_mip_levels(g: usize) -> u32 {
    mip_level_count(group_side(g), group_side(g))
}
/// Samplers in the table: wrap (repeat, clamp, mirror) × filter (linear, nearest).
pub const SAMPLERS: u32 = 6;
const SAMPLER_SHIFT: u32 = 29;

/// How textures are bound.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TexturePath {
    /// One binding array indexed by slot.
    BindingArray,
    /// Texture arrays grouped by size class and colour space.
    GroupedArrays,
}

impl TexturePath {
    /// Device features the binding-array path needs.
    pub const BINDING_ARRAY_FEATURES: wgpu::Features = wgpu::Features::TEXTURE_BINDING_ARRAY
        .union(wgpu::Features::SAMPLED_TEXTURE_AND_STORAGE_BUFFER_ARRAY_NON_UNIFORM_INDEXING);

    /// Whether a device with these features and limits can use this path.
    pub fn is_supported(self, features: wgpu::Features, limits: &wgpu::Limits) -> bool {
        match self {
            TexturePath::GroupedArrays => true,
            TexturePath::BindingArray => {
                features.contains(Self::BINDING_ARRAY_FEATURES)
                    && limits.max_binding_array_elements_per_shader_stage >= MAX_TEXTURES
            }
        }
    }

    /// The binding array where supported, grouped arrays otherwise.
    pub fn best_for(features: wgpu::Features, limits: &wgpu::Limits) -> Self {
        if TexturePath::BindingArray.is_supported(features, limits) {
            TexturePath::BindingArray
        } else {
            TexturePath::GroupedArrays
        }
    }

    /// WGSL declarations of group 2 and `sample_texture(slot, uv, duv_dx,
    /// duv_dy)`, which returns opaque white for [`crate::INVALID_SLOT`]. The
    /// caller passes the UV's screen derivatives (taken in uniform control
    /// flow), which pick the mip level.
    pub fn wgsl(self) -> String {
        match self {
            TexturePath::BindingArray => {
                let mut out = format!(
                    "@group(2) @binding(0) var texture_array: binding_array<texture_2d<f32>, {MAX_TEXTURES}>;\n"
                );
                out.push_str(&sampler_declarations(1, SAMPLERS));
                out.push_str(&format!(
                    "fn sample_texture(slot: u32, uv: vec2<f32>, duv_dx: vec2<f32>, duv_dy: vec2<f32>) -> vec4<f32> {{\n\
                     \x20   if slot >= {MAX_TEXTURES}u {{ return vec4<f32>(1.0); }}\n\
                     \x20   let location = texture_location_domain[slot];\n\
                     \x20   switch location >> {SAMPLER_SHIFT}u {{\n"
                ));
                for k in 0..SAMPLERS {
                    out.push_str(&format!(
                        "        case {k}u: {{ return textureSampleGrad(texture_array[slot], texture_sampler_{k}, uv, duv_dx, duv_dy); }}\n"
                    ));
                }
                out.push_str("        default: { return vec4<f32>(1.0); }\n    }\n}\n");
                out
            }
            TexturePath::GroupedArrays => {
                let mut out = String::new();
                for g in 0..GROUPS {
                    out.push_str(&format!("@group(2) @binding({g}) var texture_group_{g}: texture_2d_array<f32>;\n"));
                }
                out.push_str(&sampler_declarations(GROUPS as u32, GROUPED_SAMPLERS));
                out.push_str(
                    "fn wrap_uv(uv: vec2<f32>, wrap: u32, side: f32) -> vec2<f32> {\n\
                     \x20   switch wrap {\n\
                     \x20       case 1u: { let h = 0.5 / side; return clamp(uv, vec2<f32>(h), vec2<f32>(1.0 - h)); }\n\
                     \x20       case 2u: { return 1.0 - abs(fract(uv * 0.5) * 2.0 - 1.0); }\n\
                     \x20       default: { return uv; }\n\
                     \x20   }\n\
                     }\n\
                     fn nearest_texel(uv: vec2<f32>, wrap: u32, side: f32) -> vec2<i32> {\n\
                     \x20   var w = fract(uv);\n\
                     \x20   if wrap == 1u { w = clamp(uv, vec2<f32>(0.0), vec2<f32>(1.0)); }\n\
                     \x20   if wrap == 2u { w = 1.0 - abs(fract(uv * 0.5) * 2.0 - 1.0); }\n\
                     \x20   return clamp(vec2<i32>(floor(w * side)), vec2<i32>(0), vec2<i32>(i32(side) - 1));\n\
                     }\n\
                     fn sample_texture(slot: u32, uv: vec2<f32>, duv_dx: vec2<f32>, duv_dy: vec2<f32>) -> vec4<f32> {\n\
                     \x20   if slot == INVALID_SLOT { return vec4<f32>(1.0); }\n\
                     \x20   let location = texture_location_domain[slot];\n\
                     \x20   let layer = location & 0xffffffu;\n\
                     \x20   let wrap = location >> 29u;\n\
                     \x20   let nearest = (location & 0x8000000u) != 0u;\n\
                     \x20   switch (location >> 24u) & 7u {\n",
                );
                for g in 0..GROUPS {
                    let side = group_side(g);
                    out.push_str(&format!(
                        "        case {g}u: {{\n\
                         \x20           if nearest {{ return textureLoad(texture_group_{g}, nearest_texel(uv, wrap, {side}.0), layer, 0); }}\n\
                         \x20           return textureSampleGrad(texture_group_{g}, texture_sampler_0, wrap_uv(uv, wrap, {side}.0), layer, duv_dx, duv_dy);\n\
                         \x20       }}\n"
                    ));
                }
                out.push_str("        default: { return vec4<f32>(1.0); }\n    }\n}\n");
                out
            }
        }
    }
}

fn sampler_declarations(first_binding: u32, count: u32) -> String {
    (0..count)
        .map(|k| format!("@group(2) @binding({}) var texture_sampler_{k}: sampler;\n", first_binding + k))
        .collect()
}

/// The sampler of table entry `index` (see [`SAMPLERS`]).
fn create_sampler(device: &wgpu::Device, index: u32) -> wgpu::Sampler {
    let wrap = match index / 2 {
        0 => wgpu::AddressMode::Repeat,
        1 => wgpu::AddressMode::ClampToEdge,
        _ => wgpu::AddressMode::MirrorRepeat,
    };
    let filter = if index.is_multiple_of(2) { wgpu::FilterMode::Linear } else { wgpu::FilterMode::Nearest };
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("material sampler"),
        address_mode_u: wrap,
        address_mode_v: wrap,
        mag_filter: filter,
        min_filter: filter,
        // Nearest-filtered textures have a single level; linear ones blend levels.
        mipmap_filter: if index.is_multiple_of(2) {
            wgpu::MipmapFilterMode::Linear
        } else {
            wgpu::MipmapFilterMode::Nearest
        },
        ..Default::default()
    })
}

/// One texture to upload: RGBA8 texels and how to sample them.
#[derive(Clone, Copy, Debug)]
pub struct TextureUpload<'a> {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// The texels are sRGB-encoded colour (decoded when sampled).
    pub srgb: bool,
    /// Sampler-table index (wrap × 2 + nearest), see [`SAMPLERS`].
    pub sampler: u32,
    /// Tightly packed RGBA8 rows.
    pub pixels: &'a [u8],
}

struct LayerGroup {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    used_layers: u32,
}

/// The GPU side of the texture domain.
pub(crate) struct TextureHeap {
    path: TexturePath,
    layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    samplers: Vec<wgpu::Sampler>,
    /// Binding-array path: one view per slot (a white placeholder when empty).
    views: Vec<wgpu::TextureView>,
    /// Grouped path: one array per (size class, colour space).
    groups: Vec<LayerGroup>,
    stale_bind_group: bool,
    uploads: u64,
}

fn format_for(srgb: bool) -> wgpu::TextureFormat {
    if srgb { wgpu::TextureFormat::Rgba8UnormSrgb } else { wgpu::TextureFormat::Rgba8Unorm }
}

fn create_texture(
    device: &wgpu::Device,
    side: (u32, u32),
    layers: u32,
    mip_levels: u32,
    srgb: bool,
    label: &str,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: side.0, height: side.1, depth_or_array_layers: layers },
        mip_level_count: mip_levels,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: format_for(srgb),
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

/// Writes one mip level of one layer.
fn write_level(
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    (layer, mip_level): (u32, u32),
    width: u32,
    height: u32,
    pixels: &[u8],
) {
    queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level,
            origin: wgpu::Origin3d { x: 0, y: 0, z: layer },
            aspect: wgpu::TextureAspect::All,
        },
        pixels,
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(width * 4), rows_per_image: Some(height) },
        wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
    );
}

fn array_view(texture: &wgpu::Texture) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    })
}

/// Writes `levels` (level 0 first, as [`mip_chain`] returns them) into one layer.
fn write_levels(queue: &wgpu::Queue, texture: &wgpu::Texture, layer: u32, levels: &[MipLevel]) {
    for (mip, level) in levels.iter().enumerate() {
        write_level(queue, texture, (layer, mip as u32), level.width, level.height, &level.pixels);
    }
}

/// Mip levels of a `width × height` image: down to 1 × 1.
pub fn mip_level_count(width: u32, height: u32) -> u32 {
    u32::BITS - width.max(height).max(1).leading_zeros()
}

/// One level of a mip chain.
#[derive(Clone, Debug, PartialEq)]
pub struct MipLevel {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Tightly packed RGBA8 rows.
    pub pixels: Vec<u8>,
}

/// The full mip chain of an RGBA8 image, level 0 (a copy of `pixels`)
/// first, each level a 2 × 2 box filter of the one above (edges clamped for
/// odd sizes). Colour channels of sRGB images are averaged in linear light
/// and encoded again, so a chequerboard fades to its true mean, not a darker
/// grey; alpha is averaged as stored.
pub fn mip_chain(pixels: &[u8], width: u32, height: u32, srgb: bool) -> Vec<MipLevel> {
    let decode: Vec<f32> = (0..256u32)
        .map(|v| {
            let c = v as f32 / 255.0;
            if !srgb {
                c
            } else if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        })
        .collect();
    let encode = |linear: f32| -> u8 {
        let c = linear.clamp(0.0, 1.0);
        let stored = if !srgb {
            c
        } else if c <= 0.0031308 {
            c * 12.92
        } else {
            1.055 * c.powf(1.0 / 2.4) - 0.055
        };
        (stored * 255.0).round() as u8
    };
    let mut levels = vec![MipLevel { width, height, pixels: pixels.to_vec() }];
    while let Some(above) = levels.last().filter(|l| l.width > 1 || l.height > 1) {
        let (w, h) = ((above.width / 2).max(1), (above.height / 2).max(1));
        let texel = |x: u32, y: u32| {
            let i = (y.min(above.height - 1) as usize * above.width as usize + x.min(above.width - 1) as usize) * 4;
            &above.pixels[i..i + 4]
        };
        let mut out = Vec::with_capacity(w as usize * h as usize * 4);
        for y in 0..h {
            for x in 0..w {
                let quad = [
                    texel(2 * x, 2 * y),
                    texel(2 * x + 1, 2 * y),
                    texel(2 * x, 2 * y + 1),
                    texel(2 * x + 1, 2 * y + 1),
                ];
                for c in 0..3 {
                    out.push(encode(quad.iter().map(|t| decode[t[c] as usize]).sum::<f32>() / 4.0));
                }
                out.push((quad.iter().map(|t| t[3] as u32).sum::<u32>() as f32 / 4.0).round() as u8);
            }
        }
        levels.push(MipLevel { width: w, height: h, pixels: out });
    }
    levels
}

/// Level 0 only (nearest-filtered textures), or the whole chain.
fn levels_for(pixels: &[u8], width: u32, height: u32, srgb: bool, nearest: bool) -> Vec<MipLevel> {
    if nearest {
        vec![MipLevel { width, height, pixels: pixels.to_vec() }]
    } else {
        mip_chain(pixels, width, height, srgb)
    }
}

/// Resampling of RGBA8 texels (in their stored encoding), with texel
/// centres aligned and edges clamped: bilinear, or nearest for textures that
/// will be sampled with a nearest filter (so hard edges stay hard).
pub fn resample_rgba8(src: &[u8], width: u32, height: u32, new_width: u32, new_height: u32, nearest: bool) -> Vec<u8> {
    if (width, height) == (new_width, new_height) {
        return src.to_vec();
    }
    if nearest {
        let mut out = Vec::with_capacity(new_width as usize * new_height as usize * 4);
        for y in 0..new_height {
            let sy = ((y as u64 * height as u64) / new_height as u64) as usize;
            for x in 0..new_width {
                let sx = ((x as u64 * width as u64) / new_width as u64) as usize;
                let i = (sy * width as usize + sx) * 4;
                out.extend_from_slice(&src[i..i + 4]);
            }
        }
        return out;
    }
    let texel = |x: u32, y: u32, c: usize| src[(y as usize * width as usize + x as usize) * 4 + c] as f32;
    let mut out = Vec::with_capacity(new_width as usize * new_height as usize * 4);
    for y in 0..new_height {
        let fy = ((y as f32 + 0.5) * height as f32 / new_height as f32 - 0.5).clamp(0.0, (height - 1) as f32);
        let (y0, ty) = (fy.floor() as u32, fy.fract());
        let y1 = (y0 + 1).min(height - 1);
        for x in 0..new_width {
            let fx = ((x as f32 + 0.5) * width as f32 / new_width as f32 - 0.5).clamp(0.0, (width - 1) as f32);
            let (x0, tx) = (fx.floor() as u32, fx.fract());
            let x1 = (x0 + 1).min(width - 1);
            for c in 0..4 {
                let top = texel(x0, y0, c) * (1.0 - tx) + texel(x1, y0, c) * tx;
                let bottom = texel(x0, y1, c) * (1.0 - tx) + texel(x1, y1, c) * tx;
                out.push((top * (1.0 - ty) + bottom * ty).round() as u8);
            }
        }
    }
    out
}

impl TextureHeap {
    pub(crate) fn new(device: &wgpu::Device, queue: &wgpu::Queue, path: TexturePath) -> Self {
        let texture_entry = |binding, dimension, count| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: true },
                view_dimension: dimension,
                multisampled: false,
            },
            count,
        };
        let sampler_entry = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
            count: None,
        };
        let entries: Vec<_> = match path {
            TexturePath::BindingArray => {
                std::iter::once(texture_entry(0, wgpu::TextureViewDimension::D2, NonZeroU32::new(MAX_TEXTURES)))
                    .chain((0..SAMPLERS).map(|k| sampler_entry(1 + k)))
                    .collect()
            }
            TexturePath::GroupedArrays => (0..GROUPS as u32)
                .map(|g| texture_entry(g, wgpu::TextureViewDimension::D2Array, None))
                .chain((0..GROUPED_SAMPLERS).map(|k| sampler_entry(GROUPS as u32 + k)))
                .collect(),
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("bindless textures"),
            entries: &entries,
        });
        let samplers: Vec<_> = (0..SAMPLERS).map(|k| create_sampler(device, k)).collect();
        let white = [255u8; 4];
        let (views, groups) = match path {
            TexturePath::BindingArray => {
                let placeholder = create_texture(device, (1, 1), 1, 1, true, "texture placeholder");
                write_level(queue, &placeholder, (0, 0), 1, 1, &white);
                let view = placeholder.create_view(&Default::default());
                (vec![view; MAX_TEXTURES as usize], Vec::new())
            }
            TexturePath::GroupedArrays => {
                let groups = (0..GROUPS)
                    .map(|g| {
                        let side = group_side(g);
                        // Layer 0 of each array stays white: an unused array still binds.
                        let texture = create_texture(
                            device,
                            (side, side),
                            1,
                            group_mip_levels(g),
                            group_is_srgb(g),
                            "texture group",
                        );
                        let pixels = vec![255u8; side as usize * side as usize * 4];
                        let levels = mip_chain(&pixels, side, side, group_is_srgb(g));
                        write_levels(queue, &texture, 0, &levels);
                        LayerGroup { view: array_view(&texture), texture, used_layers: 1 }
                    })
                    .collect();
                (Vec::new(), groups)
            }
        };
        let bind_group = build_bind_group(device, &layout, path, &views, &groups, &samplers);
        TextureHeap { path, layout, bind_group, samplers, views, groups, stale_bind_group: false, uploads: 0 }
    }

    pub(crate) fn path(&self) -> TexturePath {
        self.path
    }

    pub(crate) fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    pub(crate) fn bind_group(&self) -> &wgpu::BindGroup {
        &self.bind_group
    }

    pub(crate) fn uploads(&self) -> u64 {
        self.uploads
    }

    /// Stores a texture for `slot` and returns its location record.
    pub(crate) fn upload(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        slot: u32,
        texture: &TextureUpload<'_>,
    ) -> Result<u32, BindlessError> {
        let TextureUpload { width, height, srgb, sampler, pixels } = *texture;
        self.uploads += 1;
        let sampler_bits = sampler.min(SAMPLERS - 1) << SAMPLER_SHIFT;
        self.stale_bind_group = true;
        match self.path {
            TexturePath::BindingArray => {
                if slot >= MAX_TEXTURES {
                    return Err(BindlessError::TooManyTextures { slot, limit: MAX_TEXTURES });
                }
                let levels = levels_for(pixels, width, height, srgb, sampler % 2 == 1);
                let texture = create_texture(device, (width, height), 1, levels.len() as u32, srgb, "material texture");
                write_levels(queue, &texture, 0, &levels);
                self.views[slot as usize] = texture.create_view(&Default::default());
                Ok(sampler_bits | slot)
            }
            TexturePath::GroupedArrays => {
                let side = width.max(height);
                let class = SIZE_CLASSES.iter().position(|c| *c >= side).unwrap_or(SIZE_CLASSES.len() - 1);
                let nearest = sampler % 2 == 1;
                let g = group_of(class, srgb);
                let class_side = SIZE_CLASSES[class];
                let resampled = resample_rgba8(pixels, width, height, class_side, class_side, nearest);
                let group = &mut self.groups[g];
                if group.used_layers == group.texture.depth_or_array_layers() {
                    let layers = group.used_layers * 2;
                    if layers > device.limits().max_texture_array_layers {
                        return Err(BindlessError::TooManyTextures { slot, limit: group.used_layers });
                    }
                    let mips = group_mip_levels(g);
                    let bigger = create_texture(device, (class_side, class_side), layers, mips, srgb, "texture group");
                    let mut encoder = device.create_command_encoder(&Default::default());
                    for mip in 0..mips {
                        let level_side = (class_side >> mip).max(1);
                        encoder.copy_texture_to_texture(
                            wgpu::TexelCopyTextureInfo { mip_level: mip, ..group.texture.as_image_copy() },
                            wgpu::TexelCopyTextureInfo { mip_level: mip, ..bigger.as_image_copy() },
                            wgpu::Extent3d {
                                width: level_side,
                                height: level_side,
                                depth_or_array_layers: group.used_layers,
                            },
                        );
                    }
                    // Submitted now so that the copy lands before this frame's writes.
                    queue.submit([encoder.finish()]);
                    group.view = array_view(&bigger);
                    group.texture = bigger;
                }
                let layer = group.used_layers;
                group.used_layers += 1;
                // The whole chain even for nearest textures: the array's layers share a level count.
                write_levels(queue, &group.texture, layer, &mip_chain(&resampled, class_side, class_side, srgb));
                // Here bits 29–31 carry the wrap mode (table index / 2).
                let wrap_bits = (sampler.min(SAMPLERS - 1) / 2) << SAMPLER_SHIFT;
                let nearest_bit = if nearest { NEAREST_BIT } else { 0 };
                Ok(wrap_bits | nearest_bit | (g as u32) << 24 | layer)
            }
        }
    }

    /// Rebuilds the bind group after uploads.
    pub(crate) fn refresh(&mut self, device: &wgpu::Device) {
        if self.stale_bind_group {
            self.stale_bind_group = false;
            self.bind_group =
                build_bind_group(device, &self.layout, self.path, &self.views, &self.groups, &self.samplers);
        }
    }
}

fn build_bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    path: TexturePath,
    views: &[wgpu::TextureView],
    groups: &[LayerGroup],
    samplers: &[wgpu::Sampler],
) -> wgpu::BindGroup {
    let view_refs: Vec<&wgpu::TextureView> = views.iter().collect();
    let entries: Vec<wgpu::BindGroupEntry<'_>> = match path {
        TexturePath::BindingArray => std::iter::once(wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::TextureViewArray(&view_refs),
        })
        .chain(samplers.iter().enumerate().map(|(k, sampler)| wgpu::BindGroupEntry {
            binding: 1 + k as u32,
            resource: wgpu::BindingResource::Sampler(sampler),
        }))
        .collect(),
        TexturePath::GroupedArrays => groups
            .iter()
            .enumerate()
            .map(|(g, group)| wgpu::BindGroupEntry {
                binding: g as u32,
                resource: wgpu::BindingResource::TextureView(&group.view),
            })
            .chain(samplers.iter().take(GROUPED_SAMPLERS as usize).enumerate().map(|(k, sampler)| {
                wgpu::BindGroupEntry {
                    binding: GROUPS as u32 + k as u32,
                    resource: wgpu::BindingResource::Sampler(sampler),
                }
            }))
            .collect(),
    };
    device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("bindless textures"), layout, entries: &entries })
}

/// Allocates one texture slot (a record in the `TextureLocations` domain).
pub fn allocate_texture_slot(slots: &mut SlotAllocators) -> Result<Allocation, crate::SlotError> {
    slots.allocate(DomainKind::TextureLocations, 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grouped_arrays_are_one_per_size_class_and_colour_space() {
        assert_eq!(GROUPS, 6);
        let mut seen = Vec::new();
        for (class, side) in SIZE_CLASSES.iter().enumerate() {
            for srgb in [true, false] {
                let g = group_of(class, srgb);
                assert!(g < GROUPS, "group {g} of class {class}");
                assert_eq!(group_side(g), *side);
                assert_eq!(group_is_srgb(g), srgb);
                assert_eq!(group_mip_levels(g), side.ilog2() + 1);
                seen.push(g);
            }
        }
        seen.sort();
        assert_eq!(seen, (0..GROUPS).collect::<Vec<_>>());
    }

    #[test]
    fn the_grouped_wgsl_reads_the_location_bits_rust_writes() {
        let wgsl = TexturePath::GroupedArrays.wgsl();
        assert_eq!(NEAREST_BIT, 1 << 27);
        assert!(wgsl.contains(&format!("(location & {NEAREST_BIT:#x}u)")), "nearest bit");
        assert!(wgsl.contains(&format!("location >> {SAMPLER_SHIFT}u")), "wrap bits");
        for g in 0..GROUPS {
            assert!(wgsl.contains(&format!("texture_group_{g}")), "group {g} declared");
        }
        assert!(!wgsl.contains(&format!("texture_group_{GROUPS}")));
    }

    #[test]
    fn the_binding_array_path_needs_its_features_and_enough_elements() {
        let enough = wgpu::Limits { max_binding_array_elements_per_shader_stage: MAX_TEXTURES, ..Default::default() };
        let too_few =
            wgpu::Limits { max_binding_array_elements_per_shader_stage: MAX_TEXTURES - 1, ..Default::default() };
        let features = TexturePath::BINDING_ARRAY_FEATURES;
        assert!(TexturePath::BindingArray.is_supported(features, &enough));
        assert!(!TexturePath::BindingArray.is_supported(features, &too_few));
        assert!(!TexturePath::BindingArray.is_supported(wgpu::Features::TEXTURE_BINDING_ARRAY, &enough));
        assert!(TexturePath::GroupedArrays.is_supported(wgpu::Features::empty(), &too_few));
        assert_eq!(TexturePath::best_for(features, &enough), TexturePath::BindingArray);
        assert_eq!(TexturePath::best_for(features, &too_few), TexturePath::GroupedArrays);
    }

    #[test]
    fn mip_chains_halve_down_to_one_texel() {
        assert_eq!(mip_level_count(1, 1), 1);
        assert_eq!(mip_level_count(256, 256), 9);
        assert_eq!(mip_level_count(5, 3), 3);
        let sizes: Vec<_> = mip_chain(&[0; 5 * 3 * 4], 5, 3, true).iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, vec![(5, 3), (2, 1), (1, 1)]);
        // Thin images halve along their long side until both are 1.
        let tall: Vec<_> = mip_chain(&[0; 4 * 4], 1, 4, false).iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(tall, vec![(1, 4), (1, 2), (1, 1)]);
        let wide: Vec<_> = mip_chain(&[0; 4 * 4], 4, 1, false).iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(wide, vec![(4, 1), (2, 1), (1, 1)]);
    }

    /// A black-and-white sRGB chequerboard averages to linear 0.5, which is
    /// sRGB 188, not the 128 a naive average of stored bytes gives; a linear
    /// (non-colour) texture averages its stored values.
    #[test]
    fn srgb_mips_average_in_linear_light() {
        let checker: Vec<u8> =
            [0u8, 255, 255, 0].iter().flat_map(|&v| [v, v, v, if v == 0 { 100 } else { 200 }]).collect();
        let srgb = mip_chain(&checker, 2, 2, true);
        assert_eq!(srgb[1].pixels, vec![188, 188, 188, 150]);
        let linear = mip_chain(&checker, 2, 2, false);
        assert_eq!(linear[1].pixels, vec![128, 128, 128, 150]);
    }

    /// Decoding and encoding are inverse: a flat mid-grey keeps its stored
    /// value down the whole chain in either colour space.
    #[test]
    fn flat_textures_keep_their_value_down_the_chain() {
        let flat = [128u8, 5, 200, 77].repeat(4 * 4);
        for srgb in [true, false] {
            for level in mip_chain(&flat, 4, 4, srgb) {
                assert!(level.pixels.chunks(4).all(|t| t == [128, 5, 200, 77]), "srgb {srgb}: {:?}", level.pixels);
            }
        }
    }

    /// Each texel of a level is the mean of its own 2 × 2 block above:
    /// an 8 × 8 image whose texels all differ checks the indexing.
    #[test]
    fn each_mip_texel_averages_its_own_block() {
        let value = |x: u32, y: u32| (x * 20 + y * 3) as u8;
        let pixels: Vec<u8> = (0..8).flat_map(|y| (0..8).flat_map(move |x| [value(x, y), 0, 0, 255])).collect();
        let chain = mip_chain(&pixels, 8, 8, false);
        for y in 0..4u32 {
            for x in 0..4u32 {
                let sum: u32 = [(0, 0), (1, 0), (0, 1), (1, 1)]
                    .iter()
                    .map(|(dx, dy)| u32::from(value(2 * x + dx, 2 * y + dy)))
                    .sum();
                let expected = (sum as f32 / 4.0).round() as u8;
                let got = chain[1].pixels[((y * 4 + x) * 4) as usize];
                assert!(got.abs_diff(expected) <= 1, "level 1 ({x}, {y}): {got}, expected {expected}");
            }
        }
    }

    #[test]
    fn each_sampler_of_the_table_gets_its_own_binding() {
        let declared = sampler_declarations(3, 2);
        assert_eq!(
            declared,
            "@group(2) @binding(3) var texture_sampler_0: sampler;\n@group(2) @binding(4) var texture_sampler_1: sampler;\n"
        );
        let binding_array = TexturePath::BindingArray.wgsl();
        for k in 0..SAMPLERS {
            assert!(binding_array.contains(&format!("@binding({}) var texture_sampler_{k}: sampler;", 1 + k)));
        }
    }

    #[test]
    fn resampling_keeps_flat_colour_and_cell_centres() {
        let flat = [10u8, 20, 30, 255].repeat(9);
        assert_eq!(resample_rgba8(&flat, 3, 3, 7, 5, false), [10u8, 20, 30, 255].repeat(35));
        assert_eq!(resample_rgba8(&flat, 3, 3, 7, 5, true), [10u8, 20, 30, 255].repeat(35));
        // A 2x2 checker upsampled 32x keeps each cell's colour at its centre.
        let checker = [255u8, 0, 0, 255, 0, 0, 255, 255, 0, 0, 255, 255, 255, 0, 0, 255];
        let big = resample_rgba8(&checker, 2, 2, 64, 64, false);
        let at = |x: usize, y: usize| &big[(y * 64 + x) * 4..(y * 64 + x) * 4 + 4];
        assert_eq!(at(8, 8), &[255, 0, 0, 255]);
        assert_eq!(at(56, 8), &[0, 0, 255, 255]);
        // Nearest keeps the edge hard: the texel just left of the middle is still red.
        let hard = resample_rgba8(&checker, 2, 2, 64, 64, true);
        assert_eq!(&hard[31 * 4..32 * 4], &[255, 0, 0, 255]);
        assert_eq!(&hard[32 * 4..33 * 4], &[0, 0, 255, 255]);
    }

    #[test]
    fn both_paths_declare_sample_texture() {
        for path in [TexturePath::BindingArray, TexturePath::GroupedArrays] {
            assert!(path.wgsl().contains(
                "fn sample_texture(slot: u32, uv: vec2<f32>, duv_dx: vec2<f32>, duv_dy: vec2<f32>) -> vec4<f32>"
            ));
        }
    }
}
