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

    /// Red channels of RGBA8 texels (green, blue and alpha fixed), row by row.
    fn red_image(reds: &[u8]) -> Vec<u8> {
        reds.iter().flat_map(|&r| [r, 7, 9, 255]).collect()
    }

    fn reds(texels: &[u8]) -> Vec<u8> {
        texels.chunks(4).map(|t| t[0]).collect()
    }

    /// Bilinear 2 × 2 → 4 × 4: output centres fall at a quarter and three
    /// quarters between the source centres (weights exact in `f32`), and
    /// the outer rows and columns copy the edge texels.
    #[test]
    fn bilinear_upsample_weights_by_distance_to_texel_centres() {
        let src = red_image(&[0, 200, 100, 40]);
        let out = resample_rgba8(&src, 2, 2, 4, 4, false);
        #[rustfmt::skip]
        let expected = [
            0, 50, 150, 200,
            25, 59, 126, 160,
            75, 76, 79, 80,
            100, 85, 55, 40,
        ];
        assert_eq!(reds(&out), expected);
        assert!(out.chunks(4).all(|t| t[1..] == [7, 9, 255]));
    }

    /// Bilinear and nearest 4 × 4 → 2 × 2: each bilinear output centre lies
    /// in the middle of a 2 × 2 block (the block's mean); nearest takes the
    /// block's first texel.
    #[test]
    fn downsampling_reads_each_output_texels_own_block() {
        let src = red_image(&(0..16u8).map(|i| 10 * (i % 4) + 60 * (i / 4)).collect::<Vec<_>>());
        assert_eq!(reds(&resample_rgba8(&src, 4, 4, 2, 2, false)), [35, 55, 155, 175]);
        assert_eq!(reds(&resample_rgba8(&src, 4, 4, 2, 2, true)), [0, 20, 120, 140]);
        // Nearest upsampling repeats texels, rows as well as columns.
        let small = red_image(&[1, 2, 3, 4]);
        assert_eq!(reds(&resample_rgba8(&small, 2, 2, 4, 4, true)), [1, 1, 2, 2, 1, 1, 2, 2, 3, 3, 4, 4, 3, 3, 4, 4]);
        let row = red_image(&[10, 20, 30]);
        assert_eq!(reds(&resample_rgba8(&row, 3, 1, 5, 1, true)), [10, 10, 20, 20, 30]);
    }

    /// Against an independent formulation, a tent filter over every source
    /// texel in `f64`, on sizes that shrink along one axis and grow along
    /// the other (within 1 for `f32` rounding at the halves).
    #[test]
    fn bilinear_matches_a_tent_filter_reference() {
        let tent = |size: u32, new_size: u32, i: u32| -> Vec<f64> {
            let s = ((i as f64 + 0.5) * size as f64 / new_size as f64 - 0.5).clamp(0.0, (size - 1) as f64);
            (0..size).map(|k| (1.0 - (s - k as f64).abs()).max(0.0)).collect()
        };
        for (w, h, nw, nh) in [(3, 2, 5, 7), (5, 3, 2, 4), (1, 4, 3, 2), (4, 1, 6, 3), (7, 5, 3, 3)] {
            let src: Vec<u8> = (0..w * h)
                .flat_map(|i| [(i * 37 % 251) as u8, (i * 91 % 256) as u8, (255 - i * 13 % 256) as u8, 255])
                .collect();
            let out = resample_rgba8(&src, w, h, nw, nh, false);
            assert_eq!(out.len(), (nw * nh * 4) as usize);
            for y in 0..nh {
                let wy = tent(h, nh, y);
                for x in 0..nw {
                    let wx = tent(w, nw, x);
                    for c in 0..4 {
                        let mut sum = 0.0;
                        for (sy, wy) in wy.iter().enumerate() {
                            for (sx, wx) in wx.iter().enumerate() {
                                sum += wy * wx * src[(sy * w as usize + sx) * 4 + c] as f64;
                            }
                        }
                        let got = out[((y * nw + x) * 4) as usize + c];
                        assert!(
                            (got as f64 - sum).abs() <= 0.5 + 1e-3,
                            "{w}x{h} -> {nw}x{nh} ({x}, {y}) channel {c}: {got}, reference {sum}"
                        );
                    }
                }
            }
        }
    }
}
