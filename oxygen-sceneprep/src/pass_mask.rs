//! `PassMask`: which passes draw a record and with which pipeline variant.
//!
//! The flags are defined here once; shaders get them as `PASS_*` constants
//! from [`PassMask::wgsl_constants`], never as copied literals.

use bitflags::bitflags;
use oxygen_core::AlphaMode;

bitflags! {
    /// Per-draw flags, emitted in finalization from the material's alpha mode
    /// and double-sidedness (and the node's shadow flag).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
    pub struct PassMask: u32 {
        /// Alpha ignored; depth pre-pass and shading.
        const OPAQUE = 1 << 0;
        /// Alpha-tested against the material cutoff.
        const MASKED = 1 << 1;
        /// Alpha-blended; transparent pass, back-to-front.
        const TRANSPARENT = 1 << 2;
        /// No back-face culling.
        const DOUBLE_SIDED = 1 << 3;
        /// Drawn into shadow views.
        const CASTS_SHADOWS = 1 << 4;
        /// The world transform mirrors (negative determinant): the winding
        /// flips, so the pipeline's front face is clockwise.
        const MIRRORED = 1 << 5;
    }
}

impl PassMask {
    /// The bits that select a pass class and pipeline variant; partitions are
    /// runs of draws equal in these bits.
    pub const PARTITION_BITS: PassMask = PassMask::OPAQUE
        .union(PassMask::MASKED)
        .union(PassMask::TRANSPARENT)
        .union(PassMask::DOUBLE_SIDED)
        .union(PassMask::MIRRORED);

    /// The mask for a material (shadow bit added by the caller).
    pub fn for_material(alpha_mode: AlphaMode, double_sided: bool) -> PassMask {
        let class = match alpha_mode {
            AlphaMode::Opaque => PassMask::OPAQUE,
            AlphaMode::Mask { .. } => PassMask::MASKED,
            AlphaMode::Blend => PassMask::TRANSPARENT,
        };
        if double_sided { class | PassMask::DOUBLE_SIDED } else { class }
    }

    /// Sort rank of the pass class: opaque 0, masked 1, transparent 2.
    pub fn pass_class(self) -> u64 {
        if self.contains(PassMask::TRANSPARENT) {
            2
        } else if self.contains(PassMask::MASKED) {
            1
        } else {
            0
        }
    }

    /// WGSL `const` declarations of every flag, `PASS_` followed by the
    /// flag's name (`const PASS_MASKED: u32 = 0x2u;`), one per line.
    pub fn wgsl_constants() -> String {
        PassMask::all()
            .iter_names()
            .map(|(name, flag)| format!("const PASS_{name}: u32 = {:#x}u;\n", flag.bits()))
            .collect()
    }

    /// Flag names joined by `|`, stable for dumps (e.g. `MASKED|DOUBLE_SIDED`).
    pub fn names(self) -> String {
        let names: Vec<&str> = self.iter_names().map(|(n, _)| n).collect();
        if names.is_empty() { "NONE".to_owned() } else { names.join("|") }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Iterating the flags themselves, so a flag added later is checked too.
    #[test]
    fn every_flag_is_a_wgsl_constant_with_its_bits() {
        let wgsl = PassMask::wgsl_constants();
        for (name, flag) in PassMask::all().iter_names() {
            let line = format!("const PASS_{name}: u32 = {:#x}u;", flag.bits());
            assert!(wgsl.lines().any(|l| l == line), "{line} missing from\n{wgsl}");
        }
        assert_eq!(wgsl.lines().count(), PassMask::all().iter().count());
        assert!(wgsl.contains("const PASS_MIRRORED: u32 = 0x20u;"));
    }
}
