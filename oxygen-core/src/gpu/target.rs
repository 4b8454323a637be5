//! Offscreen colour and depth targets for one view.

/// The textures a view renders into.
///
/// Shading writes linear radiance into the HDR target (`Rgba16Float`); the
/// tone-map step writes the displayable result into the colour target
/// (`Rgba8UnormSrgb`: shaders write linear values, the hardware encodes
/// sRGB). Depth is `Depth32Float`, reverse-Z: cleared to 0, tested with
/// `Greater`.
pub struct ViewTargets {
    /// Linear HDR colour (render attachment, sampled by the tone map).
    pub hdr: wgpu::Texture,
    /// Default view of `hdr`.
    pub hdr_view: wgpu::TextureView,
    /// Colour texture (render attachment, copy source, sampled).
    pub color: wgpu::Texture,
    /// Default view of `color`.
    pub color_view: wgpu::TextureView,
    /// Depth texture (render attachment, sampled).
    pub depth: wgpu::Texture,
    /// Default view of `depth`.
    pub depth_view: wgpu::TextureView,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl ViewTargets {
    /// Format of the HDR target.
    pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
    /// Colour format of every view's displayable target.
    pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
    /// Depth format of every view target.
    pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

    /// Creates targets of `width × height` (both must be non-zero and within
    /// the device's `max_texture_dimension_2d`; callers validate).
    pub fn new(device: &wgpu::Device, width: u32, height: u32, label: &str) -> Self {
        let size = wgpu::Extent3d { width, height, depth_or_array_layers: 1 };
        let make = |format, usage, suffix: &str| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(&format!("{label} {suffix}")),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let color = make(
            Self::COLOR_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::TEXTURE_BINDING,
            "colour",
        );
        // Copy source too: reflection probes copy their faces' HDR images.
        let hdr = make(
            Self::HDR_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            "hdr",
        );
        let depth = make(
            Self::DEPTH_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            "depth",
        );
        ViewTargets {
            hdr_view: hdr.create_view(&Default::default()),
            hdr,
            color_view: color.create_view(&Default::default()),
            depth_view: depth.create_view(&Default::default()),
            color,
            depth,
            width,
            height,
        }
    }
}
