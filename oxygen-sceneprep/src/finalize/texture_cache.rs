//! Texture slots: one `TextureLocations` record per texture some material
//! uses, allocated when the material table first refers to it and uploaded
//! once.

use std::sync::Arc;

use oxygen_bindless::{Allocation, SlotAllocators, SlotError, allocate_texture_slot};
use oxygen_core::scene::texture_index;
use oxygen_core::{TextureHandle, TextureImage};

/// Resident textures by stable texture id, plus uploads still owed.
#[derive(Default)]
pub struct TextureCache {
    entries: Vec<Option<(TextureHandle, Allocation)>>,
    pending: Vec<(Allocation, Arc<TextureImage>)>,
}

impl TextureCache {
    /// The slot of `handle`, allocating one (and queueing the upload) on first use.
    pub fn resolve(
        &mut self,
        handle: TextureHandle,
        image: &Arc<TextureImage>,
        slots: &mut SlotAllocators,
    ) -> Result<u32, SlotError> {
        let index = texture_index(handle) as usize;
        if let Some(Some((h, a))) = self.entries.get(index)
            && *h == handle
        {
            return Ok(a.start);
        }
        if let Some(Some((_, old))) = self.entries.get(index).copied() {
            self.pending.retain(|(p, _)| *p != old);
            slots.free(old)?;
        }
        let allocation = allocate_texture_slot(slots)?;
        if self.entries.len() <= index {
            self.entries.resize(index + 1, None);
        }
        self.entries[index] = Some((handle, allocation));
        self.pending.push((allocation, Arc::clone(image)));
        Ok(allocation.start)
    }

    /// Frees every texture's slot: the handles of another scene name other
    /// textures.
    pub fn clear(&mut self, slots: &mut SlotAllocators) -> Result<(), SlotError> {
        for (_, allocation) in self.entries.drain(..).flatten() {
            slots.free(allocation)?;
        }
        self.pending.clear();
        Ok(())
    }

    /// Moves the uploads owed into `out` (cleared first).
    pub fn take_pending(&mut self, out: &mut Vec<(Allocation, Arc<TextureImage>)>) {
        out.clear();
        out.append(&mut self.pending);
    }
}

#[cfg(test)]
mod tests {
    use oxygen_bindless::DomainKind;
    use slotmap::KeyData;

    use super::*;

    /// The handle of slot `index` at `version` (odd: occupied), as a scene
    /// whose texture slot was reused would hand out.
    fn handle(index: u32, version: u32) -> TextureHandle {
        TextureHandle::from(KeyData::from_ffi((u64::from(version) << 32) | u64::from(index)))
    }

    fn image(name: &str) -> Arc<TextureImage> {
        Arc::new(TextureImage::checker(name, 4, 2, [255; 4], [0, 0, 0, 255]))
    }

    /// The owed uploads, as (slot, texture name), in order.
    fn pending(cache: &mut TextureCache) -> Vec<(u32, String)> {
        let mut out = Vec::new();
        cache.take_pending(&mut out);
        out.iter().map(|(a, image)| (a.start, image.name().to_owned())).collect()
    }

    /// Each texture gets a slot of its own, the same one every time it is
    /// resolved, and its upload (to that slot) is owed once.
    #[test]
    fn a_texture_gets_one_slot_and_one_upload() -> Result<(), SlotError> {
        let mut slots = SlotAllocators::default();
        let mut cache = TextureCache::default();
        let (a, b) = (image("a"), image("b"));
        let slot_a = cache.resolve(handle(1, 1), &a, &mut slots)?;
        assert_eq!(cache.resolve(handle(1, 1), &a, &mut slots)?, slot_a);
        let slot_b = cache.resolve(handle(2, 1), &b, &mut slots)?;
        assert_ne!(slot_a, slot_b, "two textures, two slots");
        assert_eq!(pending(&mut cache), [(slot_a, "a".to_owned()), (slot_b, "b".to_owned())]);
        assert!(pending(&mut cache).is_empty(), "each upload is handed out once");
        assert_eq!(cache.resolve(handle(1, 1), &a, &mut slots)?, slot_a);
        assert!(pending(&mut cache).is_empty(), "a resident texture is not uploaded again");
        assert_eq!(slots.get(DomainKind::TextureLocations).live_allocations(), 2);
        Ok(())
    }

    /// A handle of another generation at a resident texture's index names
    /// another texture: resolving it frees the old slot (and drops its
    /// upload, if still owed) and queues the new texture's, leaving the
    /// other textures' uploads alone.
    #[test]
    fn a_new_generation_at_the_same_index_replaces_the_old_texture() -> Result<(), SlotError> {
        let mut slots = SlotAllocators::default();
        let mut cache = TextureCache::default();
        cache.resolve(handle(1, 1), &image("old"), &mut slots)?;
        let other = cache.resolve(handle(2, 1), &image("other"), &mut slots)?;
        let new = cache.resolve(handle(1, 3), &image("new"), &mut slots)?;
        assert_eq!(pending(&mut cache), [(other, "other".to_owned()), (new, "new".to_owned())]);
        assert_eq!(slots.get(DomainKind::TextureLocations).live_allocations(), 2, "the old slot was freed");
        Ok(())
    }

    /// Clearing (another scene's handles name other textures) frees every
    /// slot and owed upload; a texture resolved afterwards is uploaded anew.
    #[test]
    fn clear_frees_every_texture() -> Result<(), SlotError> {
        let mut slots = SlotAllocators::default();
        let mut cache = TextureCache::default();
        let a = image("a");
        cache.resolve(handle(1, 1), &a, &mut slots)?;
        cache.resolve(handle(2, 1), &image("b"), &mut slots)?;
        cache.clear(&mut slots)?;
        assert_eq!(slots.get(DomainKind::TextureLocations).live_allocations(), 0);
        assert!(pending(&mut cache).is_empty(), "no upload owed for a freed slot");
        let slot = cache.resolve(handle(1, 1), &a, &mut slots)?;
        assert_eq!(pending(&mut cache), [(slot, "a".to_owned())]);
        Ok(())
    }
}
