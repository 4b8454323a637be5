//! Finalization: from render items to sorted, partitioned draws.
//!
//! * [`sort_key`]: the 64-bit key (pass class, variant, material, depth);
//! * [`radix_sort`]: the stable sort of draws by key;
//! * `emit` (crate-internal): one view's sorted items become its
//!   `DrawMetadata`, indirect arguments, partitions and slots;
//! * [`partition`]: contiguous `[begin, end)` ranges with one [`PassMask`](crate::PassMask);
//! * [`geometry_cache`]: lazy, cached geometry slots (only meshes some view draws);
//! * [`materials`]: the material table, re-uploaded only when it changed;
//! * [`texture_cache`]: texture slots for the textures materials use.

pub(crate) mod emit;
pub mod geometry_cache;
pub mod materials;
pub mod partition;
pub mod radix_sort;
pub mod sort_key;
pub mod texture_cache;
