//! Copying a colour target back to the CPU: the displayable RGBA8 target as
//! an image, the linear HDR target (`Rgba16Float`) as `f32` texels.
//!
//! Both block until the GPU has finished all submitted work; they are for
//! tests, tools and screenshots, never for use inside a frame.

use crate::{GpuContext, GpuError};

/// A linear HDR picture read back from an `Rgba16Float` texture, each
/// half-float widened to `f32` exactly (NaN and infinities kept as they are,
/// so a test can find them).
#[derive(Clone, Debug, PartialEq)]
pub struct HdrImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// RGBA texels, row by row from the top-left corner.
    pub pixels: Vec<[f32; 4]>,
}

impl HdrImage {
    /// The texel at (`x`, `y`); panics outside the image.
    pub fn get(&self, x: u32, y: u32) -> [f32; 4] {
        assert!(x < self.width && y < self.height, "({x}, {y}) is outside {}×{}", self.width, self.height);
        self.pixels[(y * self.width + x) as usize]
    }

    /// Every pixel holding a NaN or an infinity in any channel, with its
    /// coordinates, in row order.
    pub fn non_finite(&self) -> impl Iterator<Item = ((u32, u32), [f32; 4])> + '_ {
        let width = self.width;
        self.pixels.iter().enumerate().filter(|(_, p)| !p.iter().all(|c| c.is_finite())).map(move |(i, p)| {
            let i = i as u32;
            ((i % width, i / width), *p)
        })
    }
}

/// Widens an IEEE 754 binary16 value to `f32`, exactly (every half is an
/// `f32`): subnormals are renormalised, infinities and NaNs kept.
pub fn f16_to_f32(bits: u16) -> f32 {
    let sign = ((bits as u32) & 0x8000) << 16;
    let exponent = ((bits >> 10) & 0x1f) as u32;
    let mantissa = (bits & 0x3ff) as u32;
    let magnitude = match (exponent, mantissa) {
        (0, 0) => 0,
        // Subnormal: mantissa × 2⁻²⁴, exactly representable as a normal f32.
        (0, m) => (m as f32 * f32::powi(2.0, -24)).to_bits(),
        // Infinity (m = 0) or NaN (quiet bit and payload moved up).
        (0x1f, m) => 0x7f80_0000 | (m << 13),
        // Normal: rebias the exponent from 15 to 127.
        (e, m) => ((e + 127 - 15) << 23) | (m << 13),
    };
    f32::from_bits(sign | magnitude)
}

impl GpuContext {
    /// Reads a 2D RGBA8 or BGRA8 texture (unorm or sRGB, stored bytes
    /// unchanged, BGRA put in RGBA order) into an image. Blocks until the
    /// GPU has finished all submitted work.
    pub fn read_rgba8(&self, texture: &wgpu::Texture) -> Result<image::RgbaImage, GpuError> {
        use wgpu::TextureFormat as F;
        let format = texture.format();
        let bgra = matches!(format, F::Bgra8Unorm | F::Bgra8UnormSrgb);
        if !bgra && !matches!(format, F::Rgba8Unorm | F::Rgba8UnormSrgb) {
            return Err(GpuError::UnsupportedReadbackFormat(format));
        }
        let mut pixels = self.read_texels(texture, 4)?;
        if bgra {
            pixels.chunks_exact_mut(4).for_each(|p| p.swap(0, 2));
        }
        // Length is exactly width * height * 4 by construction.
        Ok(image::RgbaImage::from_raw(texture.width(), texture.height(), pixels)
            .expect("readback size matches the texture"))
    }

    /// Reads a 2D `Rgba16Float` texture (a view's HDR target) as `f32`
    /// texels. Blocks until the GPU has finished all submitted work.
    pub fn read_rgba16_float(&self, texture: &wgpu::Texture) -> Result<HdrImage, GpuError> {
        let format = texture.format();
        if format != wgpu::TextureFormat::Rgba16Float {
            return Err(GpuError::UnsupportedReadbackFormat(format));
        }
        self.read_rgba16_float_layer(texture, 0, 0)
    }

    /// Reads mip level `level` of array layer `layer` of a 2D
    /// `Rgba16Float` texture (a probe face, an environment level) as `f32`
    /// texels. Blocks until the GPU has finished all submitted work.
    pub fn read_rgba16_float_layer(
        &self,
        texture: &wgpu::Texture,
        level: u32,
        layer: u32,
    ) -> Result<HdrImage, GpuError> {
        let format = texture.format();
        if format != wgpu::TextureFormat::Rgba16Float {
            return Err(GpuError::UnsupportedReadbackFormat(format));
        }
        if level >= texture.mip_level_count() || layer >= texture.depth_or_array_layers() {
            return Err(GpuError::NoSuchSubresource {
                level,
                layer,
                levels: texture.mip_level_count(),
                layers: texture.depth_or_array_layers(),
            });
        }
        let bytes = self.read_texels_at(texture, 8, level, layer)?;
        let pixels = bytes
            .chunks_exact(8)
            .map(|texel| std::array::from_fn(|c| f16_to_f32(u16::from_le_bytes([texel[2 * c], texel[2 * c + 1]]))))
            .collect();
        let (width, height) = ((texture.width() >> level).max(1), (texture.height() >> level).max(1));
        Ok(HdrImage { width, height, pixels })
    }

    /// Reads a view's HDR target as `f32` texels, whichever
    /// [`crate::HdrFormat`] it has (`Rg11b10Ufloat` reads with alpha 1).
    /// Blocks until the GPU has finished all submitted work.
    pub fn read_hdr_texels(&self, texture: &wgpu::Texture) -> Result<HdrImage, GpuError> {
        if texture.format() != wgpu::TextureFormat::Rg11b10Ufloat {
            return self.read_rgba16_float(texture);
        }
        let bytes = self.read_texels(texture, 4)?;
        let pixels = bytes
            .chunks_exact(4)
            .map(|texel| unpack_rg11b10_ufloat(u32::from_le_bytes([texel[0], texel[1], texel[2], texel[3]])))
            .collect();
        Ok(HdrImage { width: texture.width(), height: texture.height(), pixels })
    }

    /// `size` bytes of `buffer` from `offset` (the buffer needs `COPY_SRC`;
    /// offset and size multiples of 4). Waits for the GPU.
    pub fn read_buffer(&self, buffer: &wgpu::Buffer, offset: u64, size: u64) -> Result<Vec<u8>, GpuError> {
        let _span = tracing::info_span!("read_buffer", bytes = size).entered();
        if size == 0 {
            return Ok(Vec::new());
        }
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("buffer readback"),
            size,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut encoder = self.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(buffer, offset, &staging, 0, size);
        self.queue.submit([encoder.finish()]);
        let (sender, receiver) = std::sync::mpsc::channel();
        staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            // The receiver outlives the poll below; a send error cannot happen.
            let _ = sender.send(r);
        });
        self.device.poll(wgpu::PollType::wait_indefinitely())?;
        receiver.recv().unwrap_or(Err(wgpu::BufferAsyncError))?;
        let bytes = staging.slice(..).get_mapped_range()?.to_vec();
        staging.unmap();
        Ok(bytes)
    }

    /// The bytes of mip level 0 of a 2D texture of `bytes_per_texel`,
    /// tightly packed row by row.
    fn read_texels(&self, texture: &wgpu::Texture, bytes_per_texel: u32) -> Result<Vec<u8>, GpuError> {
        self.read_texels_at(texture, bytes_per_texel, 0, 0)
    }

    /// [`GpuContext::read_texels`] of one mip level of one array layer.
    fn read_texels_at(
        &self,
        texture: &wgpu::Texture,
        bytes_per_texel: u32,
        level: u32,
        layer: u32,
    ) -> Result<Vec<u8>, GpuError> {
        let (width, height) = ((texture.width() >> level).max(1), (texture.height() >> level).max(1));
        let region = TexelRegion { level, layer, origin: (0, 0), size: (width, height) };
        self.read_region(texture, bytes_per_texel, region, wgpu::TextureAspect::All)
    }

    /// Reads the `size` rectangle at `origin` of layer `layer` of a 2D
    /// RGBA8 texture (a view's tile of a batch's colour atlas) into an
    /// image. Blocks until the GPU has finished all submitted work.
    pub fn read_rgba8_region(
        &self,
        texture: &wgpu::Texture,
        layer: u32,
        origin: (u32, u32),
        size: (u32, u32),
    ) -> Result<image::RgbaImage, GpuError> {
        use wgpu::TextureFormat as F;
        let formats = [F::Rgba8Unorm, F::Rgba8UnormSrgb];
        let pixels = self.read_region_of(texture, &formats, 4, TexelRegion { level: 0, layer, origin, size })?;
        // Length is exactly width * height * 4 by construction.
        Ok(image::RgbaImage::from_raw(size.0, size.1, pixels).expect("readback size matches the region"))
    }

    /// Reads the `size` rectangle at `origin` of layer `layer` of an
    /// `R32Uint` texture (instance, class and linear-depth labels), row by
    /// row. Blocks until the GPU has finished all submitted work.
    pub fn read_u32_region(
        &self,
        texture: &wgpu::Texture,
        layer: u32,
        origin: (u32, u32),
        size: (u32, u32),
    ) -> Result<Vec<u32>, GpuError> {
        let region = TexelRegion { level: 0, layer, origin, size };
        let bytes = self.read_region_of(texture, &[wgpu::TextureFormat::R32Uint], 4, region)?;
        Ok(bytes.chunks_exact(4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect())
    }

    /// Reads the `size` rectangle at `origin` of layer `layer` of an
    /// `Rgba16Float` texture (normal labels, a tile of an HDR atlas) as
    /// `f32` texels. Blocks until the GPU has finished all submitted work.
    pub fn read_rgba16_float_region(
        &self,
        texture: &wgpu::Texture,
        layer: u32,
        origin: (u32, u32),
        size: (u32, u32),
    ) -> Result<HdrImage, GpuError> {
        let region = TexelRegion { level: 0, layer, origin, size };
        let bytes = self.read_region_of(texture, &[wgpu::TextureFormat::Rgba16Float], 8, region)?;
        let pixels = bytes
            .chunks_exact(8)
            .map(|texel| std::array::from_fn(|c| f16_to_f32(u16::from_le_bytes([texel[2 * c], texel[2 * c + 1]]))))
            .collect();
        Ok(HdrImage { width: size.0, height: size.1, pixels })
    }

    /// [`GpuContext::read_region`] of a colour texture whose format is one
    /// of `formats` (else [`GpuError::UnsupportedReadbackFormat`]).
    fn read_region_of(
        &self,
        texture: &wgpu::Texture,
        formats: &[wgpu::TextureFormat],
        bytes_per_texel: u32,
        region: TexelRegion,
    ) -> Result<Vec<u8>, GpuError> {
        let format = texture.format();
        if !formats.contains(&format) {
            return Err(GpuError::UnsupportedReadbackFormat(format));
        }
        self.read_region(texture, bytes_per_texel, region, wgpu::TextureAspect::All)
    }

    /// Reads the `size` rectangle at `origin` of layer `layer` of a
    /// `Depth32Float` texture: device depth (reverse-Z: 1 at the near
    /// plane, 0 at the far plane or nothing drawn), row by row. Depth
    /// cannot be copied in part, so the whole layer is copied and the
    /// rectangle cut from it. Blocks until the GPU has finished all
    /// submitted work.
    pub fn read_depth_region(
        &self,
        texture: &wgpu::Texture,
        layer: u32,
        origin: (u32, u32),
        size: (u32, u32),
    ) -> Result<Vec<f32>, GpuError> {
        let format = texture.format();
        if format != wgpu::TextureFormat::Depth32Float {
            return Err(GpuError::UnsupportedReadbackFormat(format));
        }
        let full = (texture.width(), texture.height());
        let inside = size.0 > 0
            && size.1 > 0
            && origin.0.checked_add(size.0).is_some_and(|r| r <= full.0)
            && origin.1.checked_add(size.1).is_some_and(|b| b <= full.1);
        if !inside {
            return Err(GpuError::RegionOutside { origin, size, texture_size: full });
        }
        let region = TexelRegion { level: 0, layer, origin: (0, 0), size: full };
        let bytes = self.read_region(texture, 4, region, wgpu::TextureAspect::DepthOnly)?;
        let row = full.0 as usize * 4;
        let mut depth = Vec::with_capacity(size.0 as usize * size.1 as usize);
        for y in origin.1..origin.1 + size.1 {
            let start = y as usize * row + origin.0 as usize * 4;
            let texels = &bytes[start..start + size.0 as usize * 4];
            depth.extend(texels.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])));
        }
        Ok(depth)
    }

    /// The bytes of `region` of a 2D texture of `bytes_per_texel`, tightly
    /// packed row by row. Fails when the region lies outside the texture.
    fn read_region(
        &self,
        texture: &wgpu::Texture,
        bytes_per_texel: u32,
        region: TexelRegion,
        aspect: wgpu::TextureAspect,
    ) -> Result<Vec<u8>, GpuError> {
        let _span = tracing::info_span!("readback").entered();
        let TexelRegion { level, layer, origin, size: (width, height) } = region;
        let (level_width, level_height) = ((texture.width() >> level).max(1), (texture.height() >> level).max(1));
        if level >= texture.mip_level_count() || layer >= texture.depth_or_array_layers() {
            return Err(GpuError::NoSuchSubresource {
                level,
                layer,
                levels: texture.mip_level_count(),
                layers: texture.depth_or_array_layers(),
            });
        }
        let inside = width > 0
            && height > 0
            && origin.0.checked_add(width).is_some_and(|r| r <= level_width)
            && origin.1.checked_add(height).is_some_and(|b| b <= level_height);
        if !inside {
            let texture_size = (level_width, level_height);
            return Err(GpuError::RegionOutside { origin, size: (width, height), texture_size });
        }
        let unpadded = width * bytes_per_texel;
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
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: level,
                origin: wgpu::Origin3d { x: origin.0, y: origin.1, z: layer },
                aspect,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
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
        let mut bytes = Vec::with_capacity((unpadded * height) as usize);
        for row in mapped.chunks(padded as usize) {
            bytes.extend_from_slice(&row[..unpadded as usize]);
        }
        drop(mapped);
        buffer.unmap();
        Ok(bytes)
    }
}

/// A rectangle of one mip level of one layer of a texture.
#[derive(Clone, Copy, Debug)]
struct TexelRegion {
    level: u32,
    layer: u32,
    origin: (u32, u32),
    size: (u32, u32),
}

/// One `Rg11b10Ufloat` texel as linear RGBA (alpha 1): red in bits 0–10,
/// green in 11–21 (5 exponent bits, 6 mantissa bits each), blue in 22–31
/// (5 exponent bits, 5 mantissa bits), exponent bias 15 as in half floats.
pub fn unpack_rg11b10_ufloat(packed: u32) -> [f32; 4] {
    let small_float = |bits: u32, mantissa_bits: u32| -> f32 {
        let exponent = bits >> mantissa_bits;
        let mantissa = (bits & ((1 << mantissa_bits) - 1)) as f32 / (1 << mantissa_bits) as f32;
        match exponent {
            0 => mantissa * f32::powi(2.0, -14),
            31 if mantissa == 0.0 => f32::INFINITY,
            31 => f32::NAN,
            e => (1.0 + mantissa) * f32::powi(2.0, e as i32 - 15),
        }
    };
    [small_float(packed & 0x7ff, 6), small_float((packed >> 11) & 0x7ff, 6), small_float(packed >> 22, 5), 1.0]
}

#[cfg(test)]
mod tests {
    #[test]
    fn packed_small_floats_widen_exactly() {
        // 1.0 is exponent 15, mantissa 0 in every channel.
        let one = (15 << 6) | ((15 << 6) << 11) | ((15 << 5) << 22);
        assert_eq!(unpack_rg11b10_ufloat(one), [1.0, 1.0, 1.0, 1.0]);
        assert_eq!(unpack_rg11b10_ufloat(0), [0.0, 0.0, 0.0, 1.0]);
        // Largest finite 11-bit value: exponent 30, mantissa all ones.
        assert_eq!(unpack_rg11b10_ufloat(0x7bf)[0], 65024.0);
        assert_eq!(unpack_rg11b10_ufloat(0x7c0)[0], f32::INFINITY);
        // Smallest subnormal of the 10-bit blue channel: 2^-14 / 32.
        assert_eq!(unpack_rg11b10_ufloat(1 << 22)[2], f32::powi(2.0, -19));
    }

    #[test]
    fn packed_small_float_nans_stay_nan() {
        // Exponent 31 with a mantissa is NaN, without one infinity, in each
        // channel (green and red: 6 mantissa bits, blue: 5).
        let nan = 0x7c1 | (0x7c1 << 11) | (0x3e1 << 22);
        assert!(unpack_rg11b10_ufloat(nan)[..3].iter().all(|c| c.is_nan()), "{:?}", unpack_rg11b10_ufloat(nan));
        let infinity = 0x7c0 | (0x7c0 << 11) | (0x3e0 << 22);
        assert_eq!(unpack_rg11b10_ufloat(infinity), [f32::INFINITY, f32::INFINITY, f32::INFINITY, 1.0]);
    }

    use super::*;

    #[test]
    fn half_floats_widen_exactly() {
        assert_eq!(f16_to_f32(0x0000), 0.0);
        assert!(f16_to_f32(0x8000).is_sign_negative() && f16_to_f32(0x8000) == 0.0);
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0xc000), -2.0);
        assert_eq!(f16_to_f32(0x3555), 0.333_251_95);
        assert_eq!(f16_to_f32(0x7bff), 65504.0, "largest finite half");
        assert_eq!(f16_to_f32(0x0400), f32::powi(2.0, -14), "smallest normal half");
        assert_eq!(f16_to_f32(0x0001), f32::powi(2.0, -24), "smallest subnormal half");
        assert_eq!(f16_to_f32(0x03ff), 1023.0 * f32::powi(2.0, -24), "largest subnormal half");
        assert_eq!(f16_to_f32(0x7c00), f32::INFINITY);
        assert_eq!(f16_to_f32(0xfc00), f32::NEG_INFINITY);
        assert!(f16_to_f32(0x7e00).is_nan());
        assert!(f16_to_f32(0x7c01).is_nan(), "a signalling NaN stays NaN");
    }

    #[test]
    fn a_texel_is_read_at_its_column_and_row() {
        // 3 × 2, each texel holding its index: the row length is the width.
        let pixels = (0..6).map(|i| [i as f32, 0.5, -1.0, 2.0]).collect();
        let image = HdrImage { width: 3, height: 2, pixels };
        for (x, y) in [(0, 0), (2, 0), (0, 1), (1, 1), (2, 1)] {
            assert_eq!(image.get(x, y), [(y * 3 + x) as f32, 0.5, -1.0, 2.0], "({x}, {y})");
        }
    }

    #[test]
    #[should_panic(expected = "(3, 0) is outside 3×2")]
    fn a_texel_past_the_row_is_refused() {
        HdrImage { width: 3, height: 2, pixels: vec![[0.0; 4]; 6] }.get(3, 0);
    }

    #[test]
    fn non_finite_pixels_are_found_with_their_coordinates() {
        let mut image = HdrImage { width: 3, height: 2, pixels: vec![[0.5; 4]; 6] };
        image.pixels[4][1] = f32::NAN;
        image.pixels[5][3] = f32::INFINITY;
        let found: Vec<_> = image.non_finite().map(|(at, _)| at).collect();
        assert_eq!(found, [(1, 1), (2, 1)]);
    }
}
