//! Textures addressed by slot, on every backend.
//!
//! A material names its texture by a slot in the `TextureLocations` domain.
//! How a shader turns that slot into texels depends on the path chosen at
//! device creation ([`path`]):
//!
//! * [`TexturePath::BindingArray`]: one `binding_array<texture_2d<f32>, N>`
//!   indexed by the slot (needs texture binding arrays with non-uniform
//!   indexing: Vulkan with descriptor indexing, Metal, DX12);
//! * [`TexturePath::GroupedArrays`]: works wherever `texture_2d_array` does
//!   (GL included). Textures are resampled to one of three square size
//!   classes (64, 512, 2048) and stored as layers of one array per size
//!   class and colour space: six arrays, which with the lighting inputs
//!   stay within GL's 16 sampled textures per shader stage. GL pairs each
//!   texture with one sampler, so every array has one (repeat, linear):
//!   other wrap modes are applied to the coordinates in the shader, and
//!   nearest filtering is a `textureLoad` of the texel under the coordinate.
//!
//! The slot's location record says where the texels are and how to sample
//! them; its bit fields are declared once in [`location`] and emitted into
//! WGSL from there. The GPU side (textures, arrays, samplers, uploads) is
//! the [`heap`]; the CPU image work it needs before an upload is in
//! [`mip_chain`] (linear-light box-filtered mip levels) and [`resample`]
//! (size-class resampling for the grouped path).
//!
//! Textures sampled with a linear filter get a full mip chain and are
//! sampled trilinearly with the UV derivatives the fragment shader passes
//! in; nearest-filtered textures read level 0 only, so that their hard edges
//! stay hard (on the binding-array path they have no other level).

pub(crate) mod heap;
pub(crate) mod location;
pub(crate) mod mip_chain;
pub(crate) mod path;
pub(crate) mod resample;
pub(crate) mod tables;

pub(crate) use heap::TextureHeap;
pub use heap::{TextureUpload, allocate_texture_slot};
pub use path::{MAX_TEXTURES, TexturePath};
pub use resample::resample_rgba8;
pub use tables::SAMPLERS;
