//! `ShaderPass`: lit shading of the opaque and masked partitions.
//!
//! Reads: the prepared frame's partitions, the frame's light arrays (through
//! their slots), and — when configured to follow a depth pre-pass — the depth
//! it left in the view's depth target, tested with `GreaterEqual` and no
//! writes; and, when `shadow_cascades` names earlier shadow views of the
//! frame, their depth maps (sampled with PCF for the first shadow-casting
//! directional light). Writes: the view's HDR target (cleared to
//! `clear_color`, linear).
//! Transparent partitions belong to the transparent pass and are skipped.

use oxygen_core::ViewTargets;
use oxygen_sceneprep::PassMask;
use tracing::info_span;

use crate::render_context::{draw_partitions, partition_pipelines};
use crate::{
    CommandRecorder, LightingInputs, MAX_CASCADES, MAX_SHADOW_TILES, PROBE_FACES, PassError, PassKind, RenderContext,
    RenderPass,
};
use bytemuck::Zeroable;
use oxygen_core::ViewId;

/// A reflection probe the shading pass samples for specular reflections.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeInput {
    /// The six face views (+X, −X, +Y, −Y, +Z, −Z); a face rendered this frame
    /// is copied into `texture`, a paused one keeps its last image.
    pub faces: [ViewId; PROBE_FACES],
    /// Six-layer HDR texture (face size × face size), copy destination and
    /// sampled. With several mip levels and `RENDER_ATTACHMENT` usage (as
    /// `ReflectionProbe` makes it), the levels below a re-rendered face are
    /// rebuilt and rough surfaces reflect the blurrier ones.
    pub texture: wgpu::Texture,
    /// The probe's world position.
    pub position: glam::Vec3,
}

/// How the shading pass is set up.
#[derive(Clone, Debug, PartialEq)]
pub struct ShaderPassConfig {
    /// Linear colour the target is cleared to.
    pub clear_color: wgpu::Color,
    /// Test against depth from a preceding [`crate::DepthPrePass`] (load it,
    /// `GreaterEqual`, no writes) rather than clearing and writing depth.
    pub depth_from_pre_pass: bool,
    /// Shadow views of this frame (nearest cascade first) whose depth maps
    /// shadow the first shadow-casting directional light; they must be
    /// registered (hence rendered) before this view.
    pub shadow_cascades: [Option<ViewId>; MAX_CASCADES],
    /// PCF kernel radius in texels: `(2r + 1)²` comparison taps. 0 is the
    /// cheapest (one bilinear comparison), 1 the default, 2 the softest.
    pub shadow_pcf_radius: u32,
    /// Normal offset of shadow lookups, in shadow-map texels: the point
    /// looked up moves this far along the surface normal (texels of the
    /// cascade, or of the local light's map at the point's distance), so a
    /// lit surface does not shadow itself (acne). Larger values detach
    /// shadows from their casters. Default 1.5.
    pub shadow_normal_offset: f32,
    /// Bias added to the cascade comparison depth (NDC depth units, towards
    /// the light), on top of the shadow map's rasterizer bias. Default 1e-4.
    pub shadow_depth_bias: f32,
    /// Reflection probes (up to `MAX_PROBES`); each surface reflects the
    /// nearest one (specular reflection on smooth and metallic surfaces).
    pub reflection_probes: Vec<ProbeInput>,
    /// Local-light shadow views by atlas tile: one per shadow-casting spot,
    /// six (one per cube face) per shadow-casting point light. The frame
    /// phase hands out tiles in node order; `register_local_shadows`
    /// registers the views in the same order.
    pub local_shadows: [Option<ViewId>; MAX_SHADOW_TILES],
}

impl Default for ShaderPassConfig {
    fn default() -> Self {
        ShaderPassConfig {
            clear_color: wgpu::Color { r: 0.02, g: 0.03, b: 0.05, a: 1.0 },
            depth_from_pre_pass: true,
            shadow_cascades: [None; MAX_CASCADES],
            shadow_pcf_radius: 1,
            shadow_normal_offset: 1.5,
            shadow_depth_bias: 1e-4,
            reflection_probes: Vec::new(),
            local_shadows: [None; MAX_SHADOW_TILES],
        }
    }
}

/// The shading pass.
pub struct ShaderPass {
    config: ShaderPassConfig,
    pipelines: Option<Vec<wgpu::RenderPipeline>>,
    lighting_inputs: Option<wgpu::BindGroup>,
}

impl ShaderPass {
    /// A pass with `config`.
    pub fn new(config: ShaderPassConfig) -> Self {
        ShaderPass { config, pipelines: None, lighting_inputs: None }
    }

    /// Group 3 for this view: the configured cascades, local-light shadow
    /// maps and probes, or `None` when the view uses none of them.
    fn lighting_inputs(
        &self,
        ctx: &RenderContext<'_>,
        rec: &mut CommandRecorder,
    ) -> Result<Option<wgpu::BindGroup>, PassError> {
        let config = &self.config;
        let probes = &config.reflection_probes[..config.reflection_probes.len().min(crate::MAX_PROBES)];
        if config.shadow_cascades.iter().all(Option::is_none)
            && config.local_shadows.iter().all(Option::is_none)
            && probes.is_empty()
        {
            return Ok(None);
        }
        let mut uniform = LightingInputs::zeroed();
        let maps = self.cascades(ctx, &mut uniform)?;
        let shadow_atlas = self.local_shadows(ctx, rec, &mut uniform)?;
        let probe_views = self.probes(ctx, rec, probes, &mut uniform)?;
        Ok(Some(ctx.pipelines.lighting_inputs_bind_group(
            &ctx.gpu.device,
            maps,
            shadow_atlas.as_ref(),
            probe_views.each_ref().map(Option::as_ref),
            &uniform,
        )))
    }

    /// The cascades' depth maps, nearest first, and their uniform fields.
    fn cascades<'a>(
        &self,
        ctx: &RenderContext<'a>,
        uniform: &mut LightingInputs,
    ) -> Result<[Option<&'a wgpu::TextureView>; MAX_CASCADES], PassError> {
        let mut maps = [None; MAX_CASCADES];
        let ids = self.config.shadow_cascades.iter().flatten();
        for (i, id) in ids.enumerate().take(MAX_CASCADES) {
            let (view, targets) = ctx
                .frame_views
                .get(*id)
                .ok_or(PassError::MissingInput { pass: self.name(), input: "a shadow cascade view" })?;
            uniform.light_view_projection[i] = view.view_projection.to_cols_array_2d();
            // Orthographic cascades: projection.x_axis.x is 1 / half-width.
            let half_width = 1.0 / view.projection.x_axis.x.abs().max(f32::MIN_POSITIVE);
            uniform.texel_world_size[i] = 2.0 * half_width / targets.width.max(1) as f32;
            uniform.uv_texel[i] = 1.0 / targets.width.max(1) as f32;
            maps[i] = Some(&targets.depth_view);
            uniform.count = i as u32 + 1;
        }
        uniform.pcf_radius = self.config.shadow_pcf_radius.min(3);
        // Non-finite knobs fall back to the defaults: no NaN reaches a shader.
        let defaults = ShaderPassConfig::default();
        let finite_or = |v: f32, default: f32| if v.is_finite() { v } else { default };
        uniform.normal_offset = finite_or(self.config.shadow_normal_offset, defaults.shadow_normal_offset);
        uniform.depth_bias = finite_or(self.config.shadow_depth_bias, defaults.shadow_depth_bias);
        Ok(maps)
    }

    /// Copies the local-light shadow maps into the atlas (by tile) and fills
    /// their uniform fields; `None` when the view samples none.
    fn local_shadows(
        &self,
        ctx: &RenderContext<'_>,
        rec: &mut CommandRecorder,
        uniform: &mut LightingInputs,
    ) -> Result<Option<wgpu::TextureView>, PassError> {
        let mut tile_maps = [None; MAX_SHADOW_TILES];
        for (slot, id) in self.config.local_shadows.iter().enumerate() {
            let Some(id) = id else { continue };
            let (view, targets) = ctx
                .frame_views
                .get(*id)
                .ok_or(PassError::MissingInput { pass: self.name(), input: "a local-light shadow view" })?;
            uniform.tile_view_projection[slot] = view.view_projection.to_cols_array_2d();
            // Perspective: projection.y_axis.y is cot(fov / 2).
            uniform.tile_texel_angle[slot] =
                2.0 / view.projection.y_axis.y.abs().max(1e-6) / targets.width.max(1) as f32;
            tile_maps[slot] = Some((*id, &targets.depth));
            uniform.tile_count = slot as u32 + 1;
        }
        if tile_maps.iter().all(Option::is_none) {
            return Ok(None);
        }
        ctx.pipelines
            .fill_shadow_atlas(&ctx.gpu.device, rec.encoder(), &tile_maps, ctx.prepared.frame_index())
            .map(Some)
            .map_err(|what| PassError::BadInput { pass: self.name(), what })
    }

    /// Copies the probe faces rendered this frame into their probes'
    /// textures (rebuilding those layers' mips; once per frame however many
    /// views sample a probe), fills the probes' uniform fields and returns
    /// their array views.
    fn probes(
        &self,
        ctx: &RenderContext<'_>,
        rec: &mut CommandRecorder,
        probes: &[ProbeInput],
        uniform: &mut LightingInputs,
    ) -> Result<[Option<wgpu::TextureView>; crate::MAX_PROBES], PassError> {
        let mut probe_views: [Option<wgpu::TextureView>; crate::MAX_PROBES] = Default::default();
        for (slot, probe) in probes.iter().enumerate() {
            let side = probe.texture.width();
            for (layer, face) in probe.faces.iter().enumerate() {
                // A paused face is absent from this frame: its layer keeps the last image.
                let Some((_, targets)) = ctx.frame_views.get(*face) else { continue };
                let Some(hdr) = targets.color.as_ref().map(|c| &c.hdr) else {
                    return Err(PassError::MissingInput {
                        pass: self.name(),
                        input: "a probe face with colour targets",
                    });
                };
                if targets.width != side || targets.height != side {
                    return Err(PassError::MissingInput {
                        pass: self.name(),
                        input: "a probe face of the probe's size",
                    });
                }
                // Another view of this frame may have copied it already.
                if !ctx.pipelines.claim_copy(&probe.texture, layer as u32, *face, ctx.prepared.frame_index()) {
                    continue;
                }
                rec.encoder().copy_texture_to_texture(
                    hdr.as_image_copy(),
                    wgpu::TexelCopyTextureInfo {
                        texture: &probe.texture,
                        mip_level: 0,
                        origin: wgpu::Origin3d { x: 0, y: 0, z: layer as u32 },
                        aspect: wgpu::TextureAspect::All,
                    },
                    wgpu::Extent3d { width: side, height: side, depth_or_array_layers: 1 },
                );
                ctx.pipelines.rebuild_probe_mips(&ctx.gpu.device, rec.encoder(), &probe.texture, layer as u32);
            }
            let relative = (probe.position.as_dvec3() - ctx.origin).as_vec3();
            uniform.probe_positions[slot] = relative.extend(1.0).to_array();
            probe_views[slot] = Some(crate::probe_view(&probe.texture));
        }
        uniform.probe_count = probes.len() as u32;
        Ok(probe_views)
    }
}

fn partitions<'a>(ctx: &'a RenderContext<'_>) -> impl Iterator<Item = &'a oxygen_sceneprep::Partition> {
    ctx.prepared.partitions_matching(PassMask::OPAQUE | PassMask::MASKED, PassMask::TRANSPARENT)
}

impl RenderPass for ShaderPass {
    fn name(&self) -> &'static str {
        "ShaderPass"
    }

    async fn prepare_resources(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        let _span = info_span!("shader_pass_prepare", view = %ctx.view.view_id).entered();
        self.lighting_inputs = self.lighting_inputs(ctx, rec)?;
        let pass = if self.config.depth_from_pre_pass { PassKind::ShadingAfterPrePass } else { PassKind::Shading };
        let pipelines =
            partition_pipelines(ctx, pass, Some(ViewTargets::HDR_FORMAT), crate::DepthBias::NONE, partitions(ctx));
        self.pipelines = Some(pipelines);
        Ok(())
    }

    async fn execute(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        let _span = info_span!("shader_pass_execute", view = %ctx.view.view_id).entered();
        let pipelines = self.pipelines.as_ref().ok_or(PassError::NotPrepared { pass: self.name() })?;
        let color = ctx.color_targets(self.name())?;
        let depth_load = if self.config.depth_from_pre_pass { wgpu::LoadOp::Load } else { wgpu::LoadOp::Clear(0.0) };
        let mut stats = rec.stats;
        {
            let mut pass = rec.encoder().begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("shader pass"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &color.hdr_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(self.config.clear_color),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &ctx.targets.depth_view,
                    depth_ops: Some(wgpu::Operations { load: depth_load, store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            stats.render_passes += 1;
            let inputs = self.lighting_inputs.as_ref().unwrap_or(ctx.pipelines.no_lighting_inputs());
            draw_partitions(&mut pass, ctx, partitions(ctx), pipelines, inputs, &mut stats);
        }
        rec.stats = stats;
        Ok(())
    }
}
