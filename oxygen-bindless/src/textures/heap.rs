//! The texture heap: the GPU textures (one per slot, or layers of grouped
//! arrays), the sampler table and the bind group of group 2, and the upload
//! that fills a slot and returns its location record.
//!
//! The heap creates textures and writes texels; it never decides the path
//! (that is [`TexturePath::best_for`]) nor computes mip levels or resampled
//! texels itself (`mip_chain`, `resample`).

use oxygen_gpu::bindings::{self, LayoutEntries};

use super::location::{binding_array_record, grouped_record};
use super::mip_chain::{MipLevel, mip_chain, mip_level_count};
use super::path::{MAX_TEXTURES, TexturePath};
use super::resample::resample_rgba8;
use super::tables::{GROUPED_SAMPLERS, GROUPS, SAMPLERS, SIZE_CLASSES, WRAP_MODES};
use crate::{Allocation, BindlessError, DomainKind, SlotAllocators};

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

/// The sampler of table entry `index` (see [`SAMPLERS`]).
fn create_sampler(device: &wgpu::Device, index: u32) -> wgpu::Sampler {
    let wrap = WRAP_MODES[(index as usize / 2).min(WRAP_MODES.len() - 1)].1;
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
    /// Sampler-table index (wrap along u × 2 + nearest), see [`SAMPLERS`].
    pub sampler: u32,
    /// Wrap mode along v (0 repeat, 1 clamp, 2 mirrored repeat); where it
    /// differs from u's, the shader wraps v itself.
    pub wrap_v: u32,
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
    oxygen_gpu::texture_2d(
        device,
        label,
        wgpu::Extent3d { width: side.0, height: side.1, depth_or_array_layers: layers },
        mip_levels,
        format_for(srgb),
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::COPY_SRC,
    )
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

/// The mip chain of an all-white square of `side` texels: every level is
/// white, so it is written directly instead of filtered. (Filtering it took
/// most of a renderer's start-up on the grouped-arrays path: the largest
/// group is 2 048 texels a side, filtered per group at every start.)
fn white_levels(side: u32, levels: u32) -> Vec<MipLevel> {
    (0..levels)
        .map(|mip| {
            let side = (side >> mip).max(1);
            MipLevel { width: side, height: side, pixels: vec![255u8; side as usize * side as usize * 4] }
        })
        .collect()
}

/// Level 0 only (nearest-filtered textures), or the whole chain.
fn levels_for(pixels: &[u8], width: u32, height: u32, srgb: bool, nearest: bool) -> Vec<MipLevel> {
    if nearest {
        vec![MipLevel { width, height, pixels: pixels.to_vec() }]
    } else {
        mip_chain(pixels, width, height, srgb)
    }
}

impl TextureHeap {
    pub(crate) fn new(device: &wgpu::Device, queue: &wgpu::Queue, path: TexturePath) -> Self {
        // Compute too: the path-traced reference samples materials.
        let entries = LayoutEntries::new(wgpu::ShaderStages::FRAGMENT.union(wgpu::ShaderStages::COMPUTE));
        let layout = match path {
            TexturePath::BindingArray => entries
                .push_array(bindings::texture_2d(bindings::FILTERABLE_FLOAT), MAX_TEXTURES)
                .repeat(SAMPLERS, bindings::sampler_filtering()),
            TexturePath::GroupedArrays => entries
                .repeat(GROUPS as u32, bindings::texture_2d_array(bindings::FILTERABLE_FLOAT))
                .repeat(GROUPED_SAMPLERS, bindings::sampler_filtering()),
        }
        .create_layout(device, "bindless textures");
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
                        write_levels(queue, &texture, 0, &white_levels(side, group_mip_levels(g)));
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
        let TextureUpload { width, height, srgb, sampler, wrap_v, pixels } = *texture;
        self.uploads += 1;
        let table_entry = sampler.min(SAMPLERS - 1);
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
                Ok(binding_array_record(slot, table_entry, wrap_v))
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
                // The shader applies the wrap mode itself: the record carries it, not the table index.
                Ok(grouped_record(g as u32, layer, table_entry / 2, wrap_v, nearest))
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
    fn white_levels_are_the_filtered_chain_of_white() {
        // The shortcut writes what filtering would: same sizes, same texels,
        // in both colour spaces (a square side and an odd one).
        for side in [16u32, 5] {
            for srgb in [true, false] {
                let filtered = mip_chain(&vec![255u8; side as usize * side as usize * 4], side, side, srgb);
                assert_eq!(white_levels(side, mip_level_count(side, side)), filtered, "side {side}, srgb {srgb}");
            }
        }
    }
}
