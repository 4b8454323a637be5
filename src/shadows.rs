//! Shadow views: the sun cascades a view owns, and the frame's local-light
//! shadow maps. Both are views the renderer creates itself each frame from
//! the lights that exist that frame, so a light added, removed or made
//! shadow-casting after registration gets or loses its shadows without the
//! application doing anything.
//!
//! * **Sun cascades.** A view registered with
//!   [`ViewDesc::with_sun_shadows`](crate::ViewDesc::with_sun_shadows) owns
//!   `count` orthographic cascade views fitted to its frustum, rendered
//!   before it, whenever the frame has a shadow sun (the first
//!   shadow-casting directional light; see
//!   [`FrameCollection::shadow_sun`](oxygen_sceneprep::FrameCollection::shadow_sun)).
//!   They are created, resized and removed with it.
//! * **Local shadows.** With [`Renderer::set_local_shadows`](crate::Renderer::set_local_shadows),
//!   every spot light that casts shadows gets one perspective view and every
//!   point light six (one per cube face), as the frame phase hands out atlas
//!   tiles; each renders straight into its tile's layer of the shared atlas.
//!   A scene without such lights renders no shadow view at all.

use std::collections::BTreeMap;

use oxygen_core::{
    CascadeSettings, LightKind, NodeKey, ResolvedView, Scene, ViewContext, ViewError, ViewId, ViewIdRange, ViewIds,
    ViewResolver, fit_cascade,
};
use oxygen_sceneprep::{FrameCollection, LocalShadowKind, ViewFilter, ViewPrepOptions};

/// ScenePrep options of a shadow view: casters only, depth only.
pub fn shadow_view_options() -> ViewPrepOptions {
    ViewPrepOptions { filter: ViewFilter::ShadowCastersOnly, depth_only: true, ..Default::default() }
}

/// Local-light shadow maps: their size and depth range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalShadowSettings {
    /// Texels a side of every tile (spot map or cube face).
    pub resolution: u32,
    /// Near plane of the light views.
    pub near: f32,
    /// Far plane of lights without a range.
    pub far: f32,
}

impl Default for LocalShadowSettings {
    fn default() -> Self {
        LocalShadowSettings { resolution: 1024, near: 0.05, far: 100.0 }
    }
}

/// One cascade of a view's sun shadows, fitted to the resolved `camera`
/// (world space) for the directional light whose node transform is
/// `light_world`.
pub fn resolve_cascade(
    view_id: ViewId,
    camera: &ResolvedView,
    light_world: glam::DMat4,
    settings: &CascadeSettings,
    index: u32,
) -> Result<ResolvedView, ViewError> {
    let direction = light_world.as_mat4().transform_vector3(glam::Vec3::NEG_Z);
    let cascade = fit_cascade(camera, direction, settings, index).ok_or_else(|| ViewError::Other {
        view: view_id,
        message: format!(
            "cascade {index} cannot be fitted (light direction {direction}, depth {}..{})",
            camera.near, camera.far
        ),
    })?;
    let side = settings.resolution.max(1);
    ResolvedView::new_f64(view_id, cascade.view, cascade.projection, glam::UVec2::splat(side), 0.0, cascade.depth)
}

/// The kind and world transform of the light on `node`, or an error for
/// `view` when the node or its light is gone.
fn light_of(scene: &Scene, node: NodeKey, view: ViewId) -> Result<(LightKind, glam::DMat4), ViewError> {
    let gone = || ViewError::Other { view, message: "the light's node or light is gone".into() };
    let light = scene.node(node).and_then(|n| n.light.as_ref()).ok_or_else(gone)?;
    Ok((light.kind, scene.world_transform(node).ok_or_else(gone)?))
}

/// A square perspective shadow view from a light: `view` (world → light, in
/// `f64`), vertical field of view `fov`, `(near, far)` depth range and
/// `resolution` texels a side.
fn light_view(
    view_id: ViewId,
    view: glam::DMat4,
    fov: f32,
    (near, far): (f32, f32),
    resolution: u32,
) -> Result<ResolvedView, ViewError> {
    let camera = oxygen_core::Camera::perspective(fov, near, Some(far));
    let projection = camera.projection_matrix(1.0).map_err(|source| ViewError::Camera { view: view_id, source })?;
    ResolvedView::new_f64(view_id, view, projection, glam::UVec2::splat(resolution.max(1)), near, far)
}

fn not_a(view: ViewId, kind: &str) -> ViewError {
    ViewError::Other { view, message: format!("the light is no longer a {kind} light") }
}

/// A spot light's shadow view: a perspective view from the light's node down
/// its −Z, wide enough for the outer cone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotShadowResolver {
    /// The node carrying the spot light.
    pub light: NodeKey,
    /// Shadow-map side in texels.
    pub resolution: u32,
    /// Near plane.
    pub near: f32,
    /// Far plane when the light has no range.
    pub far: f32,
}

impl ViewResolver for SpotShadowResolver {
    fn resolve(&self, ctx: &oxygen_core::ViewContext, scene: &Scene) -> Result<ResolvedView, ViewError> {
        let view_id = ctx.view_id;
        let (kind, world) = light_of(scene, self.light, view_id)?;
        let LightKind::Spot { range, outer_cone, .. } = kind else { return Err(not_a(view_id, "spot")) };
        let (_, rotation, position) = world.to_scale_rotation_translation();
        let view = glam::DMat4::from_rotation_translation(rotation.normalize(), position).inverse();
        // A little wider than the cone, so PCF taps at its edge stay inside.
        let fov = (outer_cone * 2.0 * 1.1).clamp(0.05, 170f32.to_radians());
        let depth = (self.near, range.filter(|r| r.is_finite() && *r > self.near).unwrap_or(self.far));
        light_view(view_id, view, fov, depth, self.resolution)
    }
}

/// One cube face of a point light's shadow: a perspective view from the
/// light's position along one of the six axes (`PROBE_FACE_AXES` order),
/// slightly wider than 90° so that PCF taps at a face's edge stay inside it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointShadowFaceResolver {
    /// The node carrying the point light.
    pub light: NodeKey,
    /// Which face (0..6: +X, −X, +Y, −Y, +Z, −Z).
    pub face: usize,
    /// Shadow-map side in texels.
    pub resolution: u32,
    /// Near plane.
    pub near: f32,
    /// Far plane when the light has no range.
    pub far: f32,
}

impl ViewResolver for PointShadowFaceResolver {
    fn resolve(&self, ctx: &oxygen_core::ViewContext, scene: &Scene) -> Result<ResolvedView, ViewError> {
        let view_id = ctx.view_id;
        let (kind, world) = light_of(scene, self.light, view_id)?;
        let LightKind::Point { range } = kind else { return Err(not_a(view_id, "point")) };
        let position = world.w_axis.truncate();
        let (forward, up) = oxygen_passes::PROBE_FACE_AXES[self.face.min(oxygen_passes::PROBE_FACES - 1)];
        let view =
            glam::DMat4::look_to_rh(position, glam::Vec3::from(forward).as_dvec3(), glam::Vec3::from(up).as_dvec3());
        // Two texels of margin on every side beyond the 90° face.
        let fov = 2.0 * (1.0 + 4.0 / self.resolution.max(1) as f32).atan();
        let depth = (self.near, range.filter(|r| r.is_finite() && *r > self.near).unwrap_or(self.far));
        light_view(view_id, view, fov, depth, self.resolution)
    }
}

/// What a frame's shadow view is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ShadowRole {
    /// Cascade `index` of `owner`'s sun shadows.
    Cascade { owner: ViewId, index: u32 },
    /// Face `face` of the local light on `light`, in atlas tile `tile`.
    Local { light: NodeKey, face: u32, tile: u32 },
}

/// A shadow view to render this frame, resolved.
pub(crate) struct PlannedShadow {
    pub(crate) id: ViewId,
    pub(crate) role: ShadowRole,
    pub(crate) resolved: Result<ResolvedView, ViewError>,
}

/// The shadow views the renderer owns, by what they are for. Their ids come
/// from the renderer's own range ([`ViewIdRange::Shadow`]), never from the
/// application's registry, and are kept while their owner and light exist,
/// so a view's slots and targets are reused frame after frame.
pub(crate) struct ShadowViews {
    ids: ViewIds,
    cascades: BTreeMap<(ViewId, u32), ViewId>,
    local: BTreeMap<(NodeKey, u32), ViewId>,
    pub(crate) local_settings: Option<LocalShadowSettings>,
}

impl ShadowViews {
    /// No shadow views; local shadows as `local_settings` says.
    pub(crate) fn new(local_settings: Option<LocalShadowSettings>) -> Self {
        ShadowViews {
            ids: ViewIds::new(ViewIdRange::Shadow),
            cascades: BTreeMap::new(),
            local: BTreeMap::new(),
            local_settings,
        }
    }

    /// Plans this frame's shadow views (frame `frame_index`, at
    /// `time_seconds`): cascades of every resolved view that asked for sun
    /// shadows (`owners`: id, resolved camera in world space, settings) when
    /// the frame has a shadow sun, and one view per local shadow tile. Ids of
    /// views no longer needed are returned in the second list, for the
    /// renderer to release.
    pub(crate) fn plan(
        &mut self,
        owners: &[(ViewId, ResolvedView, CascadeSettings)],
        frame: &FrameCollection,
        scene: &Scene,
        frame_index: u64,
        time_seconds: f32,
    ) -> (Vec<PlannedShadow>, Vec<ViewId>) {
        let ids = &mut self.ids;
        let mut allocate = || ids.allocate();
        let mut planned = Vec::new();
        let mut wanted_cascades = BTreeMap::new();
        let sun = frame.shadow_sun.and_then(|node| scene.world_transform(node));
        if let Some(light_world) = sun {
            for (owner, camera, settings) in owners {
                let settings =
                    CascadeSettings { count: settings.count.clamp(1, oxygen_passes::MAX_CASCADES as u32), ..*settings };
                for index in 0..settings.count {
                    let id = self.cascades.get(&(*owner, index)).copied().unwrap_or_else(&mut allocate);
                    wanted_cascades.insert((*owner, index), id);
                    let resolved = resolve_cascade(id, camera, light_world, &settings, index);
                    planned.push(PlannedShadow { id, role: ShadowRole::Cascade { owner: *owner, index }, resolved });
                }
            }
        }
        let mut wanted_local = BTreeMap::new();
        if let Some(settings) = self.local_settings {
            for caster in &frame.local_shadow_casters {
                for (face, tile) in caster.tiles().enumerate() {
                    let key = (caster.node, face as u32);
                    let id = self.local.get(&key).copied().unwrap_or_else(&mut allocate);
                    wanted_local.insert(key, id);
                    let ctx = ViewContext { view_id: id, frame_index, time_seconds };
                    let resolved = match caster.kind {
                        LocalShadowKind::Spot => SpotShadowResolver {
                            light: caster.node,
                            resolution: settings.resolution,
                            near: settings.near,
                            far: settings.far,
                        }
                        .resolve(&ctx, scene),
                        LocalShadowKind::Point => PointShadowFaceResolver {
                            light: caster.node,
                            face,
                            resolution: settings.resolution,
                            near: settings.near,
                            far: settings.far,
                        }
                        .resolve(&ctx, scene),
                    };
                    planned.push(PlannedShadow {
                        id,
                        role: ShadowRole::Local { light: caster.node, face: face as u32, tile },
                        resolved,
                    });
                }
            }
        }
        let mut released: Vec<ViewId> =
            self.cascades.iter().filter(|(k, _)| !wanted_cascades.contains_key(k)).map(|(_, id)| *id).collect();
        released.extend(self.local.iter().filter(|(k, _)| !wanted_local.contains_key(k)).map(|(_, id)| *id));
        self.cascades = wanted_cascades;
        self.local = wanted_local;
        (planned, released)
    }

    /// Forgets the cascades of an unregistered view (their ids are released
    /// by the caller).
    pub(crate) fn forget_owner(&mut self, owner: ViewId) {
        self.cascades.retain(|(o, _), _| *o != owner);
    }

    /// The cascade views `owner` has now, nearest first.
    pub(crate) fn cascades_of(&self, owner: ViewId) -> impl Iterator<Item = ViewId> + '_ {
        self.cascades.range((owner, 0)..=(owner, u32::MAX)).map(|(_, id)| *id)
    }

    /// Every shadow view the renderer has now.
    pub(crate) fn all(&self) -> impl Iterator<Item = ViewId> + '_ {
        self.cascades.values().chain(self.local.values()).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat4, DVec3, Mat4, Quat, UVec2, Vec3};
    use oxygen_core::{Camera, Light, LookAtResolver, Transform};
    use oxygen_sceneprep::LocalShadowCaster;

    struct Lit {
        scene: Scene,
        sun: NodeKey,
        spot: NodeKey,
        lamp: NodeKey,
    }

    const SPOT_AT: Vec3 = Vec3::new(-4.0, 4.0, 2.0);
    const LAMP_AT: Vec3 = Vec3::new(3.0, 1.5, 1.5);

    /// A sun, a spot light aimed at the origin (range 25, outer cone 0.45)
    /// and a point light (range 10).
    fn lit() -> Lit {
        let mut scene = Scene::new();
        let travelling = Vec3::new(-0.5, -1.0, -0.35).normalize();
        let sun = Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, travelling));
        let sun = scene.add_node("sun", sun);
        scene.set_light(sun, Some(Light::directional(2.0))).unwrap();
        let aim = Quat::from_rotation_arc(Vec3::NEG_Z, (Vec3::ZERO - SPOT_AT).normalize());
        let spot = scene.add_node("spot", Transform::from_translation(SPOT_AT).with_rotation(aim));
        scene.set_light(spot, Some(Light::spot(200.0, Some(25.0), 0.3, 0.45))).unwrap();
        let lamp = scene.add_node("lamp", Transform::from_translation(LAMP_AT));
        scene.set_light(lamp, Some(Light::point(20.0, Some(10.0)))).unwrap();
        Lit { scene, sun, spot, lamp }
    }

    fn context(view_id: ViewId) -> ViewContext {
        ViewContext { view_id, frame_index: 1, time_seconds: 0.0 }
    }

    fn shadow_id() -> ViewId {
        ViewIds::new(ViewIdRange::Shadow).allocate()
    }

    fn camera(scene: &Scene, view_id: ViewId) -> ResolvedView {
        let camera = Camera::perspective(50f32.to_radians(), 0.1, Some(60.0));
        let resolver = LookAtResolver::new(camera, Vec3::new(0.5, 4.0, 7.0), Vec3::ZERO, UVec2::new(128, 96));
        resolver.unwrap().resolve(&context(view_id), scene).unwrap()
    }

    fn spot(light: NodeKey) -> SpotShadowResolver {
        SpotShadowResolver { light, resolution: 256, near: 0.05, far: 100.0 }
    }

    fn point_face(light: NodeKey, face: usize) -> PointShadowFaceResolver {
        PointShadowFaceResolver { light, face, resolution: 256, near: 0.05, far: 100.0 }
    }

    /// Where a resolved view looks, in world space.
    fn forward(view: &ResolvedView) -> Vec3 {
        view.world_to_view.inverse().transform_vector3(DVec3::NEG_Z).as_vec3()
    }

    fn assert_near(a: Vec3, b: Vec3) {
        assert!(a.abs_diff_eq(b, 1e-5), "{a} is not {b}");
    }

    /// The vertical field of view of a perspective projection.
    fn fov(projection: &Mat4) -> f32 {
        2.0 * (1.0 / projection.y_axis.y).atan()
    }

    /// The frame of `lit`: its sun casts, the spot has tile 0 and the lamp
    /// tiles 1 to 6.
    fn frame(lit: &Lit) -> FrameCollection {
        let mut frame = FrameCollection::default();
        frame.shadow_sun = Some(lit.sun);
        frame.local_shadow_casters =
            vec![caster(lit.spot, LocalShadowKind::Spot, 0), caster(lit.lamp, LocalShadowKind::Point, 1)];
        frame
    }

    fn caster(node: NodeKey, kind: LocalShadowKind, first_tile: u32) -> LocalShadowCaster {
        LocalShadowCaster { node, kind, light_index: 0, first_tile, tile_count: kind.tile_count() }
    }

    fn cascades(count: u32) -> CascadeSettings {
        CascadeSettings { count, resolution: 256, max_distance: 30.0, ..Default::default() }
    }

    fn local() -> Option<LocalShadowSettings> {
        Some(LocalShadowSettings { resolution: 256, ..Default::default() })
    }

    fn owners<const N: usize>(lit: &Lit, count: u32) -> [(ViewId, ResolvedView, CascadeSettings); N] {
        let mut ids = ViewIds::default();
        std::array::from_fn(|_| {
            let id = ids.allocate();
            (id, camera(&lit.scene, id), cascades(count))
        })
    }

    fn ids_of(planned: &[PlannedShadow]) -> Vec<ViewId> {
        planned.iter().map(|p| p.id).collect()
    }

    #[test]
    fn a_shadow_view_prepares_only_casters_and_only_depth() {
        let expected =
            ViewPrepOptions { filter: ViewFilter::ShadowCastersOnly, depth_only: true, ..ViewPrepOptions::default() };
        assert_eq!(shadow_view_options(), expected);
    }

    #[test]
    fn local_shadows_default_to_1024_texels_from_5_cm_to_100_m() {
        let settings = LocalShadowSettings::default();
        assert_eq!((settings.resolution, settings.near, settings.far), (1024, 0.05, 100.0));
    }

    /// The light's position does not matter, only where its −Z points.
    #[test]
    fn a_cascade_is_fitted_down_the_lights_minus_z_at_the_settings_resolution() {
        let lit = lit();
        let id = shadow_id();
        let camera = camera(&lit.scene, id);
        // Local −Z is world −Y: straight down.
        let at = DVec3::new(10.0, 20.0, 30.0).extend(1.0);
        let light_world = DMat4::from_cols(DVec3::X.extend(0.0), DVec3::NEG_Z.extend(0.0), DVec3::Y.extend(0.0), at);
        let settings = cascades(2);
        let resolved = resolve_cascade(id, &camera, light_world, &settings, 1).unwrap();
        let fitted = fit_cascade(&camera, Vec3::NEG_Y, &settings, 1).unwrap();
        assert_eq!(resolved.view_id, id);
        assert_eq!(resolved.world_to_view, fitted.view);
        assert_eq!(resolved.projection, fitted.projection);
        assert_eq!((resolved.near, resolved.far), (0.0, fitted.depth));
        assert_eq!(resolved.viewport, UVec2::splat(256));
        let tiny = CascadeSettings { resolution: 0, ..settings };
        assert_eq!(resolve_cascade(id, &camera, light_world, &tiny, 0).unwrap().viewport, UVec2::ONE);
    }

    #[test]
    fn a_cascade_that_cannot_be_fitted_is_an_error_naming_the_view_and_the_cascade() {
        let lit = lit();
        let id = shadow_id();
        let camera = camera(&lit.scene, id);
        let message = match resolve_cascade(id, &camera, DMat4::IDENTITY, &cascades(2), 3) {
            Err(ViewError::Other { view, message }) if view == id => message,
            other => panic!("{other:?}"),
        };
        assert!(message.starts_with("cascade 3 cannot be fitted"), "{message}");
    }

    /// A tenth wider than the cone, so PCF taps at its edge stay inside.
    #[test]
    fn a_spot_shadow_looks_down_the_light_over_its_cone_and_a_tenth() {
        let lit = lit();
        let id = shadow_id();
        let resolved = spot(lit.spot).resolve(&context(id), &lit.scene).unwrap();
        assert_eq!(resolved.view_id, id);
        assert_near(resolved.camera_position, SPOT_AT);
        assert_near(forward(&resolved), (Vec3::ZERO - SPOT_AT).normalize());
        assert!((fov(&resolved.projection) - 0.45 * 2.2).abs() < 1e-5, "{}", fov(&resolved.projection));
        assert_eq!((resolved.near, resolved.far), (0.05, 25.0));
        assert_eq!(resolved.viewport, UVec2::splat(256));
    }

    #[test]
    fn a_spot_shadows_field_of_view_stays_between_a_sliver_and_170_degrees() {
        let mut lit = lit();
        for (outer_cone, expected) in [(0.001, 0.05), (2.0, 170f32.to_radians())] {
            lit.scene.set_light(lit.spot, Some(Light::spot(1.0, None, 0.0, outer_cone))).unwrap();
            let resolved = spot(lit.spot).resolve(&context(shadow_id()), &lit.scene).unwrap();
            assert!((fov(&resolved.projection) - expected).abs() < 1e-4, "cone {outer_cone}");
        }
    }

    /// A range the depth range cannot end at (none, infinite, not past the
    /// near plane) gives way to the settings' far plane.
    #[test]
    fn a_local_shadow_ends_at_the_lights_range_or_else_at_the_far_plane() {
        let mut lit = lit();
        for (range, far) in
            [(Some(25.0), 25.0), (None, 100.0), (Some(f32::INFINITY), 100.0), (Some(0.05), 100.0), (Some(0.01), 100.0)]
        {
            lit.scene.set_light(lit.spot, Some(Light::spot(1.0, range, 0.3, 0.45))).unwrap();
            lit.scene.set_light(lit.lamp, Some(Light::point(1.0, range))).unwrap();
            let spot = spot(lit.spot).resolve(&context(shadow_id()), &lit.scene);
            let point = point_face(lit.lamp, 0).resolve(&context(shadow_id()), &lit.scene);
            for resolved in [spot, point] {
                let resolved = resolved.unwrap_or_else(|e| panic!("range {range:?}: {e}"));
                assert_eq!((resolved.near, resolved.far), (0.05, far), "range {range:?}");
            }
        }
    }

    /// Two texels of margin on each side beyond the 90° face.
    #[test]
    fn a_point_shadow_face_looks_along_its_axis_from_the_light_a_little_wider_than_90_degrees() {
        let lit = lit();
        for (face, (axis, _)) in oxygen_passes::PROBE_FACE_AXES.iter().enumerate() {
            let id = shadow_id();
            let resolved = point_face(lit.lamp, face).resolve(&context(id), &lit.scene).unwrap();
            assert_eq!(resolved.view_id, id);
            assert_near(resolved.camera_position, LAMP_AT);
            assert_near(forward(&resolved), Vec3::from(*axis));
            assert!((resolved.projection.y_axis.y - 256.0 / 260.0).abs() < 1e-6, "face {face}");
            assert_eq!((resolved.far, resolved.viewport), (10.0, UVec2::splat(256)));
        }
    }

    #[test]
    fn a_point_shadow_face_past_the_sixth_is_the_sixth() {
        let lit = lit();
        let resolve = |face| point_face(lit.lamp, face).resolve(&context(shadow_id()), &lit.scene).unwrap();
        assert_eq!(resolve(9), resolve(5));
        assert_near(forward(&resolve(6)), Vec3::NEG_Z);
    }

    #[test]
    fn a_shadow_view_fails_when_its_light_changed_kind_or_is_gone() {
        let mut lit = lit();
        let id = shadow_id();
        let message = |result: Result<ResolvedView, ViewError>| match result {
            Err(ViewError::Other { view, message }) if view == id => message,
            other => panic!("{other:?}"),
        };
        assert_eq!(message(spot(lit.lamp).resolve(&context(id), &lit.scene)), "the light is no longer a spot light");
        assert_eq!(
            message(point_face(lit.spot, 0).resolve(&context(id), &lit.scene)),
            "the light is no longer a point light"
        );
        lit.scene.set_light(lit.spot, None).unwrap();
        assert_eq!(message(spot(lit.spot).resolve(&context(id), &lit.scene)), "the light's node or light is gone");
        lit.scene.remove_node(lit.lamp).unwrap();
        assert_eq!(
            message(point_face(lit.lamp, 0).resolve(&context(id), &lit.scene)),
            "the light's node or light is gone"
        );
    }

    #[test]
    fn a_frame_plans_each_owners_cascades_then_a_view_per_local_tile() {
        let lit = lit();
        let mut shadows = ShadowViews::new(local());
        let owners = owners::<1>(&lit, 2);
        let owner = owners[0].0;
        let (planned, released) = shadows.plan(&owners, &frame(&lit), &lit.scene, 3, 0.5);
        let roles: Vec<ShadowRole> = planned.iter().map(|p| p.role).collect();
        let mut expected = vec![ShadowRole::Cascade { owner, index: 0 }, ShadowRole::Cascade { owner, index: 1 }];
        expected.push(ShadowRole::Local { light: lit.spot, face: 0, tile: 0 });
        expected.extend((0..6).map(|face| ShadowRole::Local { light: lit.lamp, face, tile: face + 1 }));
        assert_eq!(roles, expected);
        let ids: std::collections::BTreeSet<ViewId> = planned.iter().map(|p| p.id).collect();
        assert_eq!(ids.len(), planned.len(), "every shadow view has an id of its own");
        assert!(ids.iter().all(|id| id.range() == ViewIdRange::Shadow));
        assert!(released.is_empty());
    }

    /// What a planned view resolved to is what its resolver gives for its id.
    #[test]
    fn each_planned_shadow_view_is_resolved_as_its_resolver_would() {
        let lit = lit();
        let mut shadows = ShadowViews::new(local());
        let owners = owners::<1>(&lit, 2);
        let sun = lit.scene.world_transform(lit.sun).unwrap();
        let (planned, _) = shadows.plan(&owners, &frame(&lit), &lit.scene, 3, 0.5);
        for shadow in &planned {
            let expected = match shadow.role {
                ShadowRole::Cascade { index, .. } => resolve_cascade(shadow.id, &owners[0].1, sun, &cascades(2), index),
                ShadowRole::Local { light, .. } if light == lit.spot => {
                    spot(light).resolve(&context(shadow.id), &lit.scene)
                }
                ShadowRole::Local { light, face, .. } => {
                    point_face(light, face as usize).resolve(&context(shadow.id), &lit.scene)
                }
            };
            assert_eq!(shadow.resolved, expected, "{:?}", shadow.role);
            assert!(shadow.resolved.is_ok(), "{:?}", shadow.role);
        }
    }

    #[test]
    fn a_shadow_view_keeps_its_id_from_frame_to_frame() {
        let lit = lit();
        let mut shadows = ShadowViews::new(local());
        let owners = owners::<2>(&lit, 2);
        let (first, _) = shadows.plan(&owners, &frame(&lit), &lit.scene, 1, 0.0);
        let (second, released) = shadows.plan(&owners, &frame(&lit), &lit.scene, 2, 0.1);
        assert_eq!(ids_of(&second), ids_of(&first));
        assert!(released.is_empty());
    }

    #[test]
    fn views_no_longer_needed_are_released_and_the_rest_kept() {
        let lit = lit();
        let mut shadows = ShadowViews::new(local());
        let owners = owners::<2>(&lit, 2);
        let (first, _) = shadows.plan(&owners, &frame(&lit), &lit.scene, 1, 0.0);
        let first = ids_of(&first);
        // The second owner is gone, and so is the lamp's shadow.
        let mut next = frame(&lit);
        next.local_shadow_casters.truncate(1);
        let (second, released) = shadows.plan(&owners[..1], &next, &lit.scene, 2, 0.1);
        assert_eq!(ids_of(&second), [first[0], first[1], first[4]]);
        assert_eq!(released, [&first[2..4], &first[5..]].concat());
        // Without a shadow sun every cascade goes.
        next.shadow_sun = None;
        let (third, released) = shadows.plan(&owners[..1], &next, &lit.scene, 3, 0.2);
        assert_eq!((ids_of(&third), released), (vec![first[4]], vec![first[0], first[1]]));
    }

    #[test]
    fn the_cascade_count_is_clamped_between_one_and_what_the_shader_samples() {
        let lit = lit();
        for (count, planned) in [(0, 1), (3, 3), (9, oxygen_passes::MAX_CASCADES)] {
            let mut shadows = ShadowViews::new(None);
            let (cascades, _) = shadows.plan(&owners::<1>(&lit, count), &frame(&lit), &lit.scene, 1, 0.0);
            assert_eq!(cascades.len(), planned, "count {count}");
            assert!(cascades.iter().all(|c| c.resolved.is_ok()), "count {count}");
        }
    }

    #[test]
    fn without_a_shadow_sun_or_local_settings_nothing_is_planned() {
        let mut lit = lit();
        let mut shadows = ShadowViews::new(None);
        let mut sunless = frame(&lit);
        sunless.shadow_sun = None;
        assert!(shadows.plan(&owners::<1>(&lit, 2), &sunless, &lit.scene, 1, 0.0).0.is_empty());
        // A sun whose node is gone casts nothing either.
        let gone = frame(&lit);
        lit.scene.remove_node(lit.sun).unwrap();
        assert!(shadows.plan(&owners::<1>(&lit, 2), &gone, &lit.scene, 2, 0.0).0.is_empty());
        assert_eq!(shadows.all().count(), 0);
    }

    #[test]
    fn an_owners_cascades_are_listed_nearest_first_and_all_lists_every_shadow_view() {
        let lit = lit();
        let mut shadows = ShadowViews::new(local());
        let owners = owners::<2>(&lit, 3);
        let (planned, _) = shadows.plan(&owners, &frame(&lit), &lit.scene, 1, 0.0);
        let ids = ids_of(&planned);
        assert_eq!(shadows.cascades_of(owners[0].0).collect::<Vec<_>>(), ids[0..3]);
        assert_eq!(shadows.cascades_of(owners[1].0).collect::<Vec<_>>(), ids[3..6]);
        assert_eq!(shadows.all().collect::<Vec<_>>(), ids);
    }

    #[test]
    fn forgetting_an_owner_drops_its_cascades_and_no_others() {
        let lit = lit();
        let mut shadows = ShadowViews::new(local());
        let owners = owners::<2>(&lit, 2);
        let (planned, _) = shadows.plan(&owners, &frame(&lit), &lit.scene, 1, 0.0);
        let ids = ids_of(&planned);
        shadows.forget_owner(owners[0].0);
        assert_eq!(shadows.cascades_of(owners[0].0).count(), 0);
        assert_eq!(shadows.cascades_of(owners[1].0).collect::<Vec<_>>(), ids[2..4]);
        assert_eq!(shadows.all().collect::<Vec<_>>(), ids[2..]);
    }
}
