//! Compute pipelines of one bind group, the shape of every screen-space
//! step (ambient occlusion, the reflection history, automatic exposure,
//! the selection outline's flood): its layout made from entries, the
//! pipeline of one entry point of a module over it.

use oxygen_gpu::bindings::LayoutEntries;

/// The compute pipeline of `entry` in `module` over one bind group of
/// `layout`; both labelled `entry`.
pub(crate) fn compute_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    entry: &str,
    layout: &wgpu::BindGroupLayout,
) -> wgpu::ComputePipeline {
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(entry),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: Some(&pipeline_layout),
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// [`compute_pipeline`] with its layout made from `entries` (labelled
/// `entry` too), returned with it.
pub(crate) fn compute_step(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    entry: &str,
    entries: LayoutEntries,
) -> (wgpu::BindGroupLayout, wgpu::ComputePipeline) {
    let layout = entries.create_layout(device, entry);
    let pipeline = compute_pipeline(device, module, entry, &layout);
    (layout, pipeline)
}
