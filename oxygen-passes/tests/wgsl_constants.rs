//! Every number the mesh shaders share with Rust reaches them as a
//! generated `const`, with the Rust value: checked in the assembled source
//! of every pass kind, iterating the Rust definitions themselves where they
//! can be iterated (a flag added to `PassMask` is checked without editing
//! this file).

mod support;

use oxygen_bindless::{INVALID_SLOT, MAX_TEXTURES};
use oxygen_passes::testing::{MAX_PROBES, MAX_SHADOW_TILES};
use oxygen_passes::{MAX_CASCADES, PROBE_FACES};
use oxygen_sceneprep::{DirectionalLightRecord, PassMask, PositionalLightRecord};
use support::{all_kinds, all_paths};

fn sources() -> Vec<(String, String)> {
    all_kinds()
        .into_iter()
        .flat_map(|kind| {
            all_paths().map(|path| (format!("{kind:?} / {path:?}"), oxygen_passes::testing::shader_source(kind, path)))
        })
        .collect()
}

fn assert_declared(what: &str, source: &str, name: &str, value: u32) {
    let line = format!("const {name}: u32 = {value:#x}u;");
    assert_eq!(source.lines().filter(|l| *l == line).count(), 1, "{what}: `{line}` not declared exactly once");
}

#[test]
fn every_pass_mask_flag_is_declared_in_every_mesh_shader() {
    for (what, source) in sources() {
        for (name, flag) in PassMask::all().iter_names() {
            assert_declared(&what, &source, &format!("PASS_{name}"), flag.bits());
        }
    }
}

#[test]
fn lighting_sizes_are_declared_in_every_mesh_shader() {
    for (what, source) in sources() {
        for (name, value) in [
            ("MAX_CASCADES", MAX_CASCADES),
            ("MAX_SHADOW_TILES", MAX_SHADOW_TILES),
            ("MAX_PROBES", MAX_PROBES),
            ("PROBE_FACES", PROBE_FACES),
        ] {
            assert_declared(&what, &source, name, value as u32);
        }
    }
}

#[test]
fn bindless_and_record_numbers_are_declared_in_every_mesh_shader() {
    for (what, source) in sources() {
        assert_declared(&what, &source, "INVALID_SLOT", INVALID_SLOT);
        assert_declared(&what, &source, "MAX_TEXTURES", MAX_TEXTURES);
        assert_declared(&what, &source, "LIGHT_SPOT", PositionalLightRecord::SPOT);
        assert_declared(&what, &source, "LIGHT_POINT", PositionalLightRecord::POINT);
        assert_declared(&what, &source, "LIGHT_CASTS_SHADOWS", DirectionalLightRecord::CASTS_SHADOWS);
        // Each generated block is in the source whole.
        for block in [
            oxygen_bindless::wgsl_constants(),
            PassMask::wgsl_constants(),
            oxygen_sceneprep::MaterialRecord::wgsl_constants(),
            PositionalLightRecord::wgsl_constants(),
        ] {
            assert!(source.contains(&block), "{what} lacks\n{block}");
        }
    }
}

/// The pass-mask bits are no longer written by hand in shared WGSL.
#[test]
fn gpu_records_wgsl_declares_no_pass_bits_of_its_own() {
    assert!(!oxygen_sceneprep::GPU_RECORDS_WGSL.contains("const PASS_"));
    assert!(!oxygen_bindless::SCENE_CONSTANTS_WGSL.contains("const INVALID_SLOT"));
}
