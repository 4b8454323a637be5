//! The render origin: where the GPU's coordinate system is centred each
//! frame.
//!
//! It lives beside the frame phase because the frame phase is what consumes
//! it: world matrices and light positions are rebased on it in `f64` before
//! they are rounded to `f32` (see [`super::frame_phase`]). The renderer
//! resolves it once per frame, from its first colour view, before
//! [`crate::ScenePrep::begin_frame`], and gives the passes every view through
//! [`ResolvedView::relative_to`] with the same origin. Nothing here reads the
//! scene.

use glam::DVec3;
use oxygen_core::ResolvedView;

/// Where the GPU's coordinate system is centred each frame.
///
/// `f32` has 24 bits of mantissa: a million units from its origin, positions
/// are rounded to 1/16 of a unit, enough to make nearby geometry visibly
/// shake and crack. Oxygen composes transforms in `f64` and, under the
/// default [`RenderOrigin::FollowFirstView`], moves the origin next to the
/// camera before anything is rounded to `f32` for the GPU. The precision this
/// buys is measured by `tests/huge_world.rs`; its cost is a frame-phase
/// re-collection whenever the origin moves (a camera crossing a grid cell),
/// no more than a frame in which every node moved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RenderOrigin {
    /// World coordinates go to the GPU as they are: exact near the world
    /// origin, 1/16-unit steps a million units out.
    Absolute,
    /// Centred on the camera of the first active view (lowest id) that
    /// renders colour (shadow views are passed over when there is another),
    /// snapped to a grid of `grid` units so that it moves, and the frame's
    /// matrices are rebuilt, only when that camera crosses a cell.
    FollowFirstView {
        /// Cell size in world units (positive and finite; otherwise the
        /// origin is not snapped).
        grid: f64,
    },
    /// Centred on a fixed world position.
    Fixed(DVec3),
}

impl Default for RenderOrigin {
    fn default() -> Self {
        RenderOrigin::FollowFirstView { grid: 1024.0 }
    }
}

impl RenderOrigin {
    /// The origin for a frame in which [`RenderOrigin::FollowFirstView`]
    /// follows `followed` (the renderer passes its first active colour view).
    ///
    /// Never non-finite: a non-finite fixed origin, a missing view or a
    /// view whose eye is not finite fall back to the world origin, because a
    /// NaN origin would turn every matrix of the frame into NaN.
    pub fn resolve(self, followed: Option<&ResolvedView>) -> DVec3 {
        match self {
            RenderOrigin::Absolute => DVec3::ZERO,
            RenderOrigin::Fixed(origin) if origin.is_finite() => origin,
            RenderOrigin::Fixed(_) => DVec3::ZERO,
            RenderOrigin::FollowFirstView { grid } => {
                let Some(eye) = followed.map(ResolvedView::camera_position_f64) else {
                    return DVec3::ZERO;
                };
                if !eye.is_finite() {
                    return DVec3::ZERO;
                }
                if grid.is_finite() && grid > 0.0 { (eye / grid).round() * grid } else { eye }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::{DMat4, UVec2, Vec3};
    use oxygen_core::{Camera, LookAtResolver, Scene, ViewContext, ViewIds, ViewResolver};

    use super::*;

    fn view_at(eye: Vec3) -> ResolvedView {
        LookAtResolver {
            camera: Camera::perspective(1.0, 0.1, Some(100.0)),
            eye,
            target: eye + Vec3::NEG_Z,
            up: Vec3::Y,
            viewport: UVec2::new(8, 8),
        }
        .resolve(
            &ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 },
            &Scene::new(),
        )
        .expect("a valid camera")
    }

    #[test]
    fn the_default_follows_the_first_view_on_a_1024_unit_grid() {
        assert_eq!(RenderOrigin::default(), RenderOrigin::FollowFirstView { grid: 1024.0 });
        let origin = RenderOrigin::default().resolve(Some(&view_at(Vec3::new(1500.0, -300.0, 2600.0))));
        assert_eq!(origin, DVec3::new(1024.0, 0.0, 3072.0));
    }

    #[test]
    fn following_snaps_to_the_nearest_cell_corner() {
        let origin = RenderOrigin::FollowFirstView { grid: 10.0 }.resolve(Some(&view_at(Vec3::new(14.0, 15.5, -26.0))));
        assert_eq!(origin, DVec3::new(10.0, 20.0, -30.0));
    }

    #[test]
    fn a_grid_that_is_not_positive_and_finite_follows_the_eye_unsnapped() {
        let eye = Vec3::new(14.25, 15.5, -26.0);
        let view = view_at(eye);
        for grid in [0.0, -8.0, f64::NAN, f64::INFINITY] {
            let origin = RenderOrigin::FollowFirstView { grid }.resolve(Some(&view));
            assert!((origin - eye.as_dvec3()).abs().max_element() < 1e-4, "grid {grid}: {origin}");
        }
    }

    #[test]
    fn following_no_view_or_a_non_finite_eye_falls_back_to_the_world_origin() {
        assert_eq!(RenderOrigin::default().resolve(None), DVec3::ZERO);
        let mut broken = view_at(Vec3::ONE);
        broken.world_to_view = DMat4::from_translation(DVec3::new(f64::NAN, 0.0, 0.0));
        assert_eq!(RenderOrigin::default().resolve(Some(&broken)), DVec3::ZERO);
        broken.world_to_view = DMat4::from_translation(DVec3::new(f64::INFINITY, 0.0, 0.0));
        assert_eq!(RenderOrigin::FollowFirstView { grid: 0.0 }.resolve(Some(&broken)), DVec3::ZERO);
    }

    #[test]
    fn absolute_is_the_world_origin_wherever_the_camera_is() {
        assert_eq!(RenderOrigin::Absolute.resolve(Some(&view_at(Vec3::splat(5000.0)))), DVec3::ZERO);
        assert_eq!(RenderOrigin::Absolute.resolve(None), DVec3::ZERO);
    }

    #[test]
    fn a_fixed_origin_is_used_as_given_unless_it_is_not_finite() {
        let view = view_at(Vec3::splat(5000.0));
        let fixed = DVec3::new(1.0e6 + 0.5, -3.0, 7.25);
        assert_eq!(RenderOrigin::Fixed(fixed).resolve(Some(&view)), fixed);
        assert_eq!(RenderOrigin::Fixed(fixed).resolve(None), fixed);
        for bad in [DVec3::NAN, DVec3::new(0.0, f64::INFINITY, 0.0), DVec3::new(0.0, 0.0, f64::NEG_INFINITY)] {
            assert_eq!(RenderOrigin::Fixed(bad).resolve(Some(&view)), DVec3::ZERO, "{bad}");
        }
    }
}
