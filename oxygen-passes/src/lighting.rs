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
    environment: Option<EnvironmentTexture>,
}

/// The prefiltered environment on the GPU, and the group 3 that binds it
/// for passes without other lighting inputs.
struct EnvironmentTexture {
    view: wgpu::TextureView,
    levels: u32,
    sh: [[f32; 4]; 9],
    no_inputs: wgpu::BindGroup,
}

/// `value` as a half float (round to nearest even; overflow to the largest
/// finite half, which the HDR target can hold; NaN to 0).
fn f32_to_f16(value: f32) -> u16 {
    if !value.is_finite() {
        return if value.is_nan() {
            0
        } else if value > 0.0 {
            0x7bff
        } else {
            0xfbff
        };
    }
    let bits = value.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let exponent = ((bits >> 23) & 0xff) as i32 - 127 + 15;
    let mantissa = bits & 0x7f_ffff;
    if exponent >= 31 {
        return sign | 0x7bff;
    }
    if exponent <= 0 {
        if exponent < -10 {
            return sign;
        }
        // Subnormal half: shift the implicit one in.
        let m = (mantissa | 0x80_0000) >> (1 - exponent);
        let rounded = (m + 0x1000) >> 13;
        return sign | rounded as u16;
    }
    let rounded = ((exponent as u32) << 10 | (mantissa >> 13))
        + u32::from((mantissa & 0x1fff) > 0x1000 || ((mantissa & 0x1fff) == 0x1000 && (mantissa >> 13) & 1 == 1));
    if rounded >= 0x7c00 { sign | 0x7bff } else { sign | rounded as u16 }
}

impl LightingResources {
    /// Creates the layout, placeholders and builders.
    pub fn new(device: &wgpu::Device) -> Self {
        LightingResources {
            inputs: LightingInputResources::new(device),
            shadow_atlas: Default::default(),
            probe_mips: crate::probe_mips::ProbeMipBuilder::new(device),
            environment: None,
        }
    }

    /// Uploads a prefiltered environment (`None` removes it): from the next
    /// recorded pass on, shading takes its diffuse and specular ambient
    /// light from it (and draws it behind the scene) instead of the
    /// constant ambient term.
    pub fn set_environment(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        environment: Option<&oxygen_core::PrefilteredEnvironment>,
    ) {
        let Some(env) = environment else {
            self.environment = None;
            return;
        };
        let levels = env.levels.len() as u32;
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("environment"),
            size: wgpu::Extent3d {
                width: env.size,
                height: env.size,
                depth_or_array_layers: crate::array_layer_count(6, true),
            },
            mip_level_count: levels,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: oxygen_core::ViewTargets::HDR_FORMAT,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        for (level, faces) in env.levels.iter().enumerate() {
            let side = (env.size >> level).max(1);
            for (face, texels) in faces.iter().enumerate() {
                let bytes: Vec<u8> = texels
                    .iter()
                    .flat_map(|t| [t.x, t.y, t.z, 1.0])
                    .flat_map(|v| f32_to_f16(v).to_le_bytes())
                    .collect();
                queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &texture,
                        mip_level: level as u32,
                        origin: wgpu::Origin3d { x: 0, y: 0, z: face as u32 },
                        aspect: wgpu::TextureAspect::All,
                    },
                    &bytes,
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(side * 8),
                        rows_per_image: Some(side),
                    },
                    wgpu::Extent3d { width: side, height: side, depth_or_array_layers: 1 },
                );
            }
        }
        let view = crate::probe_view(&texture);
        let sh = env.irradiance_sh.map(|c| c.extend(0.0).to_array());
        let mut uniform = <LightingInputs as bytemuck::Zeroable>::zeroed();
        uniform.environment_levels = levels;
        uniform.environment_sh = sh;
        let inputs = &self.inputs;
        let buffer = crate::lighting_inputs::uniform_buffer(device, &uniform);
        let no_inputs = crate::lighting_inputs::bind_group(
            device,
            &inputs.layout,
            (&inputs.sampler, &inputs.probe_sampler, &inputs.environment_sampler),
            ([&inputs.placeholder_map; MAX_CASCADES], &inputs.placeholder_atlas),
            ([&inputs.placeholder_probe; MAX_PROBES], &view),
            &buffer,
        );
        self.environment = Some(EnvironmentTexture { view, levels, sh, no_inputs });
    }

    /// Whether an environment lights the scene ([`LightingResources::set_environment`]).
    pub fn has_environment(&self) -> bool {
        self.environment.is_some()
    }

    /// The layout of bind group 3.
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.inputs.layout
    }

    /// Group 3 for passes that read no shadow maps and no probe (with the
    /// environment, when there is one).
    pub fn no_lighting_inputs(&self) -> &wgpu::BindGroup {
        self.environment.as_ref().map_or(&self.inputs.no_inputs, |e| &e.no_inputs)
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
        let mut uniform = *uniform;
        if let Some(env) = &self.environment {
            uniform.environment_levels = env.levels;
            uniform.environment_sh = env.sh;
        }
        let buffer = crate::lighting_inputs::uniform_buffer(device, &uniform);
        // Unused slots are never sampled (the uniform's counts say so) but must be bound.
        let maps = maps.map(|m| m.unwrap_or(&inputs.placeholder_map));
        let shadow_atlas = shadow_atlas.unwrap_or(&inputs.placeholder_atlas);
        let probes = probes.map(|p| p.unwrap_or(&inputs.placeholder_probe));
        let environment = self.environment.as_ref().map_or(&inputs.placeholder_probe, |e| &e.view);
        let samplers = (&inputs.sampler, &inputs.probe_sampler, &inputs.environment_sampler);
        crate::lighting_inputs::bind_group(
            device,
            &inputs.layout,
            samplers,
            (maps, shadow_atlas),
            (probes, environment),
            &buffer,
        )
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

#[cfg(test)]
mod tests {
    #[test]
    fn half_floats_round_trip_within_their_precision() {
        for v in [0.0f32, 1.0, -2.5, 0.1, 2.7, 1e-5, 6.1e-5, 65504.0, 1e6, -1e6] {
            let back = oxygen_core::gpu::f16_to_f32(super::f32_to_f16(v));
            let expected = v.clamp(-65504.0, 65504.0);
            assert!((back - expected).abs() <= expected.abs() * 1e-3 + 1e-7, "{v} -> {back}");
        }
        assert_eq!(super::f32_to_f16(f32::NAN), 0);
    }
}
