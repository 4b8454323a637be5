//! Every struct shared with WGSL has its Rust layout in the shaders that
//! read it: each composed module parsed with naga, each member's offset and
//! size and the struct's size compared with the Rust declaration. The
//! structs are the registry's `gpu_struct!` sources, walked here (one the
//! shaders never include fails too): this crate's, oxygen-bindless' scene
//! constants, ScenePrep's records. The one record still written by hand,
//! `VertexRecord` (oxygen-core's `Vertex` as scalars), is compared through
//! a layout written beside it.

use std::mem::{offset_of, size_of};

use oxygen_core::Vertex;
use oxygen_gpu::{FieldLayout, StructLayout, check_layout};

use super::compose::SourceText;
use super::registry::SOURCES;
use super::validate_tests::composed_modules;

/// The records the shaders declare by hand, with the Rust structs they
/// mirror: `VertexRecord` spells `Vertex`'s vectors as scalars (a `vec3`
/// member would be 16-byte aligned and break the 32-byte stride).
fn hand_written_twins() -> Vec<StructLayout> {
    let scalars = |names: [&'static str; 3], offset: usize| {
        names.into_iter().enumerate().map(move |(i, name)| FieldLayout {
            name,
            offset: offset + 4 * i,
            size: 4,
            wgsl_type: "",
        })
    };
    let fields = scalars(["px", "py", "pz"], offset_of!(Vertex, position))
        .chain(scalars(["nx", "ny", "nz"], offset_of!(Vertex, normal)))
        .chain(scalars(["u", "v", ""], offset_of!(Vertex, uv)).take(2))
        .collect();
    vec![StructLayout { name: "VertexRecord", size: size_of::<Vertex>(), fields }]
}

#[test]
fn every_struct_shared_with_wgsl_has_the_rust_layout_in_every_shader_declaring_it() {
    let modules = composed_modules();
    let generated = SOURCES.iter().filter_map(|s| match s.text {
        SourceText::Struct(layout) => Some(layout()),
        SourceText::Wgsl(_) | SourceText::Generated(_) => None,
    });
    let mut problems = Vec::new();
    for layout in generated.chain(hand_written_twins()) {
        let mut declared_by = 0;
        for ((root, path), (_, module)) in &modules {
            if module.types.iter().any(|(_, t)| t.name.as_deref() == Some(layout.name)) {
                declared_by += 1;
                if let Err(problem) = check_layout(module, &layout) {
                    problems.push(format!("{root} / {path:?}: {problem}"));
                }
            }
        }
        if declared_by == 0 {
            problems.push(format!("{}: no shader declares it", layout.name));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
