//! Finalization: from render items to sorted, partitioned draws.
//!
//! ScenePrep's own (the crate re-exports the [`MaterialFeatures`](materials::MaterialFeatures)
//! the material table reports):
//!
//! * `sort_key`: the 64-bit key (pass class, variant, material, depth);
//! * `radix_sort`: the stable sort of draws by key;
//! * `emit`: one view's sorted items become its `DrawMetadata`, indirect
//!   arguments, partitions and slots;
//! * `partition`: contiguous `[begin, end)` ranges with one [`PassMask`](crate::PassMask);
//! * `geometry_cache`: lazy, cached geometry slots (only meshes some view draws);
//! * [`materials`]: the material table, re-uploaded only when it changed;
//! * `texture_cache`: texture slots for the textures materials use;
//! * `triangle_table`: each geometry's indices as uploaded, with the
//!   table that finds a triangle from its first corner (deferred shading).

pub(crate) mod emit;
pub(crate) mod geometry_cache;
pub mod materials;
pub(crate) mod partition;
pub(crate) mod radix_sort;
pub(crate) mod sort_key;
pub(crate) mod texture_cache;
pub(crate) mod triangle_table;
