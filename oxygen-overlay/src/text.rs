//! Fonts and text: a line of characters laid out left to right with the
//! font's advances and kerning (no shaping: scripts that join or reorder
//! their letters come out letter by letter), `\n` starting a new line, each
//! glyph at a whole pixel so that its rasterised image is the same wherever
//! it is drawn and the atlas keeps one per glyph and size.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use ab_glyph::{Font as _, FontArc, PxScale, ScaleFont as _};
use glam::Vec2;

use crate::atlas::{Atlas, AtlasKey, AtlasRect};

/// The font shipped with the overlay: DejaVu Sans (Latin, Greek, Cyrillic
/// and more; `oxygen-overlay/fonts/LICENSE`).
static DEJAVU_SANS: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");

/// A font text is drawn with.
#[derive(Clone)]
pub struct Font {
    font: FontArc,
    /// Each glyph's inked pixels at each size, from a whole-pixel origin
    /// (top-left offset, size; `None`: nothing inked): outlining a glyph
    /// to find them is most of laying text out, and they never change.
    bounds: Arc<Mutex<InkCache>>,
}

/// Inked pixels by (glyph, size): top-left offset and size.
type InkCache = HashMap<(u16, u32), Option<(Vec2, Vec2)>>;

impl std::fmt::Debug for Font {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Font").field("glyphs", &self.font.glyph_count()).finish()
    }
}

impl Font {
    /// DejaVu Sans, shipped with the crate.
    pub fn default_sans() -> Font {
        // The bundled file is a valid font (the crate's tests load it).
        let font = FontArc::try_from_slice(DEJAVU_SANS).expect("the bundled DejaVu Sans parses");
        Font { font, bounds: Default::default() }
    }

    /// A TrueType or OpenType font from its file's bytes.
    pub fn from_bytes(bytes: Vec<u8>) -> Result<Font, crate::OverlayError> {
        FontArc::try_from_vec(bytes)
            .map(|font| Font { font, bounds: Default::default() })
            .map_err(|_| crate::OverlayError::BadFont)
    }

    /// Glyph `id`'s inked pixels at `size` from a whole-pixel origin.
    fn ink(&self, id: ab_glyph::GlyphId, size: u32) -> Option<(Vec2, Vec2)> {
        let mut cache = self.bounds.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        *cache.entry((id.0, size)).or_insert_with(|| {
            let glyph = id.with_scale_and_position(size as f32, ab_glyph::point(0.0, 0.0));
            self.font.outline_glyph(glyph).map(|outlined| {
                let b = outlined.px_bounds();
                (Vec2::new(b.min.x, b.min.y), Vec2::new(b.width(), b.height()))
            })
        })
    }
}

/// Text sizes are kept between these (pixels of the font's em).
pub(crate) const MIN_TEXT_SIZE: f32 = 1.0;
pub(crate) const MAX_TEXT_SIZE: f32 = 256.0;

/// A glyph placed by the layout: which image (font slot, glyph, size) and
/// where its top-left corner lies relative to the text's anchor, in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PlacedGlyph {
    pub(crate) key: AtlasKey,
    pub(crate) offset: Vec2,
    pub(crate) size: Vec2,
}

/// Lays `text` out at `size` pixels with `font` (in slot `slot`): its
/// glyphs relative to the top-left corner of its first line, and the size
/// of the block it fills.
pub(crate) fn layout(font: &Font, slot: u32, size: f32, text: &str) -> (Vec<PlacedGlyph>, Vec2) {
    let size = size.clamp(MIN_TEXT_SIZE, MAX_TEXT_SIZE).round();
    let scaled = font.font.as_scaled(PxScale::from(size));
    let line_height = (scaled.height() + scaled.line_gap()).ceil();
    let ascent = scaled.ascent().round();
    let mut glyphs = Vec::new();
    let (mut x, mut line) = (0.0f32, 0u32);
    let mut widest = 0.0f32;
    let mut previous = None;
    for c in text.chars() {
        if c == '\n' {
            widest = widest.max(x);
            (x, line, previous) = (0.0, line + 1, None);
            continue;
        }
        if c.is_control() {
            continue;
        }
        let id = scaled.glyph_id(c);
        if let Some(p) = previous {
            x += scaled.kern(p, id);
        }
        // At a whole-pixel origin the inked pixels are the origin's
        // bounds moved by it.
        let origin = Vec2::new(x.round(), ascent + line as f32 * line_height);
        if let Some((min, extent)) = font.ink(id, size as u32) {
            glyphs.push(PlacedGlyph {
                key: AtlasKey::Glyph { font: slot, glyph: id.0, size: size as u32 },
                offset: origin + min,
                size: extent,
            });
        }
        x += scaled.h_advance(id);
        previous = Some(id);
    }
    widest = widest.max(x);
    (glyphs, Vec2::new(widest.ceil(), (line + 1) as f32 * line_height))
}

/// The atlas rectangle of a placed glyph, rasterising it into the atlas
/// the first time (`None` when the atlas has no room for it).
pub(crate) fn glyph_rect(atlas: &mut Atlas, fonts: &[Font], glyph: &PlacedGlyph) -> Option<AtlasRect> {
    if let Some(rect) = atlas.get(&glyph.key) {
        return Some(rect);
    }
    let AtlasKey::Glyph { font, glyph: id, size } = glyph.key else {
        return None;
    };
    let font = &fonts.get(font as usize)?.font;
    // At a whole-pixel origin the coverage is the same at any whole pixel.
    let outlined =
        font.outline_glyph(ab_glyph::GlyphId(id).with_scale_and_position(size as f32, ab_glyph::point(0.0, 0.0)))?;
    let bounds = outlined.px_bounds();
    let (width, height) = (bounds.width() as u32, bounds.height() as u32);
    let mut coverage = vec![0u8; (width.max(1) * height.max(1)) as usize];
    outlined.draw(|x, y, c| {
        if x < width && y < height {
            coverage[(y * width + x) as usize] = (c.clamp(0.0, 1.0) * 255.0).round() as u8;
        }
    });
    atlas.insert(glyph.key, width, height, |x, y| [255, 255, 255, coverage[(y * width.max(1) + x) as usize]])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_lays_out_left_to_right_and_line_by_line() {
        let font = Font::default_sans();
        let (one, size) = layout(&font, 0, 20.0, "Hi");
        assert_eq!(one.len(), 2);
        assert!(one[1].offset.x > one[0].offset.x + one[0].size.x * 0.5, "{one:?}");
        assert!(size.x > 15.0 && size.y >= 20.0, "{size}");
        let (two, size2) = layout(&font, 0, 20.0, "Hi\nHi");
        assert_eq!(two.len(), 4);
        assert!(two[2].offset.y > two[0].offset.y + 15.0, "{two:?}");
        assert_eq!(two[2].offset.x, two[0].offset.x);
        assert!(size2.y > size.y * 1.9 && size2.x == size.x, "{size} {size2}");
        // Spaces and control characters place no glyph; sizes are clamped.
        assert_eq!(layout(&font, 0, 20.0, " \t").0.len(), 0);
        assert!(layout(&font, 0, 1.0e9, "A").0[0].size.y < 300.0);
    }

    /// Beyond ASCII: Greek, Cyrillic and accented Latin have glyphs of
    /// their own in the shipped font (not the missing-glyph box).
    #[test]
    fn the_shipped_font_covers_more_than_ascii() {
        let font = Font::default_sans();
        for c in ['é', 'ß', 'λ', 'Ж', '€'] {
            assert_ne!(font.font.glyph_id(c).0, 0, "{c} has no glyph");
        }
        let (glyphs, _) = layout(&font, 0, 16.0, "Ωmega — Ж");
        assert!(glyphs.len() >= 7, "{glyphs:?}");
    }

    #[test]
    fn a_glyph_is_rasterised_once_with_its_coverage_in_alpha() {
        let font = Font::default_sans();
        let fonts = [font.clone()];
        let mut atlas = Atlas::default();
        let (glyphs, _) = layout(&font, 0, 32.0, "OO");
        let a = glyph_rect(&mut atlas, &fonts, &glyphs[0]).unwrap();
        let b = glyph_rect(&mut atlas, &fonts, &glyphs[1]).unwrap();
        assert_eq!(a, b);
        assert_eq!(atlas.len(), 1);
        assert_eq!((a.width as f32, a.height as f32), (glyphs[0].size.x, glyphs[0].size.y));
        // The ring of an O: opaque somewhere, empty at its centre.
        let texel = |x: u32, y: u32| atlas.pixels()[(((a.y + y) * crate::ATLAS_SIZE + a.x + x) * 4 + 3) as usize];
        assert!((0..a.width).any(|x| texel(x, a.height / 2) > 200));
        assert_eq!(texel(a.width / 2, a.height / 2), 0);
        assert!(Font::from_bytes(vec![1, 2, 3]).is_err());
    }
}
