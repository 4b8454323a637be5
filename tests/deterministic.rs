//! The deterministic mode (`RendererOptions::deterministic`): the same
//! scene, cameras and options give bit-identical outputs — colour, depth and
//! every label plane — whatever the visibility path (CPU, GPU frustum, GPU
//! occlusion), the number of threads, the order the views were registered
//! in and what the renderer drew before.
//!
//! The scene is built to make draw order visible: pairs of nodes share
//! exactly the same surface (same cube, same transform) in different
//! colours, materials, meshes and semantic classes, so every pixel of them
//! is a depth tie that the draw order decides. A test checks that it does
//! (the front-to-back order of the ordinary mode shows other pixels than the
//! canonical order), so the equalities below are not vacuous.
//!
//! Comparisons are of whole outputs, bit for bit: this mode's promise is
//! bit equality. The GPU paths need multi-draw-indirect with counts; on an
//! adapter without it (GL) their part is counted as skipped.

mod support;

use std::collections::BTreeMap;
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex};

use oxygen::core::{AlphaMode, LodLevel, NodeFlags};
use oxygen::glam::{Quat, Vec4};
use oxygen::lighting::CascadeSettings;
use oxygen::prelude::*;
use oxygen::sceneprep::Visibility;
use oxygen::views::{ResolvedView, ViewContext, ViewError, ViewResolver};

/// A camera the test moves between frames (to give a renderer a history).
#[derive(Clone)]
struct Moving(Arc<Mutex<(Vec3, Vec3)>>, UVec2);

impl ViewResolver for Moving {
    fn resolve(&self, ctx: &ViewContext, scene: &Scene) -> Result<ResolvedView, ViewError> {
        let (eye, target) = *self.0.lock().unwrap_or_else(|e| e.into_inner());
        LookAtResolver::new(Camera::perspective(55f32.to_radians(), 0.1, Some(120.0)), eye, target, self.1)
            .expect("the test's poses are valid")
            .resolve(ctx, scene)
    }
}

/// A view every configuration registers: a name, the camera's eye and
/// target, the viewport, whether it draws labels.
type ViewSpec = (&'static str, Vec3, Vec3, (u32, u32), bool);

/// The views every configuration registers.
const VIEWS: [ViewSpec; 3] = [
    ("main", Vec3::new(3.0, 9.0, 16.0), Vec3::new(0.0, 0.0, 0.0), (96, 64), true),
    ("side", Vec3::new(-14.0, 4.0, 2.0), Vec3::new(2.0, 0.5, 0.0), (80, 60), true),
    ("overhead", Vec3::new(0.5, 24.0, 0.5), Vec3::new(0.0, 0.0, 0.0), (64, 64), false),
];

/// Pairs of nodes on one surface (see the module docs) on a grid, with
/// masked, blended, double-sided, mirrored and LOD'd members, a floor and a
/// shadow-casting sun.
fn tie_scene() -> Scene {
    let mut scene = Scene::new();
    let colour = |i: u32| {
        let f = |k: u32| ((i * 7 + k * 3) % 5) as f32 / 4.0;
        Vec4::new(f(0), f(1), f(2), 0.8)
    };
    let mut materials = Vec::new();
    for i in 0..6u32 {
        let alpha_mode = match i {
            4 => AlphaMode::Mask { cutoff: 0.5 },
            5 => AlphaMode::Blend,
            _ => AlphaMode::Opaque,
        };
        let material = Material { alpha_mode, double_sided: i == 3, ..Material::opaque(format!("m{i}"), colour(i)) };
        materials.push(scene.add_material(material));
    }
    // Two meshes of the same cube: the same surface in two groups.
    let meshes = [scene.add_geometry(Geometry::cube(1.0)), scene.add_geometry(Geometry::cube(1.0))];
    let coarse = scene.add_geometry(Geometry::cube(1.0));
    let floor = scene.add_node(
        "floor",
        Transform::from_translation(Vec3::new(0.0, -1.0, 0.0)).with_scale(Vec3::new(30.0, 1.0, 30.0)),
    );
    scene.set_renderable(floor, Renderable { geometry: meshes[0], materials: vec![materials[2]] }).unwrap();
    let mut class = 1;
    for z in 0..5 {
        for x in 0..5 {
            let i = (z * 5 + x) as usize;
            let at = Vec3::new(x as f32 * 2.5 - 5.0, 0.0, z as f32 * 2.5 - 5.0);
            let rotation = Quat::from_rotation_y(i as f32 * 0.37);
            let mut scale = Vec3::splat(0.8 + (i % 3) as f32 * 0.2);
            if i % 7 == 3 {
                scale.x = -scale.x;
            }
            let transform = Transform { translation: at, rotation, scale };
            // Two (every other cell three) members on exactly one surface,
            // added in an order that is not the canonical one: the first
            // and the third share a material but not a mesh, so the
            // canonical order (mesh, then node) draws the third first, and
            // the ordinary one (depth, equal here, then node) the first.
            let members = [
                (meshes[1], materials[i % 4]),
                (meshes[(i / 2) % 2], materials[(i + 1) % 6]),
                (meshes[0], materials[i % 4]),
            ];
            for (m, &(geometry, material)) in members.iter().enumerate().take(2 + usize::from(i.is_multiple_of(2))) {
                let node = scene.add_node(format!("cell {i} member {m}"), transform);
                scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
                scene.set_semantic_class(node, class).unwrap();
                class += 1;
                if i % 5 == 1 {
                    let lods = vec![LodLevel { geometry: coarse, below_screen_fraction: 0.15 }];
                    scene.set_lods(node, lods).unwrap();
                }
                if i % 6 == 2 {
                    scene.set_flags(node, NodeFlags::VISIBLE).unwrap();
                }
            }
        }
    }
    let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_x(-0.9)));
    scene.set_light(sun, Some(Light::directional(3.0))).unwrap();
    scene
}

/// How one configuration renders.
#[derive(Clone, Copy, Debug)]
struct Config {
    visibility: Visibility,
    threads: usize,
    reversed: bool,
    /// Frames rendered from elsewhere first (a history), then the poses.
    history: bool,
    deterministic: bool,
}

/// Every output of every view, by view name: a hash of the colour image,
/// the device depth and each label plane, bit for bit.
type Fingerprints = BTreeMap<&'static str, [u64; 3]>;

fn hash_of(bytes: impl Hash) -> u64 {
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    bytes.hash(&mut hasher);
    hasher.finish()
}

/// Renders `scene` through [`VIEWS`] as `config` says and fingerprints
/// every output; `None` (skipped, with the reason) when the adapter cannot
/// run the configuration's visibility path.
fn render(scene: &Scene, config: Config) -> Option<Fingerprints> {
    let options = RendererOptions {
        visibility: Some(config.visibility),
        prep_threads: Some(config.threads),
        deterministic: config.deterministic,
        ..Default::default()
    };
    let mut renderer = support::gpu_renderer_with(options);
    if config.visibility.on_gpu() && !renderer.gpu_visibility_supported() {
        support::skip::skip_part(
            &format!("{:?}", config.visibility),
            format_args!(
                "{} cannot run GPU visibility (needs multi-draw-indirect with counts)",
                renderer.gpu().describe()
            ),
        );
        return None;
    }
    let cascades = CascadeSettings { count: 2, resolution: 256, max_distance: 40.0, ..Default::default() };
    let mut order: Vec<usize> = (0..VIEWS.len()).collect();
    if config.reversed {
        order.reverse();
    }
    let mut views = Vec::new();
    for &v in &order {
        let (name, eye, target, (w, h), labels) = VIEWS[v];
        let pose = Arc::new(Mutex::new((eye, target)));
        let mut desc = ViewDesc::new(Moving(Arc::clone(&pose), UVec2::new(w, h)))
            .with_visibility(config.visibility)
            .with_sun_shadows(cascades);
        if labels {
            desc = desc.with_labels();
        }
        let id = renderer.register_view(desc, standard_render_graph).unwrap();
        views.push((name, id, pose, eye, target));
    }
    if config.history {
        // Elsewhere, then halfway back: what was visible, the depth
        // pyramids and the slots the meshes got all come from these frames.
        for (step, offset) in [Vec3::new(9.0, -4.0, -20.0), Vec3::new(4.0, 2.0, -6.0)].into_iter().enumerate() {
            for (_, _, pose, eye, target) in &views {
                *pose.lock().unwrap() = (*eye + offset, *target + offset * (step as f32 * 0.5));
            }
            renderer.render_frame(scene).unwrap();
        }
        for (_, _, pose, eye, target) in &views {
            *pose.lock().unwrap() = (*eye, *target);
        }
    }
    renderer.render_frame(scene).unwrap();
    let mut out = Fingerprints::new();
    for (name, id, ..) in &views {
        let colour = renderer.read_color(*id).unwrap();
        let depth: Vec<u32> = renderer.read_depth(*id).unwrap().depth.iter().map(|d| d.to_bits()).collect();
        let labels = match renderer.read_labels(*id) {
            Ok(labels) => {
                let normals: Vec<[u32; 3]> = labels.normals.iter().map(|n| n.map(f32::to_bits)).collect();
                let linear: Vec<u32> = labels.linear_depth.iter().map(|d| d.to_bits()).collect();
                hash_of((&labels.instances, normals, &labels.classes, linear))
            }
            Err(_) => 0,
        };
        out.insert(name, [hash_of(colour.as_raw()), hash_of(depth), labels]);
    }
    Some(out)
}

const REFERENCE: Config =
    Config { visibility: Visibility::Cpu, threads: 1, reversed: false, history: false, deterministic: true };

/// Names the outputs that differ between two fingerprints.
fn differences(expected: &Fingerprints, actual: &Fingerprints) -> Vec<String> {
    let mut out = Vec::new();
    for (name, want) in expected {
        let got = actual.get(name).copied().unwrap_or_default();
        for (output, (a, b)) in ["colour", "depth", "labels"].iter().zip(want.iter().zip(&got)) {
            if a != b {
                out.push(format!("{name} {output}"));
            }
        }
    }
    out
}

#[test]
fn the_tie_scene_shows_the_draw_order() {
    // Without this, the equalities below would hold for any order.
    let scene = tie_scene();
    let canonical = render(&scene, REFERENCE).unwrap();
    let front_to_back = render(&scene, Config { deterministic: false, ..REFERENCE }).unwrap();
    let differ = differences(&canonical, &front_to_back);
    assert!(
        differ.iter().any(|d| d.ends_with("colour")) && differ.iter().any(|d| d.ends_with("labels")),
        "the canonical and the front-to-back order show the same pixels ({differ:?}): the scene has no ties to decide"
    );
}

#[test]
fn every_output_is_bit_identical_across_paths_threads_orders_and_history() {
    let scene = tie_scene();
    let reference = render(&scene, REFERENCE).unwrap();
    let mut compared = 0;
    for visibility in [Visibility::Cpu, Visibility::GpuFrustum, Visibility::GpuOcclusion] {
        for (threads, reversed, history) in [(1, false, false), (3, true, false), (2, false, true), (3, true, true)] {
            let config = Config { visibility, threads, reversed, history, deterministic: true };
            if (visibility, threads, reversed, history) == (Visibility::Cpu, 1, false, false) {
                continue;
            }
            let Some(actual) = render(&scene, config) else { break };
            let differ = differences(&reference, &actual);
            assert!(differ.is_empty(), "{config:?}: {differ:?} differ from {REFERENCE:?}");
            compared += 1;
        }
    }
    eprintln!("{compared} configurations matched the reference bit for bit");
    assert!(compared >= 3, "{compared} configurations compared");
}

#[test]
fn every_path_draws_one_sequence_whatever_the_history() {
    // What the pictures above rest on, checked draw by draw: the GPU
    // paths restore the CPU path's canonical order after culling, and
    // occlusion culling's list C merges what was drawn early (visible last
    // frame) and late in that order too.
    let scene = tie_scene();
    let options = RendererOptions { deterministic: true, ..Default::default() };
    let Some(mut renderer) = support::gpu_visibility_renderer(options) else { return };
    let (_, eye, target, (w, h), _) = VIEWS[0];
    // First a close look at the grid's left column only: every group then
    // has members drawn early (seen there) and late, in no instance order.
    let pose = Arc::new(Mutex::new((Vec3::new(-5.0, 4.0, 5.0), Vec3::new(-5.0, 0.0, -2.0))));
    let mut view = |visibility| {
        let desc = ViewDesc::new(Moving(Arc::clone(&pose), UVec2::new(w, h))).with_visibility(visibility);
        renderer.register_view(desc, standard_render_graph).unwrap()
    };
    let views = [view(Visibility::Cpu), view(Visibility::GpuFrustum), view(Visibility::GpuOcclusion)];
    renderer.render_frame(&scene).unwrap();
    *pose.lock().unwrap() = (eye, target);
    renderer.render_frame(&scene).unwrap();
    let sequence = |view| -> Vec<_> {
        let draws = renderer.view_draws_in_draw_order(view).unwrap();
        draws.into_iter().map(|d| oxygen::sceneprep::DrawMetadata { generation: 0, ..d }).collect()
    };
    let cpu = sequence(views[0]);
    assert!(cpu.len() > 40, "{} draws", cpu.len());
    for (gpu, path) in [(views[1], "GPU frustum"), (views[2], "GPU occlusion")] {
        let drawn = sequence(gpu);
        let first = cpu.iter().zip(&drawn).position(|(a, b)| a != b);
        assert!(
            drawn == cpu,
            "{path} drew {} draws, the CPU path {}; first difference at {first:?}",
            drawn.len(),
            cpu.len()
        );
    }
}

#[test]
fn the_shipped_scenes_render_bit_identically_twice() {
    // The CI check of the issue: every shipped scene, rendered by two
    // renderers that differ in threads, registration order and history.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    let mut files: Vec<_> = std::fs::read_dir(&root)
        .unwrap()
        .filter_map(|dir| {
            let dir = dir.ok()?.path();
            std::fs::read_dir(&dir)
                .ok()?
                .filter_map(|f| f.ok().map(|f| f.path()))
                .find(|f| f.extension().is_some_and(|e| e == "glb" || e == "gltf"))
        })
        .collect();
    files.sort();
    assert!(files.len() >= 10, "{} shipped scenes found under {}", files.len(), root.display());
    // Two renderers for all the scenes (each compiles its pipelines once:
    // made afresh per scene, this test took a minute and a half on GL),
    // differing in threads, and per scene in registration order and history.
    let renderer = |threads: usize| {
        support::gpu_renderer_with(RendererOptions {
            prep_threads: Some(threads),
            deterministic: true,
            ..Default::default()
        })
    };
    let mut renderers = [renderer(1), renderer(2)];
    for file in &files {
        let mut scene = Scene::new();
        let imported =
            import_gltf(&mut scene, file, &SceneChoice::Default).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        // Every shipped scene has something to frame: one without bounds
        // would otherwise pass by comparing nothing.
        let bounds = imported.bounds.unwrap_or_else(|| panic!("{}: no bounds to frame", file.display()));
        oxygen_demo::add_default_sun(&mut scene);
        let (center, radius) = ((bounds.min + bounds.max) * 0.5, (bounds.max - bounds.min).length().max(0.1));
        let fingerprint = |renderer: &mut Renderer, config: Config| {
            let eyes = [Vec3::new(0.4, 0.5, 1.0), Vec3::new(-1.0, 0.3, -0.4)];
            let mut order: Vec<Vec3> = eyes.to_vec();
            if config.reversed {
                order.reverse();
            }
            let mut views = Vec::new();
            for direction in order {
                let pose = Arc::new(Mutex::new((center + direction * radius * 1.4, center)));
                let desc = ViewDesc::new(Moving(Arc::clone(&pose), UVec2::new(72, 54))).with_labels();
                let id = renderer.register_view(desc, standard_render_graph).unwrap();
                views.push((direction, id, pose));
            }
            if config.history {
                for (direction, _, pose) in &views {
                    *pose.lock().unwrap() = (center - *direction * radius * 2.0, center + Vec3::Y * radius);
                }
                renderer.render_frame(&scene).unwrap();
                for (direction, _, pose) in &views {
                    *pose.lock().unwrap() = (center + *direction * radius * 1.4, center);
                }
            }
            renderer.render_frame(&scene).unwrap();
            let mut hashes: Vec<(String, u64)> = views
                .iter()
                .map(|(direction, id, _)| {
                    let colour = renderer.read_color(*id).unwrap();
                    let labels = renderer.read_labels(*id).unwrap();
                    let depth: Vec<u32> = labels.linear_depth.iter().map(|d| d.to_bits()).collect();
                    (format!("{direction}"), hash_of((colour.as_raw(), &labels.instances, depth)))
                })
                .collect();
            for (_, id, _) in views {
                renderer.unregister_view(id).unwrap();
            }
            hashes.sort();
            hashes
        };
        let [one_thread, two_threads] = &mut renderers;
        let first = fingerprint(one_thread, Config { threads: 1, reversed: false, history: false, ..REFERENCE });
        let second = fingerprint(two_threads, Config { threads: 2, reversed: true, history: true, ..REFERENCE });
        assert_eq!(first, second, "{}: two renders of the same frame differ", file.display());
    }
}

#[test]
fn a_batchs_cameras_culled_in_one_dispatch_draw_the_cpu_paths_sequence_and_pixels() {
    // A batch's cameras on the GPU path are culled in one dispatch (the
    // camera is its z), each compacting its own occupancy: the same draw
    // sequence and the same pixels, labels included, as the same batch
    // culled on the CPU.
    use oxygen::batch::BatchDesc;
    let scene = tie_scene();
    let mut renderer = support::gpu_renderer_with(RendererOptions { deterministic: true, ..Default::default() });
    if !renderer.gpu_visibility_supported() {
        support::skip::skip(format_args!(
            "{} cannot run GPU visibility (needs multi-draw-indirect with counts)",
            renderer.gpu().describe()
        ));
        return;
    }
    let size = UVec2::new(48, 40);
    let cpu = renderer.register_batch(BatchDesc::new("cpu", size).with_labels()).unwrap();
    let gpu = renderer.register_batch(BatchDesc::new("gpu", size).with_labels()).unwrap();
    let mut pairs = Vec::new();
    for (_, eye, target, _, _) in VIEWS {
        let camera = Moving(Arc::new(Mutex::new((eye, target))), size);
        let desc = |visibility| ViewDesc::new(camera.clone()).with_visibility(visibility);
        let on_cpu = renderer.add_camera(cpu, desc(Visibility::Cpu)).unwrap();
        let on_gpu = renderer.add_camera(gpu, desc(Visibility::GpuFrustum)).unwrap();
        pairs.push((on_cpu, on_gpu));
    }
    renderer.render_frame(&scene).unwrap();
    for (on_cpu, on_gpu) in pairs {
        assert_eq!(renderer.gpu_visibility().and_then(|v| v.culled_together(on_gpu)), Some(VIEWS.len()));
        let sequence = |view| -> Vec<_> {
            let draws = renderer.view_draws_in_draw_order(view).unwrap();
            draws.into_iter().map(|d| oxygen::sceneprep::DrawMetadata { generation: 0, ..d }).collect()
        };
        assert!(sequence(on_gpu) == sequence(on_cpu), "{on_gpu} drew another sequence than {on_cpu}");
        assert!(renderer.read_color(on_gpu).unwrap() == renderer.read_color(on_cpu).unwrap(), "{on_gpu}: colour");
        let (a, b) = (renderer.read_labels(on_gpu).unwrap(), renderer.read_labels(on_cpu).unwrap());
        assert!(a.instances == b.instances && a.classes == b.classes, "{on_gpu}: labels");
    }
}

#[test]
fn a_depth_pre_pass_changes_no_pixel_in_the_deterministic_mode() {
    // With a pre-pass the last of two surfaces at one depth shows; the
    // deterministic mode's shading pass without one lets the last show too
    // ("nearer or equal"), so the automatic choice, which each path makes
    // from its own estimate, changes the time and not the picture. In the
    // ordinary mode the first drawn shows without a pre-pass.
    use oxygen::graph::PrePass;
    let scene = tie_scene();
    let outputs = |deterministic: bool| {
        let mut renderer = support::gpu_renderer_with(RendererOptions { deterministic, ..Default::default() });
        let (_, eye, target, (w, h), _) = VIEWS[0];
        let camera = Moving(Arc::new(Mutex::new((eye, target))), UVec2::new(w, h));
        let graph = |pre_pass| standard_render_graph.with_pre_pass(pre_pass);
        let with: ViewId =
            renderer.register_view(ViewDesc::new(camera.clone()).with_labels(), graph(PrePass::On)).unwrap();
        let without = renderer.register_view(ViewDesc::new(camera).with_labels(), graph(PrePass::Off)).unwrap();
        renderer.render_frame(&scene).unwrap();
        let read = |view| (renderer.read_color(view).unwrap(), renderer.read_labels(view).unwrap().instances);
        (read(with), read(without))
    };
    let (with, without) = outputs(true);
    assert!(with == without, "the deterministic mode: a pre-pass changed the picture or the labels");
    let (with, without) = outputs(false);
    assert!(with.1 != without.1, "the ordinary mode: the pre-pass should decide the ties (the scene has none?)");
}
