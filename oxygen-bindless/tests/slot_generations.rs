//! Generation-checked slots: a handle outlives its range only as an error.
//! (The GPU side of the same guarantee is `tests/gpu_debug_generations.rs`.)

use oxygen_bindless::{DomainKind, SlotAllocator, SlotError};

fn allocator() -> SlotAllocator {
    SlotAllocator::new(DomainKind::ALL[0], 1024)
}

#[test]
fn a_freed_handle_is_stale_for_validate_and_free() {
    let mut slots = allocator();
    let a = slots.allocate(8).unwrap();
    let copy = a;
    slots.validate(&a).unwrap();
    slots.free(a).unwrap();
    assert!(matches!(slots.validate(&copy), Err(SlotError::Stale { .. })));
    assert!(matches!(slots.free(copy), Err(SlotError::Stale { .. })));
}

#[test]
fn a_range_handed_out_again_does_not_revive_the_old_handle() {
    let mut slots = allocator();
    let old = slots.allocate(4).unwrap();
    let remembered = old;
    slots.free(old).unwrap();
    // First fit hands out the same slots again, under a new generation.
    let new = slots.allocate(4).unwrap();
    assert_eq!((new.start, new.count), (remembered.start, remembered.count));
    assert_ne!(new.generation(), remembered.generation());
    assert!(matches!(slots.validate(&remembered), Err(SlotError::Stale { .. })));
    slots.validate(&new).unwrap();
    assert!(matches!(slots.free(remembered), Err(SlotError::Stale { .. })));
    assert_eq!(slots.live_allocations(), 1, "the stale free must not free the new range");
}

#[test]
fn a_handle_from_another_domain_is_stale() {
    let mut first = SlotAllocator::new(DomainKind::ALL[0], 64);
    let mut second = SlotAllocator::new(DomainKind::ALL[1], 64);
    let a = first.allocate(2).unwrap();
    let _b = second.allocate(2).unwrap();
    assert!(matches!(second.validate(&a), Err(SlotError::Stale { .. })));
}

#[test]
fn an_allocation_ends_one_past_its_last_slot_and_an_empty_one_at_its_start() {
    let mut slots = allocator();
    let _first = slots.allocate(3).unwrap();
    let second = slots.allocate(5).unwrap();
    assert_eq!((second.start, second.end()), (3, 8));
    let empty = slots.allocate(0).unwrap();
    assert_eq!(empty.end(), empty.start);
    assert_eq!(empty.start, oxygen_bindless::INVALID_SLOT);
}
