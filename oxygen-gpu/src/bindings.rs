//! Bind-group layouts declared with typed entries.
//!
//! A `wgpu::BindGroupLayoutEntry` written out by hand takes ten lines for
//! what is one fact ("binding 2: a uniform block of `Params`, fragment
//! stage"). [`LayoutEntries`] lists a group's entries in binding order with
//! one visibility, numbering them 0, 1, 2, … as they are pushed; the
//! functions of this module name the binding types:
//!
//! ```
//! use oxygen_gpu::bindings::{self, LayoutEntries};
//!
//! let entries = LayoutEntries::new(wgpu::ShaderStages::FRAGMENT)
//!     .push(bindings::texture_2d(bindings::FILTERABLE_FLOAT)) // 0
//!     .push(bindings::sampler_filtering()) // 1
//!     .push(bindings::uniform_of::<[f32; 4]>()); // 2
//! assert_eq!(entries.entries()[2].binding, 2);
//! ```
//!
//! A layout with gaps, or whose entries depend on a feature, places the next
//! entry with [`LayoutEntries::at`] (or [`LayoutEntries::skip`]) and changes
//! the stages of the entries that follow with [`LayoutEntries::visibility`].
//! The entries come out exactly as a hand-written list would, in the order
//! pushed.

use std::num::NonZeroU32;

/// A float texture that may be sampled with a filtering sampler.
pub const FILTERABLE_FLOAT: wgpu::TextureSampleType = wgpu::TextureSampleType::Float { filterable: true };

/// A float texture read without filtering (`textureLoad`, or a format that
/// cannot be filtered such as `Rgba32Float`).
pub const UNFILTERABLE_FLOAT: wgpu::TextureSampleType = wgpu::TextureSampleType::Float { filterable: false };

/// The entries of one bind-group layout, numbered in the order they are
/// pushed unless placed with [`LayoutEntries::at`].
#[derive(Clone, Debug)]
pub struct LayoutEntries {
    visibility: wgpu::ShaderStages,
    next: u32,
    entries: Vec<wgpu::BindGroupLayoutEntry>,
}

impl LayoutEntries {
    /// An empty list whose entries are visible to `visibility`, the first
    /// at binding 0.
    pub fn new(visibility: wgpu::ShaderStages) -> Self {
        LayoutEntries { visibility, next: 0, entries: Vec::new() }
    }

    /// Adds an entry of type `ty` at the next binding number.
    pub fn push(self, ty: wgpu::BindingType) -> Self {
        self.push_entry(ty, None)
    }

    /// Adds `n` entries of type `ty` at the next `n` binding numbers (one
    /// binding each, unlike [`LayoutEntries::push_array`]).
    pub fn repeat(self, n: u32, ty: wgpu::BindingType) -> Self {
        (0..n).fold(self, |entries, _| entries.push(ty))
    }

    /// Adds a binding array of `count` elements of type `ty` at the next
    /// binding number (WGSL `binding_array<T, count>`).
    ///
    /// # Panics
    ///
    /// If `count` is 0.
    pub fn push_array(self, ty: wgpu::BindingType, count: u32) -> Self {
        let count = NonZeroU32::new(count).expect("a binding array has at least one element");
        self.push_entry(ty, Some(count))
    }

    /// Places the next entry at `binding` (the ones after it follow on from
    /// there): for a layout with gaps, or numbered by named constants.
    pub fn at(mut self, binding: u32) -> Self {
        self.next = binding;
        self
    }

    /// Leaves `n` binding numbers unused before the next entry.
    pub fn skip(mut self, n: u32) -> Self {
        self.next += n;
        self
    }

    /// Makes the entries pushed from now on visible to `visibility` (those
    /// already pushed keep theirs).
    pub fn visibility(mut self, visibility: wgpu::ShaderStages) -> Self {
        self.visibility = visibility;
        self
    }

    /// The entries, in the order they were pushed.
    pub fn entries(&self) -> &[wgpu::BindGroupLayoutEntry] {
        &self.entries
    }

    /// The entries, in the order they were pushed.
    pub fn into_vec(self) -> Vec<wgpu::BindGroupLayoutEntry> {
        self.entries
    }

    /// Creates the bind-group layout of these entries on `device`.
    pub fn create_layout(&self, device: &wgpu::Device, label: &str) -> wgpu::BindGroupLayout {
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries: &self.entries })
    }

    fn push_entry(mut self, ty: wgpu::BindingType, count: Option<NonZeroU32>) -> Self {
        let binding = self.next;
        debug_assert!(self.entries.iter().all(|e| e.binding != binding), "binding {binding} is already in this layout");
        self.entries.push(wgpu::BindGroupLayoutEntry { binding, visibility: self.visibility, ty, count });
        self.next = binding + 1;
        self
    }
}

impl From<LayoutEntries> for Vec<wgpu::BindGroupLayoutEntry> {
    fn from(entries: LayoutEntries) -> Self {
        entries.into_vec()
    }
}

fn buffer(ty: wgpu::BufferBindingType, has_dynamic_offset: bool, min_size: u64) -> wgpu::BindingType {
    // `BufferSize::new(0)` is `None`: no minimum size.
    wgpu::BindingType::Buffer { ty, has_dynamic_offset, min_binding_size: wgpu::BufferSize::new(min_size) }
}

/// A uniform buffer of any size (no minimum checked at bind time).
pub const fn uniform() -> wgpu::BindingType {
    wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Uniform,
        has_dynamic_offset: false,
        min_binding_size: None,
    }
}

/// A uniform buffer holding a `T` (a struct declared with
/// [`gpu_struct!`](crate::gpu_struct!)): wgpu checks at bind time that the
/// bound range is at least `size_of::<T>()` bytes.
pub fn uniform_of<T: bytemuck::Pod>() -> wgpu::BindingType {
    uniform_sized(std::mem::size_of::<T>() as u64)
}

/// A uniform buffer of at least `min_size` bytes (0: no minimum).
pub fn uniform_sized(min_size: u64) -> wgpu::BindingType {
    buffer(wgpu::BufferBindingType::Uniform, false, min_size)
}

/// A uniform buffer holding a `T`, bound at a dynamic offset (one buffer of
/// many `T`s, each draw or pass picking its own).
pub fn dynamic_uniform_of<T: bytemuck::Pod>() -> wgpu::BindingType {
    buffer(wgpu::BufferBindingType::Uniform, true, std::mem::size_of::<T>() as u64)
}

/// A read-only storage buffer of any size (WGSL `var<storage, read>`).
pub const fn storage_read_only() -> wgpu::BindingType {
    wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Storage { read_only: true },
        has_dynamic_offset: false,
        min_binding_size: None,
    }
}

/// A read-write storage buffer of any size (WGSL
/// `var<storage, read_write>`).
pub const fn storage_read_write() -> wgpu::BindingType {
    wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Storage { read_only: false },
        has_dynamic_offset: false,
        min_binding_size: None,
    }
}

const fn texture(
    sample_type: wgpu::TextureSampleType,
    view_dimension: wgpu::TextureViewDimension,
) -> wgpu::BindingType {
    wgpu::BindingType::Texture { sample_type, view_dimension, multisampled: false }
}

/// A single-sampled 2D texture (`texture_2d<f32>`, or `texture_depth_2d`
/// with [`wgpu::TextureSampleType::Depth`]).
pub const fn texture_2d(sample_type: wgpu::TextureSampleType) -> wgpu::BindingType {
    texture(sample_type, wgpu::TextureViewDimension::D2)
}

/// A single-sampled 2D array texture (`texture_2d_array<f32>`).
pub const fn texture_2d_array(sample_type: wgpu::TextureSampleType) -> wgpu::BindingType {
    texture(sample_type, wgpu::TextureViewDimension::D2Array)
}

/// A single-sampled cube texture (`texture_cube<f32>`).
pub const fn texture_cube(sample_type: wgpu::TextureSampleType) -> wgpu::BindingType {
    texture(sample_type, wgpu::TextureViewDimension::Cube)
}

/// A 2D depth texture (`texture_depth_2d`), for comparison sampling or
/// `textureLoad`.
pub const fn depth_2d() -> wgpu::BindingType {
    texture_2d(wgpu::TextureSampleType::Depth)
}

/// A multisampled 2D texture (`texture_multisampled_2d<f32>`), for
/// `textureLoad` of one sample (a depth texture too, with
/// [`UNFILTERABLE_FLOAT`], where GL cannot load a depth binding).
pub const fn texture_2d_multisampled(sample_type: wgpu::TextureSampleType) -> wgpu::BindingType {
    wgpu::BindingType::Texture { sample_type, view_dimension: wgpu::TextureViewDimension::D2, multisampled: true }
}

/// A 2D array depth texture (`texture_depth_2d_array`).
pub const fn depth_2d_array() -> wgpu::BindingType {
    texture_2d_array(wgpu::TextureSampleType::Depth)
}

/// A 2D storage texture of `format` (`texture_storage_2d<format, access>`).
pub const fn storage_texture_2d(format: wgpu::TextureFormat, access: wgpu::StorageTextureAccess) -> wgpu::BindingType {
    wgpu::BindingType::StorageTexture { access, format, view_dimension: wgpu::TextureViewDimension::D2 }
}

/// A filtering sampler (`sampler`, linear filtering allowed).
pub const fn sampler_filtering() -> wgpu::BindingType {
    wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering)
}

/// A non-filtering sampler (`sampler`, nearest only).
pub const fn sampler_non_filtering() -> wgpu::BindingType {
    wgpu::BindingType::Sampler(wgpu::SamplerBindingType::NonFiltering)
}

/// A comparison sampler (`sampler_comparison`), for depth comparisons.
pub const fn sampler_comparison() -> wgpu::BindingType {
    wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison)
}

#[cfg(test)]
mod tests {
    use super::*;

    const FRAGMENT: wgpu::ShaderStages = wgpu::ShaderStages::FRAGMENT;
    const COMPUTE: wgpu::ShaderStages = wgpu::ShaderStages::COMPUTE;

    #[repr(C)]
    #[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
    struct Params {
        a: [f32; 4],
        b: [u32; 8],
    }

    fn same(built: LayoutEntries, by_hand: &[wgpu::BindGroupLayoutEntry]) {
        assert_eq!(built.entries(), by_hand);
        assert_eq!(format!("{:?}", built.entries()), format!("{by_hand:?}"));
    }

    #[test]
    fn sequential_texture_sampler_dynamic_uniform() {
        // The cube filter's layout.
        let by_hand = [
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: FRAGMENT,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 2,
                visibility: FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: wgpu::BufferSize::new(std::mem::size_of::<Params>() as u64),
                },
                count: None,
            },
        ];
        let built = LayoutEntries::new(FRAGMENT)
            .push(texture_2d_array(FILTERABLE_FLOAT))
            .push(sampler_filtering())
            .push(dynamic_uniform_of::<Params>());
        same(built, &by_hand);
    }

    #[test]
    fn gaps_storage_and_storage_texture() {
        // The reference tracer's layout: bindings 1 to 3 unused.
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let by_hand = [
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
            storage(4, true),
            storage(5, false),
            wgpu::BindGroupLayoutEntry {
                binding: 6,
                visibility: COMPUTE,
                ty: wgpu::BindingType::StorageTexture {
                    access: wgpu::StorageTextureAccess::WriteOnly,
                    format: wgpu::TextureFormat::Rgba16Float,
                    view_dimension: wgpu::TextureViewDimension::D2,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 7,
                visibility: COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: wgpu::BufferSize::new(4096),
                },
                count: None,
            },
        ];
        let built = LayoutEntries::new(COMPUTE)
            .push(uniform())
            .skip(3)
            .push(storage_read_only())
            .push(storage_read_write())
            .push(storage_texture_2d(wgpu::TextureFormat::Rgba16Float, wgpu::StorageTextureAccess::WriteOnly))
            .push(uniform_sized(4096));
        same(built, &by_hand);
        // `at` places the same entries.
        let placed = LayoutEntries::new(COMPUTE)
            .push(uniform())
            .at(4)
            .push(storage_read_only())
            .push(storage_read_write())
            .push(storage_texture_2d(wgpu::TextureFormat::Rgba16Float, wgpu::StorageTextureAccess::WriteOnly))
            .push(uniform_sized(4096));
        same(placed, &by_hand);
    }

    #[test]
    fn repeated_depth_maps_comparison_sampler_and_sized_uniform_out_of_order() {
        // The shape of the lighting inputs: repeated depth maps, then
        // entries placed by named binding numbers, not in ascending order.
        let map = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Depth,
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let mut by_hand: Vec<_> = (0..4).map(map).collect();
        by_hand.push(wgpu::BindGroupLayoutEntry {
            binding: 4,
            visibility: FRAGMENT,
            ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
            count: None,
        });
        by_hand.push(wgpu::BindGroupLayoutEntry {
            binding: 6,
            visibility: FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: wgpu::BufferSize::new(std::mem::size_of::<Params>() as u64),
            },
            count: None,
        });
        by_hand.push(wgpu::BindGroupLayoutEntry {
            binding: 5,
            visibility: FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Depth,
                view_dimension: wgpu::TextureViewDimension::D2Array,
                multisampled: false,
            },
            count: None,
        });
        let built = LayoutEntries::new(FRAGMENT)
            .repeat(4, depth_2d())
            .push(sampler_comparison())
            .at(6)
            .push(uniform_of::<Params>())
            .at(5)
            .push(depth_2d_array());
        same(built, &by_hand);
    }

    #[test]
    fn binding_array_and_visibility_per_entry() {
        // The bindless texture heap's binding-array path, then entries
        // whose stages differ (the bindless domains).
        let both = FRAGMENT.union(COMPUTE);
        let sampler = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: both,
            ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
            count: None,
        };
        let by_hand = [
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: both,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: NonZeroU32::new(256),
            },
            sampler(1),
            sampler(2),
            sampler(3),
            wgpu::BindGroupLayoutEntry {
                binding: 5,
                visibility: COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: true },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
        ];
        let built = LayoutEntries::new(both)
            .push_array(texture_2d(FILTERABLE_FLOAT), 256)
            .repeat(3, sampler_filtering())
            .visibility(COMPUTE)
            .skip(1)
            .push(storage_read_only());
        same(built, &by_hand);
    }

    #[test]
    fn constructors_name_their_types() {
        assert_eq!(uniform(), uniform_sized(0));
        assert_eq!(
            texture_cube(UNFILTERABLE_FLOAT),
            wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::Cube,
                multisampled: false,
            }
        );
        assert_eq!(sampler_non_filtering(), wgpu::BindingType::Sampler(wgpu::SamplerBindingType::NonFiltering));
        let list: Vec<wgpu::BindGroupLayoutEntry> = LayoutEntries::new(FRAGMENT).push(uniform()).into();
        assert_eq!(list.len(), 1);
    }

    #[test]
    #[should_panic(expected = "at least one element")]
    fn an_empty_binding_array_is_refused() {
        let _ = LayoutEntries::new(FRAGMENT).push_array(sampler_filtering(), 0);
    }
}
