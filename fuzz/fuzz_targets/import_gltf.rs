//! libFuzzer target: arbitrary bytes as a `.glb` or `.gltf` file imported
//! from memory with the default [`ImportLimits`], the limits an application
//! gets for an untrusted file.
//!
//! The import must return (`Ok` or `Err`, either is fine): a panic, an
//! abort, a sanitizer report, a timeout (`-timeout`) or a process over
//! libFuzzer's memory limit (`-rss_limit_mb`, 2 GiB by default; the default
//! limits keep an import near 1 GiB) is a finding. The seed corpus is in
//! `fuzz/seeds/import_gltf/`; see `fuzz/README.md`.

#![no_main]

use libfuzzer_sys::fuzz_target;
use oxygen::core::Scene;
use oxygen::import::{ImportLimits, ImportOptions, import_gltf_slice};

fuzz_target!(|data: &[u8]| {
    let options = ImportOptions { limits: ImportLimits::default(), ..ImportOptions::default() };
    let mut scene = Scene::new();
    let _ = import_gltf_slice(&mut scene, data, "fuzz-input.glb", &options);
});
