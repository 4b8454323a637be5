//! What the crate's own tests and benchmarks reach below the public API,
//! behind the `testing` feature (which the crate's dev-dependency on itself
//! turns on): the sort key and the radix sort of finalization, and the BVH
//! builder and its ray queries. Not part of the public surface.

pub use crate::finalize::radix_sort::radix_sort_by_key;
pub use crate::finalize::sort_key::sort_key;
pub use crate::ray::bvh::{Bvh, BvhNode, ray_triangle, triangle_boxes};
