//! Every shader the passes build parses and validates with naga, without a
//! GPU, so a WGSL mistake fails here with a readable message rather than at
//! pipeline creation on some device.
//!
//! The mesh shaders are checked for every [`PassKind`] on every
//! [`TexturePath`]; both lists (in `support`) come from exhaustive matches, so adding a
//! kind or a path does not compile until it is listed here.

mod support;

use oxygen_bindless::TexturePath;
use oxygen_passes::PassKind;
use support::{all_kinds, all_paths};

/// The capabilities a device on `path` grants: the binding-array path
/// needs exactly what its device features enable, the grouped path nothing.
fn capabilities(path: TexturePath) -> naga::valid::Capabilities {
    match path {
        TexturePath::BindingArray => {
            naga::valid::Capabilities::TEXTURE_AND_SAMPLER_BINDING_ARRAY
                | naga::valid::Capabilities::TEXTURE_AND_SAMPLER_BINDING_ARRAY_NON_UNIFORM_INDEXING
        }
        TexturePath::GroupedArrays => naga::valid::Capabilities::default(),
    }
}

fn validate(what: &str, source: &str, capabilities: naga::valid::Capabilities) -> naga::Module {
    let module = naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{what} WGSL does not parse:\n{}", e.emit_to_string(source)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities)
        .validate(&module)
        .unwrap_or_else(|e| panic!("{what} WGSL does not validate: {e:?}"));
    module
}

#[test]
fn every_pass_shader_validates_on_every_texture_path() {
    for pass in all_kinds() {
        for textures in all_paths() {
            let source = oxygen_passes::testing::shader_source(pass, textures);
            validate(&format!("{pass:?} / {textures:?}"), &source, capabilities(textures));
        }
    }
}

/// The entry points each kind's pipelines use exist in its module.
#[test]
fn every_pass_shader_has_its_entry_points() {
    for pass in all_kinds() {
        let expected: &[&str] = match pass {
            PassKind::DepthPrePass | PassKind::Shadow => &["vs_main", "fs_alpha_test"],
            PassKind::ShadingAfterPrePass | PassKind::Shading | PassKind::Transparent => {
                &["vs_main", "fs_opaque", "fs_masked", "fs_blend"]
            }
            PassKind::Labels => &["vs_main", "fs_labels", "fs_labels_masked"],
        };
        for textures in all_paths() {
            let source = oxygen_passes::testing::shader_source(pass, textures);
            let module = validate(&format!("{pass:?} / {textures:?}"), &source, capabilities(textures));
            for name in expected {
                assert!(module.entry_points.iter().any(|e| e.name == *name), "{pass:?} / {textures:?} lacks {name}");
            }
        }
    }
}

#[test]
fn the_tonemap_shader_validates() {
    let module = validate("tonemap", &oxygen_passes::testing::TONEMAP_WGSL, naga::valid::Capabilities::default());
    for name in ["vs_fullscreen", "fs_tonemap"] {
        assert!(module.entry_points.iter().any(|e| e.name == name), "tonemap lacks {name}");
    }
}

/// The cube filter (environment conversion, box mips, GGX prefiltering,
/// irradiance harmonics) and the split-sum table, as their pipelines build
/// them.
#[test]
fn the_cube_filter_and_split_sum_shaders_validate() {
    let module =
        validate("cube filter", &oxygen_passes::testing::CUBE_FILTER_WGSL, naga::valid::Capabilities::default());
    for name in ["vs", "fs_downsample", "fs_sky", "fs_equirect", "fs_ggx", "fs_harmonics"] {
        assert!(module.entry_points.iter().any(|e| e.name == name), "cube filter lacks {name}");
    }
    let source = oxygen_passes::testing::split_sum_shader_source();
    let module = validate("split sum", &source, naga::valid::Capabilities::default());
    for name in ["vs", "fs"] {
        assert!(module.entry_points.iter().any(|e| e.name == name), "split sum lacks {name}");
    }
}

/// Every override constant a shading pipeline is created with is declared
/// by the shading shader (wgpu rejects an unknown one at pipeline creation),
/// and the module validates with each feature turned off in its source too.
#[test]
fn every_shading_override_constant_is_declared() {
    use oxygen_passes::{DepthBias, Exposure, PipelineKey, PipelineVariant, ShaderFeatures};
    let key = PipelineKey {
        pass: PassKind::ShadingAfterPrePass,
        variant: PipelineVariant::from_mask(oxygen_sceneprep::PassMask::OPAQUE),
        color_format: None,
        depth_format: wgpu::TextureFormat::Depth32Float,
        depth_bias: DepthBias::NONE,
        features: ShaderFeatures::NONE,
        tone_map: Some(Exposure::new(1.0)),
        samples: 1,
    };
    for textures in all_paths() {
        let source = oxygen_passes::testing::shader_source(PassKind::ShadingAfterPrePass, textures);
        let module = validate("shading", &source, capabilities(textures));
        let declared: Vec<_> = module.overrides.iter().filter_map(|(_, o)| o.name.clone()).collect();
        for (name, _) in key.override_constants() {
            assert!(declared.iter().any(|d| d == name), "{name} is not declared; declared: {declared:?}");
            // The defaults flipped, as a pipeline would set them.
            let (on, off) = (format!("override {name}: bool = true;"), format!("override {name}: bool = false;"));
            let flipped = if source.contains(&on) { source.replace(&on, &off) } else { source.replace(&off, &on) };
            validate(&format!("shading with {name} flipped"), &flipped, capabilities(textures));
        }
    }
}

/// The visibility cull shader validates and has its four entry points (its
/// records' layouts are the registry's layout test's: they are generated
/// from their Rust declarations).
#[test]
fn the_visibility_cull_shader_validates() {
    let source = oxygen_passes::testing::cull_shader_source();
    let module = validate("visibility cull", &source, naga::valid::Capabilities::default());
    for name in ["cull_early", "commands_early", "cull_late", "commands_late"] {
        assert!(module.entry_points.iter().any(|e| e.name == name), "the cull shader lacks {name}");
    }
}

/// The depth pyramid's shader validates with both its entry points.
#[test]
fn the_depth_pyramid_shader_validates() {
    let module =
        validate("depth pyramid", &oxygen_passes::testing::hiz_shader_source(), naga::valid::Capabilities::default());
    for name in ["copy_depth", "reduce"] {
        assert!(module.entry_points.iter().any(|e| e.name == name), "the depth pyramid shader lacks {name}");
    }
}

/// The path-traced reference's shader, on every texture path.
#[test]
fn the_reference_tracer_validates_on_every_texture_path() {
    for textures in all_paths() {
        let source = oxygen_passes::testing::reference_shader_source(textures);
        let module = validate(&format!("reference / {textures:?}"), &source, capabilities(textures));
        assert!(module.entry_points.iter().any(|e| e.name == "trace_paths"), "{textures:?} lacks trace_paths");
    }
}
