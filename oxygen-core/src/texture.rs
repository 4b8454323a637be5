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
