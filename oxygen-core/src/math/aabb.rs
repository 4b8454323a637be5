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

    /// A box with distinct, non-unit sizes per axis, so that a centre or
    /// extent computed with the wrong operator cannot land on the right value.
    fn lopsided_box() -> Aabb {
        Aabb::new(Vec3::new(2.0, 1.0, 3.0), Vec3::new(-1.0, -2.0, -0.5))
    }

    /// A matrix that swaps x and y, scales each axis differently and moves
    /// the box: every entry is a small integer, so the transformed bound is
    /// exact in f32 and f64.
    fn axis_permuting_matrix() -> [[f64; 4]; 4] {
        [[0.0, 2.0, 0.0, 0.0], [-3.0, 0.0, 0.0, 0.0], [0.0, 0.0, 4.0, 0.0], [10.0, -4.0, 2.0, 1.0]]
    }

    #[test]
    fn centre_and_half_extents_of_a_box() {
        let b = lopsided_box();
        assert_eq!(b.center(), Vec3::new(0.5, -0.5, 1.25));
        assert_eq!(b.half_extents(), Vec3::new(1.5, 1.5, 1.75));
        assert_eq!(Aabb::from_center_half_extents(b.center(), b.half_extents()), b);
    }

    #[test]
    fn corners_are_listed_x_fastest_then_y_then_z() {
        let c = lopsided_box().corners();
        let (lo, hi) = (Vec3::new(-1.0, -2.0, -0.5), Vec3::new(2.0, 1.0, 3.0));
        for (i, corner) in c.iter().enumerate() {
            let pick = |bit: usize, a: f32, b: f32| if i & bit == 0 { a } else { b };
            let expected = Vec3::new(pick(1, lo.x, hi.x), pick(2, lo.y, hi.y), pick(4, lo.z, hi.z));
            assert_eq!(*corner, expected, "corner {i}");
        }
    }

    #[test]
    fn finite_only_when_both_corners_are() {
        assert!(lopsided_box().is_finite());
        // One bad corner is enough; the never-grown empty box has two.
        let inf_max = Aabb { min: Vec3::ZERO, max: Vec3::new(1.0, f32::INFINITY, 1.0) };
        let nan_min = Aabb { min: Vec3::new(f32::NAN, 0.0, 0.0), max: Vec3::ONE };
        assert!(!inf_max.is_finite());
        assert!(!nan_min.is_finite());
        assert!(!Aabb::EMPTY.is_finite());
    }

    #[test]
    fn transformed_box_is_the_exact_bound_of_an_axis_permuting_transform() {
        let m = Mat4::from_cols_array_2d(&axis_permuting_matrix().map(|c| c.map(|x| x as f32)));
        // x' = -3y + 10, y' = 2x - 4, z' = 4z + 2 over the box's ranges.
        let expected = Aabb::new(Vec3::new(7.0, -6.0, 0.0), Vec3::new(16.0, 0.0, 14.0));
        assert_eq!(lopsided_box().transformed(&m), expected);
        assert_eq!(Aabb::from_points(lopsided_box().corners().map(|c| m.transform_point3(c))), expected);
    }

    #[test]
    fn transformed_box_is_tight_around_the_transformed_corners() {
        let b = lopsided_box();
        let m = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, -1.0, 0.5),
            glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, 1.1, -0.7),
            Vec3::new(10.0, -4.0, 2.0),
        );
        // The centre/extent form is exact, not only conservative: it equals
        // the corners' bound up to f32 rounding (measured 1e-6, one ulp of
        // coordinates below 16); 1e-5 allows about ten ulps.
        let t = b.transformed(&m);
        let corners = Aabb::from_points(b.corners().map(|c| m.transform_point3(c)));
        assert!((t.min - corners.min).abs().max_element() < 1e-5, "{t:?} vs {corners:?}");
        assert!((t.max - corners.max).abs().max_element() < 1e-5, "{t:?} vs {corners:?}");
    }

    #[test]
    fn f64_transformed_box_is_the_exact_bound_of_an_axis_permuting_transform() {
        let m = DMat4::from_cols_array_2d(&axis_permuting_matrix());
        let t = DAabb::transformed(&lopsided_box(), &m);
        assert_eq!(t, DAabb::new(DVec3::new(7.0, -6.0, 0.0), DVec3::new(16.0, 0.0, 14.0)));
    }

    #[test]
    fn f64_transformed_box_keeps_sub_unit_sizes_ten_million_units_out() {
        let b = lopsided_box();
        let rotation = glam::DQuat::from_euler(glam::EulerRot::XYZ, 0.3, 1.1, -0.7);
        let m = DMat4::from_scale_rotation_translation(
            DVec3::new(2.0, -1.0, 0.5),
            rotation,
            DVec3::new(1e7 + 0.25, -3e7, 0.5),
        );
        let t = DAabb::transformed(&b, &m);
        let mut corners = DAabb::new(m.transform_point3(b.min.as_dvec3()), m.transform_point3(b.min.as_dvec3()));
        for c in b.corners() {
            let p = m.transform_point3(c.as_dvec3());
            corners = corners.union(DAabb::new(p, p));
        }
        // Measured within 1e-15; an f64 ulp at 3e7 is 3.7e-9, so 1e-7 allows
        // about 25 ulps, and is still ten million times finer than the f32
        // step there (2 units).
        assert!((t.min - corners.min).abs().max_element() < 1e-7, "{t:?} vs {corners:?}");
        assert!((t.max - corners.max).abs().max_element() < 1e-7, "{t:?} vs {corners:?}");
    }

    #[test]
    fn f64_centre_and_half_extents_are_exact_far_from_the_origin() {
        // Quarter units ten million out: f32 would round them to whole units.
        let b = DAabb::new(DVec3::new(1e7 + 0.75, -3e7 + 1.5, 0.5), DVec3::new(1e7 + 0.25, -3e7, 0.125));
        assert_eq!(b.center(), DVec3::new(1e7 + 0.5, -3e7 + 0.75, 0.3125));
        assert_eq!(b.half_extents(), DVec3::new(0.25, 0.75, 0.1875));
    }

    #[test]
    fn f64_box_is_finite_only_when_both_corners_are() {
        assert!(DAabb::new(DVec3::splat(-1e300), DVec3::splat(1e300)).is_finite());
        let inf_max = DAabb { min: DVec3::ZERO, max: DVec3::new(1.0, 1.0, f64::INFINITY) };
        let nan_min = DAabb { min: DVec3::new(0.0, f64::NAN, 0.0), max: DVec3::ONE };
        assert!(!inf_max.is_finite());
        assert!(!nan_min.is_finite());
    }

    #[test]
    fn f64_box_with_f32_exact_corners_rounds_to_itself() {
        // Outward rounding only moves a corner that f32 cannot hold: one
        // already in f32 stays put, including far out where a step is 2.
        for (min, max) in [
            (DVec3::new(-1.5, 0.0, 1e7), DVec3::new(2.25, 3.0, 1e7 + 1.0)),
            (DVec3::new(-3e7, 1e-3f32 as f64, -0.0), DVec3::new(3e7 + 2.0, 0.1f32 as f64, 0.0)),
        ] {
            let b = DAabb::new(min, max);
            let rounded = b.to_f32_outward();
            assert_eq!(rounded.min.as_dvec3(), b.min, "{b:?}");
            assert_eq!(rounded.max.as_dvec3(), b.max, "{b:?}");
        }
    }
}
