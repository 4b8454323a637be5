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

/// The hasher of maps and sets keyed by [`ViewId`] ([`ViewIdMap`],
/// [`ViewIdSet`]): a multiply-and-rotate mix of the id's two words, where
/// the standard library's SipHash costs a 1 024-camera batch more than a
/// microsecond a camera a frame in lookups. Ids come from this crate's
/// allocators, never from outside, so nothing can choose keys that collide.
#[derive(Clone, Copy, Debug, Default)]
pub struct ViewIdHasher(u64);

impl ViewIdHasher {
    fn mix(&mut self, word: u64) {
        // A large odd constant (2^64 / φ): the multiply carries every bit
        // of the word into the high bits, where hash tables read their tags.
        self.0 = (self.0.rotate_left(5) ^ word).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }
}

impl std::hash::Hasher for ViewIdHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.mix(u64::from_le_bytes(word));
        }
    }
    fn write_u8(&mut self, n: u8) {
        self.mix(u64::from(n));
    }
    fn write_u32(&mut self, n: u32) {
        self.mix(u64::from(n));
    }
    fn write_u64(&mut self, n: u64) {
        self.mix(n);
    }
    fn write_isize(&mut self, n: isize) {
        self.mix(n as u64);
    }
    fn write_usize(&mut self, n: usize) {
        self.mix(n as u64);
    }
}

/// Builds [`ViewIdHasher`]s.
pub type ViewIdHashing = std::hash::BuildHasherDefault<ViewIdHasher>;
/// A hash map keyed by [`ViewId`] with the cheap [`ViewIdHasher`]
/// (`ViewIdMap::default()` makes one).
pub type ViewIdMap<V> = std::collections::HashMap<ViewId, V, ViewIdHashing>;
/// A hash set of [`ViewId`]s with the cheap [`ViewIdHasher`].
pub type ViewIdSet = std::collections::HashSet<ViewId, ViewIdHashing>;

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
    use glam::Vec4;

    use super::*;

    /// The cheap hasher tells ids apart: 4 096 ids of three ranges hash to
    /// 12 288 different values, and a run of 1 024 cameras' ids spreads
    /// over the top seven bits (the tags a hash table probes by) and the
    /// low ones (its buckets), none of them used much more than its share.
    #[test]
    fn view_ids_hash_apart() {
        use std::hash::BuildHasher;
        let hashing = ViewIdHashing::default();
        let mut all = std::collections::HashSet::new();
        for range in [ViewIdRange::Application, ViewIdRange::Shadow, ViewIdRange::ProbeFace] {
            let mut ids = ViewIds::new(range);
            for _ in 0..4096 {
                assert!(all.insert(hashing.hash_one(ids.allocate())));
            }
        }
        let mut ids = ViewIds::new(ViewIdRange::Application);
        let hashes: Vec<u64> = (0..1024).map(|_| hashing.hash_one(ids.allocate())).collect();
        for (what, bucket) in [("top 7 bits", 57u32), ("low 7 bits", 0)] {
            let mut counts = [0u32; 128];
            for h in &hashes {
                counts[((h >> bucket) & 127) as usize] += 1;
            }
            let most = counts.iter().max().copied().unwrap_or(0);
            // 8 a value on average.
            assert!(most <= 24, "{what}: {most} of 1 024 ids share a value");
        }
        let mut map: ViewIdMap<u32> = ViewIdMap::default();
        let mut ids = ViewIds::new(ViewIdRange::Shadow);
        let keys: Vec<ViewId> = (0..100).map(|_| ids.allocate()).collect();
        for (i, k) in keys.iter().enumerate() {
            map.insert(*k, i as u32);
        }
        assert!(keys.iter().enumerate().all(|(i, k)| map.get(k) == Some(&(i as u32))));
    }

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

    /// A camera near the origin looking at it, `viewport` pixels.
    fn look_at(viewport: UVec2) -> LookAtResolver {
        LookAtResolver {
            camera: Camera::perspective(1.0, 0.1, Some(100.0)),
            eye: Vec3::new(1.0, 2.0, 3.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            viewport,
        }
    }

    /// Where the far-out f64 tests put their cameras.
    const FAR_OUT: DVec3 = DVec3::new(3e7, -1e6, 3e7);

    fn d_look_at(eye: DVec3, target: DVec3, up: Vec3) -> DLookAtResolver {
        DLookAtResolver {
            camera: Camera::perspective(1.0, 0.01, Some(100.0)),
            eye,
            target,
            up,
            viewport: UVec2::new(64, 32),
        }
    }

    fn max_difference(a: Mat4, b: Mat4) -> f32 {
        (a - b).abs().to_cols_array().into_iter().fold(0.0, f32::max)
    }

    /// The largest entry difference over the largest entry of `b`.
    fn relative_difference(a: Mat4, b: Mat4) -> f32 {
        max_difference(a, b) / b.abs().to_cols_array().into_iter().fold(0.0, f32::max)
    }

    #[test]
    fn both_look_ats_project_with_the_viewport_aspect() {
        let r = look_at(UVec2::new(64, 32));
        let v = r.resolve(&ctx(), &Scene::new()).unwrap();
        assert_eq!(v.aspect(), 2.0);
        assert_eq!(v.viewport, UVec2::new(64, 32));
        assert_eq!(v.projection, r.camera.projection_matrix(2.0).unwrap());
        assert_eq!((v.near, v.far), (0.1, 100.0));

        let d = d_look_at(FAR_OUT + r.eye.as_dvec3(), FAR_OUT, Vec3::Y);
        let dv = d.resolve(&ctx(), &Scene::new()).unwrap();
        assert_eq!(dv.aspect(), 2.0);
        assert_eq!(dv.projection, d.camera.projection_matrix(2.0).unwrap());
    }

    #[test]
    fn an_empty_viewport_is_refused_as_empty_on_every_path() {
        let good = look_at(UVec2::new(8, 8)).resolve(&ctx(), &Scene::new()).unwrap();
        for size in [UVec2::new(0, 8), UVec2::new(8, 0)] {
            let empty = Err(ViewError::EmptyViewport { view: ctx().view_id, width: size.x, height: size.y });
            assert_eq!(look_at(size).resolve(&ctx(), &Scene::new()), empty);
            let d = DLookAtResolver { viewport: size, ..d_look_at(FAR_OUT + DVec3::Z, FAR_OUT, Vec3::Y) };
            assert_eq!(d.resolve(&ctx(), &Scene::new()), empty);
            assert_eq!(ResolvedView::new(good.view_id, good.view, good.projection, size, 0.1, 100.0), empty);
            assert_eq!(good.with_viewport(size), empty);
        }
    }

    #[test]
    fn a_resized_view_keeps_its_pose_and_vertical_extent() {
        let small = look_at(UVec2::new(64, 32)).resolve(&ctx(), &Scene::new()).unwrap();
        let resized = small.with_viewport(UVec2::new(96, 64)).unwrap();
        let direct = look_at(UVec2::new(96, 64)).resolve(&ctx(), &Scene::new()).unwrap();
        assert_eq!(resized.viewport, UVec2::new(96, 64));
        assert_eq!(resized.aspect(), 1.5);
        assert_eq!((resized.world_to_view, resized.view), (direct.world_to_view, direct.view));
        assert_eq!((resized.near, resized.far), (direct.near, direct.far));
        // The scale 4/3 is rounded to f32 once and each scaled entry once
        // more; measured 0, the bound (about 8 ulps of the largest entry,
        // 1.83) leaves room for another rounding order.
        let e = max_difference(resized.projection, direct.projection);
        assert!(e <= 1e-6, "projection differs by {e}");
    }

    #[test]
    fn a_resized_view_scales_the_whole_first_row_of_any_projection() {
        // An off-centre, sheared and shifted projection (a jittered or
        // tiled one): every entry of its first row is non-zero.
        let mut projection = Camera::perspective(1.0, 0.1, Some(100.0)).projection_matrix(2.0).unwrap();
        projection.y_axis.x = 0.05;
        projection.z_axis.x = 0.1;
        projection.w_axis.x = 0.2;
        let view = Mat4::look_at_rh(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y);
        let v = ResolvedView::new(fourth_id(), view, projection, UVec2::new(64, 32), 0.1, 100.0).unwrap();
        let resized = v.with_viewport(UVec2::new(96, 64)).unwrap();
        // Old aspect 2 over new aspect 1.5.
        let k = 4.0 / 3.0;
        let (got, expected) = (resized.projection.row(0), projection.row(0) * k);
        // As above: measured 0, a few ulps allowed.
        assert!((got - expected).abs().max_element() <= 1e-6, "{got} against {expected}");
        for i in 1..4 {
            assert_eq!(resized.projection.row(i), projection.row(i));
        }
        assert_eq!(resized.view, v.view);
    }

    #[test]
    fn non_finite_matrices_are_refused_naming_which() {
        let view = DMat4::look_at_rh(DVec3::new(1.0, 2.0, 3.0), DVec3::ZERO, DVec3::Y);
        let projection = Camera::perspective(1.0, 0.1, Some(100.0)).projection_matrix(1.0).unwrap();
        let resolve = |view: DMat4, projection: Mat4| {
            ResolvedView::new_f64(fourth_id(), view, projection, UVec2::new(8, 8), 0.1, 100.0)
        };
        let refused = |which| Err(ViewError::NonFiniteMatrix { view: fourth_id(), which });
        let mut nan_projection = projection;
        nan_projection.z_axis.w = f32::NAN;
        assert_eq!(resolve(view, nan_projection), refused("projection"));
        // Finite in f64, past f32's range once rounded.
        let beyond_f32 = DMat4::from_scale(DVec3::splat(1e39)) * view;
        assert_eq!(resolve(beyond_f32, projection), refused("view"));
        assert!(resolve(view, projection).is_ok());
    }

    #[test]
    fn a_view_projection_needs_a_normal_finite_determinant() {
        let resolve = |projection: Mat4| {
            ResolvedView::new_f64(fourth_id(), DMat4::IDENTITY, projection, UVec2::new(8, 8), 0.1, 100.0)
        };
        let singular = Err(ViewError::SingularViewProjection { view: fourth_id() });
        assert_eq!(resolve(Mat4::ZERO), singular);
        // Powers of two, so the determinant is exact: 2^-126, the smallest
        // normal f32, is refused (the bound is exclusive); 2^-125 is not.
        let power = |e: i32| 2f32.powi(e);
        let at = Mat4::from_diagonal(Vec4::new(power(-32), power(-32), power(-31), power(-31)));
        assert_eq!(at.determinant(), f32::MIN_POSITIVE);
        assert_eq!(resolve(at), singular);
        let above = Mat4::from_diagonal(Vec4::new(power(-32), power(-32), power(-30), power(-31)));
        assert_eq!(above.determinant(), 2.0 * f32::MIN_POSITIVE);
        assert!(resolve(above).is_ok());
        // Every entry finite but the determinant overflows: its inverse
        // would come out as all zeros.
        let huge = Mat4::from_diagonal(Vec4::splat(1e10));
        assert_eq!(huge.determinant(), f32::INFINITY);
        assert_eq!(resolve(huge), singular);
    }

    #[test]
    fn an_eye_beyond_f32_range_is_refused_even_when_the_matrices_fit() {
        // World → view shrinks by 1e-10 and moves by 1e30: both fit f32,
        // but the eye it implies lies 1e40 out.
        let shift = DVec3::new(1e30, 0.0, 0.0);
        let world_to_view = DMat4::from_translation(shift) * DMat4::from_scale(DVec3::splat(1e-10));
        // A "projection" undoing the shift leaves an invertible diagonal
        // view-projection, so only the eye is wrong.
        let projection = Mat4::from_translation(-shift.as_vec3());
        assert!((projection * world_to_view.as_mat4()).inverse().is_finite());
        assert!(!world_to_view.inverse().w_axis.truncate().as_vec3().is_finite());
        let v = ResolvedView::new_f64(fourth_id(), world_to_view, projection, UVec2::new(8, 8), 0.1, 100.0);
        assert_eq!(v, Err(ViewError::SingularViewProjection { view: fourth_id() }));
    }

    #[test]
    fn the_resolved_frustum_is_the_view_projections() {
        let v = look_at(UVec2::new(64, 32)).resolve(&ctx(), &Scene::new()).unwrap();
        let from_f32 = Frustum::from_view_projection(&v.view_projection);
        for (a, b) in v.frustum.planes.iter().zip(&from_f32.planes) {
            let (en, ed) = ((a.normal - b.normal).abs().max_element(), (a.d - b.d).abs() / b.d.abs().max(1.0));
            // The f64 planes are widened outward by their f32 rounding
            // bound: measured up to 6e-8 on normals and 1.5e-6 relative on
            // distances; the bounds allow about 4x that. A plane of another
            // matrix is off by order 1.
            assert!(en <= 2.5e-7 && ed <= 6e-6, "{a:?} against {b:?}");
        }
        let around = |p: Vec3| crate::Aabb::new(p - 0.1, p + 0.1);
        assert!(v.frustum.intersects_aabb(&around(Vec3::ZERO)));
        assert!(!v.frustum.intersects_aabb(&around(Vec3::new(2.0, 4.0, 6.0))), "behind the eye");
        assert!(!v.frustum.intersects_aabb(&around(Vec3::new(-300.0, 0.0, -300.0))), "past the far plane");
    }

    #[test]
    fn a_view_relative_to_an_origin_is_the_same_view_shifted_in_f32_and_f64() {
        let eye = DVec3::new(0.3, 0.2, 1.0);
        let far = d_look_at(FAR_OUT + eye, FAR_OUT, Vec3::Y).resolve(&ctx(), &Scene::new()).unwrap();
        let at_origin = d_look_at(eye, DVec3::ZERO, Vec3::Y).resolve(&ctx(), &Scene::new()).unwrap();
        // f64 rounding of a pose 3e7 out (ulp 4e-9): measured 7.5e-9 and
        // 9.7e-9 for the two eyes below, bound 5x that.
        let e = (far.camera_position_f64() - (FAR_OUT + eye)).length();
        assert!(e < 5e-8, "eye off by {e}");

        let relative = far.relative_to(FAR_OUT);
        let e = (relative.camera_position_f64() - eye).length();
        assert!(e < 5e-8, "relative eye off by {e}");
        for (which, a, b) in [
            ("view", relative.view, at_origin.view),
            ("view-projection", relative.view_projection, at_origin.view_projection),
            ("inverse view-projection", relative.inverse_view_projection, at_origin.inverse_view_projection),
        ] {
            // f32 rounding of the same f64 matrices: measured up to 1.5e-7
            // of the largest entry (the inverse's), bound about 3x that.
            let e = relative_difference(a, b);
            assert!(e <= 5e-7, "{which} differs by {e}");
        }
        assert_eq!((relative.projection, relative.viewport), (far.projection, far.viewport));
    }

    #[test]
    fn the_pose_check_and_resolve_share_one_threshold_on_up() {
        // Looking along +X with up (0, y, 0), |forward × up|² is y², and
        // y = 1e-6 squares exactly to the f32 threshold 1e-12.
        let at = Vec3::new(0.0, 1e-6, 0.0);
        assert_eq!(Vec3::X.cross(at).length_squared(), 1e-12);
        let above = Vec3::new(0.0, 1e-6_f32.next_up(), 0.0);
        let base = LookAtResolver { eye: Vec3::ZERO, target: Vec3::X, ..look_at(UVec2::new(8, 8)) };
        assert!(matches!(base.with_up(at), Err(CameraError::DegenerateLookAt { .. })));
        let resolved = LookAtResolver { up: at, ..base }.resolve(&ctx(), &Scene::new());
        assert!(matches!(resolved, Err(ViewError::DegenerateLookAt { .. })), "{resolved:?}");
        let accepted = base.with_up(above).unwrap();
        assert!(accepted.resolve(&ctx(), &Scene::new()).is_ok());
    }

    #[test]
    fn an_eye_closer_to_its_target_than_f32_can_square_is_degenerate_whatever_the_up() {
        // 1e-25 squared underflows f32 to 0; crossed with an up of 1e30 the
        // forward direction would look long enough (1e10 squared).
        let target = Vec3::new(1e-25, 0.0, 0.0);
        let huge_up = Vec3::new(0.0, 1e30, 0.0);
        assert_eq!(target.length_squared(), 0.0);
        assert!(target.cross(huge_up).length_squared() > 1e-12);
        let r = LookAtResolver { eye: Vec3::ZERO, target, up: huge_up, ..look_at(UVec2::new(8, 8)) };
        assert!(matches!(r.resolve(&ctx(), &Scene::new()), Err(ViewError::DegenerateLookAt { .. })));
        let r = LookAtResolver { up: Vec3::Y, ..r };
        assert!(matches!(r.with_up(huge_up), Err(CameraError::DegenerateLookAt { .. })));
    }

    #[test]
    fn a_look_at_along_its_up_is_degenerate_not_a_nan() {
        let r = LookAtResolver { eye: Vec3::new(0.0, 5.0, 0.0), target: Vec3::ZERO, ..look_at(UVec2::new(8, 8)) };
        assert!(matches!(r.resolve(&ctx(), &Scene::new()), Err(ViewError::DegenerateLookAt { .. })));
        let d = d_look_at(FAR_OUT + DVec3::Y * 5.0, FAR_OUT, Vec3::Y);
        let err = d.resolve(&ctx(), &Scene::new()).unwrap_err();
        let expected = ViewError::DegenerateLookAt {
            view: ctx().view_id,
            eye: (FAR_OUT + DVec3::Y * 5.0).as_vec3(),
            target: FAR_OUT.as_vec3(),
            up: Vec3::Y,
        };
        assert_eq!(err, expected);
        let d = d_look_at(FAR_OUT, FAR_OUT, Vec3::Y);
        assert!(matches!(d.resolve(&ctx(), &Scene::new()), Err(ViewError::DegenerateLookAt { .. })));
    }

    #[test]
    fn an_f64_look_at_refuses_an_up_at_its_threshold_and_takes_one_above() {
        // Looking along +X exactly (3e7 + 1 is exact in f64) with up
        // (0, y, z), |forward × up|² is z² + y². The f32 nearest 1e-6
        // squares to 5.05e-21 short of the f64 threshold 1e-12; this
        // z (7.1e-11) makes up the difference exactly.
        let (eye, target) = (FAR_OUT, FAR_OUT + DVec3::X);
        let at = Vec3::new(0.0, 1e-6, f32::from_bits(0x2e9c_4330));
        assert_eq!((target - eye).normalize().cross(at.as_dvec3()).length_squared(), 1e-12);
        let refused = d_look_at(eye, target, at).resolve(&ctx(), &Scene::new());
        assert!(matches!(refused, Err(ViewError::DegenerateLookAt { .. })), "{refused:?}");
        let above = Vec3::new(0.0, 2e-6, 0.0);
        assert!(d_look_at(eye, target, above).resolve(&ctx(), &Scene::new()).is_ok());
    }
}
