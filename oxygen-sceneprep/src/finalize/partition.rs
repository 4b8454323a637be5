//! Partitions: maximal runs of sorted draws that share a pass class and variant.

use crate::{DrawMetadata, PassMask};

/// A contiguous range `[begin, end)` of a view's sorted draws with one mask.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Partition {
    /// First draw.
    pub begin: u32,
    /// One past the last draw.
    pub end: u32,
    /// The pass class and variant bits ([`PassMask::PARTITION_BITS`]).
    pub mask: PassMask,
}

impl Partition {
    /// Number of draws.
    pub fn len(&self) -> u32 {
        self.end - self.begin
    }

    /// True for an empty range (never produced by [`build_partitions`]).
    pub fn is_empty(&self) -> bool {
        self.begin == self.end
    }

    /// The draw index range.
    pub fn range(&self) -> std::ops::Range<usize> {
        self.begin as usize..self.end as usize
    }
}

/// Splits sorted draws into partitions (cleared first).
pub fn build_partitions(draws: &[DrawMetadata], out: &mut Vec<Partition>) {
    out.clear();
    for (i, draw) in draws.iter().enumerate() {
        let mask = draw.mask() & PassMask::PARTITION_BITS;
        match out.last_mut() {
            Some(last) if last.mask == mask => last.end = i as u32 + 1,
            _ => out.push(Partition { begin: i as u32, end: i as u32 + 1, mask }),
        }
    }
}
