//! Depth into a float texture, for reading depth back on adapters that
//! cannot copy a depth texture into a buffer (GL lacks
//! `DownlevelFlags::DEPTH_TEXTURE_AND_BUFFER_COPIES`): a full-screen pass
//! writes the bits of each depth texel into an `R32Uint` texture of the
//! same size (GL cannot render `R32Float` either), which copies like any
//! colour texture; its bytes are the depth's `f32` bytes. Exact: the value
//! is loaded, not filtered.

use std::sync::OnceLock;

use oxygen_gpu::bindings::{self, LayoutEntries};

/// The depth-to-float pass: its layout and pipeline, made on first use.
#[derive(Default)]
pub struct DepthCopy {
    made: OnceLock<(wgpu::BindGroupLayout, wgpu::RenderPipeline)>,
}

impl DepthCopy {
    /// The format depth's bits are copied into.
    pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;

    /// Whether `device`'s adapter needs the pass to read depth back (it
    /// cannot copy depth textures into buffers).
    pub fn needed(downlevel: &wgpu::DownlevelCapabilities) -> bool {
        !downlevel.flags.contains(wgpu::DownlevelFlags::DEPTH_TEXTURE_AND_BUFFER_COPIES)
    }

    /// Records the copy of `depth` (a single-layer view of a
    /// `Depth32Float` texture of `size`) into a new `R32Uint` texture of
    /// the same size (copy source) holding its bits, which it returns.
    pub fn record(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        depth: &wgpu::TextureView,
        size: (u32, u32),
    ) -> wgpu::Texture {
        let (layout, pipeline) = self.made.get_or_init(|| {
            let layout = LayoutEntries::new(wgpu::ShaderStages::FRAGMENT)
                .push(bindings::texture_2d(bindings::UNFILTERABLE_FLOAT))
                .create_layout(device, "depth copy");
            let wgsl = crate::shaders::DEPTH_COPY.source();
            let pipeline = crate::fullscreen_pipeline(device, "depth copy", &layout, &wgsl, ("vs", "fs"), Self::FORMAT);
            (layout, pipeline)
        });
        let extent = wgpu::Extent3d { width: size.0.max(1), height: size.1.max(1), depth_or_array_layers: 1 };
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        let target = oxygen_gpu::texture_2d(device, "depth bits", extent, 1, Self::FORMAT, usage);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("depth copy"),
            layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(depth) }],
        });
        let view = target.create_view(&Default::default());
        let mut pass = crate::pipelines::fullscreen_pass(encoder, &view, "depth copy");
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.draw(0..3, 0..1);
        drop(pass);
        target
    }
}
