//! Bounding volumes, frustum planes and projections.
//!
//! Everything here is conservative by construction: a bound may be larger than
//! what it bounds, a culling test may keep an invisible object, but nothing
//! here may ever report a visible object as outside.

mod aabb;
mod frustum;
pub mod projection;
mod sphere;

pub use aabb::{Aabb, DAabb};
pub use frustum::{Frustum, Plane};
pub use sphere::Sphere;
