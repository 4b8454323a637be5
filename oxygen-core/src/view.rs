//! Views: who looks at the scene, and how.
//!
//! An application registers a view with a [`ViewResolver`]; every frame the
//! renderer hands the resolver a [`ViewContext`] and gets back a
//! [`ResolvedView`]: the matrices, frustum and viewport that ScenePrep culls
//! against and the passes render with. Resolution validates everything, so a
//! degenerate camera becomes an error for that view, never a NaN on the GPU.

use std::fmt;

use glam::{DMat4, DVec3, Mat4, UVec2, Vec3};
use thiserror::Error;

use crate::{Camera, CameraError, Frustum, Scene};

/// Identifies a view: one an application registered, or one a renderer
/// made for itself (a light's shadow view, a reflection probe's face).
///
/// Opaque: an id comes from a [`ViewIds`] allocator (the registry of views
/// holds one, the renderer one per range of its own), never from a number,
/// so it always names a view somebody allocated. Ids of different
/// [`ViewIdRange`]s never meet, so the renderer's views cannot take an id
/// the application will be handed later. Ordered by range (the
/// application's first), then by allocation order.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ViewId {
    range: ViewIdRange,
    index: u32,
}

/// Who hands out a [`ViewId`]: each range has its own allocator, so ids of
/// different ranges never collide.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[non_exhaustive]
pub enum ViewIdRange {
    /// Views an application registers (`view#N`).
    Application,
    /// Shadow views a renderer makes for its lights: sun cascades and
    /// local-light faces (`shadow-view#N`).
    Shadow,
    /// Face views of reflection probes (`probe-face#N`).
    ProbeFace,
}

impl ViewId {
    /// The range the id was allocated from.
    pub fn range(self) -> ViewIdRange {
        self.range
    }
}

impl fmt::Display for ViewId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let prefix = match self.range {
            ViewIdRange::Application => "view",
            ViewIdRange::Shadow => "shadow-view",
            ViewIdRange::ProbeFace => "probe-face",
        };
        write!(f, "{prefix}#{}", self.index)
    }
}

// The Display form says all there is (range and number) and keeps
// `{:?}` of lists of ids short.
impl fmt::Debug for ViewId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

/// Hands out the ids of one [`ViewIdRange`], each once, in order. Not
/// `Clone`: a copy would hand out the same ids again.
#[derive(Debug)]
pub struct ViewIds {
    range: ViewIdRange,
    next: u32,
}

/// An allocator of the application's ids ([`ViewIdRange::Application`]).
impl Default for ViewIds {
    fn default() -> Self {
        ViewIds::new(ViewIdRange::Application)
    }
}

impl ViewIds {
    /// An allocator of `range`'s ids, starting at its first.
    pub fn new(range: ViewIdRange) -> Self {
        ViewIds { range, next: 0 }
    }

    /// A fresh id. After 2³² ids of one allocator the numbers start over (a
    /// registry would have to outlive billions of registrations first).
    pub fn allocate(&mut self) -> ViewId {
        let id = ViewId { range: self.range, index: self.next };
        self.next = self.next.wrapping_add(1);
        id
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
    /// World → view in `f64`: the exact pose the `f32` matrices above round.
    /// [`ResolvedView::relative_to`] builds the GPU's camera-relative
    /// matrices from it, so a camera a million units from the world origin
    /// still renders without `f32` jitter.
    pub world_to_view: DMat4,
}

impl ResolvedView {
    /// Builds and validates a resolved view from its matrices. Prefer
    /// [`ResolvedView::new_f64`] when the pose is known in `f64` (cameras far
    /// from the world origin).
    pub fn new(
        view_id: ViewId,
        view: Mat4,
        projection: Mat4,
        viewport: UVec2,
        near: f32,
        far: f32,
    ) -> Result<Self, ViewError> {
        if !view.is_finite() {
            return Err(ViewError::NonFiniteMatrix { view: view_id, which: "view" });
        }
        Self::new_f64(view_id, view.as_dmat4(), projection, viewport, near, far)
    }

    /// The same view at another `viewport` size: the projection keeps its
    /// vertical extent and widens or narrows horizontally with the new
    /// aspect ratio (its first row scaled by old aspect / new aspect), as a
    /// window resized under a camera does. Fails like [`Self::new_f64`].
    pub fn with_viewport(&self, viewport: UVec2) -> Result<Self, ViewError> {
        if viewport.x == 0 || viewport.y == 0 {
            return Err(ViewError::EmptyViewport { view: self.view_id, width: viewport.x, height: viewport.y });
        }
        let old = self.viewport.x as f32 / self.viewport.y.max(1) as f32;
        let new = viewport.x as f32 / viewport.y as f32;
        let mut projection = self.projection;
        let k = old / new;
        projection.x_axis.x *= k;
        projection.y_axis.x *= k;
        projection.z_axis.x *= k;
        projection.w_axis.x *= k;
        Self::new_f64(self.view_id, self.world_to_view, projection, viewport, self.near, self.far)
    }

    /// Builds and validates a resolved view from a world → view matrix in
    /// `f64`; the `f32` matrices used for culling are rounded from it.
    pub fn new_f64(
        view_id: ViewId,
        world_to_view: DMat4,
        projection: Mat4,
        viewport: UVec2,
        near: f32,
        far: f32,
    ) -> Result<Self, ViewError> {
        if viewport.x == 0 || viewport.y == 0 {
            return Err(ViewError::EmptyViewport { view: view_id, width: viewport.x, height: viewport.y });
        }
        let view = world_to_view.as_mat4();
        for (which, m) in [("view", &view), ("projection", &projection)] {
            if !m.is_finite() || !world_to_view.is_finite() {
                return Err(ViewError::NonFiniteMatrix { view: view_id, which });
            }
        }
        let view_projection = projection * view;
        let det = view_projection.determinant();
        if !(det.abs() > f32::MIN_POSITIVE) || !det.is_finite() {
            return Err(ViewError::SingularViewProjection { view: view_id });
        }
        let inverse_view_projection = view_projection.inverse();
        let camera_position = world_to_view.inverse().w_axis.truncate().as_vec3();
        if !inverse_view_projection.is_finite() || !camera_position.is_finite() {
            return Err(ViewError::SingularViewProjection { view: view_id });
        }
        Ok(ResolvedView {
            view_id,
            view,
            projection,
            view_projection,
            inverse_view_projection,
            // In f64: the f32 view-projection of a camera far from the
            // origin would misplace the planes by units.
            frustum: Frustum::from_view_projection_f64(&(projection.as_dmat4() * world_to_view)),
            viewport,
            near,
            far,
            camera_position,
            world_to_view,
        })
    }

    /// The same view in coordinates centred on `origin` (world position
    /// `origin` becomes (0, 0, 0)): what the GPU receives under
    /// camera-relative rendering. Composed in `f64` from
    /// [`ResolvedView::world_to_view`], so the rounding to `f32` happens on
    /// small numbers. With `origin` = 0 the matrices are unchanged.
    pub fn relative_to(&self, origin: DVec3) -> ResolvedView {
        if origin == DVec3::ZERO {
            return *self;
        }
        let world_to_view = self.world_to_view * DMat4::from_translation(origin);
        let view_projection64 = self.projection.as_dmat4() * world_to_view;
        let view_projection = view_projection64.as_mat4();
        ResolvedView {
            view: world_to_view.as_mat4(),
            view_projection,
            inverse_view_projection: view_projection64.inverse().as_mat4(),
            frustum: Frustum::from_view_projection(&view_projection),
            camera_position: world_to_view.inverse().w_axis.truncate().as_vec3(),
            world_to_view,
            ..*self
        }
    }

    /// The eye position in `f64`.
    pub fn camera_position_f64(&self) -> DVec3 {
        self.world_to_view.inverse().w_axis.truncate()
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
///
/// [`LookAtResolver::new`] checks the camera and the pose where they are
/// made; a struct literal is checked only when the view resolves.
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

impl LookAtResolver {
    /// A camera at `eye` looking at `target` with +Y up, rendering `viewport`
    /// pixels; [`LookAtResolver::with_up`] picks another up.
    ///
    /// Refused now rather than at render time: an invalid `camera` (see
    /// [`Camera::validate`]), an empty viewport, a non-finite eye or target,
    /// or an eye on its target. A camera looking straight along ±Y, where +Y
    /// cannot be up, gets −Z as its up instead.
    pub fn new(camera: Camera, eye: Vec3, target: Vec3, viewport: UVec2) -> Result<Self, CameraError> {
        camera.validate()?;
        if viewport.x == 0 || viewport.y == 0 {
            return Err(CameraError::EmptyViewport { width: viewport.x, height: viewport.y });
        }
        let up = if is_usable_up(target - eye, Vec3::Y) { Vec3::Y } else { Vec3::NEG_Z };
        let resolver = LookAtResolver { camera, eye, target, up, viewport };
        resolver.check_pose()?;
        Ok(resolver)
    }

    /// The same camera with `up` as its up direction; refused if `up` is zero,
    /// not finite or parallel to `target - eye`.
    pub fn with_up(self, up: Vec3) -> Result<Self, CameraError> {
        let resolver = LookAtResolver { up, ..self };
        resolver.check_pose()?;
        Ok(resolver)
    }

    fn check_pose(&self) -> Result<(), CameraError> {
        let forward = self.target - self.eye;
        if self.eye.is_finite() && self.target.is_finite() && is_usable_up(forward, self.up) {
            Ok(())
        } else {
            Err(CameraError::DegenerateLookAt { eye: self.eye, target: self.target, up: self.up })
        }
    }
}

/// Whether `up` and a `forward` direction span a plane, so that a view basis
/// can be built from them. The threshold is the one `resolve` applies.
fn is_usable_up(forward: Vec3, up: Vec3) -> bool {
    forward.length_squared() > 0.0 && up.is_finite() && forward.cross(up).length_squared() > 1e-12
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
        let view = DMat4::look_at_rh(self.eye.as_dvec3(), self.target.as_dvec3(), self.up.as_dvec3());
        let (near, far) = self.camera.depth_range();
        ResolvedView::new_f64(view_id, view, projection, self.viewport, near, far)
    }
}

/// A look-at camera whose eye and target are f64 world positions: for
/// cameras far from the origin, where f32 positions would move the view by
/// whole units (the view matrix is built in f64, like every world matrix,
/// and only the camera-relative result is rounded to f32).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DLookAtResolver {
    /// Projection.
    pub camera: Camera,
    /// Eye position.
    pub eye: glam::DVec3,
    /// Point looked at.
    pub target: glam::DVec3,
    /// Up direction.
    pub up: Vec3,
    /// Viewport size in pixels.
    pub viewport: UVec2,
}

impl ViewResolver for DLookAtResolver {
    fn resolve(&self, ctx: &ViewContext, _scene: &Scene) -> Result<ResolvedView, ViewError> {
        let view_id = ctx.view_id;
        let forward = self.target - self.eye;
        let degenerate = || ViewError::DegenerateLookAt {
            view: view_id,
            eye: self.eye.as_vec3(),
            target: self.target.as_vec3(),
            up: self.up,
        };
        if !(forward.length_squared() > 0.0)
            || !(forward.normalize().cross(self.up.as_dvec3()).length_squared() > 1e-12)
            || !self.eye.is_finite()
            || !self.target.is_finite()
        {
            return Err(degenerate());
        }
        if self.viewport.x == 0 || self.viewport.y == 0 {
            return Err(ViewError::EmptyViewport { view: view_id, width: self.viewport.x, height: self.viewport.y });
        }
        let aspect = self.viewport.x as f32 / self.viewport.y as f32;
        let projection =
            self.camera.projection_matrix(aspect).map_err(|source| ViewError::Camera { view: view_id, source })?;
        let view = DMat4::look_at_rh(self.eye, self.target, self.up.as_dvec3());
        let (near, far) = self.camera.depth_range();
        ResolvedView::new_f64(view_id, view, projection, self.viewport, near, far)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_f64_look_at_thirty_million_units_out_sees_what_it_sees_at_the_origin() {
        let camera = |offset: glam::DVec3| DLookAtResolver {
            camera: Camera::perspective(1.0, 0.01, None),
            eye: offset + glam::DVec3::new(0.3, 0.2, 1.0),
            target: offset,
            up: Vec3::Y,
            viewport: UVec2::new(64, 64),
        };
        let near = camera(glam::DVec3::ZERO).resolve(&ctx(), &Scene::new()).unwrap();
        let far = camera(glam::DVec3::new(3e7, -1e6, 3e7)).resolve(&ctx(), &Scene::new()).unwrap();
        // The same rotation, and the same eye relative to the target.
        let rotation = |v: &ResolvedView| v.world_to_view.to_cols_array()[..11].to_vec();
        for (a, b) in rotation(&near).iter().zip(rotation(&far)) {
            assert!((a - b).abs() < 1e-9, "{a} against {b}");
        }
        let eye = |v: &ResolvedView, offset: glam::DVec3| v.world_to_view.inverse().w_axis.truncate() - offset;
        assert!((eye(&near, glam::DVec3::ZERO) - eye(&far, glam::DVec3::new(3e7, -1e6, 3e7))).length() < 1e-6);
    }

    /// The fourth id a registry hands out (`view#3`).
    fn fourth_id() -> ViewId {
        let mut ids = ViewIds::new(ViewIdRange::Application);
        for _ in 0..3 {
            ids.allocate();
        }
        ids.allocate()
    }

    #[test]
    fn ids_of_different_ranges_never_meet_and_say_whose_they_are() {
        let mut application = ViewIds::new(ViewIdRange::Application);
        let mut shadows = ViewIds::new(ViewIdRange::Shadow);
        let mut faces = ViewIds::new(ViewIdRange::ProbeFace);
        let ids = [application.allocate(), shadows.allocate(), faces.allocate(), application.allocate()];
        for (i, a) in ids.iter().enumerate() {
            for b in &ids[i + 1..] {
                assert_ne!(a, b);
            }
        }
        let names: Vec<String> = ids.iter().map(ToString::to_string).collect();
        assert_eq!(names, ["view#0", "shadow-view#0", "probe-face#0", "view#1"]);
        assert_eq!(format!("{:?}", ids[1]), "shadow-view#0");
        assert_eq!(ids[1].range(), ViewIdRange::Shadow);
        // The application's views sort first, then by allocation.
        assert!(ids[0] < ids[3] && ids[3] < ids[1] && ids[1] < ids[2]);
    }

    fn ctx() -> ViewContext {
        ViewContext { view_id: fourth_id(), frame_index: 1, time_seconds: 0.0 }
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

    /// A camera 1e6 units out, looking at a point 0.01 units to the side of
    /// its target: in absolute `f32` the point lands where the rounding of the
    /// view matrix puts it (f32 spacing at 1e6 is 0.0625); relative to an
    /// origin near the camera it lands within a micro-unit of the same scene
    /// built at the world origin.
    #[test]
    fn relative_matrices_keep_precision_a_million_units_out() {
        let offset = Vec3::new(1e6, 0.0, -1e6);
        let at = |base: Vec3| LookAtResolver {
            camera: Camera::perspective(1.0, 1e-3, None),
            eye: base + Vec3::new(0.25, 1.5, 3.0),
            target: base,
            up: Vec3::Y,
            viewport: UVec2::new(64, 64),
        };
        let reference = at(Vec3::ZERO).resolve(&ctx(), &Scene::new()).unwrap();
        let far = at(offset).resolve(&ctx(), &Scene::new()).unwrap();
        let point = Vec3::new(0.01, 0.02, -0.03);
        let ndc = |m: Mat4, p: Vec3| m.project_point3(p);
        let expected = ndc(reference.view_projection, point);

        let relative = far.relative_to(offset.as_dvec3());
        let relative_error = (ndc(relative.view_projection, point) - expected).abs().max_element();
        let absolute_error = (ndc(far.view_projection, point + offset) - expected).abs().max_element();
        assert!(relative_error < 1e-5, "relative error {relative_error}");
        assert!(absolute_error > 1e-3, "absolute f32 error {absolute_error} should be visible");
        assert!((relative.camera_position - Vec3::new(0.25, 1.5, 3.0)).length() < 1e-6);
        // The relative frustum culls relative positions.
        assert!(relative.frustum.intersects_aabb(&crate::Aabb::new(point - 0.01, point + 0.01)));
    }

    #[test]
    fn relative_to_the_world_origin_changes_nothing() {
        let v = LookAtResolver {
            camera: Camera::perspective(1.0, 0.1, Some(100.0)),
            eye: Vec3::new(1.0, 2.0, 3.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            viewport: UVec2::new(8, 8),
        }
        .resolve(&ctx(), &Scene::new())
        .unwrap();
        assert_eq!(v.relative_to(DVec3::ZERO), v);
    }
}
