//! The range allocator's arithmetic: limits, first fit, coalescing of freed
//! neighbours and the high-water mark that sizes the GPU buffer.

use oxygen_bindless::{Allocation, DomainKind, SlotAllocator, SlotError};

const DOMAIN: DomainKind = DomainKind::DrawMetadata;

#[test]
fn a_domain_fills_exactly_to_its_limit_and_then_says_how_full_it_is() {
    let mut slots = SlotAllocator::new(DOMAIN, 10);
    let _a = slots.allocate(4).unwrap();
    let _b = slots.allocate(6).unwrap();
    assert_eq!(slots.high_water(), 10);
    let err = slots.allocate(1).unwrap_err();
    assert_eq!(
        err,
        SlotError::DomainFull {
            domain: DOMAIN.name(),
            requested: 1,
            live: 10,
            limit: 10,
            limit_bytes: 10 * DOMAIN.record_size(),
        }
    );
    assert!(err.to_string().contains("640 bytes"), "{err}");
}

#[test]
fn freed_neighbours_coalesce_and_first_fit_reuses_them() {
    let mut slots = SlotAllocator::new(DOMAIN, 100);
    let a = slots.allocate(2).unwrap(); // 0..2
    let b = slots.allocate(3).unwrap(); // 2..5
    let c = slots.allocate(4).unwrap(); // 5..9
    let d = slots.allocate(1).unwrap(); // 9..10
    assert_eq!([a.start, b.start, c.start, d.start], [0, 2, 5, 9]);
    slots.free(b).unwrap();
    slots.free(a).unwrap(); // merges with b's range after it: 0..5
    slots.free(c).unwrap(); // merges with 0..5 before it: 0..9
    assert_eq!(slots.high_water(), 10, "d still holds the top");
    // Only a coalesced range of 9 fits 9 slots below the high-water mark.
    let nine = slots.allocate(9).unwrap();
    assert_eq!(nine.start, 0);
    assert_eq!(slots.high_water(), 10);
    assert_eq!(slots.live_slots(), 10);
}

#[test]
fn freeing_the_top_range_lowers_the_high_water_mark_through_free_ranges_below() {
    let mut slots = SlotAllocator::new(DOMAIN, 100);
    let a = slots.allocate(2).unwrap(); // 0..2
    let b = slots.allocate(3).unwrap(); // 2..5
    let c = slots.allocate(4).unwrap(); // 5..9
    slots.free(b).unwrap();
    assert_eq!(slots.high_water(), 9);
    slots.free(c).unwrap(); // 2..9 is free and at the top
    assert_eq!(slots.high_water(), 2);
    // The next allocation of 3 starts right after a, not at the old top.
    assert_eq!(slots.allocate(3).unwrap().start, 2);
    slots.free(a).unwrap();
    assert_eq!(slots.live_allocations(), 1);
}

#[test]
fn a_first_fit_split_leaves_the_rest_of_the_range_free() {
    let mut slots = SlotAllocator::new(DOMAIN, 100);
    let a = slots.allocate(6).unwrap(); // 0..6
    let _guard = slots.allocate(1).unwrap(); // 6..7 keeps the range below the top
    slots.free(a).unwrap();
    let two = slots.allocate(2).unwrap();
    let four = slots.allocate(4).unwrap();
    assert_eq!((two.start, four.start), (0, 2));
    assert_eq!(slots.allocate(1).unwrap().start, 7, "the freed range is used up");
}

#[test]
fn a_forged_handle_without_a_key_is_stale_unless_it_is_empty() {
    let slots = SlotAllocator::new(DOMAIN, 100);
    slots.validate(&Allocation::empty(DOMAIN)).unwrap();
    let mut forged = Allocation::empty(DOMAIN);
    forged.start = 0;
    forged.count = 3;
    assert!(matches!(slots.validate(&forged), Err(SlotError::Stale { count: 3, .. })));
}
