//! The scene as rays see it, for the path-traced reference: a bounding
//! volume hierarchy builder (`bvh`, crate-private; its flattened
//! [`BvhNode`]s are what the GPU walks) and the two-level ray scene built from
//! the frame's collection ([`RayScene`]).
//!
//! It lives beside ScenePrep's raster route (collect → finalize) because it
//! reads the same frame collection and geometry slots, but nothing on that
//! route depends on it: a renderer without a reference view never builds it.

// The CPU ray queries (`Bvh::closest_hit`, `ray_triangle`) are the
// reference the GPU walk is tested against: only tests call them.
#[cfg_attr(not(any(test, feature = "testing")), allow(dead_code))]
pub(crate) mod bvh;
mod scene;

pub use bvh::BvhNode;
pub use scene::{POSED, RayInstance, RayScene};
