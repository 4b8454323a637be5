//! Offscreen colour and depth targets for one view.

use crate::{LabelSet, LabelTargets};

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
    /// Depth texture (render attachment, sampled, copy source); for a
    /// shadow view rendering into an atlas, the whole atlas.
    pub depth: wgpu::Texture,
    /// The view of `depth` passes render into: the whole texture, or the
    /// view's layer of the atlas.
    pub depth_view: wgpu::TextureView,
    /// The layer of `depth` the view renders (0 unless it is an atlas).
    pub depth_layer: u32,
    /// Whether `depth` belongs to these targets (false for an atlas layer);
    /// only owned textures count in [`ViewTargets::bytes`].
    pub owns_depth: bool,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Multisampled colour and depth the mesh passes render into when the
    /// view asks for anti-aliasing ([`Msaa`]); the colour resolves into
    /// `color.hdr` at the end of each pass. `depth` is then not written.
    pub msaa: Option<MsaaTargets>,
    /// Where the view's rectangle lies when it is a tile of a
    /// [`TileAtlas`] (its textures are the atlas's, shared with the other
    /// cameras of its batch); `None` when the view covers its textures.
    pub tile: Option<Tile>,
    /// The per-pixel label planes the shading (or labels) pass writes,
    /// when the view asked for labels.
    pub labels: Option<LabelTargets>,
    /// A tile whose page holds other tiles' images to keep this frame (a
    /// camera of its batch that does not render): the page's passes load
    /// it and clear this view's tile alone. Set by the renderer each frame.
    pub page_kept: bool,
    /// Deferred shading's textures, when the view is a tile of an atlas
    /// made for it ([`TileAtlas::new`]).
    pub deferred: Option<DeferredTargets>,
}

/// What deferred shading adds to a page of a [`TileAtlas`]: the
/// visibility pass's target, and a view of the page's display colour the
/// shading pass stores into. Such a page's colour texture is `Rgba8Unorm`
/// (a storage texture cannot be sRGB), viewed as sRGB
/// ([`ViewTargets::COLOR_FORMAT`]) by everything else, so the compute pass
/// writes the sRGB bytes itself and no copy follows (a copy from a separate
/// image cost an H200 4.2 ms of a 256-view field's 56, docs/performance.md).
#[derive(Clone)]
pub struct DeferredTargets {
    /// Each pixel's surface id ([`DeferredTargets::VISIBILITY_FORMAT`]):
    /// the draw's index in the view's draws plus one (0 for none) in the
    /// high bits, the vertex that starts its triangle in the low
    /// `surface_vertex_bits` (`RendererConstants`).
    pub visibility: wgpu::Texture,
    /// Its default view.
    pub visibility_view: wgpu::TextureView,
    /// The page's display colour as [`DeferredTargets::SHADED_FORMAT`],
    /// for the shading pass to store sRGB-encoded bytes into.
    pub color_storage_view: wgpu::TextureView,
}

impl DeferredTargets {
    /// The visibility target's format.
    pub const VISIBILITY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
    /// The format of the page's colour texture and of the shading pass's
    /// view of it.
    pub const SHADED_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
    /// Bytes a pixel of the visibility target takes (the colour is the
    /// page's own).
    pub const BYTES_PER_PIXEL: u64 = 4;

    /// The textures for a page of `size` whose display colour is `color`
    /// (made by [`DeferredTargets::color_texture`]).
    pub fn new(device: &wgpu::Device, size: wgpu::Extent3d, color: &wgpu::Texture, label: &str) -> Self {
        let visibility = texture_2d(
            device,
            &format!("{label} visibility"),
            size,
            1,
            Self::VISIBILITY_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        DeferredTargets {
            visibility_view: visibility.create_view(&Default::default()),
            color_storage_view: color
                .create_view(&wgpu::TextureViewDescriptor { format: Some(Self::SHADED_FORMAT), ..Default::default() }),
            visibility,
        }
    }

    /// A page's display colour that deferred shading can store into:
    /// `Rgba8Unorm` with `usage` and storage, viewable as sRGB.
    pub fn color_texture(
        device: &wgpu::Device,
        size: wgpu::Extent3d,
        usage: wgpu::TextureUsages,
        label: &str,
    ) -> wgpu::Texture {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: Self::SHADED_FORMAT,
            usage: usage | wgpu::TextureUsages::STORAGE_BINDING,
            view_formats: &[ViewTargets::COLOR_FORMAT],
        })
    }
}

/// A view's rectangle in a [`TileAtlas`]: `width × height` pixels of
/// [`ViewTargets`] starting at (`x`, `y`) of page `page`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Tile {
    /// Left edge in pixels.
    pub x: u32,
    /// Top edge in pixels.
    pub y: u32,
    /// The page the tile is on.
    pub page: u32,
    /// The tile's index in the atlas (page by page, row by row).
    pub index: u32,
}

/// The shared targets of a batch of equally sized views: pages of tiles,
/// one tile per view, so that every view of a batch draws into one render
/// pass per page instead of targets of its own. Each page is a set of 2D
/// textures of its own (not a layer of an array: GL can sample and render
/// a 2D texture, not a single layer of an array as one): display colour
/// (`Rgba8UnormSrgb`, or `Rgba8Unorm` viewed as sRGB with deferred
/// shading's targets) and depth (`Depth32Float`, reverse-Z) always, the
/// HDR colour, the labels and deferred shading's visibility target only
/// when [`TileAtlas::new`] is asked for them.
pub struct TileAtlas {
    /// Pixels of one tile.
    pub tile_size: (u32, u32),
    /// The largest page side asked for ([`TileAtlas::new`]), if any.
    pub max_side: Option<u32>,
    /// Tiles across one page.
    pub columns: u32,
    /// Tiles down one page.
    pub rows: u32,
    /// The pages, in tile order.
    pub pages: Vec<AtlasPage>,
}

/// One page of a [`TileAtlas`]: its textures and their render views.
pub struct AtlasPage {
    /// Display colour.
    pub color: wgpu::Texture,
    /// Linear HDR colour, when asked for.
    pub hdr: Option<wgpu::Texture>,
    /// Depth.
    pub depth: wgpu::Texture,
    /// Instance ids and normals, when asked for.
    pub labels: Option<LabelTargets>,
    /// Deferred shading's textures, when asked for.
    pub deferred: Option<DeferredTargets>,
    color_view: wgpu::TextureView,
    hdr_view: Option<wgpu::TextureView>,
    depth_view: wgpu::TextureView,
}

impl TileAtlas {
    /// The layout of `tiles` tiles of `tile_size` pixels on pages at most
    /// `max_side` pixels square: (columns, rows, pages). `None` when a tile
    /// is empty or larger than `max_side`, or when there are no tiles.
    pub fn layout(tile_size: (u32, u32), tiles: u32, max_side: u32) -> Option<(u32, u32, u32)> {
        let (w, h) = tile_size;
        if w == 0 || h == 0 || w > max_side || h > max_side || tiles == 0 {
            return None;
        }
        let (max_columns, max_rows) = (max_side / w, max_side / h);
        // As square a page as the tiles need (columns first), no larger
        // than the limit allows: a batch smaller than a page takes one page
        // just big enough.
        let columns = (tiles as f64).sqrt().ceil().min(f64::from(max_columns)).max(1.0) as u32;
        let rows = tiles.div_ceil(columns).min(max_rows).max(1);
        let pages = tiles.div_ceil(columns * rows);
        Some((columns, rows, pages))
    }

    /// Bytes the atlas of [`TileAtlas::layout`] takes: 4 (depth) + 4
    /// (colour) bytes a pixel, plus `hdr_bytes_per_pixel` with HDR,
    /// the label planes' bytes ([`LabelSet::bytes_per_pixel`]) and
    /// deferred shading's ([`DeferredTargets::BYTES_PER_PIXEL`]). Known before anything
    /// is allocated, so a renderer can refuse a batch that does not fit its
    /// target budget.
    pub fn bytes_for(
        tile_size: (u32, u32),
        layout: (u32, u32, u32),
        hdr_bytes_per_pixel: Option<u64>,
        labels: LabelSet,
        deferred: bool,
    ) -> u64 {
        let (columns, rows, pages) = layout;
        let pixels = u64::from(columns * tile_size.0) * u64::from(rows * tile_size.1) * u64::from(pages);
        let deferred = if deferred { DeferredTargets::BYTES_PER_PIXEL } else { 0 };
        pixels * (8 + hdr_bytes_per_pixel.unwrap_or(0) + labels.bytes_per_pixel() + deferred)
    }

    /// Allocates the atlas for `tiles` tiles of `tile_size` on pages no
    /// larger than `max_side` (and the device's limit; see
    /// [`TileAtlas::layout`]), with an HDR colour texture of `hdr_format`
    /// when given, the label planes of `labels` and deferred shading's
    /// textures when `deferred`. `None` when the tiles do not fit the device.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        device: &wgpu::Device,
        tile_size: (u32, u32),
        tiles: u32,
        hdr_format: Option<HdrFormat>,
        labels: LabelSet,
        deferred: bool,
        max_side: Option<u32>,
        label: &str,
    ) -> Option<Self> {
        let limit = device.limits().max_texture_dimension_2d;
        let side = max_side.map_or(limit, |s| s.min(limit));
        let (columns, rows, pages) = Self::layout(tile_size, tiles, side)?;
        let size =
            wgpu::Extent3d { width: columns * tile_size.0, height: rows * tile_size.1, depth_or_array_layers: 1 };
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC;
        let pages = (0..pages)
            .map(|page| {
                let name = |what: &str| format!("{label} {what} page {page}");
                // Deferred shading stores into the colour: unorm, viewed as sRGB.
                let color = if deferred {
                    DeferredTargets::color_texture(device, size, usage, &name("colour"))
                } else {
                    texture_2d(device, &name("colour"), size, 1, ViewTargets::COLOR_FORMAT, usage)
                };
                let hdr = hdr_format.map(|f| texture_2d(device, &name("hdr"), size, 1, f.texture_format(), usage));
                let depth = texture_2d(device, &name("depth"), size, 1, ViewTargets::DEPTH_FORMAT, usage);
                let labels = (!labels.is_empty())
                    .then(|| LabelTargets::new(device, size.width, size.height, labels, &name("labels")));
                let deferred = deferred.then(|| DeferredTargets::new(device, size, &color, &name("deferred")));
                AtlasPage {
                    deferred,
                    // sRGB cannot be stored into: the view leaves storage out.
                    color_view: color.create_view(&wgpu::TextureViewDescriptor {
                        format: Some(ViewTargets::COLOR_FORMAT),
                        usage: Some(color.usage() - wgpu::TextureUsages::STORAGE_BINDING),
                        ..Default::default()
                    }),
                    hdr_view: hdr.as_ref().map(|t| t.create_view(&Default::default())),
                    depth_view: depth.create_view(&Default::default()),
                    color,
                    hdr,
                    depth,
                    labels,
                }
            })
            .collect();
        Some(TileAtlas { tile_size, max_side, columns, rows, pages })
    }

    /// Page size in pixels.
    pub fn page_size(&self) -> (u32, u32) {
        (self.columns * self.tile_size.0, self.rows * self.tile_size.1)
    }

    /// Whether the pages have HDR colour.
    pub fn has_hdr(&self) -> bool {
        self.pages.first().is_some_and(|p| p.hdr.is_some())
    }

    /// Whether the pages have deferred shading's textures.
    pub fn has_deferred(&self) -> bool {
        self.pages.first().is_some_and(|p| p.deferred.is_some())
    }

    /// The label planes the pages have.
    pub fn labels(&self) -> LabelSet {
        self.pages.first().and_then(|p| p.labels.as_ref()).map_or(LabelSet::NONE, LabelTargets::set)
    }

    /// Tiles the atlas holds.
    pub fn capacity(&self) -> u32 {
        self.columns * self.rows * self.pages.len() as u32
    }

    /// Bytes the atlas takes.
    pub fn bytes(&self) -> u64 {
        let hdr = self
            .pages
            .first()
            .and_then(|p| p.hdr.as_ref())
            .map(|t| u64::from(t.format().block_copy_size(None).unwrap_or(8)));
        let layout = (self.columns, self.rows, self.pages.len() as u32);
        Self::bytes_for(self.tile_size, layout, hdr, self.labels(), self.has_deferred())
    }

    /// Where tile `index` lies, or `None` past the capacity.
    pub fn tile(&self, index: u32) -> Option<Tile> {
        if index >= self.capacity() {
            return None;
        }
        let per_page = self.columns * self.rows;
        let (page, within) = (index / per_page, index % per_page);
        Some(Tile {
            x: (within % self.columns) * self.tile_size.0,
            y: (within / self.columns) * self.tile_size.1,
            page,
            index,
        })
    }

    /// The targets of the view drawn into tile `index`: its page's textures
    /// (owned by the atlas, so they count nothing in
    /// [`ViewTargets::bytes`]) and the tile's rectangle; `None` past the
    /// capacity.
    pub fn view_targets(&self, index: u32) -> Option<ViewTargets> {
        let tile = self.tile(index)?;
        let page = &self.pages[tile.page as usize];
        // Without an HDR texture the display colour stands in for it: only
        // passes that tone-map in place write colour then.
        let (hdr, hdr_view) = match (&page.hdr, &page.hdr_view) {
            (Some(t), Some(v)) => (t.clone(), v.clone()),
            _ => (page.color.clone(), page.color_view.clone()),
        };
        Some(ViewTargets {
            color: Some(ColorTargets {
                hdr,
                hdr_view,
                hdr_layer: 0,
                color: Some(page.color.clone()),
                color_view: Some(page.color_view.clone()),
            }),
            depth: page.depth.clone(),
            depth_view: page.depth_view.clone(),
            depth_layer: 0,
            owns_depth: false,
            width: self.tile_size.0,
            height: self.tile_size.1,
            msaa: None,
            tile: Some(tile),
            labels: page.labels.clone(),
            page_kept: false,
            deferred: page.deferred.clone(),
        })
    }
}

/// Samples per pixel of a view's mesh passes: the anti-aliasing knob
/// (multisample anti-aliasing; time in `examples/msaa_bench.rs`, edge error
/// against a supersampled render in `tests/msaa.rs`, both in
/// docs/performance.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Msaa {
    /// One sample per pixel: aliased edges, no extra memory or time.
    #[default]
    Off,
    /// Two samples per pixel.
    X2,
    /// Four samples per pixel.
    X4,
}

impl Msaa {
    /// Samples per pixel.
    pub fn samples(self) -> u32 {
        match self {
            Msaa::Off => 1,
            Msaa::X2 => 2,
            Msaa::X4 => 4,
        }
    }

    /// The setting of `samples` samples per pixel (1, 2 or 4).
    pub fn from_samples(samples: u32) -> Option<Msaa> {
        match samples {
            1 => Some(Msaa::Off),
            2 => Some(Msaa::X2),
            4 => Some(Msaa::X4),
            _ => None,
        }
    }
}

/// A view's multisampled attachments.
pub struct MsaaTargets {
    /// Samples per pixel (2 or 4).
    pub samples: u32,
    /// Multisampled HDR colour (the HDR target's format).
    pub color: wgpu::Texture,
    /// Its default view.
    pub color_view: wgpu::TextureView,
    /// Multisampled depth (`Depth32Float`).
    pub depth: wgpu::Texture,
    /// Its default view.
    pub depth_view: wgpu::TextureView,
}

/// The colour half of a view's targets.
pub struct ColorTargets {
    /// Linear HDR colour (render attachment, sampled by the tone map); for
    /// a reflection-probe face, the probe's whole cube texture.
    pub hdr: wgpu::Texture,
    /// The view of `hdr` passes render into: the whole texture, or the
    /// face's layer (mip 0) of the probe cube.
    pub hdr_view: wgpu::TextureView,
    /// The layer of `hdr` the view renders (0 unless it is a probe face).
    pub hdr_layer: u32,
    /// Displayable colour (render attachment, copy source, sampled); `None`
    /// for views that are never tone-mapped (probe faces). Its texture
    /// format is [`ViewTargets::COLOR_FORMAT`], or `Rgba8Unorm` on a
    /// deferred atlas page ([`DeferredTargets`]): render and sample it
    /// through `color_view`, whose format is always `COLOR_FORMAT`.
    pub color: Option<wgpu::Texture>,
    /// The view of `color` passes render into and readers sample, in
    /// [`ViewTargets::COLOR_FORMAT`].
    pub color_view: Option<wgpu::TextureView>,
}

impl ColorTargets {
    /// The format passes render `hdr_view` in: the HDR texture's, or
    /// [`ViewTargets::COLOR_FORMAT`] where the display colour stands in
    /// for it (no HDR formats are 8-bit unorm; a deferred atlas page's
    /// colour texture is `Rgba8Unorm`, viewed as sRGB).
    pub fn hdr_format(&self) -> wgpu::TextureFormat {
        match self.hdr.format() {
            wgpu::TextureFormat::Rgba8Unorm => ViewTargets::COLOR_FORMAT,
            format => format,
        }
    }
}

/// The format of a view's HDR target: a speed/memory knob with a measured
/// error (`tests/frame_economy.rs`, `examples/hdr_format_bench.rs`,
/// docs/performance.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum HdrFormat {
    /// Four half floats, 8 bytes a pixel: 11 significant bits per channel.
    #[default]
    Rgba16Float,
    /// Packed unsigned floats, 4 bytes a pixel: 6 mantissa bits for red and
    /// green, 5 for blue, no alpha, no negative values. Half the memory and
    /// bandwidth; smooth gradients show coarser steps (blue most). Needs
    /// `Features::RG11B10UFLOAT_RENDERABLE`.
    Rg11b10Ufloat,
}

impl HdrFormat {
    /// The texture format.
    pub fn texture_format(self) -> wgpu::TextureFormat {
        match self {
            HdrFormat::Rgba16Float => wgpu::TextureFormat::Rgba16Float,
            HdrFormat::Rg11b10Ufloat => wgpu::TextureFormat::Rg11b10Ufloat,
        }
    }

    /// Bytes a pixel.
    pub fn bytes_per_pixel(self) -> u64 {
        match self {
            HdrFormat::Rgba16Float => 8,
            HdrFormat::Rg11b10Ufloat => 4,
        }
    }

    /// The device features rendering into this format needs.
    pub fn required_features(self) -> wgpu::Features {
        match self {
            HdrFormat::Rgba16Float => wgpu::Features::empty(),
            HdrFormat::Rg11b10Ufloat => wgpu::Features::RG11B10UFLOAT_RENDERABLE,
        }
    }
}

impl ViewTargets {
    /// Format of the HDR target by default ([`HdrFormat::Rgba16Float`];
    /// [`ViewTargets::with_hdr_format`] picks another) and of probe cubes.
    pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
    /// Colour format of every view's displayable target.
    pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
    /// Depth format of every view target.
    pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

    /// Creates colour and depth targets of `width × height` (both must be
    /// non-zero and within the device's `max_texture_dimension_2d`; callers
    /// validate).
    pub fn new(device: &wgpu::Device, width: u32, height: u32, label: &str) -> Self {
        Self::with_hdr_format(device, width, height, label, HdrFormat::Rgba16Float)
    }

    /// [`ViewTargets::new`] with an HDR target of `hdr_format` (the device
    /// must have its [`HdrFormat::required_features`]).
    pub fn with_hdr_format(device: &wgpu::Device, width: u32, height: u32, label: &str, hdr_format: HdrFormat) -> Self {
        Self::create(device, width, height, label, Some(hdr_format))
    }

    /// Creates only the depth target: what a shadow view renders. A 2048²
    /// shadow view saves the 48 MiB its colour targets would take.
    pub fn depth_only(device: &wgpu::Device, width: u32, height: u32, label: &str) -> Self {
        Self::create(device, width, height, label, None)
    }

    /// Bytes of GPU memory the targets of a `width × height` view take:
    /// depth (4 bytes a pixel), plus HDR (8) and display colour (4) unless
    /// the view is depth-only. Known before anything is allocated, so a
    /// renderer can refuse an oversized view instead of trying.
    pub fn bytes_for(width: u32, height: u32, with_color: bool) -> u64 {
        Self::bytes_for_format(width, height, with_color.then_some(HdrFormat::Rgba16Float))
    }

    /// [`ViewTargets::bytes_for`] with the HDR target in `hdr_format`
    /// (`None`: depth only): 16 bytes a pixel with `Rgba16Float`, 12 with
    /// `Rg11b10Ufloat`.
    pub fn bytes_for_format(width: u32, height: u32, hdr_format: Option<HdrFormat>) -> u64 {
        let per_pixel = 4 + hdr_format.map_or(0, |f| f.bytes_per_pixel() + 4);
        u64::from(width) * u64::from(height) * per_pixel
    }

    /// [`ViewTargets::bytes_for_format`] with `samples` samples per pixel:
    /// the multisampled colour and depth come on top (`samples` × (HDR
    /// bytes + 4) a pixel).
    pub fn bytes_for_msaa(width: u32, height: u32, hdr_format: Option<HdrFormat>, samples: u32) -> u64 {
        let single = Self::bytes_for_format(width, height, hdr_format);
        match hdr_format {
            Some(f) if samples > 1 => {
                single + u64::from(width) * u64::from(height) * u64::from(samples) * (f.bytes_per_pixel() + 4)
            }
            _ => single,
        }
    }

    /// Bytes of the textures these targets own: a shadow view's atlas
    /// layer, a probe face's cube and a batch camera's tile are counted by
    /// their owners.
    pub fn bytes(&self) -> u64 {
        // A tile's textures are its atlas's, counted there.
        if self.tile.is_some() {
            return 0;
        }
        let pixels = u64::from(self.width) * u64::from(self.height);
        let depth = if self.owns_depth { 4 } else { 0 };
        let hdr_bytes = |c: &ColorTargets| u64::from(c.hdr.format().block_copy_size(None).unwrap_or(8));
        let color = match &self.color {
            Some(c) if c.color.is_some() => hdr_bytes(c) + 4,
            _ => 0,
        };
        let msaa = match (&self.msaa, &self.color) {
            (Some(m), Some(c)) => u64::from(m.samples) * (hdr_bytes(c) + 4),
            _ => 0,
        };
        let labels = self.labels.as_ref().map_or(0, LabelTargets::bytes_per_pixel);
        pixels * (depth + color + msaa + labels)
    }

    /// Samples per pixel of the mesh passes (1 without MSAA).
    pub fn samples(&self) -> u32 {
        self.msaa.as_ref().map_or(1, |m| m.samples)
    }

    /// The depth view mesh passes render into: the multisampled one with
    /// MSAA, else [`ViewTargets::depth_view`].
    pub fn render_depth_view(&self) -> &wgpu::TextureView {
        self.msaa.as_ref().map_or(&self.depth_view, |m| &m.depth_view)
    }

    /// True when the targets are `width × height`, own their textures, have
    /// colour exactly when `with_color` says so, and `samples` samples.
    pub fn fits(&self, width: u32, height: u32, with_color: bool, samples: u32) -> bool {
        self.width == width
            && self.height == height
            && self.owns_depth
            && self.samples() == samples
            && self.color.as_ref().map_or(!with_color, |c| with_color && c.color.is_some())
    }

    /// These targets with multisampled colour and depth of `samples`
    /// samples (2 or 4; the device must support the count for the HDR and
    /// depth formats). Targets without colour are returned as they are.
    pub fn with_msaa(self, device: &wgpu::Device, samples: u32, label: &str) -> Self {
        self.with_msaa_depth(device, samples, label, false)
    }

    /// [`ViewTargets::with_msaa`] whose multisampled depth can also be
    /// bound for reading (screen-space effects load its first sample).
    /// Not on GL: there a sampled multisampled depth is a texture instead
    /// of a renderbuffer, and llvmpipe's GL then renders multisampled views
    /// wrongly (`tests/msaa.rs` fails), so GL views keep the renderbuffer
    /// and refuse those effects.
    pub fn with_msaa_sampled_depth(self, device: &wgpu::Device, samples: u32, label: &str) -> Self {
        self.with_msaa_depth(device, samples, label, true)
    }

    fn with_msaa_depth(mut self, device: &wgpu::Device, samples: u32, label: &str, sampled_depth: bool) -> Self {
        let Some(color) = &self.color else { return self };
        if samples <= 1 {
            return self;
        }
        let size = wgpu::Extent3d { width: self.width, height: self.height, depth_or_array_layers: 1 };
        let make = |format, suffix: &str, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(&format!("{label} {suffix} ×{samples}")),
                size,
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let msaa_color = make(color.hdr.format(), "hdr", wgpu::TextureUsages::RENDER_ATTACHMENT);
        let depth_usage = if sampled_depth {
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING
        } else {
            wgpu::TextureUsages::RENDER_ATTACHMENT
        };
        let msaa_depth = make(Self::DEPTH_FORMAT, "depth", depth_usage);
        self.msaa = Some(MsaaTargets {
            samples,
            color_view: msaa_color.create_view(&Default::default()),
            color: msaa_color,
            depth_view: msaa_depth.create_view(&Default::default()),
            depth: msaa_depth,
        });
        self
    }

    /// These targets with label planes of their own for the labels of
    /// `set` ([`LabelTargets`]); none when `set` is empty.
    pub fn with_labels(mut self, device: &wgpu::Device, set: LabelSet, label: &str) -> Self {
        self.labels = (!set.is_empty()).then(|| LabelTargets::new(device, self.width, self.height, set, label));
        self
    }

    /// Targets of a shadow view that renders into `layer` of a depth array
    /// (`atlas`, `Depth32Float`, square): no texture of its own.
    pub fn atlas_layer(atlas: &wgpu::Texture, layer: u32) -> Self {
        ViewTargets {
            color: None,
            depth_view: single_layer_view(atlas, layer, "atlas layer"),
            depth: atlas.clone(),
            depth_layer: layer,
            owns_depth: false,
            width: atlas.width(),
            height: atlas.height(),
            msaa: None,
            tile: None,
            labels: None,
            page_kept: false,
            deferred: None,
        }
    }

    /// Targets of a reflection-probe face: its own depth, and level 0 of
    /// `layer` of the probe's HDR `cube` (a six-layer `Rgba16Float` array)
    /// as its colour; nothing to tone-map into.
    pub fn probe_face(device: &wgpu::Device, cube: &wgpu::Texture, layer: u32, label: &str) -> Self {
        let mut targets = Self::create(device, cube.width(), cube.height(), label, None);
        targets.color = Some(ColorTargets {
            hdr: cube.clone(),
            hdr_view: single_layer_view(cube, layer, "probe face"),
            hdr_layer: layer,
            color: None,
            color_view: None,
        });
        targets
    }

    fn create(device: &wgpu::Device, width: u32, height: u32, label: &str, hdr_format: Option<HdrFormat>) -> Self {
        let size = wgpu::Extent3d { width, height, depth_or_array_layers: 1 };
        let make =
            |format, usage, suffix: &str| texture_2d(device, &format!("{label} {suffix}"), size, 1, format, usage);
        let color = hdr_format.map(|hdr_format| {
            let color = make(
                Self::COLOR_FORMAT,
                wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::TEXTURE_BINDING,
                "colour",
            );
            // Copy destination: a path-traced view copies its mean in.
            let hdr = make(
                hdr_format.texture_format(),
                wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::COPY_DST,
                "hdr",
            );
            ColorTargets {
                hdr_view: hdr.create_view(&Default::default()),
                hdr,
                hdr_layer: 0,
                color_view: Some(color.create_view(&Default::default())),
                color: Some(color),
            }
        });
        let depth = make(
            Self::DEPTH_FORMAT,
            // Copy source: read back by tests and tools.
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            "depth",
        );
        ViewTargets {
            color,
            depth_view: depth.create_view(&Default::default()),
            depth,
            depth_layer: 0,
            owns_depth: true,
            width,
            height,
            msaa: None,
            tile: None,
            labels: None,
            page_kept: false,
            deferred: None,
        }
    }
}

/// A 2D view of level 0 of one layer of an array texture.
fn single_layer_view(texture: &wgpu::Texture, layer: u32, label: &str) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some(label),
        dimension: Some(wgpu::TextureViewDimension::D2),
        base_mip_level: 0,
        mip_level_count: Some(1),
        base_array_layer: layer,
        array_layer_count: Some(1),
        ..Default::default()
    })
}

/// A single-sampled 2D texture (a 2D array when `size` has several layers)
/// with `mip_level_count` levels: the one descriptor every sampled, stored
/// or rendered-to texture outside the multisampled targets shares.
pub fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    size: wgpu::Extent3d,
    mip_level_count: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size,
        mip_level_count,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

#[cfg(test)]
mod tile_tests {
    use super::{LabelSet, TileAtlas};

    #[test]
    fn tiles_fill_a_square_page_then_more_pages() {
        // One tile: a page of one.
        assert_eq!(TileAtlas::layout((128, 128), 1, 8192), Some((1, 1, 1)));
        // 5 tiles: 3 columns, 2 rows.
        assert_eq!(TileAtlas::layout((128, 128), 5, 8192), Some((3, 2, 1)));
        // 1 024 cameras of 128²: 32 × 32 on one 4 096² page.
        assert_eq!(TileAtlas::layout((128, 128), 1024, 8192), Some((32, 32, 1)));
        // 256 views of 640 × 360 under an 8 192 limit: 12 columns (7 680
        // pixels), 16 rows would be 5 760 pixels high: fits 22 rows, so
        // 256 / 12 = 22 rows on one page.
        assert_eq!(TileAtlas::layout((640, 360), 256, 8192), Some((12, 22, 1)));
        // 1 024 of them need pages: 12 × 22 = 264 a page.
        assert_eq!(TileAtlas::layout((640, 360), 1024, 8192), Some((12, 22, 4)));
    }

    #[test]
    fn empty_or_oversized_tiles_have_no_layout() {
        assert_eq!(TileAtlas::layout((0, 128), 4, 8192), None);
        assert_eq!(TileAtlas::layout((128, 0), 4, 8192), None);
        assert_eq!(TileAtlas::layout((8193, 16), 4, 8192), None);
        assert_eq!(TileAtlas::layout((16, 16), 0, 8192), None);
    }

    #[test]
    fn bytes_count_depth_colour_and_hdr() {
        // 2 × 1 tiles of 4 × 4 on one page: 32 pixels.
        assert_eq!(TileAtlas::bytes_for((4, 4), (2, 1, 1), None, LabelSet::NONE, false), 32 * 8);
        assert_eq!(TileAtlas::bytes_for((4, 4), (2, 1, 3), Some(8), LabelSet::NONE, false), 3 * 32 * 16);
        assert_eq!(TileAtlas::bytes_for((4, 4), (2, 1, 1), None, LabelSet::ALL, false), 32 * 28);
        // Deferred shading's visibility target (4 bytes; it shades into the
        // page's own colour).
        assert_eq!(TileAtlas::bytes_for((4, 4), (2, 1, 1), None, LabelSet::NONE, true), 32 * 12);
    }
}
