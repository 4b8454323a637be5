//! The scene as rays see it, for the path-traced reference: a bounding
//! volume hierarchy builder ([`bvh`]) and the two-level ray scene built from
//! the frame's collection ([`RayScene`]).
//!
//! It lives beside ScenePrep's raster route (collect → finalize) because it
//! reads the same frame collection and geometry slots, but nothing on that
//! route depends on it: a renderer without a reference view never builds it.

pub mod bvh;
mod scene;

pub use scene::{POSED, RayInstance, RayScene};
