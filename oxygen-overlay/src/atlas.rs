//! One RGBA texture of everything an overlay samples: rasterised glyphs
//! (white, their coverage in alpha) and the images it was given, packed in
//! shelves. Filled on the CPU; the GPU copy is brought up to date from the
//! rows changed since it was last uploaded ([`Atlas::dirty_rows`]).

use std::collections::HashMap;
use std::ops::Range;

/// Side of the atlas in texels: 4 MiB of RGBA.
pub const ATLAS_SIZE: u32 = 1024;

/// Empty texels around each entry, so bilinear sampling at its edge never
/// reads a neighbour.
const PADDING: u32 = 1;

/// What an atlas entry holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum AtlasKey {
    /// A glyph of font `font` (its slot in the overlay) at `size` pixels.
    Glyph { font: u32, glyph: u16, size: u32 },
    /// An image given to [`crate::Overlay::add_image`].
    Image(u32),
}

/// Where an entry lies, in texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct AtlasRect {
    pub(crate) x: u32,
    pub(crate) y: u32,
    pub(crate) width: u32,
    pub(crate) height: u32,
}

impl AtlasRect {
    /// Its corners half a texel in (top-left, bottom-right): a stretched
    /// image's edge pixels then sample its edge texels, not the padding.
    pub(crate) fn uv_inset(&self) -> ([f32; 2], [f32; 2]) {
        let s = ATLAS_SIZE as f32;
        (
            [(self.x as f32 + 0.5) / s, (self.y as f32 + 0.5) / s],
            [((self.x + self.width) as f32 - 0.5) / s, ((self.y + self.height) as f32 - 0.5) / s],
        )
    }

    /// Its corners in texture coordinates (0 to 1): top-left, bottom-right.
    pub(crate) fn uv(&self) -> ([f32; 2], [f32; 2]) {
        let s = ATLAS_SIZE as f32;
        ([self.x as f32 / s, self.y as f32 / s], [(self.x + self.width) as f32 / s, (self.y + self.height) as f32 / s])
    }
}

/// A row of entries of at most `height` texels.
#[derive(Clone, Copy, Debug)]
struct Shelf {
    y: u32,
    height: u32,
    /// The next free column.
    x: u32,
}

/// The texels and where each entry lies.
#[derive(Clone)]
pub struct Atlas {
    pixels: Vec<u8>,
    shelves: Vec<Shelf>,
    entries: HashMap<AtlasKey, AtlasRect>,
    dirty: Option<Range<u32>>,
    generation: u64,
}

impl Default for Atlas {
    fn default() -> Self {
        Atlas {
            pixels: vec![0; (ATLAS_SIZE * ATLAS_SIZE * 4) as usize],
            shelves: Vec::new(),
            entries: HashMap::new(),
            dirty: None,
            generation: 0,
        }
    }
}

impl Atlas {
    /// The texels, RGBA, row by row (`ATLAS_SIZE` × `ATLAS_SIZE`; colour in
    /// sRGB, alpha linear).
    pub fn pixels(&self) -> &[u8] {
        &self.pixels
    }

    /// Rows written since [`Atlas::mark_uploaded`], if any.
    pub fn dirty_rows(&self) -> Option<Range<u32>> {
        self.dirty.clone()
    }

    /// Says the GPU copy now holds every row.
    pub fn mark_uploaded(&mut self) {
        self.dirty = None;
    }

    /// Counts the times the atlas was emptied to make room (its entries
    /// moved): a copy made before a change of generation is stale
    /// everywhere, not just in the dirty rows.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Entries it holds.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether it holds nothing.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    pub(crate) fn get(&self, key: &AtlasKey) -> Option<AtlasRect> {
        self.entries.get(key).copied()
    }

    /// Places a `width × height` entry for `key` and lets `fill` write its
    /// texels (`fill(x, y) -> [r, g, b, a]`); `None` when it cannot fit even
    /// in an empty atlas, or the atlas is full (the caller may
    /// [`Atlas::clear`] and ask again).
    pub(crate) fn insert(
        &mut self,
        key: AtlasKey,
        width: u32,
        height: u32,
        fill: impl Fn(u32, u32) -> [u8; 4],
    ) -> Option<AtlasRect> {
        if let Some(rect) = self.get(&key) {
            return Some(rect);
        }
        let (w, h) = (width.max(1) + 2 * PADDING, height.max(1) + 2 * PADDING);
        if w > ATLAS_SIZE || h > ATLAS_SIZE {
            return None;
        }
        // The first shelf tall enough with room left, else a new one.
        let shelf = match self.shelves.iter_mut().find(|s| s.height >= h && ATLAS_SIZE - s.x >= w) {
            Some(shelf) => shelf,
            None => {
                let y = self.shelves.last().map_or(0, |s| s.y + s.height);
                if ATLAS_SIZE - y < h {
                    return None;
                }
                self.shelves.push(Shelf { y, height: h, x: 0 });
                self.shelves.last_mut()?
            }
        };
        let rect = AtlasRect { x: shelf.x + PADDING, y: shelf.y + PADDING, width: width.max(1), height: height.max(1) };
        shelf.x += w;
        for y in 0..rect.height {
            for x in 0..rect.width {
                let at = (((rect.y + y) * ATLAS_SIZE + rect.x + x) * 4) as usize;
                self.pixels[at..at + 4].copy_from_slice(&fill(x, y));
            }
        }
        let rows = rect.y..rect.y + rect.height;
        self.dirty = Some(match self.dirty.take() {
            Some(d) => d.start.min(rows.start)..d.end.max(rows.end),
            None => rows,
        });
        self.entries.insert(key, rect);
        Some(rect)
    }

    /// Empties it (a new generation: every entry must be placed again).
    pub(crate) fn clear(&mut self) {
        self.pixels.fill(0);
        self.shelves.clear();
        self.entries.clear();
        self.generation += 1;
        self.dirty = Some(0..ATLAS_SIZE);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_never_overlap_and_keep_a_texel_apart() {
        let mut atlas = Atlas::default();
        let mut rects = Vec::new();
        for i in 0..500u32 {
            let (w, h) = (3 + i % 37, 5 + (i * 7) % 29);
            let key = AtlasKey::Glyph { font: 0, glyph: i as u16, size: 12 };
            match atlas.insert(key, w, h, |_, _| [255; 4]) {
                Some(rect) => rects.push(rect),
                None => break,
            }
        }
        assert!(rects.len() > 100, "only {} entries fitted", rects.len());
        for (i, a) in rects.iter().enumerate() {
            assert!(a.x + a.width < ATLAS_SIZE && a.y + a.height < ATLAS_SIZE, "{a:?} leaves the atlas");
            for b in &rects[i + 1..] {
                let apart_x = a.x + a.width + PADDING <= b.x || b.x + b.width + PADDING <= a.x;
                let apart_y = a.y + a.height + PADDING <= b.y || b.y + b.height + PADDING <= a.y;
                assert!(apart_x || apart_y, "{a:?} and {b:?} touch");
            }
        }
    }

    #[test]
    fn an_entry_is_placed_once_and_its_rows_are_dirty_until_uploaded() {
        let mut atlas = Atlas::default();
        let key = AtlasKey::Image(7);
        let first = atlas.insert(key, 4, 3, |x, y| [x as u8, y as u8, 0, 255]).unwrap();
        let again = atlas.insert(key, 4, 3, |_, _| [9; 4]).unwrap();
        assert_eq!(first, again);
        let texel = |x: u32, y: u32| {
            let at = (((first.y + y) * ATLAS_SIZE + first.x + x) * 4) as usize;
            atlas.pixels()[at..at + 4].to_vec()
        };
        assert_eq!(texel(3, 2), [3, 2, 0, 255]);
        assert_eq!(atlas.dirty_rows(), Some(first.y..first.y + 3));
        atlas.mark_uploaded();
        assert_eq!(atlas.dirty_rows(), None);
        assert!(atlas.insert(AtlasKey::Image(8), ATLAS_SIZE, 1, |_, _| [0; 4]).is_none(), "wider than the atlas");
        atlas.clear();
        assert_eq!((atlas.len(), atlas.generation(), atlas.dirty_rows()), (0, 1, Some(0..ATLAS_SIZE)));
    }
}
