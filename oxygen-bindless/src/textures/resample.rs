//! CPU resampling of RGBA8 texels, which the grouped-arrays path needs to
//! fit every texture into one of its square size classes.

/// Resampling of RGBA8 texels (in their stored encoding), with texel
/// centres aligned and edges clamped: bilinear, or nearest for textures that
/// will be sampled with a nearest filter (so hard edges stay hard).
pub fn resample_rgba8(src: &[u8], width: u32, height: u32, new_width: u32, new_height: u32, nearest: bool) -> Vec<u8> {
    if (width, height) == (new_width, new_height) {
        return src.to_vec();
    }
    if nearest {
        let mut out = Vec::with_capacity(new_width as usize * new_height as usize * 4);
        for y in 0..new_height {
            let sy = ((y as u64 * height as u64) / new_height as u64) as usize;
            for x in 0..new_width {
                let sx = ((x as u64 * width as u64) / new_width as u64) as usize;
                let i = (sy * width as usize + sx) * 4;
                out.extend_from_slice(&src[i..i + 4]);
            }
        }
        return out;
    }
    let texel = |x: u32, y: u32, c: usize| src[(y as usize * width as usize + x as usize) * 4 + c] as f32;
    let mut out = Vec::with_capacity(new_width as usize * new_height as usize * 4);
    for y in 0..new_height {
        let fy = ((y as f32 + 0.5) * height as f32 / new_height as f32 - 0.5).clamp(0.0, (height - 1) as f32);
        let (y0, ty) = (fy.floor() as u32, fy.fract());
        let y1 = (y0 + 1).min(height - 1);
        for x in 0..new_width {
            let fx = ((x as f32 + 0.5) * width as f32 / new_width as f32 - 0.5).clamp(0.0, (width - 1) as f32);
            let (x0, tx) = (fx.floor() as u32, fx.fract());
            let x1 = (x0 + 1).min(width - 1);
            for c in 0..4 {
                let top = texel(x0, y0, c) * (1.0 - tx) + texel(x1, y0, c) * tx;
                let bottom = texel(x0, y1, c) * (1.0 - tx) + texel(x1, y1, c) * tx;
                out.push((top * (1.0 - ty) + bottom * ty).round() as u8);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resampling_keeps_flat_colour_and_cell_centres() {
        let flat = [10u8, 20, 30, 255].repeat(9);
        assert_eq!(resample_rgba8(&flat, 3, 3, 7, 5, false), [10u8, 20, 30, 255].repeat(35));
        assert_eq!(resample_rgba8(&flat, 3, 3, 7, 5, true), [10u8, 20, 30, 255].repeat(35));
        // A 2x2 checker upsampled 32x keeps each cell's colour at its centre.
        let checker = [255u8, 0, 0, 255, 0, 0, 255, 255, 0, 0, 255, 255, 255, 0, 0, 255];
        let big = resample_rgba8(&checker, 2, 2, 64, 64, false);
        let at = |x: usize, y: usize| &big[(y * 64 + x) * 4..(y * 64 + x) * 4 + 4];
        assert_eq!(at(8, 8), &[255, 0, 0, 255]);
        assert_eq!(at(56, 8), &[0, 0, 255, 255]);
        // Nearest keeps the edge hard: the texel just left of the middle is still red.
        let hard = resample_rgba8(&checker, 2, 2, 64, 64, true);
        assert_eq!(&hard[31 * 4..32 * 4], &[255, 0, 0, 255]);
        assert_eq!(&hard[32 * 4..33 * 4], &[0, 0, 255, 255]);
    }
}
