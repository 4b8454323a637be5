//! Cameras: reverse-Z perspective (optionally with an infinite far plane) and
//! orthographic projections, validated before they produce a matrix.

use glam::Mat4;
use thiserror::Error;

use crate::math::projection::{reverse_z_orthographic, reverse_z_perspective};

/// A projection.
#[derive(Clone, Copy, Debug, PartialEq)]
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

/// A projection that cannot produce a usable matrix.
#[derive(Debug, Error, PartialEq)]
pub enum CameraError {
    /// Field of view out of `(0, π)`.
    #[error("field of view {0} rad is outside (0, π)")]
    BadFieldOfView(f32),
    /// Near/far planes out of order, non-positive or non-finite.
    #[error("near {near} / far {far:?} planes are invalid (need 0 < near < far, finite)")]
    BadDepthRange {
        /// Near distance.
        near: f32,
        /// Far distance.
        far: Option<f32>,
    },
    /// Aspect ratio or size not positive and finite.
    #[error("aspect ratio {0} is not a positive finite number")]
    BadAspect(f32),
}

/// A camera: a projection; its pose comes from a node or a resolver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// The projection.
    pub projection: Projection,
}

impl Camera {
    /// A perspective camera.
    pub fn perspective(fov_y: f32, near: f32, far: Option<f32>) -> Self {
        Camera { projection: Projection::Perspective { fov_y, near, far } }
    }

    /// An orthographic camera.
    pub fn orthographic(half_height: f32, near: f32, far: f32) -> Self {
        Camera { projection: Projection::Orthographic { half_height, near, far } }
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
        match self.projection {
            Projection::Perspective { fov_y, near, far } => {
                if !(fov_y > 0.0 && fov_y < std::f32::consts::PI) {
                    return Err(CameraError::BadFieldOfView(fov_y));
                }
                let far_ok = far.is_none_or(|f| f.is_finite() && f > near);
                if !(near > 0.0 && near.is_finite() && far_ok) {
                    return Err(CameraError::BadDepthRange { near, far });
                }
                Ok(reverse_z_perspective(fov_y, aspect, near, far))
            }
            Projection::Orthographic { half_height, near, far } => {
                if !(half_height > 0.0 && half_height.is_finite()) {
                    return Err(CameraError::BadAspect(half_height));
                }
                if !(near.is_finite() && far.is_finite() && far > near) {
                    return Err(CameraError::BadDepthRange { near, far: Some(far) });
                }
                Ok(reverse_z_orthographic(half_height * aspect, half_height, near, far))
            }
        }
    }
}
