//! Reverse-Z projections for wgpu's `[0, 1]` clip depth.
//!
//! Reverse-Z maps the near plane to depth 1 and the far plane to 0. Floating
//! point has most of its precision near 0, which is where the distant geometry
//! lands, so depth precision stays nearly uniform in log space: this is what
//! lets near = 1e-3 and far = 1e7 coexist. Depth is cleared to 0 and tested
//! with `Greater`.

use glam::Mat4;

/// Right-handed reverse-Z perspective. `far = None` gives an infinite far
/// plane (the limit as far → ∞, with no precision cost).
pub fn reverse_z_perspective(fov_y: f32, aspect: f32, near: f32, far: Option<f32>) -> Mat4 {
    match far {
        Some(far) => Mat4::perspective_rh(fov_y, aspect, far, near),
        None => Mat4::perspective_infinite_reverse_rh(fov_y, aspect, near),
    }
}

/// Right-handed reverse-Z orthographic projection of the box
/// `[-half_width, half_width] × [-half_height, half_height]` between `near` and `far`.
pub fn reverse_z_orthographic(half_width: f32, half_height: f32, near: f32, far: f32) -> Mat4 {
    Mat4::orthographic_rh(-half_width, half_width, -half_height, half_height, far, near)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec4;

    fn depth_at(proj: &Mat4, distance: f32) -> f32 {
        let clip = *proj * Vec4::new(0.0, 0.0, -distance, 1.0);
        clip.z / clip.w
    }

    #[test]
    fn near_maps_to_one_and_far_to_zero() {
        let p = reverse_z_perspective(1.0, 1.5, 0.5, Some(50.0));
        assert!((depth_at(&p, 0.5) - 1.0).abs() < 1e-6);
        assert!(depth_at(&p, 50.0).abs() < 1e-6);
        let o = reverse_z_orthographic(2.0, 2.0, 1.0, 11.0);
        assert!((depth_at(&o, 1.0) - 1.0).abs() < 1e-6);
        assert!(depth_at(&o, 11.0).abs() < 1e-6);
    }

    /// Depth must stay strictly ordered from 1e-3 to 1e7 when objects are
    /// 0.1 % apart: the extreme range the architecture promises.
    #[test]
    fn reverse_z_orders_depths_from_a_millimetre_to_ten_thousand_kilometres() {
        for far in [Some(1e7), None] {
            let p = reverse_z_perspective(1.0, 1.0, 1e-3, far);
            let mut d = 2e-3f32;
            let mut previous = depth_at(&p, d);
            while d < 5e6 {
                let next_d = d * 1.001;
                let next = depth_at(&p, next_d);
                assert!(next < previous, "depth not decreasing at {d} (far {far:?}): {previous} -> {next}");
                previous = next;
                d = next_d;
            }
        }
    }
}
