//! What group 2 holds on each texture path, counted once: the sampler table
//! and the grouped path's arrays. The heap creates them and `path` declares
//! them in WGSL; both read these numbers here, so neither depends on the
//! other.

/// Grouped path: the square sides textures are resampled to.
pub(crate) const SIZE_CLASSES: [u32; 3] = [64, 512, 2048];
/// Grouped path: one array per size class × colour space.
pub(crate) const GROUPS: usize = SIZE_CLASSES.len() * 2;
/// Grouped path: the repeat-linear sampler (table entry 0).
pub(crate) const GROUPED_SAMPLERS: u32 = 1;

/// Wrap modes of the sampler table with their WGSL names, in table order:
/// entry `index` wraps with `WRAP_MODES[index / 2]`. The grouped path's
/// shader applies the mode to the coordinate, so its index is emitted into
/// WGSL (`TEXTURE_WRAP_*`).
pub(crate) const WRAP_MODES: [(&str, wgpu::AddressMode); 3] = [
    ("REPEAT", wgpu::AddressMode::Repeat),
    ("CLAMP", wgpu::AddressMode::ClampToEdge),
    ("MIRROR", wgpu::AddressMode::MirrorRepeat),
];

/// Samplers in the table: wrap (repeat, clamp, mirror) × filter (linear, nearest).
pub const SAMPLERS: u32 = WRAP_MODES.len() as u32 * 2;
