//! A stable LSD radix sort of `(key, payload)` pairs by key.
//!
//! Draws are produced in (node id, submesh) order, so a *stable* sort by the
//! 64-bit key alone yields exactly (key, node id, submesh) order — the
//! deterministic tie-break — without widening the key. The sort key's low 16
//! bits are always zero and passes whose byte is the same for every key are
//! skipped (e.g. the pass-class byte in an all-opaque view), so a typical
//! frame needs 4–6 passes of one histogram and one scatter each.
//! `benches/prep.rs` measures it against `sort_unstable`.

/// Sorts `items` by `.0`, stably, using `scratch` as the second buffer
/// (both keep their capacity across calls).
pub fn radix_sort_by_key(items: &mut Vec<(u64, u32)>, scratch: &mut Vec<(u64, u32)>) {
    let n = items.len();
    if n < 64 {
        // Insertion-friendly sizes: the standard stable sort is faster here.
        items.sort_by_key(|(k, _)| *k);
        return;
    }
    // One read of the data builds all eight histograms.
    let mut histograms = [[0u32; 256]; 8];
    for (key, _) in items.iter() {
        for (byte, histogram) in histograms.iter_mut().enumerate() {
            histogram[((key >> (byte * 8)) & 0xff) as usize] += 1;
        }
    }
    scratch.clear();
    scratch.resize(n, (0, 0));
    for (byte, histogram) in histograms.iter().enumerate() {
        // Every key has the same value in this byte: the pass would not move anything.
        if histogram.iter().any(|&count| count as usize == n) {
            continue;
        }
        let mut offsets = [0u32; 256];
        let mut running = 0;
        for (offset, count) in offsets.iter_mut().zip(histogram) {
            *offset = running;
            running += count;
        }
        let shift = byte * 8;
        for item in items.iter() {
            let bucket = ((item.0 >> shift) & 0xff) as usize;
            scratch[offsets[bucket] as usize] = *item;
            offsets[bucket] += 1;
        }
        std::mem::swap(items, scratch);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_a_stable_comparison_sort() {
        let mut state = 0x1234_5678_9abc_def0u64;
        for n in [0, 1, 5, 63, 64, 65, 1000, 10_000] {
            let mut items: Vec<(u64, u32)> = (0..n)
                .map(|i| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    // Few distinct keys, so ties (and stability) matter.
                    ((state % 37) << 40 | (state % 3) << 62, i)
                })
                .collect();
            let mut expected = items.clone();
            expected.sort_by_key(|(k, _)| *k);
            radix_sort_by_key(&mut items, &mut Vec::new());
            assert_eq!(items, expected, "n = {n}");
        }
    }
}
