//! The numbers this crate defines that shaders read, emitted as WGSL
//! `const` declarations so that no shader copies them by hand.
//!
//! [`wgsl_constants`] is prepended to every mesh shader (before
//! [`crate::SCENE_CONSTANTS_WGSL`]); each name is the Rust one, prefixed
//! where it would be ambiguous in a shader.

use std::fmt::Write;

use crate::textures::{location, tables::WRAP_MODES};
use crate::{INVALID_SLOT, MAX_TEXTURES, RendererConstants};

/// WGSL `const` declarations of [`INVALID_SLOT`], the debug bits of
/// [`RendererConstants::debug_flags`] (`DEBUG_GENERATIONS`),
/// [`MAX_TEXTURES`], the texture sampler table's wrap modes
/// (`TEXTURE_WRAP_*`, by table index / 2) and the bit fields of a
/// texture-location record (`TEXTURE_LOCATION_*`).
pub fn wgsl_constants() -> String {
    let mut out = String::new();
    // Writing into a String cannot fail.
    let mut emit = |name: &str, value: u32| {
        let _ = writeln!(out, "const {name}: u32 = {value:#x}u;");
    };
    emit("INVALID_SLOT", INVALID_SLOT);
    emit("DEBUG_GENERATIONS", RendererConstants::DEBUG_GENERATIONS);
    emit("MAX_TEXTURES", MAX_TEXTURES);
    for (index, (name, _)) in WRAP_MODES.iter().enumerate() {
        emit(&format!("TEXTURE_WRAP_{name}"), index as u32);
    }
    out.push_str(&location::wgsl_constants());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn declares(wgsl: &str, name: &str, value: u32) -> bool {
        wgsl.lines().any(|line| line == format!("const {name}: u32 = {value:#x}u;"))
    }

    #[test]
    fn every_shared_number_is_declared_with_its_rust_value() {
        let wgsl = wgsl_constants();
        assert!(declares(&wgsl, "INVALID_SLOT", INVALID_SLOT), "{wgsl}");
        assert!(declares(&wgsl, "DEBUG_GENERATIONS", RendererConstants::DEBUG_GENERATIONS), "{wgsl}");
        assert!(declares(&wgsl, "MAX_TEXTURES", MAX_TEXTURES), "{wgsl}");
        for (index, (name, _)) in WRAP_MODES.iter().enumerate() {
            assert!(declares(&wgsl, &format!("TEXTURE_WRAP_{name}"), index as u32), "{name}: {wgsl}");
        }
        for line in location::wgsl_constants().lines() {
            assert!(wgsl.lines().any(|l| l == line), "{line}");
        }
    }

    /// The block parses on its own and declares each name once.
    #[test]
    fn the_constants_parse_as_wgsl() {
        let wgsl = wgsl_constants();
        let module = naga::front::wgsl::parse_str(&wgsl).expect("wgsl_constants() parses");
        assert_eq!(module.constants.len(), wgsl.lines().count());
    }
}
