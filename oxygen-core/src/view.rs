//! Views: who looks at the scene, and how.
//!
//! An application registers a view with a [`ViewResolver`]; every frame the
//! renderer hands the resolver a [`ViewContext`] and gets back a
//! [`ResolvedView`]: the matrices, frustum and viewport that ScenePrep culls
//! against and the passes render with. Resolution validates everything, so a
//! degenerate camera becomes an error for that view, never a NaN on the GPU.

use std::fmt;

use glam::{Mat4, UVec2, Vec3};
use thiserror::Error;

use crate::{Camera, CameraError, Frustum, Scene};

/// Identifies a registered view. Views are prepared and submitted in
/// ascending id order, which is registration order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ViewId(pub u32);

impl fmt::Display for ViewId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "view#{}", self.0)
    }
}

/// What a resolver knows about the frame it resolves for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewContext {
    /// The view being resolved.
    pub view_id: ViewId,
    /// Frame sequence number, starting at 1.
    pub frame_index: u64,
    /// Seconds since the renderer started (application-provided clock).
    pub time_seconds: f32,
}

/// Why a view could not be resolved.
#[derive(Debug, Error, PartialEq)]
pub enum ViewError {
    /// The camera's projection is invalid.
    #[error("{view}: {source}")]
    Camera {
        /// The view.
        view: ViewId,
        /// What was wrong with the camera.
        source: CameraError,
    },
    /// A matrix has NaN or infinite entries.
    #[error("{view}: the {which} matrix is not finite")]
    NonFiniteMatrix {
        /// The view.
        view: ViewId,
        /// Which matrix.
        which: &'static str,
    },
    /// The view-projection matrix cannot be inverted.
    #[error("{view}: the view-projection matrix is singular")]
    SingularViewProjection {
        /// The view.
        view: ViewId,
    },
    /// Width or height is zero.
    #[error("{view}: viewport {width}x{height} is empty")]
    EmptyViewport {
        /// The view.
        view: ViewId,
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// Eye and target coincide, or up is parallel to the view direction.
    #[error("{view}: look-at is degenerate (eye {eye}, target {target}, up {up})")]
    DegenerateLookAt {
        /// The view.
        view: ViewId,
        /// Eye.
        eye: Vec3,
        /// Target.
        target: Vec3,
        /// Up.
        up: Vec3,
    },
    /// A resolver-specific failure.
    #[error("{view}: {message}")]
    Other {
        /// The view.
        view: ViewId,
        /// What went wrong.
        message: String,
    },
}

/// Everything ScenePrep and the passes need to know about one view this frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResolvedView {
    /// The view.
    pub view_id: ViewId,
    /// World → view.
    pub view: Mat4,
    /// View → clip (reverse-Z).
    pub projection: Mat4,
    /// World → clip.
    pub view_projection: Mat4,
    /// Clip → world.
    pub inverse_view_projection: Mat4,
    /// Culling planes from `view_projection`.
    pub frustum: Frustum,
    /// Target size in pixels.
    pub viewport: UVec2,
    /// Near distance.
    pub near: f32,
    /// Far distance (`f32::INFINITY` when the far plane is infinite).
    pub far: f32,
    /// World-space eye position.
    pub camera_position: Vec3,
}

impl ResolvedView {
    /// Builds and validates a resolved view from its matrices.
    pub fn new(
        view_id: ViewId,
        view: Mat4,
        projection: Mat4,
        viewport: UVec2,
        near: f32,
        far: f32,
    ) -> Result<Self, ViewError> {
        if viewport.x == 0 || viewport.y == 0 {
            return Err(ViewError::EmptyViewport { view: view_id, width: viewport.x, height: viewport.y });
        }
        for (which, m) in [("view", &view), ("projection", &projection)] {
            if !m.is_finite() {
                return Err(ViewError::NonFiniteMatrix { view: view_id, which });
            }
        }
        let view_projection = projection * view;
        let det = view_projection.determinant();
        if !(det.abs() > f32::MIN_POSITIVE) || !det.is_finite() {
            return Err(ViewError::SingularViewProjection { view: view_id });
        }
        let inverse_view_projection = view_projection.inverse();
        let camera_position = view.inverse().w_axis.truncate();
        if !inverse_view_projection.is_finite() || !camera_position.is_finite() {
            return Err(ViewError::SingularViewProjection { view: view_id });
        }
        Ok(ResolvedView {
            view_id,
            view,
            projection,
            view_projection,
            inverse_view_projection,
            frustum: Frustum::from_view_projection(&view_projection),
            viewport,
            near,
            far,
            camera_position,
        })
    }

    /// Width / height of the viewport.
    pub fn aspect(&self) -> f32 {
        self.viewport.x as f32 / self.viewport.y as f32
    }
}

/// Turns a camera description into a [`ResolvedView`] each frame.
///
/// Any `Fn(&ViewContext, &Scene) -> Result<ResolvedView, ViewError>` closure
/// is a resolver; [`LookAtResolver`] covers the common fixed camera.
pub trait ViewResolver: Send + Sync {
    /// Resolves the view for this frame.
    fn resolve(&self, ctx: &ViewContext, scene: &Scene) -> Result<ResolvedView, ViewError>;
}

impl<F> ViewResolver for F
where
    F: Fn(&ViewContext, &Scene) -> Result<ResolvedView, ViewError> + Send + Sync,
{
    fn resolve(&self, ctx: &ViewContext, scene: &Scene) -> Result<ResolvedView, ViewError> {
        self(ctx, scene)
    }
}

/// A camera at `eye` looking at `target`, rendering `viewport` pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LookAtResolver {
    /// Projection.
    pub camera: Camera,
    /// Eye position (world).
    pub eye: Vec3,
    /// Point looked at (world).
    pub target: Vec3,
    /// Up direction (world); must not be parallel to `target - eye`.
    pub up: Vec3,
    /// Target size in pixels.
    pub viewport: UVec2,
}

impl ViewResolver for LookAtResolver {
    fn resolve(&self, ctx: &ViewContext, _scene: &Scene) -> Result<ResolvedView, ViewError> {
        let view_id = ctx.view_id;
        let forward = self.target - self.eye;
        if !(forward.length_squared() > 0.0)
            || !(forward.cross(self.up).length_squared() > 1e-12)
            || !self.eye.is_finite()
        {
            return Err(ViewError::DegenerateLookAt { view: view_id, eye: self.eye, target: self.target, up: self.up });
        }
        if self.viewport.x == 0 || self.viewport.y == 0 {
            return Err(ViewError::EmptyViewport { view: view_id, width: self.viewport.x, height: self.viewport.y });
        }
        let aspect = self.viewport.x as f32 / self.viewport.y as f32;
        let projection =
            self.camera.projection_matrix(aspect).map_err(|source| ViewError::Camera { view: view_id, source })?;
        let view = Mat4::look_at_rh(self.eye, self.target, self.up);
        let (near, far) = self.camera.depth_range();
        ResolvedView::new(view_id, view, projection, self.viewport, near, far)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ctx() -> ViewContext {
        ViewContext { view_id: ViewId(3), frame_index: 1, time_seconds: 0.0 }
    }

    #[test]
    fn degenerate_look_at_is_an_error_not_a_nan() {
        let r = LookAtResolver {
            camera: Camera::perspective(1.0, 0.1, None),
            eye: Vec3::ONE,
            target: Vec3::ONE,
            up: Vec3::Y,
            viewport: UVec2::new(8, 8),
        };
        assert!(matches!(r.resolve(&ctx(), &Scene::new()), Err(ViewError::DegenerateLookAt { .. })));
    }

    #[test]
    fn bad_near_plane_names_the_view() {
        let r = LookAtResolver {
            camera: Camera::perspective(1.0, 0.0, Some(10.0)),
            eye: Vec3::Z,
            target: Vec3::ZERO,
            up: Vec3::Y,
            viewport: UVec2::new(8, 8),
        };
        let err = r.resolve(&ctx(), &Scene::new()).unwrap_err();
        assert!(err.to_string().starts_with("view#3"), "{err}");
    }

    #[test]
    fn tiny_near_and_huge_far_resolve_to_finite_matrices() {
        let r = LookAtResolver {
            camera: Camera::perspective(1.0, 1e-3, Some(1e7)),
            eye: Vec3::new(1e6, 10.0, 1e6),
            target: Vec3::new(1e6, 0.0, 1e6 - 10.0),
            up: Vec3::Y,
            viewport: UVec2::new(64, 32),
        };
        let v = r.resolve(&ctx(), &Scene::new()).unwrap();
        assert!(v.inverse_view_projection.is_finite());
        assert!((v.camera_position - r.eye).length() < 1.0);
    }
}
