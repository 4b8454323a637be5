//! CPU mip generation: the levels the heap uploads under each linearly
//! filtered texture, box-filtered in linear light.
//!
//! Pure functions of the texels: no device, so they are tested on the CPU.

/// Mip levels of a `width × height` image: down to 1 × 1.
pub fn mip_level_count(width: u32, height: u32) -> u32 {
    u32::BITS - width.max(height).max(1).leading_zeros()
}

/// One level of a mip chain.
#[derive(Clone, Debug, PartialEq)]
pub struct MipLevel {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Tightly packed RGBA8 rows.
    pub pixels: Vec<u8>,
}

/// The full mip chain of an RGBA8 image, level 0 (a copy of `pixels`)
/// first, each level a 2 × 2 box filter of the one above (edges clamped for
/// odd sizes). Colour channels of sRGB images are averaged in linear light
/// and encoded again, so a chequerboard fades to its true mean, not a darker
/// grey; alpha is averaged as stored.
pub fn mip_chain(pixels: &[u8], width: u32, height: u32, srgb: bool) -> Vec<MipLevel> {
    let decode: Vec<f32> = (0..256u32)
        .map(|v| {
            let c = v as f32 / 255.0;
            if !srgb {
                c
            } else if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        })
        .collect();
    let encode = |linear: f32| -> u8 {
        let c = linear.clamp(0.0, 1.0);
        let stored = if !srgb {
            c
        } else if c <= 0.0031308 {
            c * 12.92
        } else {
            1.055 * c.powf(1.0 / 2.4) - 0.055
        };
        (stored * 255.0).round() as u8
    };
    let mut levels = vec![MipLevel { width, height, pixels: pixels.to_vec() }];
    while let Some(above) = levels.last().filter(|l| l.width > 1 || l.height > 1) {
        let (w, h) = ((above.width / 2).max(1), (above.height / 2).max(1));
        let texel = |x: u32, y: u32| {
            let i = (y.min(above.height - 1) as usize * above.width as usize + x.min(above.width - 1) as usize) * 4;
            &above.pixels[i..i + 4]
        };
        let mut out = Vec::with_capacity(w as usize * h as usize * 4);
        for y in 0..h {
            for x in 0..w {
                let quad = [
                    texel(2 * x, 2 * y),
                    texel(2 * x + 1, 2 * y),
                    texel(2 * x, 2 * y + 1),
                    texel(2 * x + 1, 2 * y + 1),
                ];
                for c in 0..3 {
                    out.push(encode(quad.iter().map(|t| decode[t[c] as usize]).sum::<f32>() / 4.0));
                }
                out.push((quad.iter().map(|t| t[3] as u32).sum::<u32>() as f32 / 4.0).round() as u8);
            }
        }
        levels.push(MipLevel { width: w, height: h, pixels: out });
    }
    levels
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mip_chains_halve_down_to_one_texel() {
        assert_eq!(mip_level_count(1, 1), 1);
        assert_eq!(mip_level_count(256, 256), 9);
        assert_eq!(mip_level_count(5, 3), 3);
        let sizes: Vec<_> = mip_chain(&[0; 5 * 3 * 4], 5, 3, true).iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, vec![(5, 3), (2, 1), (1, 1)]);
        // Thin images halve along their long side until both are 1.
        let tall: Vec<_> = mip_chain(&[0; 4 * 4], 1, 4, false).iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(tall, vec![(1, 4), (1, 2), (1, 1)]);
        let wide: Vec<_> = mip_chain(&[0; 4 * 4], 4, 1, false).iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(wide, vec![(4, 1), (2, 1), (1, 1)]);
    }

    /// A black-and-white sRGB chequerboard averages to linear 0.5, which is
    /// sRGB 188, not the 128 a naive average of stored bytes gives; a linear
    /// (non-colour) texture averages its stored values.
    #[test]
    fn srgb_mips_average_in_linear_light() {
        let checker: Vec<u8> =
            [0u8, 255, 255, 0].iter().flat_map(|&v| [v, v, v, if v == 0 { 100 } else { 200 }]).collect();
        let srgb = mip_chain(&checker, 2, 2, true);
        assert_eq!(srgb[1].pixels, vec![188, 188, 188, 150]);
        let linear = mip_chain(&checker, 2, 2, false);
        assert_eq!(linear[1].pixels, vec![128, 128, 128, 150]);
    }

    /// Decoding and encoding are inverse: a flat mid-grey keeps its stored
    /// value down the whole chain in either colour space.
    #[test]
    fn flat_textures_keep_their_value_down_the_chain() {
        let flat = [128u8, 5, 200, 77].repeat(4 * 4);
        for srgb in [true, false] {
            for level in mip_chain(&flat, 4, 4, srgb) {
                assert!(level.pixels.chunks(4).all(|t| t == [128, 5, 200, 77]), "srgb {srgb}: {:?}", level.pixels);
            }
        }
    }

    /// Each texel of a level is the mean of its own 2 × 2 block above:
    /// an 8 × 8 image whose texels all differ checks the indexing.
    #[test]
    fn each_mip_texel_averages_its_own_block() {
        let value = |x: u32, y: u32| (x * 20 + y * 3) as u8;
        let pixels: Vec<u8> = (0..8).flat_map(|y| (0..8).flat_map(move |x| [value(x, y), 0, 0, 255])).collect();
        let chain = mip_chain(&pixels, 8, 8, false);
        for y in 0..4u32 {
            for x in 0..4u32 {
                let sum: u32 = [(0, 0), (1, 0), (0, 1), (1, 1)]
                    .iter()
                    .map(|(dx, dy)| u32::from(value(2 * x + dx, 2 * y + dy)))
                    .sum();
                let expected = (sum as f32 / 4.0).round() as u8;
                let got = chain[1].pixels[((y * 4 + x) * 4) as usize];
                assert!(got.abs_diff(expected) <= 1, "level 1 ({x}, {y}): {got}, expected {expected}");
            }
        }
    }

    /// Each of the four texels of a block counts once: a single bright
    /// texel at each position of a 2 × 2 block, in turn, gives a quarter of
    /// its value to that block's texel below and nothing to the others.
    #[test]
    fn each_corner_of_a_block_counts_once() {
        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            // 4 × 4, so an index off by a row or column lands in another block.
            let mut pixels = [0u8, 0, 0, 0].repeat(16);
            let (x, y) = (2 + dx, dy);
            pixels[(y * 4 + x) * 4] = 200;
            pixels[(y * 4 + x) * 4 + 3] = 200;
            let level = &mip_chain(&pixels, 4, 4, false)[1];
            let expected = [0, 0, 0, 0, 50, 0, 0, 50, 0, 0, 0, 0, 0, 0, 0, 0];
            assert_eq!(level.pixels, expected, "bright texel at ({x}, {y})");
        }
    }
}
