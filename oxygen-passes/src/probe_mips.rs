//! Mip chains of reflection-probe faces, for rough reflections.
//!
//! A probe face is copied into level 0 of its layer; each further level is a
//! draw that averages 2 × 2 texels of the level above (one bilinear tap at
//! their shared corner). The shading pass then reads a rough surface's
//! reflection from a level chosen by its roughness: a box-filtered stand-in
//! for a GGX-prefiltered environment, cheap enough to rebuild whenever a face
//! is re-rendered. Faces are filtered one by one, so texels at a face's edge
//! do not blend with the neighbouring face.
//!
//! The level above is bound as a one-level `D2Array` view of every layer and
//! the draw picks the layer (the vertex index carries it): wgpu's GL backend
//! binds a sampled view as its whole texture, so a `D2` view of layer `k > 0`
//! would read layer 0 there (wgpu-hal logs "Unable to create a sampled
//! texture binding for non-zero array layer").

use oxygen_core::ViewTargets;

/// The probe-mip downsampling shader (self-contained).
pub const PROBE_MIP_WGSL: &str = include_str!("probe_mips.wgsl");

/// The downsampling pipeline, shared by every probe.
pub(crate) struct ProbeMipBuilder {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    sampler: wgpu::Sampler,
}

impl ProbeMipBuilder {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("probe mip"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let pipeline = crate::pipelines::fullscreen_pipeline(
            device,
            "probe mip",
            &layout,
            PROBE_MIP_WGSL,
            ("vs", "fs"),
            ViewTargets::HDR_FORMAT,
        );
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("probe mip"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        ProbeMipBuilder { layout, pipeline, sampler }
    }

    /// Rebuilds levels 1.. of `layer` from its level 0. Does nothing for a
    /// texture of one level or one that cannot be rendered to (a probe
    /// texture made by the application without `RENDER_ATTACHMENT`).
    pub(crate) fn rebuild(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        texture: &wgpu::Texture,
        layer: u32,
    ) {
        if texture.mip_level_count() < 2
            || texture.format() != ViewTargets::HDR_FORMAT
            || !texture.usage().contains(wgpu::TextureUsages::RENDER_ATTACHMENT)
        {
            return;
        }
        for mip in 1..texture.mip_level_count() {
            let source = texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some("probe mip source level"),
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                base_mip_level: mip - 1,
                mip_level_count: Some(1),
                ..Default::default()
            });
            let target = texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some("probe mip level"),
                dimension: Some(wgpu::TextureViewDimension::D2),
                base_mip_level: mip,
                mip_level_count: Some(1),
                base_array_layer: layer,
                array_layer_count: Some(1),
                ..Default::default()
            });
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("probe mip"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&source) },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&self.sampler) },
                ],
            });
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("probe mip"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.draw(3 * layer..3 * layer + 3, 0..1);
        }
    }
}
