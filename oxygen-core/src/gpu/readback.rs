//! Copying a colour target back to the CPU as an image.

use super::{GpuContext, GpuError};

impl GpuContext {
    /// Reads a 2D RGBA8 texture (unorm or sRGB, stored bytes unchanged) into
    /// an image. Blocks until the GPU has finished all submitted work.
    pub fn read_rgba8(&self, texture: &wgpu::Texture) -> Result<image::RgbaImage, GpuError> {
        let _span = tracing::info_span!("readback").entered();
        let format = texture.format();
        if !matches!(format, wgpu::TextureFormat::Rgba8Unorm | wgpu::TextureFormat::Rgba8UnormSrgb) {
            return Err(GpuError::UnsupportedReadbackFormat(format));
        }
        let (width, height) = (texture.width(), texture.height());
        let unpadded = width * 4;
        // Buffer rows must be 256-byte aligned for texture copies.
        let padded = unpadded.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: padded as u64 * height as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut encoder = self.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded),
                    rows_per_image: Some(height),
                },
            },
            texture.size(),
        );
        self.queue.submit([encoder.finish()]);
        let (sender, receiver) = std::sync::mpsc::channel();
        buffer.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            // The receiver outlives the poll below; a send error cannot happen.
            let _ = sender.send(r);
        });
        self.device.poll(wgpu::PollType::wait_indefinitely())?;
        receiver.recv().unwrap_or(Err(wgpu::BufferAsyncError))?;
        let mapped = buffer.slice(..).get_mapped_range()?;
        let mut pixels = Vec::with_capacity((unpadded * height) as usize);
        for row in mapped.chunks(padded as usize) {
            pixels.extend_from_slice(&row[..unpadded as usize]);
        }
        drop(mapped);
        buffer.unmap();
        // Length is exactly width * height * 4 by construction.
        Ok(image::RgbaImage::from_raw(width, height, pixels).expect("readback size matches the texture"))
    }
}
