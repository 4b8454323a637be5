//! Shadow views are ordinary registered views. This module registers them for
//! the lights that need them and builds the render graphs that use them.
//!
//! Only shadow-casting directional lights (the light says so *and* its node
//! does) get cascades; a scene without such a light gets no shadow view at
//! all, so nothing is prepared or rendered for shadows.

use std::sync::Arc;

use oxygen_core::{CascadeResolver, CascadeSettings, LightKind, NodeFlags, NodeKey, Scene, ViewId, ViewResolver};
use oxygen_passes::{CommandRecorder, MAX_CASCADES, RenderContext, RenderPass, ShaderPassConfig, ShadowPass};
use oxygen_sceneprep::{ViewFilter, ViewPrepOptions};

use crate::{RenderGraphFuture, Renderer};

/// ScenePrep options of a shadow view: casters only, depth only.
pub fn shadow_view_options() -> ViewPrepOptions {
    ViewPrepOptions { filter: ViewFilter::ShadowCastersOnly, depth_only: true, ..Default::default() }
}

/// The render graph of a shadow view: depth of its casters, nothing else.
pub fn shadow_render_graph<'a>(
    _id: ViewId,
    ctx: &'a RenderContext<'a>,
    rec: &'a mut CommandRecorder,
) -> RenderGraphFuture<'a> {
    Box::pin(async move { ShadowPass::new().run(ctx, rec).await })
}

/// The first directional light that casts shadows (light flag and node flag).
pub fn shadow_casting_sun(scene: &Scene) -> Option<NodeKey> {
    scene.nodes().find_map(|(key, node)| {
        let light = node.light.as_ref()?;
        let casts = light.casts_shadows
            && light.affects_world
            && node.flags.contains(NodeFlags::CASTS_SHADOWS | NodeFlags::VISIBLE);
        (casts && light.kind == LightKind::Directional).then_some(key)
    })
}

/// Registers one cascade view per cascade of the scene's shadow-casting sun
/// (none when there is no such light) and returns their ids, nearest first,
/// ready for [`ShaderPassConfig::shadow_cascades`]. Register them before the
/// main view so they render first.
pub fn register_sun_cascades(
    renderer: &mut Renderer,
    scene: &Scene,
    main: Arc<dyn ViewResolver>,
    settings: CascadeSettings,
) -> [Option<ViewId>; MAX_CASCADES] {
    let mut ids = [None; MAX_CASCADES];
    let Some(sun) = shadow_casting_sun(scene) else { return ids };
    let settings = CascadeSettings { count: settings.count.clamp(1, MAX_CASCADES as u32), ..settings };
    for index in 0..settings.count {
        let cascade = CascadeResolver { main: Arc::clone(&main), light: sun, settings, index };
        ids[index as usize] =
            Some(renderer.register_view_with_options(cascade, shadow_view_options(), shadow_render_graph));
    }
    ids
}

/// The standard graph with the shading pass sampling `cascades`.
pub fn shadowed_render_graph(
    cascades: [Option<ViewId>; MAX_CASCADES],
) -> impl for<'a> Fn(ViewId, &'a RenderContext<'a>, &'a mut CommandRecorder) -> RenderGraphFuture<'a> + 'static {
    crate::lit_render_graph(ShaderPassConfig { shadow_cascades: cascades, ..Default::default() })
}

/// The kind and world transform of the light on `node`, or an error for
/// `view` when the node or its light is gone.
fn light_of(scene: &Scene, node: NodeKey, view: ViewId) -> Result<(LightKind, glam::DMat4), oxygen_core::ViewError> {
    let gone = || oxygen_core::ViewError::Other { view, message: "the light's node or light is gone".into() };
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
) -> Result<oxygen_core::ResolvedView, oxygen_core::ViewError> {
    let camera = oxygen_core::Camera::perspective(fov, near, Some(far));
    let projection =
        camera.projection_matrix(1.0).map_err(|source| oxygen_core::ViewError::Camera { view: view_id, source })?;
    oxygen_core::ResolvedView::new_f64(view_id, view, projection, glam::UVec2::splat(resolution.max(1)), near, far)
}

fn not_a(view: ViewId, kind: &str) -> oxygen_core::ViewError {
    oxygen_core::ViewError::Other { view, message: format!("the light is no longer a {kind} light") }
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
    fn resolve(
        &self,
        ctx: &oxygen_core::ViewContext,
        scene: &Scene,
    ) -> Result<oxygen_core::ResolvedView, oxygen_core::ViewError> {
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
    fn resolve(
        &self,
        ctx: &oxygen_core::ViewContext,
        scene: &Scene,
    ) -> Result<oxygen_core::ResolvedView, oxygen_core::ViewError> {
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

/// Registers the shadow views of every shadow-casting spot light (one view)
/// and point light (six, one per cube face) while the
/// [`oxygen_passes::MAX_SHADOW_TILES`] atlas tiles last, in node order with
/// the frame phase's gating, so that view `i` of the result is atlas tile
/// `i`, as [`ShaderPassConfig::local_shadows`] expects. Register them before
/// the views that sample them.
pub fn register_local_shadows(
    renderer: &mut Renderer,
    scene: &Scene,
    resolution: u32,
) -> [Option<ViewId>; oxygen_passes::MAX_SHADOW_TILES] {
    let mut ids = [None; oxygen_passes::MAX_SHADOW_TILES];
    let mut next_tile = 0;
    for (key, node) in scene.nodes() {
        let Some(light) = node.light.as_ref() else { continue };
        let casts = light.casts_shadows
            && light.affects_world
            && light.mobility != oxygen_core::Mobility::Baked
            && node.flags.contains(NodeFlags::CASTS_SHADOWS)
            && scene.is_effectively_visible(key);
        let faces = match light.kind {
            LightKind::Spot { .. } => 1,
            LightKind::Point { .. } => oxygen_passes::PROBE_FACES,
            LightKind::Directional => 0,
        };
        if !casts || faces == 0 || next_tile + faces > ids.len() {
            continue;
        }
        for face in 0..faces {
            let options = shadow_view_options();
            ids[next_tile + face] = Some(if matches!(light.kind, LightKind::Spot { .. }) {
                let resolver = SpotShadowResolver { light: key, resolution, near: 0.05, far: 100.0 };
                renderer.register_view_with_options(resolver, options, shadow_render_graph)
            } else {
                let resolver = PointShadowFaceResolver { light: key, face, resolution, near: 0.05, far: 100.0 };
                renderer.register_view_with_options(resolver, options, shadow_render_graph)
            });
        }
        next_tile += faces;
    }
    ids
}
