//! Texture images: RGBA8 pixels an asset (or glTF) provides for materials.

use thiserror::Error;

/// How a texture's bytes encode colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum ColorSpace {
    /// sRGB-encoded colour (base colour, emissive): decoded when sampled.
    Srgb,
    /// Linear data (normals, metallic-roughness).
    Linear,
}

/// How texture coordinates outside `[0, 1]` are treated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Wrap {
    /// Tile.
    #[default]
    Repeat,
    /// Clamp to the edge texel.
    ClampToEdge,
    /// Tile, mirroring every other tile.
    MirroredRepeat,
}

/// How texels are filtered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Filter {
    /// Bilinear.
    #[default]
    Linear,
    /// Nearest texel.
    Nearest,
}

/// How a texture is sampled: a wrap mode per axis and a filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Sampling {
    /// Wrap mode along u (glTF `wrapS`).
    pub wrap_u: Wrap,
    /// Wrap mode along v (glTF `wrapT`).
    pub wrap_v: Wrap,
    /// Filter.
    pub filter: Filter,
}

impl Wrap {
    /// The mode's number in the renderer's sampler table and location
    /// records: repeat 0, clamp 1, mirrored repeat 2.
    pub fn index(self) -> u32 {
        match self {
            Wrap::Repeat => 0,
            Wrap::ClampToEdge => 1,
            Wrap::MirroredRepeat => 2,
        }
    }
}

impl Sampling {
    /// The same wrap mode on both axes.
    pub fn new(wrap: Wrap, filter: Filter) -> Self {
        Sampling { wrap_u: wrap, wrap_v: wrap, filter }
    }

    /// Index into the renderer's sampler table (wrap × filter, 6 entries):
    /// the entry that wraps both axes like u. Where v wraps differently,
    /// the shader wraps v itself (see `oxygen_bindless`'s texture module).
    pub fn table_index(self) -> u32 {
        self.wrap_u.index() * 2 + u32::from(self.filter == Filter::Nearest)
    }
}

/// What was wrong with a texture handed to [`TextureImage::new`].
#[derive(Debug, Error, PartialEq)]
pub enum TextureError {
    /// Zero width or height, or a side above 16 384 texels.
    #[error("texture '{name}': size {width}x{height} is outside 1..=16384")]
    BadSize {
        /// Texture name.
        name: String,
        /// Width.
        width: u32,
        /// Height.
        height: u32,
    },
    /// The pixel buffer does not hold `width * height * 4` bytes.
    #[error("texture '{name}': {got} bytes for {width}x{height} RGBA8 (need {need})")]
    WrongLength {
        /// Texture name.
        name: String,
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// Bytes given.
        got: usize,
        /// Bytes needed.
        need: usize,
    },
}

/// An RGBA8 image, validated.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureImage {
    name: String,
    width: u32,
    height: u32,
    color_space: ColorSpace,
    sampling: Sampling,
    pixels: Vec<u8>,
}

impl TextureImage {
    /// Largest side accepted.
    pub const MAX_SIDE: u32 = 16_384;

    /// Validates and builds an image from tightly packed RGBA8 rows.
    pub fn new(
        name: impl Into<String>,
        width: u32,
        height: u32,
        color_space: ColorSpace,
        pixels: Vec<u8>,
    ) -> Result<Self, TextureError> {
        let name = name.into();
        if width == 0 || height == 0 || width > Self::MAX_SIDE || height > Self::MAX_SIDE {
            return Err(TextureError::BadSize { name, width, height });
        }
        let need = width as usize * height as usize * 4;
        if pixels.len() != need {
            return Err(TextureError::WrongLength { name, width, height, got: pixels.len(), need });
        }
        Ok(TextureImage { name, width, height, color_space, sampling: Sampling::default(), pixels })
    }

    /// A `cells × cells` checkerboard of `size × size` texels in two sRGB colours.
    pub fn checker(name: impl Into<String>, size: u32, cells: u32, a: [u8; 4], b: [u8; 4]) -> Self {
        let size = size.clamp(1, Self::MAX_SIDE);
        let cell = (size / cells.max(1)).max(1);
        let mut pixels = Vec::with_capacity(size as usize * size as usize * 4);
        for y in 0..size {
            for x in 0..size {
                pixels.extend_from_slice(if (x / cell + y / cell).is_multiple_of(2) { &a } else { &b });
            }
        }
        // Size and length are consistent by construction.
        TextureImage::new(name, size, size, ColorSpace::Srgb, pixels).expect("checker is well-formed")
    }

    /// This image sampled another way.
    pub fn with_sampling(self, sampling: Sampling) -> Self {
        TextureImage { sampling, ..self }
    }

    /// How it is sampled.
    pub fn sampling(&self) -> Sampling {
        self.sampling
    }

    /// Name for logs and errors.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Width in texels.
    pub fn width(&self) -> u32 {
        self.width
    }
    /// Height in texels.
    pub fn height(&self) -> u32 {
        self.height
    }
    /// Colour space of the bytes.
    pub fn color_space(&self) -> ColorSpace {
        self.color_space
    }
    /// RGBA8 texels, row-major, tightly packed.
    pub fn pixels(&self) -> &[u8] {
        &self.pixels
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The renderer's sampler table and location records index by these
    /// numbers, so they are part of the contract, not an implementation detail.
    #[test]
    fn wrap_modes_number_repeat_clamp_mirror_as_0_1_2() {
        assert_eq!(Wrap::Repeat.index(), 0);
        assert_eq!(Wrap::ClampToEdge.index(), 1);
        assert_eq!(Wrap::MirroredRepeat.index(), 2);
    }

    #[test]
    fn the_sampler_table_index_is_wrap_times_two_plus_nearest_and_ignores_wrap_v() {
        let expected = [
            (Wrap::Repeat, Filter::Linear, 0),
            (Wrap::Repeat, Filter::Nearest, 1),
            (Wrap::ClampToEdge, Filter::Linear, 2),
            (Wrap::ClampToEdge, Filter::Nearest, 3),
            (Wrap::MirroredRepeat, Filter::Linear, 4),
            (Wrap::MirroredRepeat, Filter::Nearest, 5),
        ];
        for (wrap, filter, index) in expected {
            assert_eq!(Sampling::new(wrap, filter).table_index(), index, "{wrap:?} {filter:?}");
            // v wrapping differently is the shader's business: the entry follows u.
            let mixed = Sampling { wrap_u: wrap, wrap_v: Wrap::MirroredRepeat, filter };
            assert_eq!(mixed.table_index(), index, "{wrap:?} {filter:?} with mirrored v");
        }
    }

    /// 5 texels in cells of 5 / 2 = 2: the last column and row start a third
    /// cell that continues the alternation.
    #[test]
    fn a_checker_alternates_cells_of_size_over_cells_texels_up_to_the_last_texel() {
        let (a, b) = ([255, 0, 0, 255], [0, 0, 255, 255]);
        let image = TextureImage::checker("checker", 5, 2, a, b);
        assert_eq!((image.width(), image.height()), (5, 5));
        assert_eq!(image.color_space(), ColorSpace::Srgb);
        let rows = ["aabba", "aabba", "bbaab", "bbaab", "aabba"];
        for (y, row) in rows.iter().enumerate() {
            for (x, cell) in row.chars().enumerate() {
                let at = (y * 5 + x) * 4;
                let want = if cell == 'a' { a } else { b };
                assert_eq!(image.pixels()[at..at + 4], want, "texel ({x}, {y})");
            }
        }
    }

    #[test]
    fn an_image_reports_what_it_was_built_from() {
        let pixels: Vec<u8> = (0..3 * 2 * 4).collect();
        let image = TextureImage::new("bricks", 3, 2, ColorSpace::Linear, pixels.clone()).expect("valid image");
        assert_eq!(image.name(), "bricks");
        assert_eq!((image.width(), image.height()), (3, 2));
        assert_eq!(image.color_space(), ColorSpace::Linear);
        assert_eq!(image.pixels(), pixels.as_slice());
        assert_eq!(image.sampling(), Sampling::default());
    }

    #[test]
    fn with_sampling_replaces_the_sampling_and_keeps_the_texels() {
        let image = TextureImage::checker("checker", 4, 2, [0; 4], [255; 4]);
        let sampling = Sampling { wrap_u: Wrap::ClampToEdge, wrap_v: Wrap::MirroredRepeat, filter: Filter::Nearest };
        let resampled = image.clone().with_sampling(sampling);
        assert_eq!(resampled.sampling(), sampling);
        assert_eq!(resampled.pixels(), image.pixels());
        assert_eq!(resampled.name(), "checker");
    }
}
