//! What the forward lit pass reads through bind group 1: from other views,
//! the view's own sun cascades, the frame's local-light shadow atlas and the
//! reflection probes the view is linked to; of its own, its light clusters
//! when it culls its lights, and its screen-space buffers (ambient
//! occlusion, depth in metres, reflection history) when it has them. Every
//! input is awaited: the pass goes on once the views that render it have
//! recorded.

use bytemuck::Zeroable;

use crate::lighting::clusters::{ClusterJob, GridShape};
use crate::{ForwardLitConfig, LightCulling, LightingInputs, MAX_CASCADES, MAX_PROBES, PassError, RenderContext};

/// Whether the view culls its positional lights into clusters this frame
/// (it asks to, and the frame has positional lights).
pub(crate) fn clusters_lights(ctx: &RenderContext<'_>, config: &ForwardLitConfig) -> bool {
    matches!(config.light_culling, LightCulling::Clustered(_)) && ctx.prepared.slots().positional_lights.count > 0
}

/// Whether the view reads a shadow map, a probe or its light clusters
/// through group 1 (else the shared empty group is bound, and there is
/// nothing to await).
pub(crate) fn reads_inputs(ctx: &RenderContext<'_>, config: &ForwardLitConfig) -> bool {
    let inputs = &ctx.inputs;
    (config.sun_shadows && !inputs.cascades.is_empty())
        || (config.local_shadows && inputs.local_shadows.is_some())
        || (config.reflections && !inputs.probes.is_empty())
        || clusters_lights(ctx, config)
        || config.ambient_occlusion.is_some()
        || config.contact_shadows.is_some()
        || config.screen_space_reflections.is_some()
}

/// Group 1 for this view, or `None` when it reads no shadow map, no probe
/// and no light clusters (the shared empty group is bound then); with the
/// cluster pass to record before the view shades, when it culls its lights.
pub(crate) async fn bind_group(
    ctx: &RenderContext<'_>,
    config: &ForwardLitConfig,
) -> Result<(Option<wgpu::BindGroup>, Option<ClusterJob>), PassError> {
    if !reads_inputs(ctx, config) {
        return Ok((None, None));
    }
    let inputs = &ctx.inputs;
    let cascades = if config.sun_shadows { &inputs.cascades[..inputs.cascades.len().min(MAX_CASCADES)] } else { &[] };
    let local = inputs.local_shadows.as_ref().filter(|_| config.local_shadows);
    let probes = if config.reflections { &inputs.probes[..inputs.probes.len().min(MAX_PROBES)] } else { &[] };
    let producers: Vec<_> = cascades
        .iter()
        .map(|c| c.producer)
        .chain(local.iter().flat_map(|l| l.tiles.iter().flatten().map(|t| t.producer)))
        .chain(probes.iter().flat_map(|p| p.faces))
        .collect();
    ctx.progress.recorded(&producers).await;

    let mut uniform = LightingInputs::zeroed();
    let mut maps = [None; MAX_CASCADES];
    for (i, cascade) in cascades.iter().enumerate() {
        uniform.light_view_projection[i] = cascade.view.view_projection.to_cols_array_2d();
        // Orthographic cascades: projection.x_axis.x is 1 / half-width.
        let half_width = 1.0 / cascade.view.projection.x_axis.x.abs().max(f32::MIN_POSITIVE);
        uniform.texel_world_size[i] = 2.0 * half_width / cascade.resolution.max(1) as f32;
        uniform.uv_texel[i] = 1.0 / cascade.resolution.max(1) as f32;
        maps[i] = Some(cascade.depth);
        uniform.count = i as u32 + 1;
    }
    uniform.pcf_radius = config.shadow_pcf_radius.min(3);
    uniform.shadow_filter = config.shadow_filter.uniform();
    // A non-finite offset falls back to the default: no NaN reaches a shader.
    uniform.normal_offset = if config.shadow_normal_offset.is_finite() {
        config.shadow_normal_offset
    } else {
        ForwardLitConfig::DEFAULT.shadow_normal_offset
    };

    if let Some(local) = local {
        for (tile, map) in local.tiles.iter().enumerate() {
            let Some(map) = map else { continue };
            uniform.tile_view_projection[tile] = map.view.view_projection.to_cols_array_2d();
            // Perspective: projection.y_axis.y is cot(fov / 2).
            uniform.tile_texel_angle[tile] =
                2.0 / map.view.projection.y_axis.y.abs().max(1e-6) / map.resolution.max(1) as f32;
            // Clip z = z_axis.z · z_view + w_axis.z and clip w = −z_view:
            // depth = −z_axis.z + w_axis.z / distance.
            let terms = [-map.view.projection.z_axis.z, map.view.projection.w_axis.z];
            let terms = if terms.iter().all(|t| t.is_finite()) { terms } else { [0.0, 0.0] };
            uniform.tile_depth[tile / 2][(tile % 2) * 2..(tile % 2) * 2 + 2].copy_from_slice(&terms);
            uniform.tile_count = tile as u32 + 1;
        }
    }

    let mut probe_views: [Option<wgpu::TextureView>; MAX_PROBES] = Default::default();
    for (slot, probe) in probes.iter().enumerate() {
        let relative = (probe.position.as_dvec3() - ctx.origin).as_vec3();
        uniform.probe_positions[slot] = relative.extend(1.0).to_array();
        if let Some(bounds) = probe.parallax {
            let min = (bounds.min.as_dvec3() - ctx.origin).as_vec3();
            let max = (bounds.max.as_dvec3() - ctx.origin).as_vec3();
            uniform.probe_box_min[slot] = min.extend(1.0).to_array();
            uniform.probe_box_max[slot] = max.extend(1.0).to_array();
        }
        probe_views[slot] = Some(crate::probe_view(probe.texture));
    }
    uniform.probe_count = probes.len() as u32;

    let clusters = match config.light_culling {
        LightCulling::Clustered(grid) if clusters_lights(ctx, config) => {
            let lights = ctx.prepared.slots().positional_lights.count;
            let shape = GridShape::new(&grid, ctx.view.viewport, ctx.view.near, ctx.view.far, lights);
            (uniform.cluster_grid, uniform.cluster_depth) = shape.uniform_fields();
            Some(ctx.lighting.clusters().prepare(ctx, &shape)?)
        }
        _ => None,
    };
    let (bits, job) = clusters.map_or((None, None), |(bits, job)| (Some(bits), job));

    let frame = ctx.prepared.frame_index();
    let screen = ctx.lighting.ambient_occlusion();
    let missing = |what: &str, pass: &str| PassError::BadInput {
        pass: "forward lit",
        what: format!(
            "{what} is asked for, but no {pass} ran for the view this frame (record one after its depth \
             pre-pass; the standard graph does)"
        ),
    };
    let ambient_occlusion = match config.ambient_occlusion {
        Some(_) => Some(
            screen
                .output(ctx.view.view_id, frame)
                .ok_or_else(|| missing("ambient occlusion", "AmbientOcclusionPass"))?,
        ),
        None => None,
    };
    if let Some(contact) = config.contact_shadows {
        if let Some(problem) = contact.problem() {
            return Err(PassError::BadInput { pass: "forward lit", what: problem });
        }
        uniform.contact_shadows = contact.uniform();
    }
    let mut history = None;
    if let Some(reflections) = config.screen_space_reflections {
        if let Some(problem) = reflections.problem() {
            return Err(PassError::BadInput { pass: "forward lit", what: problem });
        }
        uniform.screen_reflections = reflections.uniform();
        uniform.screen_view[0] = ctx.view.near;
        // None on the view's first frame: the probe or environment then.
        history = ctx.lighting.reflection_history().previous(ctx);
        if let Some(history) = &history {
            uniform.reflection_reprojection = history.reprojection.to_cols_array_2d();
            uniform.reflection_history = history.shape;
        }
    }
    let depth = match (config.contact_shadows, config.screen_space_reflections) {
        (None, None) => None,
        _ => Some(screen.depth(ctx.view.view_id, frame).ok_or_else(|| {
            let what = if config.contact_shadows.is_some() { "contact shadows" } else { "screen-space reflections" };
            missing(what, "LinearDepthPass")
        })?),
    };
    if ambient_occlusion.is_some() || depth.is_some() {
        uniform.screen_width = ctx.targets.width;
    }
    uniform.screen_view[1] = if ambient_occlusion.is_some() { 1.0 } else { 0.0 };

    let group = ctx.lighting.bind_group(
        &ctx.gpu.device,
        maps,
        local.map(|l| l.atlas),
        probe_views.each_ref().map(Option::as_ref),
        crate::lighting::inputs::ScreenBuffers {
            clusters: bits.as_ref(),
            ambient_occlusion: ambient_occlusion.as_ref(),
            depth: depth.as_ref(),
            reflection_history: history.as_ref().map(|h| &h.buffer),
        },
        &uniform,
    );
    Ok((Some(group), job))
}
