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
