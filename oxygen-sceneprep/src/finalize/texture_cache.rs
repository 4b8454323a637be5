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
