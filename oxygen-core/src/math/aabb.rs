//! Axis-aligned bounding boxes.

use glam::{Mat4, Vec3};

/// An axis-aligned bounding box. `min <= max` on every axis for a non-empty box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box: growing it by any point gives that point's box.
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    /// A box from two corners, in any order.
    pub fn new(a: Vec3, b: Vec3) -> Self {
        Aabb { min: a.min(b), max: a.max(b) }
    }

    /// A box centred at `center` with half-size `half_extents`.
    pub fn from_center_half_extents(center: Vec3, half_extents: Vec3) -> Self {
        Aabb::new(center - half_extents, center + half_extents)
    }

    /// The smallest box holding every point; [`Aabb::EMPTY`] for none.
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        points.into_iter().fold(Aabb::EMPTY, |b, p| b.including(p))
    }

    /// This box grown to include `p`.
    pub fn including(self, p: Vec3) -> Self {
        Aabb { min: self.min.min(p), max: self.max.max(p) }
    }

    /// True when the box holds no point (a never-grown [`Aabb::EMPTY`]).
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// True when both corners are finite numbers.
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }

    /// Centre point.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Half the size along each axis.
    pub fn half_extents(&self) -> Vec3 {
        (self.max - self.min) * 0.5
    }

    /// The eight corners, in `x` fastest, then `y`, then `z` order.
    pub fn corners(&self) -> [Vec3; 8] {
        let (a, b) = (self.min, self.max);
        [
            Vec3::new(a.x, a.y, a.z),
            Vec3::new(b.x, a.y, a.z),
            Vec3::new(a.x, b.y, a.z),
            Vec3::new(b.x, b.y, a.z),
            Vec3::new(a.x, a.y, b.z),
            Vec3::new(b.x, a.y, b.z),
            Vec3::new(a.x, b.y, b.z),
            Vec3::new(b.x, b.y, b.z),
        ]
    }

    /// The box that bounds this box after an affine transform.
    ///
    /// Uses the centre/extent form: the new half-extent on each axis is the sum
    /// of the absolute transformed half-extents, which is exact for the
    /// transformed box's bound and needs no corner loop.
    pub fn transformed(&self, m: &Mat4) -> Aabb {
        let center = m.transform_point3(self.center());
        let e = self.half_extents();
        let abs_x = m.x_axis.truncate().abs() * e.x;
        let abs_y = m.y_axis.truncate().abs() * e.y;
        let abs_z = m.z_axis.truncate().abs() * e.z;
        Aabb::from_center_half_extents(center, abs_x + abs_y + abs_z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transformed_box_holds_every_transformed_corner() {
        let b = Aabb::new(Vec3::new(-1.0, -2.0, -0.5), Vec3::new(2.0, 1.0, 3.0));
        let m = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, -1.0, 0.5),
            glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, 1.1, -0.7),
            Vec3::new(10.0, -4.0, 2.0),
        );
        let t = b.transformed(&m);
        for c in b.corners() {
            let p = m.transform_point3(c);
            assert!(p.cmpge(t.min - 1e-4).all() && p.cmple(t.max + 1e-4).all());
        }
    }

    #[test]
    fn empty_box_grows_to_a_point() {
        assert!(Aabb::EMPTY.is_empty());
        let b = Aabb::EMPTY.including(Vec3::ONE);
        assert_eq!(b.min, Vec3::ONE);
        assert!(!b.is_empty());
    }
}
