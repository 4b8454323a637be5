//! The lighting resources every view shares: the layout and placeholders of
//! bind group 3 (what the forward pass reads from other views), the local
//! shadow atlas and the probe mip builder. Split from [`crate::Pipelines`]
//! because they are inputs of the lighting, not pipeline state.

use crate::lighting_inputs::LightingInputResources;
use crate::{LightingInputs, MAX_CASCADES, MAX_PROBES};

/// Group 3's layout and placeholders, the local shadow atlas, the probe mip
/// builder.
pub struct LightingResources {
    inputs: LightingInputResources,
    shadow_atlas: crate::shadow_atlas::ShadowAtlas,
    probe_mips: crate::probe_mips::ProbeMipBuilder,
}

impl LightingResources {
    /// Creates the layout, placeholders and builders.
    pub fn new(device: &wgpu::Device) -> Self {
        LightingResources {
            inputs: LightingInputResources::new(device),
            shadow_atlas: Default::default(),
            probe_mips: crate::probe_mips::ProbeMipBuilder::new(device),
        }
    }

    /// The layout of bind group 3.
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.inputs.layout
    }

    /// Group 3 for passes that read no shadow maps and no probe.
    pub fn no_lighting_inputs(&self) -> &wgpu::BindGroup {
        &self.inputs.no_inputs
    }

    /// A group 3 with these cascade maps (unused slots `None`), local shadow
    /// atlas, probes (six-layer array views, or `None`) and their uniform
    /// block.
    pub fn bind_group(
        &self,
        device: &wgpu::Device,
        maps: [Option<&wgpu::TextureView>; MAX_CASCADES],
        shadow_atlas: Option<&wgpu::TextureView>,
        probes: [Option<&wgpu::TextureView>; MAX_PROBES],
        uniform: &LightingInputs,
    ) -> wgpu::BindGroup {
        let inputs = &self.inputs;
        let buffer = crate::lighting_inputs::uniform_buffer(device, uniform);
        // Unused slots are never sampled (the uniform's counts say so) but must be bound.
        let maps = maps.map(|m| m.unwrap_or(&inputs.placeholder_map));
        let shadow_atlas = shadow_atlas.unwrap_or(&inputs.placeholder_atlas);
        let probes = probes.map(|p| p.unwrap_or(&inputs.placeholder_probe));
        let samplers = (&inputs.sampler, &inputs.probe_sampler);
        crate::lighting_inputs::bind_group(device, &inputs.layout, samplers, (maps, shadow_atlas), probes, &buffer)
    }

    /// The local shadow atlas with room for `layers` tiles of `resolution`²
    /// (kept across frames; recreated when it no longer fits).
    pub fn local_shadow_atlas(&self, device: &wgpu::Device, resolution: u32, layers: u32) -> wgpu::Texture {
        self.shadow_atlas.ensure(device, resolution, layers)
    }

    /// Rebuilds the mip levels of one layer of a probe texture from its
    /// level 0 (nothing for a one-level texture).
    pub fn rebuild_probe_mips(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        texture: &wgpu::Texture,
        layer: u32,
    ) {
        self.probe_mips.rebuild(device, encoder, texture, layer);
    }
}
