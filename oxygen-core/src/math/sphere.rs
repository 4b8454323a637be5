//! Bounding spheres: a cheaper, looser bound than [`Aabb`](super::Aabb).

use glam::Vec3;

use super::Aabb;

/// A bounding sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre in world (or local) space.
    pub center: Vec3,
    /// Radius; never negative.
    pub radius: f32,
}

impl Sphere {
    /// The sphere through the corners of `aabb` (it holds the whole box).
    pub fn from_aabb(aabb: &Aabb) -> Self {
        Sphere { center: aabb.center(), radius: aabb.half_extents().length() }
    }
}
