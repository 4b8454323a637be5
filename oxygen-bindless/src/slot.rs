//! CPU-side slot allocation with generation-checked handles.
//!
//! A domain is a line of record slots. An [`Allocation`] is a contiguous range
//! of them plus a key with a generation: freeing the range bumps the
//! generation, so writing through or freeing a stale handle is an error
//! instead of a silent write into someone else's records. Freed ranges go to
//! a first-fit free list and are coalesced, so a steady-state frame loop that
//! frees and re-allocates the same sizes gets the same slots back and the
//! domain does not grow.

use slotmap::{SlotMap, new_key_type};
use thiserror::Error;

use crate::DomainKind;

/// The absent slot. Shaders treat it as "no such record".
pub const INVALID_SLOT: u32 = u32::MAX;

new_key_type! {
    /// Generation-checked identity of a live allocation.
    struct AllocationKey;
}

/// A contiguous range of slots in one domain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Allocation {
    key: Option<AllocationKey>,
    domain: DomainKind,
    /// First slot, or [`INVALID_SLOT`] for an empty allocation.
    pub start: u32,
    /// Number of slots.
    pub count: u32,
}

impl Allocation {
    /// An empty allocation: nothing to free, `start` is [`INVALID_SLOT`].
    pub const fn empty(domain: DomainKind) -> Self {
        Allocation { key: None, domain, start: INVALID_SLOT, count: 0 }
    }

    /// The domain this range lives in.
    pub fn domain(&self) -> DomainKind {
        self.domain
    }

    /// The generation of this range's handle (its key version; 0 when empty).
    /// Debug builds of a view write it into GPU records so shaders can detect
    /// a read through a stale slot.
    pub fn generation(&self) -> u32 {
        self.key.map_or(0, |k| (slotmap::Key::data(&k).as_ffi() >> 32) as u32)
    }

    /// One past the last slot.
    pub fn end(&self) -> u32 {
        if self.count == 0 { self.start } else { self.start + self.count }
    }
}

/// A misuse of slots.
#[derive(Debug, Error, PartialEq)]
pub enum SlotError {
    /// The handle was freed (or belongs to another allocator).
    #[error("stale {domain} slot range {start}..+{count}: it was freed or never belonged to this heap")]
    Stale {
        /// Domain name.
        domain: &'static str,
        /// First slot of the stale range.
        start: u32,
        /// Its length.
        count: u32,
    },
    /// The domain would exceed its maximum size.
    #[error(
        "{domain} domain cannot hold {requested} more records ({live} live, limit {limit} records = {limit_bytes} bytes, the adapter's max_storage_buffer_binding_size)"
    )]
    DomainFull {
        /// Domain name.
        domain: &'static str,
        /// Records asked for.
        requested: u32,
        /// Records already in use (high-water mark).
        live: u32,
        /// Record limit.
        limit: u32,
        /// Byte limit.
        limit_bytes: u64,
    },
    /// A write does not fit its allocation.
    #[error("writing {records} records into a {domain} allocation of {count}")]
    WriteTooLarge {
        /// Domain name.
        domain: &'static str,
        /// Records written.
        records: usize,
        /// Allocation size.
        count: u32,
    },
}

/// Range allocator of one domain.
#[derive(Debug)]
pub struct SlotAllocator {
    domain: DomainKind,
    live: SlotMap<AllocationKey, (u32, u32)>,
    /// Free ranges below `high_water`, sorted by start, never adjacent.
    free: Vec<(u32, u32)>,
    high_water: u32,
    limit: u32,
}

impl SlotAllocator {
    /// An allocator that refuses to go past `limit` records.
    pub fn new(domain: DomainKind, limit: u32) -> Self {
        SlotAllocator { domain, live: SlotMap::with_key(), free: Vec::new(), high_water: 0, limit }
    }

    /// Allocates `count` contiguous slots (first fit).
    pub fn allocate(&mut self, count: u32) -> Result<Allocation, SlotError> {
        if count == 0 {
            return Ok(Allocation::empty(self.domain));
        }
        let start = if let Some(i) = self.free.iter().position(|(_, len)| *len >= count) {
            let (start, len) = self.free[i];
            if len == count {
                self.free.remove(i);
            } else {
                self.free[i] = (start + count, len - count);
            }
            start
        } else {
            let end = self.high_water as u64 + count as u64;
            if end > self.limit as u64 {
                return Err(SlotError::DomainFull {
                    domain: self.domain.name(),
                    requested: count,
                    live: self.high_water,
                    limit: self.limit,
                    limit_bytes: self.limit as u64 * self.domain.record_size(),
                });
            }
            let start = self.high_water;
            self.high_water += count;
            start
        };
        let key = self.live.insert((start, count));
        Ok(Allocation { key: Some(key), domain: self.domain, start, count })
    }

    /// Checks that `allocation` is live in this allocator.
    pub fn validate(&self, allocation: &Allocation) -> Result<(), SlotError> {
        match allocation.key {
            None if allocation.count == 0 => Ok(()),
            Some(key)
                if allocation.domain == self.domain
                    && self.live.get(key) == Some(&(allocation.start, allocation.count)) =>
            {
                Ok(())
            }
            _ => Err(self.stale(allocation)),
        }
    }

    fn stale(&self, a: &Allocation) -> SlotError {
        SlotError::Stale { domain: a.domain.name(), start: a.start, count: a.count }
    }

    /// Returns the range to the free list; a stale handle is an error.
    pub fn free(&mut self, allocation: Allocation) -> Result<(), SlotError> {
        self.validate(&allocation)?;
        let Some(key) = allocation.key else { return Ok(()) };
        self.live.remove(key);
        let (start, count) = (allocation.start, allocation.count);
        let i = self.free.partition_point(|(s, _)| *s < start);
        self.free.insert(i, (start, count));
        // Coalesce with the next, then the previous neighbour.
        if i + 1 < self.free.len() && self.free[i].0 + self.free[i].1 == self.free[i + 1].0 {
            self.free[i].1 += self.free[i + 1].1;
            self.free.remove(i + 1);
        }
        if i > 0 && self.free[i - 1].0 + self.free[i - 1].1 == self.free[i].0 {
            self.free[i - 1].1 += self.free[i].1;
            self.free.remove(i);
        }
        // A free range at the top gives its slots back to the high-water mark.
        if let Some(&(s, len)) = self.free.last()
            && s + len == self.high_water
        {
            self.high_water = s;
            self.free.pop();
        }
        Ok(())
    }

    /// One past the highest slot ever in use now; the GPU buffer must hold this many.
    pub fn high_water(&self) -> u32 {
        self.high_water
    }

    /// Number of live allocations.
    pub fn live_allocations(&self) -> usize {
        self.live.len()
    }

    /// Number of slots in live allocations.
    pub fn live_slots(&self) -> u64 {
        self.live.values().map(|(_, c)| *c as u64).sum()
    }

    /// The domain.
    pub fn domain(&self) -> DomainKind {
        self.domain
    }
}

/// One [`SlotAllocator`] per domain.
#[derive(Debug)]
pub struct SlotAllocators {
    domains: Vec<SlotAllocator>,
}

impl SlotAllocators {
    /// Allocators whose record limits follow from `max_binding_bytes`.
    pub fn new(max_binding_bytes: u64) -> Self {
        let domains = DomainKind::ALL
            .iter()
            .map(|k| {
                let limit = (max_binding_bytes / k.record_size()).min(u32::MAX as u64 - 1) as u32;
                SlotAllocator::new(*k, limit)
            })
            .collect();
        SlotAllocators { domains }
    }

    /// The allocator of one domain.
    pub fn get(&self, kind: DomainKind) -> &SlotAllocator {
        &self.domains[kind.index()]
    }

    /// The allocator of one domain, mutably.
    pub fn get_mut(&mut self, kind: DomainKind) -> &mut SlotAllocator {
        &mut self.domains[kind.index()]
    }

    /// Allocates in `kind`.
    pub fn allocate(&mut self, kind: DomainKind, count: u32) -> Result<Allocation, SlotError> {
        self.get_mut(kind).allocate(count)
    }

    /// Frees an allocation in its own domain.
    pub fn free(&mut self, allocation: Allocation) -> Result<(), SlotError> {
        self.get_mut(allocation.domain).free(allocation)
    }
}

impl Default for SlotAllocators {
    /// Limits of WebGPU's default `max_storage_buffer_binding_size` (128 MiB).
    fn default() -> Self {
        SlotAllocators::new(128 << 20)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn freed_ranges_are_reused_and_coalesced() {
        let mut a = SlotAllocator::new(DomainKind::Materials, 1000);
        let x = a.allocate(10).unwrap();
        let y = a.allocate(5).unwrap();
        let z = a.allocate(7).unwrap();
        assert_eq!((x.start, y.start, z.start), (0, 10, 15));
        a.free(x).unwrap();
        a.free(y).unwrap();
        let w = a.allocate(15).unwrap();
        assert_eq!(w.start, 0, "coalesced 10 + 5 should fit 15 at slot 0");
        assert_eq!(a.high_water(), 22);
        a.free(z).unwrap();
        a.free(w).unwrap();
        assert_eq!(a.high_water(), 0);
        assert_eq!(a.live_allocations(), 0);
    }

    #[test]
    fn stale_handle_is_detected_not_reused() {
        let mut a = SlotAllocator::new(DomainKind::DrawMetadata, 1000);
        let x = a.allocate(4).unwrap();
        a.free(x).unwrap();
        let y = a.allocate(4).unwrap();
        assert_eq!(y.start, x.start, "same slots come back");
        assert!(matches!(a.validate(&x), Err(SlotError::Stale { .. })));
        assert!(a.free(x).is_err());
        assert!(a.validate(&y).is_ok());
    }

    #[test]
    fn a_full_domain_names_itself_and_its_limit() {
        let mut a = SlotAllocator::new(DomainKind::Vertices, 100);
        a.allocate(90).unwrap();
        let err = a.allocate(20).unwrap_err();
        let text = err.to_string();
        assert!(text.contains("vertices") && text.contains("limit 100"), "{text}");
    }

    #[test]
    fn steady_state_alloc_free_does_not_grow() {
        let mut a = SlotAllocator::new(DomainKind::DrawMetadata, 1 << 20);
        let persistent = a.allocate(3).unwrap();
        for frame in 0..10_000u32 {
            let n = 1 + frame % 17;
            let x = a.allocate(n).unwrap();
            let y = a.allocate(2 * n).unwrap();
            a.free(x).unwrap();
            a.free(y).unwrap();
        }
        assert_eq!(a.high_water(), 3);
        assert_eq!(a.live_allocations(), 1);
        a.free(persistent).unwrap();
        assert_eq!(a.live_slots(), 0);
    }
}
