//! Cameras: reverse-Z perspective (optionally with an infinite far plane) and
//! orthographic projections, validated before they produce a matrix.

use std::fmt;

use glam::{Mat4, Vec3};
use thiserror::Error;

use crate::math::projection::{reverse_z_orthographic, reverse_z_perspective};

/// A projection.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Projection {
    /// Reverse-Z perspective.
    Perspective {
        /// Vertical field of view in radians, in `(0, π)`.
        fov_y: f32,
        /// Near plane distance, `> 0`.
        near: f32,
        /// Far plane distance; `None` for an infinite far plane.
        far: Option<f32>,
    },
    /// Reverse-Z orthographic.
    Orthographic {
        /// Half the visible height in world units; the width follows the aspect.
        half_height: f32,
        /// Near plane distance (may be negative).
        near: f32,
        /// Far plane distance, `> near`.
        far: f32,
    },
}

/// Why a camera (or a look-at pose around it) cannot produce a usable view.
/// Each message names the values at fault as numbers, so it can be read
/// without knowing the field types.
#[derive(Debug, Error, PartialEq)]
pub enum CameraError {
    /// Field of view out of `(0, π)`.
    #[error("field of view {0} rad is outside (0, π)")]
    BadFieldOfView(f32),
    /// Perspective near/far planes out of order, non-positive or non-finite.
    #[error("perspective depth range near {near}, {} is invalid (need 0 < near < far, near finite, far finite or infinite)", FarPlane(*.far))]
    BadDepthRange {
        /// Near distance.
        near: f32,
        /// Far distance; `None` is an infinite far plane.
        far: Option<f32>,
    },
    /// Orthographic near/far planes out of order or non-finite.
    #[error("orthographic depth range near {near}, far {far} is invalid (need near < far, both finite)")]
    BadOrthographicDepthRange {
        /// Near distance (may be negative).
        near: f32,
        /// Far distance.
        far: f32,
    },
    /// Orthographic half-height not positive and finite.
    #[error("orthographic half-height {0} is not a positive finite number")]
    BadHalfHeight(f32),
    /// Aspect ratio not positive and finite.
    #[error("aspect ratio {0} is not a positive finite number")]
    BadAspect(f32),
    /// Width or height of the viewport is zero.
    #[error("viewport {width}x{height} is empty")]
    EmptyViewport {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// Eye or target is not finite, they coincide, or up is zero, not finite
    /// or parallel to the view direction.
    #[error(
        "look-at is degenerate: eye {eye}, target {target}, up {up} (need finite, distinct eye and target and an up not parallel to target - eye)"
    )]
    DegenerateLookAt {
        /// Eye.
        eye: Vec3,
        /// Target.
        target: Vec3,
        /// Up.
        up: Vec3,
    },
}

/// Writes a far plane as a reader would say it: `far 100` or `infinite far`.
struct FarPlane(Option<f32>);

impl fmt::Display for FarPlane {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(far) => write!(f, "far {far}"),
            None => f.write_str("infinite far"),
        }
    }
}

/// A camera: a projection; its pose comes from a node or a resolver.
///
/// Build it with [`Camera::try_perspective`] or [`Camera::try_orthographic`]
/// to have a bad projection refused where it is made. [`Camera::perspective`]
/// and [`Camera::orthographic`] (and the public field) accept anything; such
/// a camera is checked when a view resolves it, and a bad one makes that view
/// be skipped with a warning in the frame report.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Camera {
    /// The projection.
    pub projection: Projection,
}

impl Camera {
    /// A perspective camera: vertical field of view `fov_y` in radians,
    /// `near` > 0 and `far` > `near` (`None` for an infinite far plane).
    ///
    /// Not checked here, so that constant cameras stay one expression: an
    /// invalid one (say `near` = 0) is refused only when a view resolves it,
    /// at render time. Use [`Camera::try_perspective`] for values that come
    /// from a user or a file.
    pub fn perspective(fov_y: f32, near: f32, far: Option<f32>) -> Self {
        Camera { projection: Projection::Perspective { fov_y, near, far } }
    }

    /// A perspective camera, refused now if [`Camera::validate`] would refuse
    /// it: `fov_y` in `(0, π)`, `0 < near < far`, `near` finite, `far` finite
    /// or `None` (infinite).
    pub fn try_perspective(fov_y: f32, near: f32, far: Option<f32>) -> Result<Self, CameraError> {
        let camera = Self::perspective(fov_y, near, far);
        camera.validate()?;
        Ok(camera)
    }

    /// An orthographic camera showing `half_height` world units above and
    /// below its axis, between `near` (may be negative) and `far`.
    ///
    /// Not checked here; an invalid one is refused when a view resolves it.
    /// Use [`Camera::try_orthographic`] to be told at once.
    pub fn orthographic(half_height: f32, near: f32, far: f32) -> Self {
        Camera { projection: Projection::Orthographic { half_height, near, far } }
    }

    /// An orthographic camera, refused now if [`Camera::validate`] would
    /// refuse it: `half_height` positive and finite, `near < far`, both finite.
    pub fn try_orthographic(half_height: f32, near: f32, far: f32) -> Result<Self, CameraError> {
        let camera = Self::orthographic(half_height, near, far);
        camera.validate()?;
        Ok(camera)
    }

    /// Checks everything about the projection that does not depend on the
    /// viewport: the same checks [`Camera::projection_matrix`] makes, minus
    /// the aspect ratio.
    pub fn validate(&self) -> Result<(), CameraError> {
        match self.projection {
            Projection::Perspective { fov_y, near, far } => {
                if !(fov_y > 0.0 && fov_y < std::f32::consts::PI) {
                    return Err(CameraError::BadFieldOfView(fov_y));
                }
                let far_ok = far.is_none_or(|f| f.is_finite() && f > near);
                if !(near > 0.0 && near.is_finite() && far_ok) {
                    return Err(CameraError::BadDepthRange { near, far });
                }
            }
            Projection::Orthographic { half_height, near, far } => {
                if !(half_height > 0.0 && half_height.is_finite()) {
                    return Err(CameraError::BadHalfHeight(half_height));
                }
                if !(near.is_finite() && far.is_finite() && far > near) {
                    return Err(CameraError::BadOrthographicDepthRange { near, far });
                }
            }
        }
        Ok(())
    }

    /// Near and far distances (`far` is `f32::INFINITY` for an infinite perspective).
    pub fn depth_range(&self) -> (f32, f32) {
        match self.projection {
            Projection::Perspective { near, far, .. } => (near, far.unwrap_or(f32::INFINITY)),
            Projection::Orthographic { near, far, .. } => (near, far),
        }
    }

    /// The reverse-Z projection matrix for a viewport of the given aspect.
    pub fn projection_matrix(&self, aspect: f32) -> Result<Mat4, CameraError> {
        if !(aspect > 0.0 && aspect.is_finite()) {
            return Err(CameraError::BadAspect(aspect));
        }
        self.validate()?;
        Ok(match self.projection {
            Projection::Perspective { fov_y, near, far } => reverse_z_perspective(fov_y, aspect, near, far),
            Projection::Orthographic { half_height, near, far } => {
                reverse_z_orthographic(half_height * aspect, half_height, near, far)
            }
        })
    }
}

#[cfg(test)]
mod tests {

    /// A far plane on the near plane holds no depth: refused, as one before it.
    #[test]
    fn a_far_plane_on_the_near_plane_is_refused() {
        let camera = |far| Camera { projection: Projection::Perspective { fov_y: 1.0, near: 0.5, far: Some(far) } };
        assert!(matches!(camera(0.5).validate(), Err(CameraError::BadDepthRange { .. })));
        assert!(matches!(camera(0.25).validate(), Err(CameraError::BadDepthRange { .. })));
        assert!(camera(0.5001).validate().is_ok());
    }
    use super::*;

    #[test]
    fn try_perspective_refuses_a_zero_near_plane_and_names_it_plainly() {
        let err = Camera::try_perspective(1.0, 0.0, Some(100.0)).unwrap_err();
        assert_eq!(err, CameraError::BadDepthRange { near: 0.0, far: Some(100.0) });
        let message = err.to_string();
        assert!(message.contains("near 0, far 100"), "{message}");
        assert!(!message.contains("Some("), "{message}");
    }

    #[test]
    fn an_infinite_far_plane_is_named_in_words() {
        let message = Camera::try_perspective(1.0, -1.0, None).unwrap_err().to_string();
        assert!(message.contains("near -1, infinite far"), "{message}");
        assert!(!message.contains("None"), "{message}");
    }

    #[test]
    fn try_perspective_refuses_far_before_near_and_a_non_finite_far() {
        assert!(matches!(Camera::try_perspective(1.0, 10.0, Some(1.0)), Err(CameraError::BadDepthRange { .. })));
        assert!(matches!(
            Camera::try_perspective(1.0, 0.1, Some(f32::INFINITY)),
            Err(CameraError::BadDepthRange { .. })
        ));
        assert!(matches!(Camera::try_perspective(1.0, f32::NAN, None), Err(CameraError::BadDepthRange { .. })));
    }

    #[test]
    fn try_perspective_refuses_a_field_of_view_outside_zero_to_pi() {
        for fov in [0.0, -0.5, std::f32::consts::PI, f32::NAN] {
            assert!(matches!(Camera::try_perspective(fov, 0.1, None), Err(CameraError::BadFieldOfView(_))), "{fov}");
        }
    }

    #[test]
    fn try_perspective_accepts_what_perspective_builds() {
        let camera = Camera::try_perspective(1.0, 1e-3, None).unwrap();
        assert_eq!(camera, Camera::perspective(1.0, 1e-3, None));
        assert!(Camera::try_perspective(1.0, 0.1, Some(100.0)).is_ok());
    }

    #[test]
    fn try_orthographic_refuses_a_bad_half_height_or_depth_range() {
        let err = Camera::try_orthographic(0.0, 0.1, 10.0).unwrap_err();
        assert_eq!(err, CameraError::BadHalfHeight(0.0));
        assert!(err.to_string().contains("half-height 0"), "{err}");
        let err = Camera::try_orthographic(1.0, 5.0, 5.0).unwrap_err();
        assert_eq!(err, CameraError::BadOrthographicDepthRange { near: 5.0, far: 5.0 });
        assert!(err.to_string().contains("near 5, far 5"), "{err}");
        assert!(Camera::try_orthographic(1.0, -10.0, 10.0).is_ok(), "a negative near plane is legal");
    }

    #[test]
    fn validate_catches_what_the_unchecked_constructors_let_through() {
        assert!(Camera::perspective(1.0, 0.0, Some(100.0)).validate().is_err());
        assert!(Camera::orthographic(1.0, 1.0, f32::NAN).validate().is_err());
        assert!(Camera::perspective(1.0, 0.1, None).validate().is_ok());
    }

    #[test]
    fn projection_matrix_checks_the_aspect_before_the_projection() {
        let bad = Camera::perspective(1.0, 0.0, None);
        assert_eq!(bad.projection_matrix(0.0), Err(CameraError::BadAspect(0.0)));
        assert!(matches!(bad.projection_matrix(1.0), Err(CameraError::BadDepthRange { .. })));
    }

    /// An orthographic camera shows `half_height` above and below its axis
    /// and `half_height × aspect` to either side: with 2 and 1.5, the
    /// corner (3, 2) of the view lands on the NDC corner (1, 1).
    #[test]
    fn an_orthographic_view_is_as_wide_as_its_height_times_the_aspect() {
        let camera = Camera::orthographic(2.0, 0.5, 10.0);
        let m = camera.projection_matrix(1.5).unwrap();
        let corner = m.project_point3(glam::Vec3::new(3.0, 2.0, -5.0));
        assert!((corner.truncate() - glam::Vec2::ONE).abs().max_element() < 1e-6, "{corner}");
    }
}
