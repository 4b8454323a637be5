//! The texture-location record: one `u32` per texture slot, written by the
//! heap at upload and decoded by `sample_texture` in WGSL.
//!
//! Both sides read the bit fields declared here: Rust through
//! [`binding_array_record`] and [`grouped_record`], WGSL through the
//! constants [`wgsl_constants`] emits, so a field moved here moves in every
//! shader.
//!
//! | bits  | binding-array path          | grouped-arrays path        |
//! |-------|-----------------------------|----------------------------|
//! | 0–21  | the slot (unused by shaders) | layer in the array        |
//! | 22–23 | wrap mode along v           | wrap mode along v          |
//! | 24–26 | —                           | array (size class × colour space) |
//! | 27    | —                           | nearest filtering          |
//! | 29–31 | sampler-table index (wraps u) | wrap mode along u (table index / 2) |

use std::fmt::Write;

/// The bit fields of a location record, named as a struct so that
/// [`wgsl_constants`] must destructure (and so emit) every one of them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LocationBits {
    /// Grouped path: mask of the layer field (bits 0–21).
    pub(crate) layer_mask: u32,
    /// Shift of the v-axis wrap mode (both paths).
    pub(crate) wrap_v_shift: u32,
    /// Mask of the v-axis wrap mode once shifted down.
    pub(crate) wrap_v_mask: u32,
    /// Grouped path: shift of the array field.
    pub(crate) group_shift: u32,
    /// Grouped path: mask of the array field once shifted down.
    pub(crate) group_mask: u32,
    /// Grouped path: set for nearest-filtered textures.
    pub(crate) nearest_bit: u32,
    /// Shift of the sampler index (binding-array path) or wrap mode
    /// (grouped path); the field runs to bit 31, so it needs no mask.
    pub(crate) sampler_shift: u32,
}

/// The one definition of the record's layout.
pub(crate) const BITS: LocationBits = LocationBits {
    layer_mask: 0x003f_ffff,
    wrap_v_shift: 22,
    wrap_v_mask: 0x3,
    group_shift: 24,
    group_mask: 0x7,
    nearest_bit: 1 << 27,
    sampler_shift: 29,
};

/// The record of a binding-array texture: its slot, sampler-table index
/// and v-axis wrap mode. The slot is kept for debugging only: it is masked
/// to its field (slots stay far below it, `MAX_TEXTURES`).
pub(crate) fn binding_array_record(slot: u32, sampler: u32, wrap_v: u32) -> u32 {
    sampler << BITS.sampler_shift | (wrap_v & BITS.wrap_v_mask) << BITS.wrap_v_shift | (slot & BITS.layer_mask)
}

/// The record of a grouped-arrays texture: array `group`, `layer` in it,
/// wrap modes and filter.
pub(crate) fn grouped_record(group: u32, layer: u32, wrap_u: u32, wrap_v: u32, nearest: bool) -> u32 {
    let nearest_bit = if nearest { BITS.nearest_bit } else { 0 };
    wrap_u << BITS.sampler_shift
        | nearest_bit
        | group << BITS.group_shift
        | (wrap_v & BITS.wrap_v_mask) << BITS.wrap_v_shift
        | layer
}

/// WGSL `const` declarations of every field of [`BITS`], prefixed
/// `TEXTURE_LOCATION_`.
pub(crate) fn wgsl_constants() -> String {
    // No `..`: a field added to `LocationBits` does not compile until it is emitted.
    let LocationBits { layer_mask, wrap_v_shift, wrap_v_mask, group_shift, group_mask, nearest_bit, sampler_shift } =
        BITS;
    let fields = [
        ("LAYER_MASK", layer_mask),
        ("WRAP_V_SHIFT", wrap_v_shift),
        ("WRAP_V_MASK", wrap_v_mask),
        ("GROUP_SHIFT", group_shift),
        ("GROUP_MASK", group_mask),
        ("NEAREST_BIT", nearest_bit),
        ("SAMPLER_SHIFT", sampler_shift),
    ];
    let mut out = String::new();
    for (name, value) in fields {
        // Writing into a String cannot fail.
        let _ = writeln!(out, "const TEXTURE_LOCATION_{name}: u32 = {value:#x}u;");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_location_field_is_emitted_with_its_value() {
        let wgsl = wgsl_constants();
        let LocationBits { layer_mask, wrap_v_shift, wrap_v_mask, group_shift, group_mask, nearest_bit, sampler_shift } =
            BITS;
        for (name, value) in [
            ("LAYER_MASK", layer_mask),
            ("WRAP_V_SHIFT", wrap_v_shift),
            ("WRAP_V_MASK", wrap_v_mask),
            ("GROUP_SHIFT", group_shift),
            ("GROUP_MASK", group_mask),
            ("NEAREST_BIT", nearest_bit),
            ("SAMPLER_SHIFT", sampler_shift),
        ] {
            assert!(wgsl.contains(&format!("const TEXTURE_LOCATION_{name}: u32 = {value:#x}u;\n")), "{name}:\n{wgsl}");
        }
        assert_eq!(wgsl.lines().count(), 7);
    }

    #[test]
    fn the_fields_do_not_overlap() {
        let group = BITS.group_mask << BITS.group_shift;
        let sampler = u32::MAX << BITS.sampler_shift;
        let wrap_v = BITS.wrap_v_mask << BITS.wrap_v_shift;
        let fields = [BITS.layer_mask, wrap_v, group, BITS.nearest_bit, sampler];
        for (i, a) in fields.iter().enumerate() {
            for b in &fields[i + 1..] {
                assert_eq!(a & b, 0, "{a:#x} overlaps {b:#x}");
            }
        }
    }

    /// Decoded the way `sample_texture` decodes it, a grouped record gives
    /// back what was written.
    #[test]
    fn grouped_records_decode_to_what_was_written() {
        for (group, layer, wrap_u, wrap_v, nearest) in
            [(0, 0, 0, 0, false), (5, 0x003f_ffff, 2, 1, true), (3, 1234, 1, 2, false)]
        {
            let record = grouped_record(group, layer, wrap_u, wrap_v, nearest);
            assert_eq!(record & BITS.layer_mask, layer);
            assert_eq!((record >> BITS.group_shift) & BITS.group_mask, group);
            assert_eq!(record >> BITS.sampler_shift, wrap_u);
            assert_eq!((record >> BITS.wrap_v_shift) & BITS.wrap_v_mask, wrap_v);
            assert_eq!(record & BITS.nearest_bit != 0, nearest);
        }
        let record = binding_array_record(17, 5, 1);
        // The slot is for debugging only, and it must still read back.
        assert_eq!(record & BITS.layer_mask, 17);
        assert_eq!(record >> BITS.sampler_shift, 5);
        assert_eq!((record >> BITS.wrap_v_shift) & BITS.wrap_v_mask, 1);
        // Every slot the binding-array path can have fits its field.
        const _: () = assert!(super::super::path::MAX_TEXTURES <= BITS.layer_mask);
    }
}
