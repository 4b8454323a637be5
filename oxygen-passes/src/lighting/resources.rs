//! The lighting resources every view shares: the layout and placeholders of
//! bind group 1 (what the forward pass reads from other views), the local
//! shadow atlas, the split-sum table, the prefiltered environment and the
//! cube filter that builds it and re-filters probes. Split from
//! [`crate::Pipelines`] because they are inputs of the lighting, not
//! pipeline state.

use crate::lighting::ibl::cube_filter::{CubeFilter, EnvironmentQuality, HARMONICS_LAYER};
use crate::lighting::inputs::{LightingInputResources, ScreenBuffers};
use crate::{LightingInputs, MAX_CASCADES, MAX_PROBES};

/// Group 1's layout and placeholders, the local shadow atlas, the
/// environment and the cube filter.
pub struct LightingResources {
    inputs: LightingInputResources,
    shadow_atlas: crate::lighting::shadow_atlas::ShadowAtlas,
    cube_filter: CubeFilter,
    environment: Option<EnvironmentTexture>,
    /// Counts environment changes (views that accumulate restart on one).
    environment_generation: u64,
    /// Clustered light culling's pipeline and per-view buffers.
    clusters: crate::lighting::clusters::LightClusters,
    /// Ambient occlusion's pipelines and per-view buffers.
    ambient_occlusion: crate::lighting::ambient_occlusion::AmbientOcclusionState,
    /// Screen-space reflections' pipelines and per-view histories.
    reflection_history: crate::lighting::reflections::ReflectionHistoryState,
    /// The tone map's effects (bloom, automatic exposure): pipelines and
    /// per-view buffers. Here with the other per-view lighting state:
    /// exposure is the last step of what light a picture shows.
    effects: crate::post::effects::EffectsState,
    /// The overlay pass's pipelines and per-view buffers (kept here with
    /// the other per-view state the renderer frees with its views).
    overlay: crate::post::overlay::OverlayState,
}

/// The prefiltered environment on the GPU (faces and levels, the
/// harmonics in layer 6), and the group 1 that binds it for passes without
/// other lighting inputs.
struct EnvironmentTexture {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    no_inputs: wgpu::BindGroup,
}

impl LightingResources {
    /// Creates the layout, placeholders and builders, and computes the
    /// split-sum table (submitted on `queue`).
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        LightingResources {
            inputs: LightingInputResources::new(device, queue),
            shadow_atlas: Default::default(),
            cube_filter: CubeFilter::new(device),
            environment: None,
            environment_generation: 0,
            clusters: Default::default(),
            ambient_occlusion: Default::default(),
            reflection_history: Default::default(),
            effects: Default::default(),
            overlay: Default::default(),
        }
    }

    /// Lights the scene with `environment` (`None`: the constant ambient
    /// term), converted and prefiltered on the GPU at `quality` (submitted
    /// on `queue` before this returns): from the next recorded pass on,
    /// shading takes its diffuse and specular ambient light from it and
    /// the clearing pass draws it behind the scene.
    pub fn set_environment(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        environment: Option<&oxygen_core::Environment>,
        quality: EnvironmentQuality,
    ) {
        self.environment_generation += 1;
        let Some(environment) = environment else {
            self.environment = None;
            return;
        };
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("environment") });
        let texture = self.cube_filter.build_environment(device, queue, &mut encoder, environment, quality);
        queue.submit([encoder.finish()]);
        self.install_environment(device, texture);
    }

    /// [`LightingResources::set_environment`] with an environment
    /// prefiltered on the CPU ([`oxygen_core::Environment::prefilter`],
    /// the reference the GPU's is tested against): uploaded as it is
    /// (faces narrower than 4 texels excepted, which stay black; a face of
    /// the wrong texel count is skipped).
    pub fn set_prefiltered_environment(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        environment: Option<&oxygen_core::PrefilteredEnvironment>,
    ) {
        self.environment_generation += 1;
        let Some(env) = environment else {
            self.environment = None;
            return;
        };
        // At least 4 wide: the harmonics layer holds a 3 × 3 block. A
        // smaller environment's faces do not fit the padded texture: its
        // cube stays black (said so), its harmonics still light.
        let size = env.size.max(4);
        if env.size < 4 {
            tracing::warn!(
                size = env.size,
                "a prefiltered environment narrower than 4 texels: its faces are left black"
            );
        }
        let levels = env.levels.len().max(1) as u32;
        let texture = oxygen_gpu::texture_2d(
            device,
            "environment",
            wgpu::Extent3d { width: size, height: size, depth_or_array_layers: HARMONICS_LAYER + 1 },
            levels.min(u32::BITS - size.leading_zeros()),
            oxygen_gpu::ViewTargets::HDR_FORMAT,
            wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::COPY_SRC,
        );
        let write = |level: u32, layer: u32, side: u32, texels: &[glam::Vec3]| {
            let bytes: Vec<u8> = texels
                .iter()
                .flat_map(|t| [t.x, t.y, t.z, 1.0])
                .flat_map(|v| crate::lighting::ibl::half::f32_to_f16(v).to_le_bytes())
                .collect();
            let rows = (texels.len() as u32).div_ceil(side);
            // `side` texels per row (the harmonics: three rows of three).
            queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &texture,
                    mip_level: level,
                    origin: wgpu::Origin3d { x: 0, y: 0, z: layer },
                    aspect: wgpu::TextureAspect::All,
                },
                &bytes,
                wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(side * 8), rows_per_image: Some(rows) },
                wgpu::Extent3d { width: (texels.len() as u32).min(side), height: rows, depth_or_array_layers: 1 },
            );
        };
        for (level, faces) in env.levels.iter().enumerate().take(texture.mip_level_count() as usize) {
            let side = (size >> level).max(1);
            for (face, texels) in faces.iter().enumerate() {
                // A face of the wrong size (a hand-made environment) is
                // skipped rather than written out of bounds.
                if texels.len() as u64 == u64::from(side) * u64::from(side) {
                    write(level as u32, face as u32, side, texels);
                }
            }
        }
        let scaled = env.irradiance_sh.map(|c| c / crate::lighting::ibl::cube_filter::HARMONICS_SCALE);
        write(0, HARMONICS_LAYER, 3, &scaled);
        self.install_environment(device, texture);
    }

    fn install_environment(&mut self, device: &wgpu::Device, texture: wgpu::Texture) {
        let view = crate::probe_view(&texture);
        let mut uniform = <LightingInputs as bytemuck::Zeroable>::zeroed();
        uniform.environment_levels = texture.mip_level_count();
        let inputs = &self.inputs;
        let buffer = crate::lighting::inputs::uniform_buffer(device, &uniform);
        let no_inputs = crate::lighting::inputs::bind_group(
            device,
            &inputs.layout,
            inputs.shared(),
            ([&inputs.placeholder_map; MAX_CASCADES], &inputs.placeholder_atlas),
            ([&inputs.placeholder_probe; MAX_PROBES], &view),
            (&buffer, ScreenBuffers::default()),
        );
        self.environment = Some(EnvironmentTexture { texture, view, no_inputs });
    }

    /// The environment's texture as the GPU holds it: faces `0..6` with
    /// their prefiltered levels, the nine harmonics in the 3 × 3 corner of
    /// layer 6 (coefficient `i` at `(i % 3, i / 3)`) (for
    /// tools and tests that read it back).
    pub fn environment_texture(&self) -> Option<&wgpu::Texture> {
        self.environment.as_ref().map(|e| &e.texture)
    }

    /// How many times the environment was set or removed (setting the same
    /// one again counts: the renderer does not compare them): a view that
    /// accumulates over frames (the path-traced reference) restarts when
    /// it changes, so set it once, not every frame.
    pub fn environment_generation(&self) -> u64 {
        self.environment_generation
    }

    /// The environment's six-face array view, or a 1 × 1 black placeholder
    /// without one.
    pub(crate) fn environment_view(&self) -> &wgpu::TextureView {
        self.environment.as_ref().map_or(&self.inputs.placeholder_probe, |e| &e.view)
    }

    /// The environment's trilinear sampler.
    pub(crate) fn environment_sampler(&self) -> &wgpu::Sampler {
        &self.inputs.environment_sampler
    }

    /// The split-sum table as the shaders read it (a uniform buffer).
    pub(crate) fn split_sum_buffer(&self) -> &wgpu::Buffer {
        &self.inputs.split_sum_buffer
    }

    /// The split-sum table (`A`, `B` in red and green; see `split_sum.rs`).
    pub fn split_sum_lut(&self) -> &wgpu::Texture {
        &self.inputs.split_sum_lut
    }

    /// Whether an environment lights the scene ([`LightingResources::set_environment`]).
    pub fn has_environment(&self) -> bool {
        self.environment.is_some()
    }

    /// Clustered light culling's pipeline and per-view buffers.
    pub(crate) fn clusters(&self) -> &crate::lighting::clusters::LightClusters {
        &self.clusters
    }

    /// Ambient occlusion's pipelines and per-view buffers.
    pub(crate) fn ambient_occlusion(&self) -> &crate::lighting::ambient_occlusion::AmbientOcclusionState {
        &self.ambient_occlusion
    }

    /// Views holding ambient-occlusion buffers: those that computed it in
    /// a frame they still render (a view without the knob holds none).
    pub fn ambient_occlusion_views(&self) -> usize {
        self.ambient_occlusion.occlusion_views()
    }

    /// Screen-space reflections' pipelines and per-view histories.
    pub(crate) fn reflection_history(&self) -> &crate::lighting::reflections::ReflectionHistoryState {
        &self.reflection_history
    }

    /// Views holding a reflection history (screen-space reflections): a
    /// view without the knob holds none.
    pub fn reflection_history_views(&self) -> usize {
        self.reflection_history.views()
    }

    /// The overlay pass's pipelines and per-view buffers.
    pub(crate) fn overlay(&self) -> &crate::post::overlay::OverlayState {
        &self.overlay
    }

    /// Views holding overlay buffers (a view that never drew an overlay
    /// holds none).
    pub fn overlay_views(&self) -> usize {
        self.overlay.views()
    }

    /// Views holding ids or a depth drawn for their overlay (an outline
    /// without instance labels, tested shapes on a multisampled view):
    /// dropped the first frame they are no longer needed. Like the
    /// overlay's own buffers they are not counted against the renderer's
    /// target budget (at most 8 bytes a pixel of the view).
    pub fn overlay_id_views(&self) -> usize {
        self.overlay.id_views()
    }

    /// The tone map's effects.
    pub(crate) fn effects(&self) -> &crate::post::effects::EffectsState {
        &self.effects
    }

    /// Views holding buffers of the tone map's effects (bloom, automatic
    /// exposure): a view with neither holds none.
    pub fn tone_map_effect_views(&self) -> usize {
        self.effects.views()
    }

    /// Views holding screen-space buffers (depth in metres, for ambient
    /// occlusion or contact shadows): a view with neither holds none.
    pub fn screen_space_views(&self) -> usize {
        self.ambient_occlusion.views()
    }

    /// Frees the light clusters, the screen-space buffers and the tone
    /// map's effects of the views
    /// `keep` says no to (the renderer calls it once a frame with the views
    /// it renders).
    pub fn retain_views(&self, keep: impl Fn(oxygen_core::ViewId) -> bool) {
        self.clusters.retain(&keep);
        self.ambient_occlusion.retain(&keep);
        self.reflection_history.retain(&keep);
        self.overlay.retain(&keep);
        self.effects.retain(keep);
    }

    /// The layout of bind group 1.
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.inputs.layout
    }

    /// Group 1 for passes that read no shadow maps and no probe (with the
    /// environment, when there is one).
    pub fn no_lighting_inputs(&self) -> &wgpu::BindGroup {
        self.environment.as_ref().map_or(&self.inputs.no_inputs, |e| &e.no_inputs)
    }

    /// A group 1 with these cascade maps (unused slots `None`), local shadow
    /// atlas, probes (six-layer array views, or `None`), light clusters
    /// (`None` for a view that does not cull its lights), ambient
    /// occlusion, depth in metres and reflection history (`None` for a view
    /// without) and their uniform block.
    pub fn bind_group(
        &self,
        device: &wgpu::Device,
        maps: [Option<&wgpu::TextureView>; MAX_CASCADES],
        shadow_atlas: Option<&wgpu::TextureView>,
        probes: [Option<&wgpu::TextureView>; MAX_PROBES],
        screen: ScreenBuffers<'_>,
        uniform: &LightingInputs,
    ) -> wgpu::BindGroup {
        let inputs = &self.inputs;
        let mut uniform = *uniform;
        if let Some(env) = &self.environment {
            uniform.environment_levels = env.texture.mip_level_count();
        }
        let buffer = crate::lighting::inputs::uniform_buffer(device, &uniform);
        // Unused slots are never sampled (the uniform's counts say so) but must be bound.
        let maps = maps.map(|m| m.unwrap_or(&inputs.placeholder_map));
        let shadow_atlas = shadow_atlas.unwrap_or(&inputs.placeholder_atlas);
        let probes = probes.map(|p| p.unwrap_or(&inputs.placeholder_probe));
        let environment = self.environment.as_ref().map_or(&inputs.placeholder_probe, |e| &e.view);
        crate::lighting::inputs::bind_group(
            device,
            &inputs.layout,
            inputs.shared(),
            (maps, shadow_atlas),
            (probes, environment),
            (&buffer, screen),
        )
    }

    /// The local shadow atlas with room for `layers` tiles of `resolution`²
    /// (kept across frames; recreated when it no longer fits).
    pub fn local_shadow_atlas(&self, device: &wgpu::Device, resolution: u32, layers: u32) -> wgpu::Texture {
        self.shadow_atlas.ensure(device, resolution, layers)
    }

    /// Re-filters a probe texture whose faces (level 0) were just
    /// rendered: levels `1..=levels − 3` become its GGX-prefiltered
    /// radiance, as the environment's are (`samples` per texel; nothing
    /// for a texture too small or not renderable).
    pub fn prefilter_probe(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        texture: &wgpu::Texture,
        samples: u32,
    ) {
        self.cube_filter.prefilter_probe(device, encoder, texture, samples);
    }
}
