//! What the shading pass reads from other views (bind group 1): up to four
//! cascade depth maps rendered by earlier shadow views of the frame (with a
//! comparison sampler and the cascades' light view-projections), the atlas of
//! spot and point-light shadow maps, and up to four reflection probes' six
//! faces each.
//!
//! Every mesh pipeline's layout has group 1, so passes that read none of this
//! bind [`crate::LightingResources::no_lighting_inputs`]: 1 × 1 placeholders, a
//! cascade count of 0 and no probe.

use bytemuck::Zeroable;
use oxygen_gpu::bindings::{self, LayoutEntries};

use super::params::{
    AMBIENT_OCCLUSION_BINDING, CLUSTER_LIGHTS_BINDING, COMPARISON_SAMPLER_BINDING, ENVIRONMENT_BINDING,
    ENVIRONMENT_SAMPLER_BINDING, FIRST_PROBE_BINDING, LightingInputs, MAX_CASCADES, MAX_PROBES, PROBE_FACES,
    PROBE_SAMPLER_BINDING, REFLECTION_HISTORY_BINDING, SHADOW_ATLAS_BINDING, SPLIT_SUM_BINDING, UNIFORM_BINDING,
    VIEW_DEPTH_BINDING,
};

/// (forward, up) of each probe face camera, in layer order; the shader's
/// `sample_probe` uses the same table.
pub const PROBE_FACE_AXES: [([f32; 3], [f32; 3]); PROBE_FACES] = [
    ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ([-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ([0.0, 1.0, 0.0], [0.0, 0.0, -1.0]),
    ([0.0, -1.0, 0.0], [0.0, 0.0, 1.0]),
    ([0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
    ([0.0, 0.0, -1.0], [0.0, 1.0, 0.0]),
];

pub(crate) struct LightingInputResources {
    pub(crate) layout: wgpu::BindGroupLayout,
    pub(crate) sampler: wgpu::Sampler,
    pub(crate) probe_sampler: wgpu::Sampler,
    pub(crate) environment_sampler: wgpu::Sampler,
    pub(crate) split_sum_lut: wgpu::Texture,
    pub(crate) split_sum_buffer: wgpu::Buffer,
    pub(crate) no_inputs: wgpu::BindGroup,
    pub(crate) placeholder_map: wgpu::TextureView,
    pub(crate) placeholder_probe: wgpu::TextureView,
    pub(crate) placeholder_atlas: wgpu::TextureView,
    /// One zero word: the light clusters of a view that does not cull its
    /// lights (the shader never reads it then).
    pub(crate) no_clusters: wgpu::Buffer,
}

/// What every group 1 binds alike: the samplers and the split-sum table.
pub(crate) struct SharedInputs<'a> {
    sampler: &'a wgpu::Sampler,
    probe_sampler: &'a wgpu::Sampler,
    environment_sampler: &'a wgpu::Sampler,
    split_sum: &'a wgpu::Buffer,
    no_clusters: &'a wgpu::Buffer,
}

impl LightingInputResources {
    pub(crate) fn shared(&self) -> SharedInputs<'_> {
        SharedInputs {
            sampler: &self.sampler,
            probe_sampler: &self.probe_sampler,
            environment_sampler: &self.environment_sampler,
            split_sum: &self.split_sum_buffer,
            no_clusters: &self.no_clusters,
        }
    }

    pub(crate) fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        // Fragment shading reads them, and deferred shading's compute pass
        // (mesh/deferred.wgsl) runs the same code.
        let layout = LayoutEntries::new(wgpu::ShaderStages::FRAGMENT.union(wgpu::ShaderStages::COMPUTE))
            .repeat(MAX_CASCADES as u32, bindings::depth_2d())
            .at(COMPARISON_SAMPLER_BINDING)
            .push(bindings::sampler_comparison())
            .at(UNIFORM_BINDING)
            .push(bindings::uniform_of::<LightingInputs>())
            .at(FIRST_PROBE_BINDING)
            .repeat(MAX_PROBES as u32, bindings::texture_2d_array(bindings::FILTERABLE_FLOAT))
            // The prefiltered environment: six faces with their mip chain
            // (the probes' layout), sampled with the probe sampler.
            .at(ENVIRONMENT_BINDING)
            .push(bindings::texture_2d_array(bindings::FILTERABLE_FLOAT))
            .at(SPLIT_SUM_BINDING)
            .push(bindings::uniform_sized(crate::lighting::split_sum::SPLIT_SUM_LUT_BYTES))
            .at(PROBE_SAMPLER_BINDING)
            .push(bindings::sampler_filtering())
            .at(ENVIRONMENT_SAMPLER_BINDING)
            .push(bindings::sampler_filtering())
            .at(SHADOW_ATLAS_BINDING)
            .push(bindings::depth_2d_array())
            .at(CLUSTER_LIGHTS_BINDING)
            .push(bindings::storage_read_only())
            .at(AMBIENT_OCCLUSION_BINDING)
            .push(bindings::storage_read_only())
            .at(VIEW_DEPTH_BINDING)
            .push(bindings::storage_read_only())
            .at(REFLECTION_HISTORY_BINDING)
            .push(bindings::storage_read_only())
            .create_layout(device, "lighting inputs");
        // Reverse-Z: a fragment is lit when it is at least as close to the
        // light as the stored depth, i.e. its depth is greater or equal.
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("shadow comparison"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::GreaterEqual),
            ..Default::default()
        });
        let dummy = oxygen_gpu::texture_2d(
            device,
            "no shadow map",
            wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
            1,
            oxygen_gpu::ViewTargets::DEPTH_FORMAT,
            wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let dummy_view = dummy.create_view(&Default::default());
        // Trilinear, as the environment's: probes are prefiltered alike.
        let probe_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("probe"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        // Trilinear: a roughness between two prefiltered levels blends them.
        let environment_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("environment"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        // A spare layer, as probes have: see `array_layer_count`.
        let probe_layers = crate::array_layer_count(PROBE_FACES as u32, true);
        let dummy_probe = oxygen_gpu::texture_2d(
            device,
            "no probe",
            wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: probe_layers },
            1,
            oxygen_gpu::ViewTargets::HDR_FORMAT,
            wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let dummy_probe_view = probe_view(&dummy_probe);
        let placeholder_atlas = oxygen_gpu::texture_2d(
            device,
            "no shadow atlas",
            // Two layers: a one-layer array is a plain 2D texture on GL.
            wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: crate::array_layer_count(1, true) },
            1,
            crate::lighting::shadow_atlas::SHADOW_ATLAS_FORMAT,
            wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let placeholder_atlas = crate::lighting::shadow_atlas::atlas_view(&placeholder_atlas);
        let uniform = uniform_buffer(device, &LightingInputs::zeroed());
        let (split_sum_lut, split_sum_buffer) = crate::lighting::split_sum::build_lut(device, queue);
        let no_clusters = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("no light clusters"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let shared = SharedInputs {
            sampler: &sampler,
            probe_sampler: &probe_sampler,
            environment_sampler: &environment_sampler,
            split_sum: &split_sum_buffer,
            no_clusters: &no_clusters,
        };
        let no_inputs = bind_group(
            device,
            &layout,
            shared,
            ([&dummy_view; MAX_CASCADES], &placeholder_atlas),
            ([&dummy_probe_view; MAX_PROBES], &dummy_probe_view),
            (&uniform, ScreenBuffers::default()),
        );
        LightingInputResources {
            layout,
            sampler,
            probe_sampler,
            environment_sampler,
            split_sum_lut,
            split_sum_buffer,
            no_inputs,
            placeholder_map: dummy_view,
            placeholder_probe: dummy_probe_view,
            placeholder_atlas,
            no_clusters,
        }
    }
}

/// A six-layer array view of a probe texture.
pub(crate) fn probe_view(texture: &wgpu::Texture) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    })
}

pub(crate) fn uniform_buffer(device: &wgpu::Device, uniform: &LightingInputs) -> wgpu::Buffer {
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("lighting inputs"),
        size: std::mem::size_of::<LightingInputs>() as u64,
        usage: wgpu::BufferUsages::UNIFORM,
        mapped_at_creation: true,
    });
    // Mapped at creation with exactly this size, so the copy fits.
    buffer.slice(..).get_mapped_range_mut().expect("mapped at creation").copy_from_slice(bytemuck::bytes_of(uniform));
    buffer.unmap();
    buffer
}

/// A view's own buffers in group 1, each `None` for a view without it (a
/// zero word is bound in its place, which the shader never reads then).
#[derive(Clone, Copy, Default)]
pub struct ScreenBuffers<'a> {
    /// Its light clusters' bits ([`crate::LightCulling::Clustered`]).
    pub clusters: Option<&'a wgpu::Buffer>,
    /// Its ambient occlusion, one float a pixel.
    pub ambient_occlusion: Option<&'a wgpu::Buffer>,
    /// Its depth in metres, one float a pixel.
    pub depth: Option<&'a wgpu::Buffer>,
    /// Its reflection history (screen-space reflections).
    pub reflection_history: Option<&'a wgpu::Buffer>,
}

pub(crate) fn bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    shared: SharedInputs<'_>,
    (maps, shadow_atlas): ([&wgpu::TextureView; MAX_CASCADES], &wgpu::TextureView),
    (probes, environment): ([&wgpu::TextureView; MAX_PROBES], &wgpu::TextureView),
    (uniform, screen): (&wgpu::Buffer, ScreenBuffers<'_>),
) -> wgpu::BindGroup {
    let ScreenBuffers { clusters, ambient_occlusion, depth, reflection_history } = screen;
    let mut entries: Vec<wgpu::BindGroupEntry<'_>> = maps
        .iter()
        .enumerate()
        .map(|(i, view)| wgpu::BindGroupEntry { binding: i as u32, resource: wgpu::BindingResource::TextureView(view) })
        .collect();
    entries.push(wgpu::BindGroupEntry {
        binding: COMPARISON_SAMPLER_BINDING,
        resource: wgpu::BindingResource::Sampler(shared.sampler),
    });
    entries.push(wgpu::BindGroupEntry { binding: UNIFORM_BINDING, resource: uniform.as_entire_binding() });
    for (i, probe) in probes.iter().enumerate() {
        entries.push(wgpu::BindGroupEntry {
            binding: FIRST_PROBE_BINDING + i as u32,
            resource: wgpu::BindingResource::TextureView(probe),
        });
    }
    entries.push(wgpu::BindGroupEntry {
        binding: ENVIRONMENT_BINDING,
        resource: wgpu::BindingResource::TextureView(environment),
    });
    entries.push(wgpu::BindGroupEntry {
        binding: PROBE_SAMPLER_BINDING,
        resource: wgpu::BindingResource::Sampler(shared.probe_sampler),
    });
    entries.push(wgpu::BindGroupEntry {
        binding: ENVIRONMENT_SAMPLER_BINDING,
        resource: wgpu::BindingResource::Sampler(shared.environment_sampler),
    });
    entries.push(wgpu::BindGroupEntry { binding: SPLIT_SUM_BINDING, resource: shared.split_sum.as_entire_binding() });
    entries.push(wgpu::BindGroupEntry {
        binding: SHADOW_ATLAS_BINDING,
        resource: wgpu::BindingResource::TextureView(shadow_atlas),
    });
    entries.push(wgpu::BindGroupEntry {
        binding: CLUSTER_LIGHTS_BINDING,
        resource: clusters.unwrap_or(shared.no_clusters).as_entire_binding(),
    });
    // The same zero word stands for a view without ambient occlusion or
    // depth in metres (the shader reads them only with their feature on and
    // `shadows.screen_width` > 0).
    entries.push(wgpu::BindGroupEntry {
        binding: AMBIENT_OCCLUSION_BINDING,
        resource: ambient_occlusion.unwrap_or(shared.no_clusters).as_entire_binding(),
    });
    entries.push(wgpu::BindGroupEntry {
        binding: VIEW_DEPTH_BINDING,
        resource: depth.unwrap_or(shared.no_clusters).as_entire_binding(),
    });
    entries.push(wgpu::BindGroupEntry {
        binding: REFLECTION_HISTORY_BINDING,
        resource: reflection_history.unwrap_or(shared.no_clusters).as_entire_binding(),
    });
    device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("lighting inputs"), layout, entries: &entries })
}
