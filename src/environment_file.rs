//! Environments from files: an equirectangular Radiance `.hdr` image as an
//! [`Environment`] for image-based lighting.

use std::path::{Path, PathBuf};

use oxygen_core::{Environment, EquirectImage};
use thiserror::Error;

/// The largest side an environment image may have (a 16k × 8k panorama is
/// 1.5 GiB of f32 texels; larger files are refused before decoding).
pub const MAX_ENVIRONMENT_SIDE: u32 = 16_384;

/// Why an environment file could not be loaded. Every variant names the file.
#[derive(Debug, Error)]
pub enum EnvironmentFileError {
    /// The file could not be read or decoded.
    #[error("{path}: {reason}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// Its dimensions pass [`MAX_ENVIRONMENT_SIDE`] or are zero.
    #[error("{path}: an environment of {width} × {height} (each side 1 to {MAX_ENVIRONMENT_SIDE})")]
    Size {
        /// The file.
        path: PathBuf,
        /// Width in the header.
        width: u32,
        /// Height in the header.
        height: u32,
    },
}

/// Loads an equirectangular environment from a Radiance `.hdr` file (or a
/// PNG or JPEG panorama, whose 8- or 16-bit texels are taken as sRGB and
/// converted to linear radiance in [0, 1]). The header's size is checked
/// before the texels are decoded.
pub fn load_hdr_environment(path: impl AsRef<Path>) -> Result<Environment, EnvironmentFileError> {
    let path = path.as_ref();
    let _span = tracing::info_span!("load_hdr_environment", path = %path.display()).entered();
    let read = |reason: String| EnvironmentFileError::Read { path: path.to_owned(), reason };
    let reader = image::ImageReader::open(path)
        .map_err(|e| read(e.to_string()))?
        .with_guessed_format()
        .map_err(|e| read(e.to_string()))?;
    let (width, height) = image::ImageReader::open(path)
        .and_then(|r| r.with_guessed_format())
        .map_err(|e| read(e.to_string()))?
        .into_dimensions()
        .map_err(|e| read(e.to_string()))?;
    if width == 0 || height == 0 || width > MAX_ENVIRONMENT_SIDE || height > MAX_ENVIRONMENT_SIDE {
        return Err(EnvironmentFileError::Size { path: path.to_owned(), width, height });
    }
    let decoded = reader.decode().map_err(|e| read(e.to_string()))?;
    // Float images hold linear radiance; integer ones hold sRGB-encoded
    // colour, which `into_rgb32f` only rescales.
    let encoded = !matches!(decoded, image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_));
    let image = decoded.into_rgb32f();
    let linear = |c: f32| if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) };
    let texels = image
        .pixels()
        .map(|p| {
            let c = oxygen_core::glam::Vec3::from(p.0);
            if encoded { oxygen_core::glam::Vec3::new(linear(c.x), linear(c.y), linear(c.z)) } else { c }
        })
        .collect();
    let image = EquirectImage::new(width, height, texels).map_err(|e| read(e.to_string()))?;
    Ok(Environment::Image(image))
}
