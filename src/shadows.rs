//! Shadow views are ordinary registered views. This module registers them for
//! the lights that need them and builds the render graphs that use them.
//!
//! Only shadow-casting directional lights (the light says so *and* its node
//! does) get cascades; a scene without such a light gets no shadow view at
//! all, so nothing is prepared or rendered for shadows.

use std::sync::Arc;

use oxygen_core::{CascadeResolver, CascadeSettings, LightKind, NodeFlags, NodeKey, Scene, ViewId, ViewResolver};
use oxygen_passes::{
    CommandRecorder, DepthPrePass, MAX_CASCADES, RenderContext, RenderPass, ShaderPass, ShaderPassConfig, TonemapPass,
    TransparentPass,
};
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
    Box::pin(async move {
        let mut depth = DepthPrePass::new();
        depth.prepare_resources(ctx, rec).await?;
        depth.execute(ctx, rec).await
    })
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

/// The standard graph (depth pre-pass, shading, transparency, tone map) with
/// the shading pass sampling `cascades`.
pub fn shadowed_render_graph(
    cascades: [Option<ViewId>; MAX_CASCADES],
) -> impl for<'a> Fn(ViewId, &'a RenderContext<'a>, &'a mut CommandRecorder) -> RenderGraphFuture<'a> + 'static {
    move |_id, ctx, rec| {
        Box::pin(async move {
            let mut depth = DepthPrePass::new();
            depth.prepare_resources(ctx, rec).await?;
            depth.execute(ctx, rec).await?;
            let mut shading = ShaderPass::new(ShaderPassConfig { shadow_cascades: cascades, ..Default::default() });
            shading.prepare_resources(ctx, rec).await?;
            shading.execute(ctx, rec).await?;
            let mut transparent = TransparentPass::new();
            transparent.prepare_resources(ctx, rec).await?;
            transparent.execute(ctx, rec).await?;
            let mut tonemap = TonemapPass::default();
            tonemap.prepare_resources(ctx, rec).await?;
            tonemap.execute(ctx, rec).await
        })
    }
}
