//! The draw sort key.
//!
//! Opaque and masked draws:
//!
//! ```text
//! bit 63..62  pass class      0 opaque, 1 masked
//! bit 61      variant         double-sided
//! bit 60      variant         mirrored (clockwise front face)
//! bit 59..40  material        stable material id (20 bits, saturating)
//! bit 39..16  depth           24-bit quantized view depth, ascending (front-to-back)
//! bit 15..0   zero
//! ```
//!
//! Transparent draws put depth first, because blending is only right
//! back-to-front across the whole class, whatever the material:
//!
//! ```text
//! bit 63..62  pass class      2
//! bit 61..38  depth           24-bit quantized view depth, inverted (back-to-front)
//! bit 37      variant         mirrored
//! bit 36      variant         double-sided
//! bit 35..16  material        (20 bits)
//! ```
//! (The architecture brief orders transparent keys like opaque ones; that
//! sorts back-to-front only within one material and blends wrongly across
//! materials, so the measurement — the picture — wins.)
//!
//! With [`Instancing::ByGeometry`](crate::Instancing::ByGeometry), opaque and
//! masked keys put the geometry above the depth, so that draws of one mesh
//! and material sit side by side and become one instanced command:
//!
//! ```text
//! bit 59..40  material        (20 bits)
//! bit 39..24  geometry        stable geometry id (16 bits, saturating)
//! bit 23..0   depth           24-bit quantized view depth, ascending
//! ```
//!
//! Ties are broken by (node id, submesh) outside the key, so the same scene
//! always gives the same order.
//!
//! Depth quantization keeps the top 24 bits of the IEEE-754 pattern of the
//! (non-negative) depth: monotonic, scale-free (no near/far needed, so an
//! infinite far plane is fine) with a relative resolution of 2^-16.

use crate::PassMask;

const MATERIAL_BITS: u32 = 20;
const DEPTH_BITS: u32 = 24;

/// Quantizes a view depth to 24 monotonic bits; negative depth (behind the
/// eye, possible for a box straddling the near plane) and NaN become 0.
pub fn quantize_depth(view_depth: f32) -> u32 {
    let d = if view_depth > 0.0 { view_depth } else { 0.0 };
    // Positive finite floats order like their bit patterns; the top bit is 0,
    // so dropping 7 low bits leaves exactly 24.
    let d = if d.is_finite() { d } else { f32::MAX };
    d.to_bits() >> (31 - DEPTH_BITS)
}

/// The key for a draw.
pub fn sort_key(mask: PassMask, material: u32, view_depth: f32) -> u64 {
    let class = mask.pass_class();
    let double_sided = u64::from(mask.contains(PassMask::DOUBLE_SIDED));
    let mirrored = u64::from(mask.contains(PassMask::MIRRORED));
    let material = u64::from(material.min((1 << MATERIAL_BITS) - 1));
    let depth = u64::from(quantize_depth(view_depth));
    if class == 2 {
        let back_to_front = ((1 << DEPTH_BITS) - 1) - depth;
        (class << 62) | (back_to_front << 38) | (mirrored << 37) | (double_sided << 36) | (material << 16)
    } else {
        (class << 62) | (double_sided << 61) | (mirrored << 60) | (material << 40) | (depth << 16)
    }
}

/// The key for a draw when draws of one geometry are grouped: as
/// [`sort_key`], with the geometry between material and depth for opaque and
/// masked draws (front-to-back order then holds within one mesh of one
/// material). Transparent draws keep their back-to-front key.
pub fn sort_key_grouped(mask: PassMask, material: u32, geometry: u32, view_depth: f32) -> u64 {
    let key = sort_key(mask, material, view_depth);
    if mask.pass_class() == 2 {
        return key;
    }
    let geometry = u64::from(geometry.min((1 << GEOMETRY_BITS) - 1));
    let depth = u64::from(quantize_depth(view_depth));
    (key & !((1u64 << 40) - 1)) | (geometry << DEPTH_BITS) | depth
}

const GEOMETRY_BITS: u32 = 16;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantized_depth_is_monotonic() {
        let mut previous = 0;
        let mut d = 1e-6f32;
        while d < 1e30 {
            let q = quantize_depth(d);
            assert!(q >= previous);
            previous = q;
            d *= 1.01;
        }
        assert_eq!(quantize_depth(-5.0), 0);
        assert_eq!(quantize_depth(f32::NAN), 0);
    }

    #[test]
    fn transparent_sorts_back_to_front_opaque_front_to_back() {
        let near = sort_key(PassMask::OPAQUE, 0, 1.0);
        let far = sort_key(PassMask::OPAQUE, 0, 10.0);
        assert!(near < far);
        let near = sort_key(PassMask::TRANSPARENT, 0, 1.0);
        let far = sort_key(PassMask::TRANSPARENT, 0, 10.0);
        assert!(far < near);
        assert!(sort_key(PassMask::OPAQUE, 9, 1e9) < sort_key(PassMask::MASKED, 0, 0.0));
        assert!(sort_key(PassMask::MASKED | PassMask::DOUBLE_SIDED, 0, 0.0) > sort_key(PassMask::MASKED, 5, 1e9));
        // Transparent: depth decides before material and variant.
        let far_late_material = sort_key(PassMask::TRANSPARENT, 9, 10.0);
        let near_early_material = sort_key(PassMask::TRANSPARENT | PassMask::DOUBLE_SIDED, 0, 1.0);
        assert!(far_late_material < near_early_material);
    }

    /// A bound whose centre lies exactly in the eye's plane has a view depth
    /// of −0.0 (the negation of +0.0). It must quantize like 0: the sign
    /// bit's pattern shifted down is 2^24, one past the depth field, which
    /// would spill into the material bits of the key.
    #[test]
    fn negative_zero_depth_quantizes_like_zero() {
        assert_eq!(quantize_depth(-0.0), 0);
        for mask in [PassMask::OPAQUE, PassMask::TRANSPARENT] {
            assert_eq!(sort_key(mask, 3, -0.0), sort_key(mask, 3, 0.0), "{mask:?}");
        }
        assert_eq!(sort_key_grouped(PassMask::OPAQUE, 3, 9, -0.0), sort_key_grouped(PassMask::OPAQUE, 3, 9, 0.0));
    }

    /// Material ids past the 20-bit field saturate to its largest value
    /// (0xF_FFFF), in both layouts: such a draw sorts with the last
    /// material and never spills into the variant bits above the field.
    #[test]
    fn material_ids_past_the_field_saturate() {
        let largest = 0xF_FFFF;
        for mask in [PassMask::OPAQUE, PassMask::MASKED, PassMask::TRANSPARENT] {
            for id in [largest + 1, largest + 2, u32::MAX] {
                assert_eq!(sort_key(mask, id, 2.0), sort_key(mask, largest, 2.0), "{mask:?}, material {id}");
            }
        }
    }

    /// Geometry ids past the 16-bit field of a grouped key saturate to its
    /// largest value (0xFFFF) and never spill into the material above it.
    #[test]
    fn geometry_ids_past_the_field_saturate() {
        let largest = 0xFFFF;
        for id in [largest + 1, largest + 2, u32::MAX] {
            assert_eq!(
                sort_key_grouped(PassMask::OPAQUE, 5, id, 2.0),
                sort_key_grouped(PassMask::OPAQUE, 5, largest, 2.0),
                "geometry {id}"
            );
        }
    }

    /// Each variant has the bit the module's layout gives it (opaque and
    /// masked: double-sided 61, mirrored 60; transparent: mirrored 37,
    /// double-sided 36), so draws that differ only in a variant get
    /// different keys and the sort keeps each variant together (one
    /// partition, one pipeline) instead of interleaving them by node id.
    #[test]
    fn each_variant_sets_its_own_bit() {
        let layouts = [
            (PassMask::OPAQUE, 1u64 << 60, 1u64 << 61),
            (PassMask::MASKED, 1 << 60, 1 << 61),
            (PassMask::TRANSPARENT, 1 << 37, 1 << 36),
        ];
        for (class, mirrored_bit, double_sided_bit) in layouts {
            let plain = sort_key(class, 7, 3.0);
            assert_eq!(sort_key(class | PassMask::MIRRORED, 7, 3.0), plain | mirrored_bit, "{class:?} mirrored");
            assert_eq!(
                sort_key(class | PassMask::DOUBLE_SIDED, 7, 3.0),
                plain | double_sided_bit,
                "{class:?} double-sided"
            );
            assert_eq!(plain & (mirrored_bit | double_sided_bit), 0, "{class:?}");
        }
    }
}
