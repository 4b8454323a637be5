//! The draw sort key.
//!
//! ```text
//! bit 63..62  pass class      0 opaque, 1 masked, 2 transparent
//! bit 61      variant         1 = double-sided
//! bit 60..40  material        stable material id (21 bits, saturating)
//! bit 39..16  depth           24-bit quantized view depth; opaque ascending
//!                             (front-to-back), transparent inverted (back-to-front)
//! bit 15..0   zero
//! ```
//! Ties are broken by (node id, submesh) outside the key, so the same scene
//! always gives the same order.
//!
//! Depth quantization keeps the top 24 bits of the IEEE-754 pattern of the
//! (non-negative) depth: monotonic, scale-free (no near/far needed, so an
//! infinite far plane is fine) with a relative resolution of 2^-16.

use crate::PassMask;

const MATERIAL_BITS: u32 = 21;
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
    let variant = u64::from(mask.contains(PassMask::DOUBLE_SIDED));
    let material = u64::from(material.min((1 << MATERIAL_BITS) - 1));
    let mut depth = u64::from(quantize_depth(view_depth));
    if class == 2 {
        depth = ((1 << DEPTH_BITS) - 1) - depth;
    }
    (class << 62) | (variant << 61) | (material << 40) | (depth << 16)
}

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
    }
}
