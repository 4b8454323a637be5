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
        let missing = || oxygen_core::ViewError::Other {
            view: view_id,
            message: "the spot light's node or light is gone".into(),
        };
        let node = scene.node(self.light).ok_or_else(missing)?;
        let light = node.light.as_ref().ok_or_else(missing)?;
        let LightKind::Spot { range, outer_cone, .. } = light.kind else { return Err(missing()) };
        let world = scene.world_transform(self.light).ok_or_else(missing)?;
        let (_, rotation, position) = world.to_scale_rotation_translation();
        let view = glam::DMat4::from_rotation_translation(rotation.normalize(), position).inverse();
        // A little wider than the cone, so PCF taps at its edge stay inside.
        let fov = (outer_cone * 2.0 * 1.1).clamp(0.05, 170f32.to_radians());
        let far = range.filter(|r| r.is_finite() && *r > self.near).unwrap_or(self.far);
        let camera = oxygen_core::Camera::perspective(fov, self.near, Some(far));
        let projection =
            camera.projection_matrix(1.0).map_err(|source| oxygen_core::ViewError::Camera { view: view_id, source })?;
        oxygen_core::ResolvedView::new_f64(
            view_id,
            view,
            projection,
            glam::UVec2::splat(self.resolution.max(1)),
            self.near,
            far,
        )
    }
}

/// Registers one shadow view per shadow-casting spot light (up to
/// [`oxygen_passes::MAX_SPOT_SHADOWS`]), in the order the frame phase
/// numbers their shadow slots (node order, same gating), ready for
/// [`ShaderPassConfig::spot_shadows`]. Register them before the views that
/// sample them.
pub fn register_spot_shadows(
    renderer: &mut Renderer,
    scene: &Scene,
    resolution: u32,
) -> [Option<ViewId>; oxygen_passes::MAX_SPOT_SHADOWS] {
    let mut ids = [None; oxygen_passes::MAX_SPOT_SHADOWS];
    let casting_spots = scene.nodes().filter(|(key, node)| {
        node.light.as_ref().is_some_and(|light| {
            matches!(light.kind, LightKind::Spot { .. })
                && light.casts_shadows
                && light.affects_world
                && light.mobility != oxygen_core::Mobility::Baked
                && node.flags.contains(NodeFlags::CASTS_SHADOWS)
                && scene.is_effectively_visible(*key)
        })
    });
    for (slot, (key, _)) in casting_spots.take(ids.len()).enumerate() {
        let resolver = SpotShadowResolver { light: key, resolution, near: 0.05, far: 100.0 };
        ids[slot] = Some(renderer.register_view_with_options(resolver, shadow_view_options(), shadow_render_graph));
    }
    ids
}
