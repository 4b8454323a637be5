//! The overlay of one view and the canvases shapes are drawn on.

use std::collections::HashMap;
use std::sync::Arc;

use glam::{DMat4, DVec3, Vec2};
use oxygen_core::ResolvedView;

use crate::atlas::{Atlas, AtlasKey};
use crate::text::{Font, PlacedGlyph, layout};

/// A colour: sRGB-encoded red, green and blue, straight (not premultiplied)
/// alpha, each from 0 to 1. Values outside are clamped, NaN reads as 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rgba {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
    /// Opacity.
    pub a: f32,
}

impl Rgba {
    /// Opaque white.
    pub const WHITE: Rgba = Rgba::rgb(1.0, 1.0, 1.0);
    /// Opaque black.
    pub const BLACK: Rgba = Rgba::rgb(0.0, 0.0, 0.0);

    /// A colour with opacity `a`.
    pub const fn new(r: f32, g: f32, b: f32, a: f32) -> Rgba {
        Rgba { r, g, b, a }
    }

    /// An opaque colour.
    pub const fn rgb(r: f32, g: f32, b: f32) -> Rgba {
        Rgba { r, g, b, a: 1.0 }
    }

    /// The same colour with opacity `a`.
    pub const fn with_alpha(self, a: f32) -> Rgba {
        Rgba { a, ..self }
    }

    /// Eight bits a channel, as the vertices carry it.
    pub fn unorm8(self) -> [u8; 4] {
        // NaN stays NaN through the clamp and casts to 0.
        let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        [q(self.r), q(self.g), q(self.b), q(self.a)]
    }
}

/// Whether a world-space shape is hidden behind the view's surfaces.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DepthMode {
    /// Hidden where a surface of the scene is nearer (the default): a
    /// debug shape sits in the scene.
    #[default]
    Tested,
    /// Drawn over everything.
    OnTop,
}

/// An image given to [`Overlay::add_image`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ImageId(pub(crate) u32);

/// What the overlay refuses.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum OverlayError {
    /// An image whose pixels do not match its size, or that is empty or
    /// larger than the atlas.
    #[error("an image of {width} × {height} with {bytes} bytes of RGBA (at most {max} × {max})")]
    BadImage {
        /// Width given.
        width: u32,
        /// Height given.
        height: u32,
        /// Bytes given.
        bytes: usize,
        /// The largest side an image may have.
        max: u32,
    },
    /// Font bytes that are not a TrueType or OpenType font.
    #[error("the bytes are not a TrueType or OpenType font")]
    BadFont,
}

/// One shape as drawn: screen shapes in the view's pixels (x right, y
/// down, from the top-left corner), world shapes in world units.
#[derive(Clone, Debug)]
pub(crate) enum Shape {
    Rect {
        min: Vec2,
        max: Vec2,
        color: [u8; 4],
    },
    Image {
        min: Vec2,
        max: Vec2,
        image: u32,
        tint: [u8; 4],
    },
    Line {
        a: Vec2,
        b: Vec2,
        width: f32,
        color: [u8; 4],
    },
    /// A disc (`width` 0), ring or arc: `sweep` radians clockwise on screen
    /// from `start` (from +x towards +y, down).
    Arc {
        center: Vec2,
        radius: f32,
        width: f32,
        start: f32,
        sweep: f32,
        color: [u8; 4],
    },
    Text {
        at: Vec2,
        glyphs: Arc<[PlacedGlyph]>,
        color: [u8; 4],
    },
    WorldLine {
        a: DVec3,
        b: DVec3,
        width: f32,
        color: [u8; 4],
        depth: DepthMode,
    },
    WorldText {
        anchor: DVec3,
        offset: Vec2,
        glyphs: Arc<[PlacedGlyph]>,
        color: [u8; 4],
        depth: DepthMode,
    },
    Grid(Grid),
}

/// An editor grid on a horizontal plane (see [`Canvas::grid`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Grid {
    pub(crate) height: f64,
    pub(crate) spacing: f64,
    pub(crate) lines: u32,
    pub(crate) width: f32,
    pub(crate) color: [u8; 4],
    pub(crate) fade: f64,
}

/// The overlay of one view: an immediate canvas cleared after each frame,
/// a retained one kept until cleared, the fonts text was laid out with and
/// the atlas of glyphs and images.
#[derive(Clone, Default)]
pub struct Overlay {
    immediate: Vec<Shape>,
    retained: Vec<Shape>,
    /// Every font text was laid out with (shapes name them by slot); the
    /// last is the current one. Empty until text is first drawn.
    pub(crate) fonts: Vec<Font>,
    /// Images by id: their pixels, kept to place them again after the atlas
    /// is emptied.
    pub(crate) images: Vec<(u32, u32, Vec<u8>)>,
    pub(crate) atlas: Atlas,
    /// Shapes refused for a coordinate or size that is not finite.
    dropped: u64,
    /// The selection outline, when one is asked for.
    outline: Option<Outline>,
    /// Text laid out so far, by font slot, size and string: a label drawn
    /// again every frame is laid out once.
    layouts: Layouts,
}

/// A string's glyphs and the size of the block they fill.
type LaidOut = (Arc<[PlacedGlyph]>, Vec2);

/// Laid-out text by font slot and pixel size, then string; emptied when
/// it holds [`Layouts::MOST`] strings.
#[derive(Clone, Default)]
pub(crate) struct Layouts {
    laid_out: HashMap<(u32, u32), HashMap<Box<str>, LaidOut>>,
    strings: usize,
}

impl Layouts {
    /// Strings kept at most (a tool drawing ever new strings, a counter
    /// say, empties the cache now and then instead of growing it).
    const MOST: usize = 4096;

    /// `text`'s glyphs and block size at `size` in font `slot`.
    fn get(&mut self, font: &Font, slot: u32, size: f32, text: &str) -> LaidOut {
        let key = (slot, size.to_bits());
        if let Some((glyphs, extent)) = self.laid_out.get(&key).and_then(|strings| strings.get(text)) {
            return (Arc::clone(glyphs), *extent);
        }
        if self.strings >= Self::MOST {
            self.laid_out.clear();
            self.strings = 0;
        }
        let (glyphs, extent) = layout(font, slot, size, text);
        let glyphs: Arc<[PlacedGlyph]> = glyphs.into();
        self.laid_out.entry(key).or_default().insert(text.into(), (Arc::clone(&glyphs), extent));
        self.strings += 1;
        (glyphs, extent)
    }
}

/// A selection outline ([`Overlay::set_outline`]): a line `width` pixels
/// wide around what the chosen nodes cover in the view, outside them,
/// found by jump flooding the view's instance ids (its labels, or an ID
/// render).
#[derive(Clone, Debug, PartialEq)]
pub struct Outline {
    /// The nodes outlined, by stable id (`oxygen_core::scene::node_index`,
    /// what picking returns).
    pub nodes: Vec<u32>,
    /// Width in pixels, 0.5 to 64.
    pub width: f32,
    /// Its colour.
    pub color: Rgba,
}

impl Outline {
    /// Most pixels an outline is wide.
    pub const MAX_WIDTH: f32 = 64.0;

    /// Node ids an outline takes: below 2^24 (a scene's stable ids are
    /// slot indices; the set is a bit per id up to the largest).
    pub const MAX_NODE_ID: u32 = 1 << 24;

    /// Why it cannot be drawn, if it cannot: a width that is not between
    /// 0.5 and [`Outline::MAX_WIDTH`], or a node id of
    /// [`Outline::MAX_NODE_ID`] or more.
    pub fn problem(&self) -> Option<String> {
        if !(0.5..=Self::MAX_WIDTH).contains(&self.width) {
            return Some(format!("an outline {} pixels wide (0.5 to {} are drawn)", self.width, Self::MAX_WIDTH));
        }
        self.nodes
            .iter()
            .find(|n| **n >= Self::MAX_NODE_ID)
            .map(|n| format!("an outline of node id {n} (ids below {} are outlined)", Self::MAX_NODE_ID))
    }

    /// The chosen nodes as a bit set over their ids (bit `id` of word
    /// `id / 32`), as the outline's shader tests them.
    /// Ids of [`Outline::MAX_NODE_ID`] or more are left out.
    pub fn node_bits(&self) -> Vec<u32> {
        let kept = || self.nodes.iter().filter(|n| **n < Self::MAX_NODE_ID);
        let words = kept().map(|n| *n as usize / 32 + 1).max().unwrap_or(1);
        let mut bits = vec![0u32; words];
        for n in kept() {
            bits[*n as usize / 32] |= 1 << (n % 32);
        }
        bits
    }
}

impl std::fmt::Debug for Overlay {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Overlay")
            .field("immediate", &self.immediate.len())
            .field("retained", &self.retained.len())
            .field("images", &self.images.len())
            .field("dropped", &self.dropped)
            .field("outline", &self.outline)
            .finish()
    }
}

impl Overlay {
    /// An empty overlay.
    pub fn new() -> Overlay {
        Overlay::default()
    }

    /// The canvas whose shapes last one frame: the renderer clears it
    /// after each frame it renders ([`Overlay::end_frame`]).
    pub fn immediate(&mut self) -> Canvas<'_> {
        Canvas {
            shapes: &mut self.immediate,
            fonts: &mut self.fonts,
            layouts: &mut self.layouts,
            dropped: &mut self.dropped,
        }
    }

    /// The canvas whose shapes stay until [`Overlay::clear_retained`].
    pub fn retained(&mut self) -> Canvas<'_> {
        Canvas {
            shapes: &mut self.retained,
            fonts: &mut self.fonts,
            layouts: &mut self.layouts,
            dropped: &mut self.dropped,
        }
    }

    /// Removes the retained shapes.
    pub fn clear_retained(&mut self) {
        self.retained.clear();
    }

    /// Removes the immediate shapes (the renderer calls it after each
    /// frame).
    pub fn end_frame(&mut self) {
        self.immediate.clear();
    }

    /// Whether there is nothing to draw (the overlay pass then records
    /// nothing).
    pub fn is_empty(&self) -> bool {
        self.immediate.is_empty() && self.retained.is_empty() && self.outline.is_none()
    }

    /// Outlines the nodes `outline` names from the next frame on (`None`:
    /// no outline). Kept until changed. The outline is found in the view's
    /// instance labels when it draws them (`ViewDesc::with_labels`),
    /// otherwise in an ID render of the view made for it each frame (its
    /// opaque draws drawn once more: the cost of a depth pre-pass).
    pub fn set_outline(&mut self, outline: Option<Outline>) {
        self.outline = outline.filter(|o| !o.nodes.is_empty());
    }

    /// The selection outline, if any.
    pub fn outline(&self) -> Option<&Outline> {
        self.outline.as_ref()
    }

    /// Shapes on both canvases (a box or a sphere counts its lines).
    pub fn shape_count(&self) -> usize {
        self.immediate.len() + self.retained.len()
    }

    /// Whether a shape is tested against the view's depth (a world shape
    /// with [`DepthMode::Tested`], a grid): a multisampled view then draws
    /// its depth once more, single-sampled, for them.
    pub fn depth_tested(&self) -> bool {
        self.immediate.iter().chain(&self.retained).any(|shape| match shape {
            Shape::WorldLine { depth, .. } | Shape::WorldText { depth, .. } => *depth == DepthMode::Tested,
            Shape::Grid(_) => true,
            _ => false,
        })
    }

    /// Shapes refused so far for a coordinate or size that is not finite.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Text drawn from now on uses `font` (DejaVu Sans until then).
    pub fn set_font(&mut self, font: Font) {
        self.fonts.push(font);
    }

    /// Makes an image available to [`Canvas::image`]: `rgba` holds
    /// `width × height` texels of sRGB colour and straight alpha, row by
    /// row. Images live in the overlay's atlas with its glyphs, so each
    /// side is at most [`crate::ATLAS_SIZE`] less two texels of padding.
    pub fn add_image(&mut self, width: u32, height: u32, rgba: Vec<u8>) -> Result<ImageId, OverlayError> {
        let max = crate::ATLAS_SIZE - 2;
        if width == 0
            || height == 0
            || width > max
            || height > max
            || rgba.len() as u64 != u64::from(width) * u64::from(height) * 4
        {
            return Err(OverlayError::BadImage { width, height, bytes: rgba.len(), max });
        }
        self.images.push((width, height, rgba));
        Ok(ImageId(self.images.len() as u32 - 1))
    }

    /// The atlas of glyphs and images the vertices sample.
    pub fn atlas(&self) -> &Atlas {
        &self.atlas
    }

    /// The atlas, to mark it uploaded.
    pub fn atlas_mut(&mut self) -> &mut Atlas {
        &mut self.atlas
    }

    /// Whether `image` is one of this overlay's images.
    pub(crate) fn has_image(&self, image: u32) -> bool {
        (image as usize) < self.images.len()
    }

    /// Places image `image` in the atlas if it is not there.
    pub(crate) fn image_rect(&mut self, image: u32) -> Option<crate::atlas::AtlasRect> {
        let (width, height, pixels) = self.images.get(image as usize)?;
        let width = *width;
        self.atlas.insert(AtlasKey::Image(image), width, *height, |x, y| {
            let at = ((y * width + x) * 4) as usize;
            [pixels[at], pixels[at + 1], pixels[at + 2], pixels[at + 3]]
        })
    }

    pub(crate) fn split_for_tessellation(&mut self) -> (Vec<Shape>, Vec<Shape>) {
        (std::mem::take(&mut self.retained), std::mem::take(&mut self.immediate))
    }

    pub(crate) fn restore_after_tessellation(&mut self, (retained, immediate): (Vec<Shape>, Vec<Shape>)) {
        self.retained = retained;
        self.immediate = immediate;
    }
}

/// Draws shapes onto one of an overlay's canvases. Every call takes
/// screen positions in the view's pixels (x right, y down, from the
/// top-left corner) or world positions in world units; a shape with a
/// coordinate or size that is not finite is dropped and counted
/// ([`Overlay::dropped`]), never drawn.
pub struct Canvas<'a> {
    shapes: &'a mut Vec<Shape>,
    fonts: &'a mut Vec<Font>,
    layouts: &'a mut Layouts,
    dropped: &'a mut u64,
}

/// Segments of a world sphere's circles.
const SPHERE_SEGMENTS: usize = 32;

impl Canvas<'_> {
    fn keep(&mut self, finite: bool, shape: Shape) -> &mut Self {
        if finite {
            self.shapes.push(shape);
        } else {
            *self.dropped += 1;
            tracing::warn!("an overlay shape with a coordinate or size that is not finite was dropped");
        }
        self
    }

    /// A filled rectangle from `min` to `max` (pixels).
    pub fn rect(&mut self, min: Vec2, max: Vec2, color: Rgba) -> &mut Self {
        let finite = min.is_finite() && max.is_finite();
        self.keep(finite, Shape::Rect { min: min.min(max), max: min.max(max), color: color.unorm8() })
    }

    /// A rectangle's outline, `width` pixels wide, centred on its edges.
    pub fn rect_outline(&mut self, min: Vec2, max: Vec2, width: f32, color: Rgba) -> &mut Self {
        let corners = [min, Vec2::new(max.x, min.y), max, Vec2::new(min.x, max.y), min];
        self.polyline(&corners, width, color)
    }

    /// Image `image` ([`Overlay::add_image`]) stretched over the rectangle
    /// from `min` to `max`, its colours multiplied by `tint`.
    pub fn image(&mut self, min: Vec2, max: Vec2, image: ImageId, tint: Rgba) -> &mut Self {
        let finite = min.is_finite() && max.is_finite();
        self.keep(finite, Shape::Image { min, max, image: image.0, tint: tint.unorm8() })
    }

    /// A line from `a` to `b`, `width` pixels wide (square ends).
    pub fn line(&mut self, a: Vec2, b: Vec2, width: f32, color: Rgba) -> &mut Self {
        let finite = a.is_finite() && b.is_finite() && width.is_finite();
        self.keep(finite, Shape::Line { a, b, width: width.max(0.0), color: color.unorm8() })
    }

    /// Lines through `points` in turn.
    pub fn polyline(&mut self, points: &[Vec2], width: f32, color: Rgba) -> &mut Self {
        for pair in points.windows(2) {
            self.line(pair[0], pair[1], width, color);
        }
        self
    }

    /// A filled circle.
    pub fn circle(&mut self, center: Vec2, radius: f32, color: Rgba) -> &mut Self {
        self.arc_shape(center, radius, 0.0, 0.0, std::f32::consts::TAU, color)
    }

    /// A circle's outline, `width` pixels wide, centred on the circle.
    pub fn circle_outline(&mut self, center: Vec2, radius: f32, width: f32, color: Rgba) -> &mut Self {
        self.arc_shape(center, radius, width.max(0.0), 0.0, std::f32::consts::TAU, color)
    }

    /// An arc of the circle around `center`: `sweep` radians from angle
    /// `start`, both clockwise on screen from the +x axis, `width` pixels
    /// wide.
    pub fn arc(&mut self, center: Vec2, radius: f32, width: f32, start: f32, sweep: f32, color: Rgba) -> &mut Self {
        self.arc_shape(center, radius, width.max(0.0), start, sweep, color)
    }

    fn arc_shape(&mut self, center: Vec2, radius: f32, width: f32, start: f32, sweep: f32, color: Rgba) -> &mut Self {
        let finite =
            center.is_finite() && radius.is_finite() && width.is_finite() && start.is_finite() && sweep.is_finite();
        let (start, sweep) = if sweep < 0.0 { (start + sweep, -sweep) } else { (start, sweep) };
        let shape = Shape::Arc {
            center,
            radius: radius.max(0.0),
            width,
            start: start.rem_euclid(std::f32::consts::TAU),
            sweep: sweep.min(std::f32::consts::TAU),
            color: color.unorm8(),
        };
        self.keep(finite, shape)
    }

    fn font(&mut self) -> (u32, &Font) {
        if self.fonts.is_empty() {
            self.fonts.push(Font::default_sans());
        }
        let slot = self.fonts.len() - 1;
        (slot as u32, &self.fonts[slot])
    }

    /// `text` laid out at `size` in the current font (once per string and
    /// size: [`Layouts`]).
    fn laid_out(&mut self, size: f32, text: &str) -> (Arc<[PlacedGlyph]>, Vec2) {
        self.font();
        let slot = self.fonts.len() - 1;
        self.layouts.get(&self.fonts[slot], slot as u32, size, text)
    }

    /// `text` with the top-left corner of its first line at `at`, its em
    /// `size` pixels tall (1 to 256); `\n` starts a line. Returns the size
    /// of the block it fills, in pixels.
    pub fn text(&mut self, at: Vec2, size: f32, color: Rgba, text: &str) -> Vec2 {
        let finite = at.is_finite() && size.is_finite();
        let (glyphs, extent) = if finite { self.laid_out(size, text) } else { (Arc::from([]), Vec2::ZERO) };
        self.keep(finite, Shape::Text { at: at.round(), glyphs, color: color.unorm8() });
        extent
    }

    /// A line in the world from `a` to `b`, `width` pixels wide.
    pub fn world_line(&mut self, a: DVec3, b: DVec3, width: f32, color: Rgba, depth: DepthMode) -> &mut Self {
        let finite = a.is_finite() && b.is_finite() && width.is_finite();
        self.keep(finite, Shape::WorldLine { a, b, width: width.max(0.0), color: color.unorm8(), depth })
    }

    /// The twelve edges of the axis-aligned box from `min` to `max`.
    pub fn world_box(&mut self, min: DVec3, max: DVec3, width: f32, color: Rgba, depth: DepthMode) -> &mut Self {
        let transform = DMat4::from_translation((min + max) * 0.5) * DMat4::from_scale(max - min);
        self.world_cube(transform, width, color, depth)
    }

    /// The twelve edges of the cube from −0.5 to 0.5 moved by `transform`
    /// (an oriented box: a node's world transform times its bounds).
    pub fn world_cube(&mut self, transform: DMat4, width: f32, color: Rgba, depth: DepthMode) -> &mut Self {
        let corner = |i: usize| {
            let unit = DVec3::new((i & 1) as f64 - 0.5, ((i >> 1) & 1) as f64 - 0.5, ((i >> 2) & 1) as f64 - 0.5);
            transform.transform_point3(unit)
        };
        self.edges(&std::array::from_fn::<DVec3, 8, _>(corner), width, color, depth)
    }

    /// Twelve edges between eight corners numbered as bits (x = bit 0,
    /// y = bit 1, z = bit 2).
    fn edges(&mut self, corners: &[DVec3; 8], width: f32, color: Rgba, depth: DepthMode) -> &mut Self {
        for i in 0..8usize {
            for bit in [1usize, 2, 4] {
                if i & bit == 0 {
                    self.world_line(corners[i], corners[i | bit], width, color, depth);
                }
            }
        }
        self
    }

    /// A sphere as its three great circles along the axes.
    pub fn world_sphere(&mut self, center: DVec3, radius: f64, width: f32, color: Rgba, depth: DepthMode) -> &mut Self {
        let point = |axis: usize, t: f64| {
            let (s, c) = (t.sin() * radius, t.cos() * radius);
            center
                + match axis {
                    0 => DVec3::new(0.0, c, s),
                    1 => DVec3::new(c, 0.0, s),
                    _ => DVec3::new(c, s, 0.0),
                }
        };
        for axis in 0..3 {
            for i in 0..SPHERE_SEGMENTS {
                let t = |k: usize| k as f64 / SPHERE_SEGMENTS as f64 * std::f64::consts::TAU;
                self.world_line(point(axis, t(i)), point(axis, t(i + 1)), width, color, depth);
            }
        }
        self
    }

    /// An arrow from `from` to `to`: its shaft and a head of four strokes a
    /// fifth of its length.
    pub fn world_arrow(&mut self, from: DVec3, to: DVec3, width: f32, color: Rgba, depth: DepthMode) -> &mut Self {
        self.world_line(from, to, width, color, depth);
        let along = to - from;
        let length = along.length();
        if length.is_nan() || length <= 0.0 {
            return self;
        }
        let dir = along / length;
        let side = dir.any_orthonormal_vector();
        let up = dir.cross(side);
        let back = to - dir * (length * 0.2);
        for spoke in [side, -side, up, -up] {
            self.world_line(to, back + spoke * (length * 0.08), width, color, depth);
        }
        self
    }

    /// The frustum `view` sees: its near rectangle, and its far one at the
    /// far plane or `max_distance` in front of the eye, whichever is nearer
    /// (an infinite far plane needs the second). World units, in `f64`.
    pub fn view_frustum(
        &mut self,
        view: &ResolvedView,
        max_distance: f64,
        width: f32,
        color: Rgba,
        depth: DepthMode,
    ) -> &mut Self {
        match frustum_corners(view, max_distance) {
            Some(corners) => self.edges(&corners, width, color, depth),
            None => {
                *self.dropped += 1;
                tracing::warn!(view = %view.view_id, "a frustum whose matrices do not invert was dropped");
                self
            }
        }
    }

    /// `text` with the top-left corner of its first line `offset` pixels
    /// from where `anchor` appears in the view (a label on a world point).
    pub fn world_text(
        &mut self,
        anchor: DVec3,
        offset: Vec2,
        size: f32,
        color: Rgba,
        text: &str,
        depth: DepthMode,
    ) -> &mut Self {
        let finite = anchor.is_finite() && offset.is_finite() && size.is_finite();
        let glyphs = if finite { self.laid_out(size, text).0 } else { Arc::from([]) };
        self.keep(finite, Shape::WorldText { anchor, offset: offset.round(), glyphs, color: color.unorm8(), depth })
    }

    /// An editor grid on the horizontal plane at `height` (world y): lines
    /// `spacing` apart along x and z, `lines` on each side of the point
    /// under the eye (snapped to the grid, so the lines stay on the world's
    /// multiples of `spacing` as the camera moves), `width` pixels wide,
    /// fading out from half of `fade_distance` to it, measured along the
    /// plane from the point under the eye. Depth-tested.
    pub fn grid(
        &mut self,
        height: f64,
        spacing: f64,
        lines: u32,
        width: f32,
        color: Rgba,
        fade_distance: f64,
    ) -> &mut Self {
        let finite = height.is_finite()
            && spacing.is_finite()
            && spacing > 0.0
            && width.is_finite()
            && fade_distance.is_finite();
        let grid = Grid {
            height,
            spacing,
            lines: lines.min(1000),
            width,
            color: color.unorm8(),
            fade: fade_distance.max(0.0),
        };
        self.keep(finite, Shape::Grid(grid))
    }
}

/// The eight corners of the frustum `view` sees (numbered as bits: x = bit
/// 0, y = bit 1, far = bit 2), the far ones at most `max_distance` in front
/// of the eye; `None` for a view whose matrices do not invert.
pub fn frustum_corners(view: &ResolvedView, max_distance: f64) -> Option<[DVec3; 8]> {
    let projection = view.projection.as_dmat4();
    let clip_to_view = projection.inverse();
    let view_to_world = view.world_to_view.inverse();
    if !clip_to_view.is_finite() || !view_to_world.is_finite() {
        return None;
    }
    let far = f64::from(view.far).min(max_distance.max(f64::from(view.near)));
    let orthographic = projection.w_axis.w == 1.0 && projection.z_axis.w == 0.0;
    let mut corners = [DVec3::ZERO; 8];
    for (i, corner) in corners.iter_mut().enumerate() {
        let ndc = DVec3::new(if i & 1 == 0 { -1.0 } else { 1.0 }, if i & 2 == 0 { -1.0 } else { 1.0 }, 1.0);
        // Reverse-Z: depth 1 is the near plane.
        let near = clip_to_view.project_point3(ndc);
        let point = if i & 4 == 0 {
            near
        } else if orthographic {
            DVec3::new(near.x, near.y, -far)
        } else {
            near * (far / -near.z)
        };
        *corner = view_to_world.transform_point3(point);
    }
    corners.iter().all(|c| c.is_finite()).then_some(corners)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn glyphs_of(shape: &Shape) -> &Arc<[PlacedGlyph]> {
        match shape {
            Shape::Text { glyphs, .. } | Shape::WorldText { glyphs, .. } => glyphs,
            _ => panic!("not text"),
        }
    }

    /// A label drawn again is laid out once (the same glyphs, shared); at
    /// another size, or after another font is set, it is laid out anew.
    #[test]
    fn text_drawn_again_is_laid_out_once() {
        let mut overlay = Overlay::new();
        let first = overlay.immediate().text(Vec2::ZERO, 14.0, Rgba::WHITE, "label 42");
        let again = overlay.immediate().text(Vec2::new(5.0, 5.0), 14.0, Rgba::WHITE, "label 42");
        overlay.immediate().text(Vec2::ZERO, 20.0, Rgba::WHITE, "label 42");
        overlay.immediate().world_text(DVec3::ZERO, Vec2::ZERO, 14.0, Rgba::WHITE, "label 42", DepthMode::OnTop);
        assert_eq!(first, again);
        let shapes = &overlay.immediate;
        assert!(Arc::ptr_eq(glyphs_of(&shapes[0]), glyphs_of(&shapes[1])), "laid out twice");
        assert!(Arc::ptr_eq(glyphs_of(&shapes[0]), glyphs_of(&shapes[3])), "world text laid out again");
        assert!(!Arc::ptr_eq(glyphs_of(&shapes[0]), glyphs_of(&shapes[2])), "another size shares a layout");
        assert_eq!(glyphs_of(&shapes[0]).len(), 7, "seven letters and a space");
        overlay.set_font(Font::default_sans());
        overlay.immediate().text(Vec2::ZERO, 14.0, Rgba::WHITE, "label 42");
        let shapes = &overlay.immediate;
        assert!(!Arc::ptr_eq(glyphs_of(&shapes[0]), glyphs_of(&shapes[4])), "another font shares a layout");
        // Ever new strings: the cache is emptied rather than grown.
        for i in 0..2 * Layouts::MOST {
            overlay.immediate().text(Vec2::ZERO, 14.0, Rgba::WHITE, &i.to_string());
        }
        assert!(overlay.layouts.strings <= Layouts::MOST, "{} strings kept", overlay.layouts.strings);
    }
}
