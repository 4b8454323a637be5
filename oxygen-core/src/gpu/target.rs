//! Offscreen colour and depth targets for one view.

/// The textures a view renders into.
///
/// Shading writes linear radiance into the HDR target (`Rgba16Float`); the
/// tone-map step writes the displayable result into the colour target
/// (`Rgba8UnormSrgb`: shaders write linear values, the hardware encodes
/// sRGB). Depth is `Depth32Float`, reverse-Z: cleared to 0, tested with
/// `Greater`. Depth-only views (shadow maps) have no colour half at all.
pub struct ViewTargets {
    /// HDR and display colour; `None` for a depth-only view.
    pub color: Option<ColorTargets>,
    /// Depth texture (render attachment, sampled, copy source).
    pub depth: wgpu::Texture,
    /// Default view of `depth`.
    pub depth_view: wgpu::TextureView,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// The colour half of a view's targets.
pub struct ColorTargets {
    /// Linear HDR colour (render attachment, sampled by the tone map, copy
    /// source for reflection probes).
    pub hdr: wgpu::Texture,
    /// Default view of `hdr`.
    pub hdr_view: wgpu::TextureView,
    /// Displayable colour (render attachment, copy source, sampled).
    pub color: wgpu::Texture,
    /// Default view of `color`.
    pub color_view: wgpu::TextureView,
}

impl ViewTargets {
    /// Format of the HDR target.
    pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
    /// Colour format of every view's displayable target.
    pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
    /// Depth format of every view target.
    pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

    /// Creates colour and depth targets of `width × height` (both must be
    /// non-zero and within the device's `max_texture_dimension_2d`; callers
    /// validate).
    pub fn new(device: &wgpu::Device, width: u32, height: u32, label: &str) -> Self {
        Self::create(device, width, height, label, true)
    }

    /// Creates only the depth target: what a shadow view renders. A 2048²
    /// shadow view saves the 48 MiB its colour targets would take.
    pub fn depth_only(device: &wgpu::Device, width: u32, height: u32, label: &str) -> Self {
        Self::create(device, width, height, label, false)
    }

    /// Bytes of GPU memory the targets of a `width × height` view take:
    /// depth (4 bytes a pixel), plus HDR (8) and display colour (4) unless
    /// the view is depth-only. Known before anything is allocated, so a
    /// renderer can refuse an oversized view instead of trying.
    pub fn bytes_for(width: u32, height: u32, with_color: bool) -> u64 {
        let per_pixel = if with_color { 4 + 8 + 4 } else { 4 };
        u64::from(width) * u64::from(height) * per_pixel
    }

    /// Bytes these targets take ([`ViewTargets::bytes_for`]).
    pub fn bytes(&self) -> u64 {
        Self::bytes_for(self.width, self.height, self.color.is_some())
    }

    /// True when the targets are `width × height` and have colour exactly
    /// when `with_color` says so.
    pub fn fits(&self, width: u32, height: u32, with_color: bool) -> bool {
        self.width == width && self.height == height && self.color.is_some() == with_color
    }

    fn create(device: &wgpu::Device, width: u32, height: u32, label: &str, with_color: bool) -> Self {
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
        let color = with_color.then(|| {
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
            ColorTargets {
                hdr_view: hdr.create_view(&Default::default()),
                hdr,
                color_view: color.create_view(&Default::default()),
                color,
            }
        });
        let depth = make(
            Self::DEPTH_FORMAT,
            // Copy source: local-light shadow maps are copied into the atlas.
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            "depth",
        );
        ViewTargets { color, depth_view: depth.create_view(&Default::default()), depth, width, height }
    }
}
