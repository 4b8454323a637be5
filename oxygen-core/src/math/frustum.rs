//! View frustum planes, extracted from a view-projection matrix.
//!
//! Planes follow Gribb and Hartmann: each is a sum or difference of rows of
//! the clip matrix, normalized so that `dot(n, p) + d` is a signed distance in
//! world units, positive inside. wgpu clips to `0 <= z <= w`, so the two depth
//! planes are `row2` and `row3 - row2`; with reverse-Z these are the far and
//! near planes respectively. An infinite far plane yields a degenerate
//! `row2` (zero normal); it is replaced by a plane that keeps everything.

use glam::{DMat4, DVec4, Mat4, Vec3, Vec4};

use super::{Aabb, Sphere};

/// A plane `dot(normal, p) + d = 0`; points with a positive distance are inside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Unit normal pointing into the kept half-space.
    pub normal: Vec3,
    /// Offset: the signed distance of the origin.
    pub d: f32,
}

impl Plane {
    /// A plane that every point is inside (used for an infinite far plane).
    pub const KEEP_ALL: Plane = Plane { normal: Vec3::ZERO, d: f32::INFINITY };

    /// Normalizes `(a, b, c, d)`; a plane with a (near) zero normal keeps all.
    fn from_row(v: Vec4) -> Plane {
        let len = v.truncate().length();
        if !(len > 1e-12) || !len.is_finite() {
            return Plane::KEEP_ALL;
        }
        Plane { normal: v.truncate() / len, d: v.w / len }
    }

    /// Normalizes `(a, b, c, d)` in f64, then rounds to f32 and moves the
    /// plane outward by a bound on the f32 error of testing a point near
    /// it: the rounding of `d` and of `dot(normal, p)` for points about
    /// `|d|` from the origin (eight f32 epsilons of `|d| + 1`). A thousandth
    /// of a unit at 1e4, ten units ten million units out: never culling
    /// what is inside, at the price of keeping a sliver outside.
    fn from_row_f64(v: DVec4) -> Plane {
        let len = v.truncate().length();
        if !(len > 1e-12) || !len.is_finite() {
            return Plane::KEEP_ALL;
        }
        let d = v.w / len;
        let slack = 8.0 * f64::from(f32::EPSILON) * (d.abs() + 1.0);
        Plane { normal: (v.truncate() / len).as_vec3(), d: (d + slack) as f32 }
    }

    /// Signed distance from the plane, positive inside.
    pub fn distance(&self, p: Vec3) -> f32 {
        self.normal.dot(p) + self.d
    }
}

/// Six planes bounding what a view can see, in the order
/// left, right, bottom, top, near, far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frustum {
    /// Left, right, bottom, top, near, far.
    pub planes: [Plane; 6],
}

impl Frustum {
    /// Extracts normalized planes from a reverse-Z (or standard) wgpu
    /// view-projection matrix.
    pub fn from_view_projection(view_projection: &Mat4) -> Self {
        let m = view_projection.transpose(); // rows of the original as columns
        Self::from_rows([m.x_axis, m.y_axis, m.z_axis, m.w_axis], Plane::from_row)
    }

    /// The six planes of the rows `r` of a view-projection matrix, each made
    /// a [`Plane`] by `plane`: −w ≤ x ≤ w, −w ≤ y ≤ w, 0 ≤ z ≤ w. Reverse-Z
    /// maps the near plane to z = w, the far plane to z = 0; which is which
    /// only matters for naming, since both are tested.
    fn from_rows<R>(r: [R; 4], plane: impl Fn(R) -> Plane) -> Self
    where
        R: Copy + std::ops::Add<Output = R> + std::ops::Sub<Output = R>,
    {
        let [r0, r1, r2, r3] = r;
        Frustum { planes: [plane(r3 + r0), plane(r3 - r0), plane(r3 + r1), plane(r3 - r1), plane(r3 - r2), plane(r2)] }
    }

    /// Conservative box test by the p-vertex method: for each plane, the box
    /// corner furthest along the plane normal is tested; if even that corner is
    /// outside, the whole box is. May keep a box that is outside near a
    /// frustum corner; never drops one that intersects the frustum.
    pub fn intersects_aabb(&self, aabb: &Aabb) -> bool {
        self.planes.iter().all(|plane| {
            let p = Vec3::select(plane.normal.cmpge(Vec3::ZERO), aabb.max, aabb.min);
            plane.distance(p) >= 0.0
        })
    }

    /// The frustum of `projection × world_to_view`, extracted in f64 and
    /// rounded outward ([`Plane`]'s f64 path): for views far from the
    /// origin, whose f32 view-projection would place the planes a unit or
    /// more off.
    pub fn from_view_projection_f64(view_projection: &DMat4) -> Self {
        let m = view_projection.transpose();
        Self::from_rows([m.x_axis, m.y_axis, m.z_axis, m.w_axis], Plane::from_row_f64)
    }

    /// Conservative sphere test: cheaper and looser than [`Self::intersects_aabb`].
    pub fn intersects_sphere(&self, sphere: &Sphere) -> bool {
        self.planes.iter().all(|plane| plane.distance(sphere.center) >= -sphere.radius)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::projection::reverse_z_perspective;

    fn test_frustum(far: Option<f32>) -> Frustum {
        let view = Mat4::look_at_rh(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y);
        let proj = reverse_z_perspective(90f32.to_radians(), 1.0, 0.1, far);
        Frustum::from_view_projection(&(proj * view))
    }

    #[test]
    fn planes_are_normalized_signed_distances() {
        let f = test_frustum(Some(100.0));
        // A point 5 units in front of the camera: 4.9 from the near plane.
        let near = f.planes[4];
        assert!((near.distance(Vec3::new(0.0, 0.0, -5.0)) - 4.9).abs() < 1e-4);
        let far = f.planes[5];
        assert!((far.distance(Vec3::new(0.0, 0.0, -5.0)) - 95.0).abs() < 1e-3);
    }

    #[test]
    fn infinite_far_plane_keeps_distant_objects() {
        let f = test_frustum(None);
        let far_box = Aabb::from_center_half_extents(Vec3::new(0.0, 0.0, -1e7), Vec3::ONE);
        assert!(f.intersects_aabb(&far_box));
        let behind = Aabb::from_center_half_extents(Vec3::new(0.0, 0.0, 10.0), Vec3::ONE);
        assert!(!f.intersects_aabb(&behind));
    }

    #[test]
    fn culling_drops_objects_fully_outside_each_plane() {
        let f = test_frustum(Some(100.0));
        // With a 90° frustum looking down -Z, at depth 10 the sides are at ±10.
        let outside = [
            Vec3::new(-30.0, 0.0, -10.0), // left
            Vec3::new(30.0, 0.0, -10.0),  // right
            Vec3::new(0.0, -30.0, -10.0), // bottom
            Vec3::new(0.0, 30.0, -10.0),  // top
            Vec3::new(0.0, 0.0, 5.0),     // behind the near plane
            Vec3::new(0.0, 0.0, -200.0),  // beyond the far plane
        ];
        for (plane, c) in outside.iter().enumerate() {
            let b = Aabb::from_center_half_extents(*c, Vec3::ONE);
            assert!(!f.intersects_aabb(&b), "box outside plane {plane} was kept");
            assert!(!f.intersects_sphere(&Sphere::from_aabb(&b)), "sphere outside plane {plane} was kept");
        }
    }

    #[test]
    fn culling_keeps_objects_straddling_a_plane() {
        let f = test_frustum(Some(100.0));
        let straddling = [
            Vec3::new(-10.0, 0.0, -10.0), // on the left plane
            Vec3::new(10.0, 0.0, -10.0),
            Vec3::new(0.0, -10.0, -10.0),
            Vec3::new(0.0, 10.0, -10.0),
            Vec3::new(0.0, 0.0, -0.1),   // on the near plane
            Vec3::new(0.0, 0.0, -100.0), // on the far plane
        ];
        for (plane, c) in straddling.iter().enumerate() {
            let b = Aabb::from_center_half_extents(*c, Vec3::splat(0.5));
            assert!(f.intersects_aabb(&b), "box straddling plane {plane} was dropped");
            assert!(f.intersects_sphere(&Sphere::from_aabb(&b)));
        }
    }

    #[test]
    fn a_normal_of_length_1e_minus_12_counts_as_degenerate() {
        // sqrt(x * x) == x exactly in binary floating point, so these rows'
        // normals are exactly at the threshold, which is exclusive.
        assert_eq!(Plane::from_row(Vec4::new(1e-12, 0.0, 0.0, 1.0)), Plane::KEEP_ALL);
        assert_eq!(Plane::from_row_f64(DVec4::new(0.0, 1e-12, 0.0, 1.0)), Plane::KEEP_ALL);
        // Twice as long is a real plane, however far from the origin.
        assert_eq!(Plane::from_row(Vec4::new(2e-12, 0.0, 0.0, 1e-12)), Plane { normal: Vec3::X, d: 0.5 });
        // Through the origin: d is the slack alone, 8 eps (|0| + 1).
        let p = Plane::from_row_f64(DVec4::new(0.0, 2e-12, 0.0, 0.0));
        assert_eq!(p, Plane { normal: Vec3::Y, d: 8.0 * f32::EPSILON });
    }

    #[test]
    fn f64_rows_without_a_usable_normal_keep_everything() {
        for row in [
            DVec4::ZERO,
            DVec4::new(0.0, 0.0, 0.0, 5.0),
            DVec4::new(f64::NAN, 1.0, 0.0, 0.0),
            DVec4::new(1.0, f64::INFINITY, 0.0, 0.0),
            DVec4::new(1e300, 1e300, 0.0, 0.0), // length overflows to infinity
        ] {
            assert_eq!(Plane::from_row_f64(row), Plane::KEEP_ALL, "{row}");
        }
    }

    #[test]
    fn f64_plane_of_a_known_row_is_normalized_and_moved_out_by_its_slack() {
        // |(3, 0, 4)| = 5: normal (0.6, 0, 0.8), d = 10 / 5 = 2, slack
        // 8 eps (|2| + 1) = 24 eps, twelve f32 steps at 2 (exact in f32).
        let p = Plane::from_row_f64(DVec4::new(3.0, 0.0, 4.0, 10.0));
        assert_eq!(p.normal, Vec3::new(0.6, 0.0, 0.8));
        assert_eq!(p.d, 2.0 + 24.0 * f32::EPSILON);
        // A negative offset is moved the same way, towards keeping more.
        let q = Plane::from_row_f64(DVec4::new(0.0, -6.0, 8.0, -20.0));
        assert_eq!(q.normal, Vec3::new(0.0, -0.6, 0.8));
        assert_eq!(q.d, -2.0 + 24.0 * f32::EPSILON);
        // Near the origin the slack is 8 eps: a point on the exact plane
        // is inside by about that much.
        let r = Plane::from_row_f64(DVec4::new(0.0, 0.0, -2.0, 0.0));
        assert_eq!(r, Plane { normal: Vec3::NEG_Z, d: 8.0 * f32::EPSILON });
    }

    #[test]
    fn f64_frustum_matches_the_f32_one_near_the_origin_and_is_never_tighter() {
        let view = Mat4::look_at_rh(Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.0, 0.0, -5.0), Vec3::Y);
        let proj = reverse_z_perspective(70f32.to_radians(), 1.5, 0.1, Some(100.0));
        let vp = proj * view;
        let f32_planes = Frustum::from_view_projection(&vp).planes;
        let f64_planes = Frustum::from_view_projection_f64(&vp.as_dmat4()).planes;
        for (i, (a, b)) in f32_planes.iter().zip(&f64_planes).enumerate() {
            // The two extractions differ by f32 rounding of the normal (an
            // ulp or two near 1) and by the f64 path's slack of eight
            // epsilons of |d| + 1 (below 1e-4 for |d| < 100).
            assert!((a.normal - b.normal).abs().max_element() < 1e-6, "plane {i}: {a:?} vs {b:?}");
            let slack = 8.0 * f32::EPSILON * (b.d.abs() + 1.0);
            assert!(b.d >= a.d && b.d - a.d < 2.0 * slack, "plane {i}: {a:?} vs {b:?}");
        }
    }
}
