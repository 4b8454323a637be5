//! Every struct shared with WGSL has its Rust layout in the shaders that
//! read it: each composed module parsed with naga, each member's offset and
//! size and the struct's size compared with the Rust declaration. The
//! structs are the registry's `gpu_struct!` sources, walked here (one the
//! shaders never include fails too): this crate's, oxygen-bindless' scene
//! constants, ScenePrep's records. oxygen-core's records of the vertex
//! domain, which shaders read through `VertexRecord`'s members, are
//! compared with `VertexRecord`'s layout (checked against naga's like the
//! others).

use oxygen_gpu::{GpuStruct, check_layout, check_overlay};
use oxygen_sceneprep::{VertexRecord, vertex_record_overlays};

use super::compose::SourceText;
use super::registry::SOURCES;
use super::validate_tests::composed_modules;

#[test]
fn every_struct_shared_with_wgsl_has_the_rust_layout_in_every_shader_declaring_it() {
    let modules = composed_modules();
    let generated = SOURCES.iter().filter_map(|s| match s.text {
        SourceText::Struct(layout) => Some(layout()),
        SourceText::Wgsl(_) | SourceText::Generated(_) => None,
    });
    let mut problems = Vec::new();
    for layout in generated {
        let mut declared_by = 0;
        for ((root, path, varyings), (_, module)) in &modules {
            if module.types.iter().any(|(_, t)| t.name.as_deref() == Some(layout.name)) {
                declared_by += 1;
                if let Err(problem) = check_layout(module, &layout) {
                    problems.push(format!("{root} / {path:?} / {varyings:?}: {problem}"));
                }
            }
        }
        if declared_by == 0 {
            problems.push(format!("{}: no shader declares it", layout.name));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// oxygen-core's vertex, attribute and skin records (and morph targets'
/// displacements, written as vertices) lie over whole `VertexRecord`
/// members, starting at the members the shaders read each field through.
#[test]
fn every_record_of_the_vertex_domain_lies_over_the_members_shaders_read() {
    let record = VertexRecord::layout();
    let problems: Vec<String> =
        vertex_record_overlays().iter().filter_map(|overlay| check_overlay(&record, overlay).err()).collect();
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
