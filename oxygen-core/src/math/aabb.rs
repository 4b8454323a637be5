//! Axis-aligned bounding boxes.

use glam::{DMat4, DVec3, Mat4, Vec3};

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

/// An axis-aligned bounding box in f64: world bounds far from the origin,
/// where f32 corners would be rounded by whole units (a million units out
/// f32 steps by 1/16, thirty million out by 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DAabb {
    /// Smallest corner.
    pub min: DVec3,
    /// Largest corner.
    pub max: DVec3,
}

impl DAabb {
    /// A box from two corners, in any order.
    pub fn new(a: DVec3, b: DVec3) -> Self {
        DAabb { min: a.min(b), max: a.max(b) }
    }

    /// `local` (an f32 box, exact in f64) moved by `m`: the box around its
    /// transformed corners, computed in f64.
    pub fn transformed(local: &Aabb, m: &DMat4) -> Self {
        let center = m.transform_point3(local.center().as_dvec3());
        let e = local.half_extents().as_dvec3();
        let extent =
            m.x_axis.truncate().abs() * e.x + m.y_axis.truncate().abs() * e.y + m.z_axis.truncate().abs() * e.z;
        DAabb { min: center - extent, max: center + extent }
    }

    /// The smallest box holding both.
    pub fn union(self, other: DAabb) -> Self {
        DAabb { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    /// Centre point.
    pub fn center(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }

    /// Half the size along each axis.
    pub fn half_extents(&self) -> DVec3 {
        (self.max - self.min) * 0.5
    }

    /// True when both corners are finite numbers.
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }

    /// The f32 box that holds this one: each corner rounded outward (a
    /// corner that f32 rounds inward moves one step out), so culling with
    /// it never drops what the f64 box would keep.
    pub fn to_f32_outward(&self) -> Aabb {
        let down = |x: f64| {
            let f = x as f32;
            if f64::from(f) > x { f.next_down() } else { f }
        };
        let up = |x: f64| {
            let f = x as f32;
            if f64::from(f) < x { f.next_up() } else { f }
        };
        Aabb {
            min: Vec3::new(down(self.min.x), down(self.min.y), down(self.min.z)),
            max: Vec3::new(up(self.max.x), up(self.max.y), up(self.max.z)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f64_boxes_round_outward_to_f32_far_from_the_origin() {
        // Seeded corners 1e7 out, where f32 steps by a whole unit.
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..10_000 {
            let a = DVec3::new(1e7 + next() * 100.0, -3e7 + next() * 100.0, next() * 1e-3);
            let b = a + DVec3::new(next(), next(), next()) * 0.5;
            let exact = DAabb::new(a, b);
            let rounded = exact.to_f32_outward();
            assert!(rounded.min.as_dvec3().cmple(exact.min).all(), "{rounded:?} loses the minimum of {exact:?}");
            assert!(rounded.max.as_dvec3().cmpge(exact.max).all(), "{rounded:?} loses the maximum of {exact:?}");
            // And by at most one f32 step each way.
            let step = DVec3::splat(4.0);
            assert!((exact.min - rounded.min.as_dvec3()).cmple(step).all());
        }
    }

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
