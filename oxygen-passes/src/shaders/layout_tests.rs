//! Every struct shared with WGSL has its Rust layout in the shaders that
//! read it: each composed module parsed with naga, each member's offset and
//! size and the struct's size compared with the Rust declaration. The
//! crate's structs are the registry's `gpu_struct!` sources, walked here
//! (one the shaders never include fails too); ScenePrep's GPU scene
//! records, which the cull shader declares by hand, are compared through
//! layouts written beside them.

use oxygen_gpu::{StructLayout, check_layout, gpu_layout};
use oxygen_sceneprep::DrawIndexedIndirect;
use oxygen_sceneprep::{GpuGroup, GpuInstance, GpuLod};

use super::compose::SourceText;
use super::registry::SOURCES;
use super::validate_tests::composed_modules;

/// The records the cull shader declares by hand, with the Rust structs
/// ScenePrep fills.
fn hand_written_twins() -> Vec<StructLayout> {
    vec![
        gpu_layout!(GpuInstance {
            aabb_min,
            group,
            aabb_max,
            flags,
            sphere,
            transform_index,
            node_id,
            submesh,
            lod_first,
            lod_count,
            joint_base,
            skin_slot,
            morph_base
        }),
        gpu_layout!(GpuGroup {
            vertex_slot,
            index_slot,
            first_index,
            index_count,
            base_vertex,
            material,
            pass_mask,
            command_base,
            draw_base,
            partition => "partition_index",
            capacity,
            attributes_slot
        }),
        gpu_layout!(GpuLod { below_screen_fraction, group }),
        gpu_layout!(DrawIndexedIndirect as "Command" {
            index_count,
            instance_count,
            first_index,
            base_vertex,
            first_instance
        }),
    ]
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
