//! Every shader module the crate compiles composes, parses and validates
//! with naga on every texture path it is built for, and holds each of its
//! entry points at its stage: one walk over [`ENTRY_POINTS`]. A WGSL mistake
//! fails here with a readable message rather than at pipeline creation on
//! some device. The mesh pipelines' choices (which entry points and which
//! override constants each [`PassKind`] uses) are checked against the same
//! composed modules.

use std::collections::{HashMap, HashSet};

use oxygen_bindless::TexturePath;

use super::compose::{Composer, SourceText};
use super::registry::{ENTRY_POINTS, MeshVaryings, SOURCES, ShaderModule, Stage};
use crate::pipelines::{
    DepthBias, Exposure, PassKind, PipelineKey, PipelineVariant, ShaderFeatures, mesh_entry_points, mesh_module,
};

/// The texture paths a module is composed for (`None`: it reads none).
pub(super) fn paths(module: ShaderModule) -> Vec<Option<TexturePath>> {
    if module.textured {
        // Exhaustive: a new path does not compile until it is listed.
        [TexturePath::BindingArray, TexturePath::GroupedArrays]
            .into_iter()
            .map(|path| match path {
                TexturePath::BindingArray | TexturePath::GroupedArrays => Some(path),
            })
            .collect()
    } else {
        vec![None]
    }
}

/// Each composition of a module: a texture path of [`paths`], and for a
/// mesh module each set of vertex outputs (the others compose with one).
pub(super) fn compositions(module: ShaderModule) -> Vec<(Option<TexturePath>, MeshVaryings)> {
    let varyings: &[MeshVaryings] = if module.mesh { &MeshVaryings::ALL } else { &[MeshVaryings::WithAttributes] };
    paths(module).into_iter().flat_map(|path| varyings.iter().map(move |v| (path, *v))).collect()
}

/// A composed module's key: its root, texture path and vertex outputs.
pub(super) type ModuleKey = (&'static str, Option<TexturePath>, MeshVaryings);

/// What a device on `path` grants: the binding-array path needs exactly
/// what its device features enable, the others nothing.
fn capabilities(path: Option<TexturePath>) -> naga::valid::Capabilities {
    match path {
        Some(TexturePath::BindingArray) => {
            naga::valid::Capabilities::TEXTURE_AND_SAMPLER_BINDING_ARRAY
                | naga::valid::Capabilities::TEXTURE_AND_SAMPLER_BINDING_ARRAY_NON_UNIFORM_INDEXING
        }
        Some(TexturePath::GroupedArrays) | None => naga::valid::Capabilities::default(),
    }
}

/// `source` parsed and validated with what a device on `path` grants;
/// panics naming `what` with naga's message.
fn validate(what: &str, source: &str, path: Option<TexturePath>) -> naga::Module {
    let module = naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{what} does not parse:\n{}", e.emit_to_string(source)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities(path))
        .validate(&module)
        .unwrap_or_else(|e| panic!("{what} does not validate: {e:?}"));
    module
}

/// Every module of [`ENTRY_POINTS`] in every composition, composed, parsed
/// and validated: (module, path, vertex outputs) → (source, module).
pub(super) fn composed_modules() -> HashMap<ModuleKey, (String, naga::Module)> {
    let mut modules = HashMap::new();
    for entry in ENTRY_POINTS {
        for (path, varyings) in compositions(entry.module) {
            modules.entry((entry.module.root, path, varyings)).or_insert_with(|| {
                let what = format!("{} / {path:?} / {varyings:?}", entry.module.root);
                let source =
                    entry.module.compose(path, varyings).unwrap_or_else(|e| panic!("{what} does not compose: {e}"));
                let module = validate(&what, &source, path);
                (source, module)
            });
        }
    }
    modules
}

#[test]
fn every_entry_point_validates_at_its_stage_in_every_composition() {
    let modules = composed_modules();
    for entry in ENTRY_POINTS {
        for (path, varyings) in compositions(entry.module) {
            let (_, module) = &modules[&(entry.module.root, path, varyings)];
            let found = module.entry_points.iter().find(|e| e.name == entry.name);
            let stage = found.map(|e| match e.stage {
                naga::ShaderStage::Vertex => Stage::Vertex,
                naga::ShaderStage::Fragment => Stage::Fragment,
                naga::ShaderStage::Compute => Stage::Compute,
                other => panic!("{}: unexpected stage {other:?}", entry.name),
            });
            assert_eq!(
                stage,
                Some(entry.stage),
                "{} / {path:?} / {varyings:?}: entry point {}",
                entry.module.root,
                entry.name
            );
        }
    }
    // And nothing else: every entry point of a module is listed.
    for ((root, path, varyings), (_, module)) in &modules {
        for e in &module.entry_points {
            assert!(
                ENTRY_POINTS.iter().any(|l| l.module.root == *root && l.name == e.name),
                "{root} / {path:?} / {varyings:?}: entry point {} is not in ENTRY_POINTS",
                e.name
            );
        }
    }
}

/// The plain vertex outputs are what their name says: fewer locations
/// than those with vertex attributes, and no colour or second UV set.
#[test]
fn plain_vertex_outputs_leave_the_attributes_out() {
    let modules = composed_modules();
    let locations = |varyings| {
        let (source, _) = &modules[&(super::FORWARD_LIT.root, Some(TexturePath::GroupedArrays), varyings)];
        let start = source.find("struct MeshIo {").expect("the vertex outputs are declared");
        let end = start + source[start..].find('}').expect("and closed");
        source[start..end].matches("@location(").count()
    };
    assert_eq!(locations(MeshVaryings::Plain), 3);
    assert_eq!(locations(MeshVaryings::WithAttributes), 5);
}

/// Every source of the registry is part of some module: the registry holds
/// no dead WGSL.
#[test]
fn every_registered_source_is_included_by_some_module() {
    let modules = composed_modules();
    for source in SOURCES {
        let marker = format!("// ---- {}\n", source.name);
        assert!(
            modules.values().any(|(text, _)| text.contains(&marker)),
            "{} is in the registry but no shader includes it",
            source.name
        );
    }
}

/// The registry's names are unique (a second source of a name would never
/// be found), and every WGSL file of the crate is registered.
#[test]
fn every_wgsl_file_is_registered_once() {
    for (i, source) in SOURCES.iter().enumerate() {
        assert!(SOURCES[..i].iter().all(|s| s.name != source.name), "{} registered twice", source.name);
    }
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/src");
    let mut files = Vec::new();
    let mut dirs = vec![std::path::PathBuf::from(root)];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).expect("src is readable") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "wgsl") {
                let name = path.strip_prefix(root).expect("below src").to_string_lossy().replace('\\', "/");
                files.push(name);
            }
        }
    }
    for file in files {
        let registered = SOURCES.iter().find(|s| s.name == file);
        assert!(registered.is_some(), "{file} is not in the shader registry");
        assert!(matches!(registered.map(|s| s.text), Some(SourceText::Wgsl(_))), "{file} is not registered as WGSL");
    }
}

/// A root that is not registered, and a registered module on a path it
/// was not built for, fail with the composer's error instead of a partial
/// shader.
#[test]
fn composing_outside_the_registry_is_an_error() {
    assert!(Composer::new(SOURCES).compose("mesh/nowhere.wgsl").is_err());
    let error = super::FORWARD_LIT
        .compose(None, MeshVaryings::WithAttributes)
        .expect_err("the texture path is chosen per device");
    assert!(error.to_string().contains("bindless/textures"), "{error}");
}

/// Every pass kind. The match has no wildcard: a new kind does not compile
/// until it is listed here, and so is checked below.
fn pass_kinds() -> [PassKind; 7] {
    let kinds = [
        PassKind::DepthPrePass,
        PassKind::Shadow,
        PassKind::ShadingAfterPrePass,
        PassKind::Shading,
        PassKind::Transparent,
        PassKind::Labels,
        PassKind::Visibility,
    ];
    for kind in kinds {
        match kind {
            PassKind::DepthPrePass
            | PassKind::Shadow
            | PassKind::ShadingAfterPrePass
            | PassKind::Shading
            | PassKind::Transparent
            | PassKind::Labels
            | PassKind::Visibility => {}
        }
    }
    kinds
}

/// The entry points every pass kind's pipelines are created with (what
/// `mesh_entry_points` answers the pipeline cache, masked or not) are
/// listed in [`ENTRY_POINTS`] for the module the kind compiles, at their
/// stage, so the walk above validated them.
#[test]
fn every_pass_kind_uses_listed_entry_points_of_its_module() {
    for pass in pass_kinds() {
        let module = mesh_module(pass);
        for (masked, labels) in [(false, false), (true, false), (false, true), (true, true)] {
            let (vertex, fragment) = mesh_entry_points(pass, masked, labels);
            for (name, stage) in [(Some(vertex), Stage::Vertex), (fragment, Stage::Fragment)] {
                let Some(name) = name else { continue };
                assert!(
                    ENTRY_POINTS.iter().any(|e| e.module == module && e.name == name && e.stage == stage),
                    "{pass:?} (masked: {masked}, labels: {labels}) uses {name}, not a {stage:?} entry point of {} in ENTRY_POINTS",
                    module.root
                );
            }
        }
    }
}

/// Every override constant a mesh pipeline is created with is declared by
/// the module its kind compiles, on every texture path (wgpu rejects an
/// unknown one at pipeline creation), and the module validates with each
/// boolean's default flipped, as a pipeline may set it.
#[test]
fn every_override_constant_of_a_mesh_pipeline_is_declared() {
    let modules = composed_modules();
    let mut flipped_already = HashSet::new();
    for pass in pass_kinds() {
        let key = PipelineKey {
            pass,
            variant: PipelineVariant::from_mask(oxygen_sceneprep::PassMask::OPAQUE),
            color_format: None,
            depth_format: wgpu::TextureFormat::Depth32Float,
            depth_bias: DepthBias::NONE,
            features: ShaderFeatures::NONE,
            tone_map: Some(Exposure::new(1.0)),
            samples: 1,
            labels: oxygen_gpu::LabelSet::ALL,
            last_tie_wins: false,
        };
        let module = mesh_module(pass);
        for (path, varyings) in compositions(module) {
            let (source, parsed) = &modules[&(module.root, path, varyings)];
            let declared: Vec<_> = parsed.overrides.iter().filter_map(|(_, o)| o.name.clone()).collect();
            for (name, _) in key.override_constants() {
                assert!(
                    declared.iter().any(|d| d == name),
                    "{pass:?} / {path:?}: {name} is not declared by {}; declared: {declared:?}",
                    module.root
                );
                // Several kinds share a module: flip each of its constants once.
                if !flipped_already.insert((module.root, path, varyings, name)) {
                    continue;
                }
                let (on, off) = (format!("override {name}: bool = true;"), format!("override {name}: bool = false;"));
                let flipped = if source.contains(&on) { source.replace(&on, &off) } else { source.replace(&off, &on) };
                validate(&format!("{} / {path:?} / {varyings:?} with {name} flipped", module.root), &flipped, path);
            }
        }
    }
}
