//! The split-sum environment BRDF as a lookup table: which fraction of the
//! prefiltered environment a surface reflects, `F0 · A + B`, by `n·v` and
//! roughness. Computed once per renderer on the GPU (a 32 × 32 draw, 1024
//! GGX samples per texel) for the lobe the direct lights use, so a surface
//! lit by its environment and by a light agrees on how shiny it is.
//!
//! Shaders read it from a uniform buffer (the texture's half floats copied
//! as they are, two texels per `vec4<u32>`) with their own bilinear
//! interpolation, not as a texture: GL allows 16 sampled textures per
//! stage and the shading pass already binds 16. It replaces the analytic
//! fit (Karis 2014) the shading and the reference's raster model used
//! before; `tests/environment.rs` measures both against the CPU twin,
//! `oxygen_core::split_sum_brdf`.

pub(crate) use super::params::SPLIT_SUM_LUT_BYTES;
pub use super::params::SPLIT_SUM_LUT_SIZE;

/// The table's format: A in red, B in green.
pub(crate) const SPLIT_SUM_LUT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// The shader as compiled: [`SPLIT_SUM_WGSL`] with the lighting constants
/// (`SPLIT_SUM_LUT_SIZE`) it includes.
pub fn split_sum_shader_source() -> String {
    crate::shaders::SPLIT_SUM.source()
}

// One row is 256 bytes, the copy alignment: the texture copies into the
// buffer tightly packed.
const _: () = assert!(SPLIT_SUM_LUT_SIZE * 8 == wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);

/// Builds the table (submitted on `queue`; ready for any later
/// submission): the texture (for readback) and the uniform buffer the
/// shaders read.
pub(crate) fn build_lut(device: &wgpu::Device, queue: &wgpu::Queue) -> (wgpu::Texture, wgpu::Buffer) {
    let _span = tracing::info_span!("split_sum_lut", size = SPLIT_SUM_LUT_SIZE).entered();
    let texture = oxygen_gpu::texture_2d(
        device,
        "split-sum BRDF",
        wgpu::Extent3d { width: SPLIT_SUM_LUT_SIZE, height: SPLIT_SUM_LUT_SIZE, depth_or_array_layers: 1 },
        1,
        SPLIT_SUM_LUT_FORMAT,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
    );
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: None, entries: &[] });
    let pipeline = crate::pipelines::fullscreen_pipeline(
        device,
        "split-sum BRDF",
        &layout,
        &split_sum_shader_source(),
        ("vs", "fs"),
        SPLIT_SUM_LUT_FORMAT,
    );
    let view = texture.create_view(&Default::default());
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("split-sum BRDF") });
    {
        let mut pass = crate::pipelines::fullscreen_pass(&mut encoder, &view, "split-sum BRDF");
        pass.set_pipeline(&pipeline);
        pass.draw(0..3, 0..1);
    }
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("split-sum BRDF"),
        size: SPLIT_SUM_LUT_BYTES,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(SPLIT_SUM_LUT_SIZE * 8),
                rows_per_image: Some(SPLIT_SUM_LUT_SIZE),
            },
        },
        texture.size(),
    );
    queue.submit([encoder.finish()]);
    (texture, buffer)
}
