//! GPU-driven visibility against the CPU reference, rendered for real.
//!
//! * Frustum culling on the GPU draws exactly the CPU path's draws (same
//!   draws in every partition, compared in canonical order because the GPU's
//!   order within a partition is whatever order its threads won their
//!   slots), on seeded random scenes with every pass class, variant, LODs,
//!   mirrored transforms and shadow cascades, and on shipped glTF scenes.
//! * Two-phase occlusion culling never drops a visible object: along a
//!   camera path through a dense procedural city, each frame's picture with
//!   occlusion culling equals the same frame without it, and the test
//!   reports (and checks) how many draws it culled.
//! * A static scene seen by a still camera uploads under 1 KB per frame.
//!
//! The GPU paths need multi-draw-indirect with counts: on an adapter
//! without it (the GL backend) each test says so and returns.

mod support;

use oxygen::FrameReport;
use oxygen::core::LodLevel;
use oxygen::core::{AlphaMode, NodeFlags};
use oxygen::glam::{Quat, Vec4};
use oxygen::lighting::CascadeSettings;
use oxygen::prelude::*;
use oxygen::sceneprep::{DrawMetadata, PassMask, Visibility, canonical_dump};
use oxygen::views::{ResolvedView, ViewContext, ViewError, ViewResolver};
use support::golden::compare;
use support::gpu_renderer_with;
use support::rng::Rng;

/// A renderer whose default path is `visibility`, or `None` (with the
/// reason printed) when the adapter cannot run the GPU paths.
fn renderer(visibility: Visibility) -> Option<Renderer> {
    let renderer = gpu_renderer_with(RendererOptions { visibility: Some(visibility), ..Default::default() });
    if !renderer.gpu_visibility_supported() {
        support::skip::skip(format_args!(
            "{} cannot run GPU visibility (needs multi-draw-indirect with counts)",
            renderer.gpu().describe()
        ));
        return None;
    }
    Some(renderer)
}

/// Boxes of every pass class and variant scattered around the origin, some
/// mirrored, some not casting shadows, some with a coarser LOD, under a sun.
fn random_scene(seed: u64, count: usize) -> Scene {
    let mut rng = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let mut scene = Scene::new();
    let mut materials = Vec::new();
    for (i, alpha_mode) in [AlphaMode::Opaque, AlphaMode::Mask { cutoff: 0.5 }, AlphaMode::Blend, AlphaMode::Opaque]
        .into_iter()
        .enumerate()
    {
        for double_sided in [false, true] {
            let color = Vec4::new(rng.unit(), rng.unit(), rng.unit(), 0.7);
            let name = format!("material {i} {double_sided}");
            materials.push(scene.add_material(Material { alpha_mode, double_sided, ..Material::opaque(name, color) }));
        }
    }
    let meshes: Vec<_> = (0..3).map(|i| scene.add_geometry(Geometry::cube(0.5 + i as f32 * 0.5))).collect();
    let coarse = scene.add_geometry(Geometry::cube(1.0));
    for i in 0..count {
        let at = Vec3::new(rng.range(-40.0, 40.0), rng.range(-3.0, 6.0), rng.range(-40.0, 40.0));
        let mut scale = Vec3::splat(rng.range(0.3, 2.0));
        if rng.below(6) == 0 {
            scale.x = -scale.x;
        }
        let rotation = Quat::from_rotation_y(rng.range(0.0, std::f32::consts::TAU));
        let node = scene.add_node(format!("box {i}"), Transform { translation: at, rotation, scale });
        let geometry = meshes[rng.below(meshes.len())];
        let material = materials[rng.below(materials.len())];
        scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
        if rng.below(4) == 0 {
            scene.set_flags(node, NodeFlags::VISIBLE).unwrap();
        }
        if rng.below(3) == 0 {
            let lods = vec![LodLevel { geometry: coarse, below_screen_fraction: rng.range(0.02, 0.2) }];
            scene.set_lods(node, lods).unwrap();
        }
    }
    let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_x(-0.9)));
    scene.set_light(sun, Some(Light::directional(3.0))).unwrap();
    scene
}

fn look_at(eye: Vec3, target: Vec3, viewport: UVec2) -> LookAtResolver {
    LookAtResolver::new(Camera::perspective(60f32.to_radians(), 0.1, Some(200.0)), eye, target, viewport).unwrap()
}

/// Draws with their slots, without the fields that only say which range
/// they were read through (the generation tag).
fn comparable(draws: Vec<(PassMask, Vec<DrawMetadata>)>) -> Vec<(PassMask, Vec<DrawMetadata>)> {
    draws
        .into_iter()
        .map(|(mask, draws)| (mask, draws.into_iter().map(|d| DrawMetadata { generation: 0, ..d }).collect()))
        .collect()
}

fn assert_same_draws(renderer: &Renderer, cpu: ViewId, gpu: ViewId, what: &str) -> usize {
    let expected = comparable(renderer.view_draws(cpu).unwrap());
    let actual = comparable(renderer.view_draws(gpu).unwrap());
    if expected != actual {
        let (e, a) = (canonical_dump(&expected), canonical_dump(&actual));
        let first = e.lines().zip(a.lines()).position(|(x, y)| x != y);
        panic!(
            "{what}: GPU frustum culling drew other draws than the CPU path (first difference at line {first:?}):\n--- CPU\n{e}\n--- GPU\n{a}"
        );
    }
    expected.iter().map(|(_, d)| d.len()).sum()
}

#[test]
fn gpu_frustum_culling_draws_what_the_cpu_path_draws_on_random_scenes() {
    let Some(mut renderer) = renderer(Visibility::GpuFrustum) else { return };
    let viewport = UVec2::new(160, 96);
    let mut checked = 0;
    for seed in 0..6u64 {
        let scene = random_scene(seed, 300);
        let mut rng = Rng(seed + 77);
        let eye = Vec3::new(rng.range(-30.0, 30.0), rng.range(2.0, 20.0), rng.range(-30.0, 30.0));
        let target = Vec3::new(rng.range(-10.0, 10.0), 0.0, rng.range(-10.0, 10.0));
        let cascades = CascadeSettings { count: 2, resolution: 256, ..Default::default() };
        let desc = |visibility| {
            ViewDesc::new(look_at(eye, target, viewport)).with_sun_shadows(cascades).with_visibility(visibility)
        };
        let cpu = renderer.register_view(desc(Visibility::Cpu), standard_render_graph).unwrap();
        let gpu = renderer.register_view(desc(Visibility::GpuFrustum), standard_render_graph).unwrap();
        let report = renderer.render_frame(&scene).unwrap();
        let gpu_report = report.views.iter().find(|v| v.view == gpu).unwrap();
        assert_eq!(gpu_report.visibility, Visibility::GpuFrustum);
        checked += assert_same_draws(&renderer, cpu, gpu, &format!("seed {seed}, main view"));
        // Transparent draws stay on the CPU, back to front: the same order.
        let order = |id| -> Vec<u32> {
            let frame = renderer.prepared_frame(id).unwrap();
            frame.draws().iter().filter(|d| d.mask().contains(PassMask::TRANSPARENT)).map(|d| d.node_id).collect()
        };
        assert_eq!(order(cpu), order(gpu), "seed {seed}: transparent draws in another order");
        assert!(!order(gpu).is_empty(), "seed {seed}: the scene should have transparent draws in view");
        // Each view's cascades cull the way their owner does.
        for (c, g) in renderer.sun_cascades(cpu).into_iter().zip(renderer.sun_cascades(gpu)) {
            let cascade = report.views.iter().find(|v| v.view == g).unwrap();
            assert_eq!(cascade.visibility, Visibility::GpuFrustum, "a GPU view's cascade");
            checked += assert_same_draws(&renderer, c, g, &format!("seed {seed}, cascade"));
        }
        // And the pictures agree (the order within a partition differs, so
        // a few edge pixels of coplanar faces may too).
        let (a, b) = (renderer.read_color(cpu).unwrap(), renderer.read_color(gpu).unwrap());
        let diff = compare(&b, &a, 2);
        assert!(diff.differing <= diff.total / 500, "seed {seed}: {} of {} pixels differ", diff.differing, diff.total);
        renderer.unregister_view(cpu).unwrap();
        renderer.unregister_view(gpu).unwrap();
    }
    eprintln!("{checked} draws compared");
    assert!(checked > 1000, "the scenes should give many draws to compare, got {checked}");
}

#[test]
fn gpu_frustum_culling_draws_what_the_cpu_path_draws_on_gltf_scenes() {
    let Some(mut renderer) = renderer(Visibility::GpuFrustum) else { return };
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    let mut compared = 0;
    // MultiUVTest: a mesh with attribute records (its second UV set), whose
    // slot the GPU path must carry into its draws like the CPU path;
    // RiggedSimple: a skinned mesh (skin records, joint matrices);
    // SimpleMorph: morph targets (a morph header among the matrices).
    for file in [
        "Cubes/Cubes.glb",
        "AlphaBlendModeTest/AlphaBlendModeTest.glb",
        "OrientationTest/OrientationTest.glb",
        "MultiUVTest/MultiUVTest.glb",
        "RiggedSimple/RiggedSimple.glb",
        "SimpleMorph/SimpleMorph.gltf",
    ] {
        let mut scene = Scene::new();
        let imported =
            import_gltf(&mut scene, root.join(file), &SceneChoice::Default).unwrap_or_else(|e| panic!("{file}: {e}"));
        let bounds = imported.bounds.unwrap_or_else(|| panic!("{file} has no bounds"));
        let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_x(-0.9)));
        scene.set_light(sun, Some(Light::directional(3.0))).unwrap();
        let center = (bounds.min + bounds.max) * 0.5;
        let radius = (bounds.max - bounds.min).length().max(1.0);
        for eye in [center + Vec3::new(0.3, 0.4, 1.0) * radius, center + Vec3::new(-1.0, 0.2, -0.2) * radius * 0.6] {
            let desc =
                |visibility| ViewDesc::new(look_at(eye, center, UVec2::new(128, 96))).with_visibility(visibility);
            let cpu = renderer.register_view(desc(Visibility::Cpu), standard_render_graph).unwrap();
            let gpu = renderer.register_view(desc(Visibility::GpuFrustum), standard_render_graph).unwrap();
            renderer.render_frame(&scene).unwrap();
            compared += assert_same_draws(&renderer, cpu, gpu, file);
            renderer.unregister_view(cpu).unwrap();
            renderer.unregister_view(gpu).unwrap();
        }
    }
    assert!(compared > 10, "{compared} draws compared");
}

/// A grid of tall buildings with streets between them: from street level,
/// the first row hides most of the city. With `ids`, every building is
/// unlit and emits its own colour, and there is no light: an ID render,
/// from whose HDR image [`decode_id`] reads which building each pixel shows.
fn city(blocks: u32, ids: bool) -> Scene {
    let mut scene = Scene::new();
    let mut rng = Rng(0xC17);
    let colors = [Vec4::new(0.7, 0.7, 0.75, 1.0), Vec4::new(0.6, 0.5, 0.4, 1.0), Vec4::new(0.4, 0.45, 0.5, 1.0)];
    let mut materials: Vec<_> =
        colors.iter().enumerate().map(|(i, c)| scene.add_material(Material::opaque(format!("wall {i}"), *c))).collect();
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let ground_material = scene.add_material(Material::opaque("ground", Vec4::new(0.2, 0.2, 0.2, 1.0)));
    let ground = scene.add_geometry(Geometry::plane(1.0));
    let half = blocks as f32 * 6.0;
    let floor =
        scene.add_node("ground", Transform { scale: Vec3::new(half * 2.0, 1.0, half * 2.0), ..Transform::IDENTITY });
    scene.set_renderable(floor, Renderable { geometry: ground, materials: vec![ground_material] }).unwrap();
    for x in 0..blocks {
        for z in 0..blocks {
            let height = rng.range(6.0, 30.0);
            let at = Vec3::new(x as f32 * 12.0 - half + 6.0, height * 0.5, z as f32 * 12.0 - half + 6.0);
            let node = scene.add_node(
                format!("building {x} {z}"),
                Transform { translation: at, rotation: Quat::IDENTITY, scale: Vec3::new(8.0, height, 8.0) },
            );
            let mut material = materials[rng.below(materials.len())];
            if ids {
                let id = x * blocks + z;
                let emissive = Vec3::new((id % 8 + 1) as f32, (id / 8 % 8 + 1) as f32, (id / 64 + 1) as f32) / 8.0;
                let unlit =
                    Material { emissive, ..Material::opaque(format!("id {id}"), Vec4::new(0.0, 0.0, 0.0, 1.0)) };
                material = scene.add_material(unlit);
                materials.push(material);
            }
            scene.set_renderable(node, Renderable { geometry: cube, materials: vec![material] }).unwrap();
        }
    }
    if !ids {
        let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_x(-0.8)));
        scene.set_light(sun, Some(Light::directional(3.0))).unwrap();
    }
    scene
}

/// The building an ID render's pixel shows (`None`: the ground or the sky).
fn decode_id(pixel: [f32; 4]) -> Option<u32> {
    let digit = |v: f32| {
        let d = (v * 8.0).round();
        (1.0..=8.0).contains(&d).then(|| d as u32 - 1)
    };
    Some(digit(pixel[0])? + 8 * digit(pixel[1])? + 64 * digit(pixel[2])?)
}

/// A resolver whose camera the test moves between frames.
#[derive(Clone)]
struct Walker(std::sync::Arc<std::sync::Mutex<(Vec3, Vec3)>>, UVec2);

impl ViewResolver for Walker {
    fn resolve(&self, ctx: &ViewContext, scene: &Scene) -> Result<ResolvedView, ViewError> {
        let (eye, target) = *self.0.lock().unwrap();
        look_at(eye, target, self.1).resolve(ctx, scene)
    }
}

/// A renderer with two views of one moving camera: frustum culling (the
/// reference) and occlusion culling.
fn walkers(camera: &std::sync::Arc<std::sync::Mutex<(Vec3, Vec3)>>) -> Option<(Renderer, ViewId, ViewId)> {
    let mut renderer = renderer(Visibility::GpuFrustum)?;
    let walker = Walker(camera.clone(), UVec2::new(192, 128));
    let mut view = |visibility| {
        renderer
            .register_view(ViewDesc::new(walker.clone()).with_visibility(visibility), standard_render_graph)
            .unwrap()
    };
    let (reference, occluded) = (view(Visibility::GpuFrustum), view(Visibility::GpuOcclusion));
    Some((renderer, reference, occluded))
}

fn node_ids(renderer: &Renderer, view: ViewId) -> std::collections::BTreeSet<u32> {
    renderer.view_draws(view).unwrap().iter().flat_map(|(_, d)| d.iter().map(|d| d.node_id)).collect()
}

#[test]
fn occlusion_culling_never_drops_a_visible_object_along_a_camera_path() {
    let camera = std::sync::Arc::new(std::sync::Mutex::new((Vec3::ZERO, Vec3::X)));
    let Some((mut lit, lit_reference, lit_occluded)) = walkers(&camera) else { return };
    let Some((mut id, id_reference, id_occluded)) = walkers(&camera) else { return };
    let (lit_city, id_city) = (city(16, false), city(16, true));
    // The node id (slot index) of building k = x·16 + z, as draws carry it.
    let node_of: std::collections::BTreeMap<u32, u32> = id_city
        .nodes()
        .filter_map(|(key, node)| {
            let mut xz = node.name.strip_prefix("building ")?.split(' ').map(|n| n.parse::<u32>().ok());
            Some((xz.next()?? * 16 + xz.next()??, oxygen::core::scene::node_index(key)))
        })
        .collect();
    let (mut drawn_reference, mut drawn_occlusion, mut visible_total) = (0usize, 0usize, 0usize);
    let (mut street_reference, mut street_occlusion) = (0usize, 0usize);
    // Walking down a street at 2 units a frame, looking around, then rising
    // above the roofs: objects come into view every frame, from behind
    // buildings and at the frame's edges.
    const STREET_FRAMES: usize = 36;
    let path: Vec<(Vec3, Vec3)> = (0..STREET_FRAMES + 8)
        .map(|i| {
            let t = i as f32;
            let eye = if i < STREET_FRAMES {
                Vec3::new(-90.0 + t * 2.0, 2.0, 0.0)
            } else {
                Vec3::new(-90.0 + STREET_FRAMES as f32 * 2.0, 2.0 + (i - STREET_FRAMES + 1) as f32 * 6.0, 0.0)
            };
            let target = eye + Vec3::new((t * 0.15).cos(), -0.05, (t * 0.15).sin() * 0.6);
            (eye, target)
        })
        .collect();
    for (frame, (eye, target)) in path.iter().enumerate() {
        *camera.lock().unwrap() = (*eye, *target);
        let report = lit.render_frame(&lit_city).unwrap();
        let visibility = report.views.iter().find(|v| v.view == lit_occluded).unwrap().visibility;
        assert_eq!(visibility, Visibility::GpuOcclusion);
        let (a, b) = (lit.read_color(lit_reference).unwrap(), lit.read_color(lit_occluded).unwrap());
        let diff = compare(&b, &a, 2);
        if diff.differing > 0 {
            let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
            let _ = b.save(dir.join(format!("occlusion_frame{frame}.png")));
            let _ = a.save(dir.join(format!("occlusion_frame{frame}_reference.png")));
            let _ = diff.diff.save(dir.join(format!("occlusion_frame{frame}_diff.png")));
        }
        let lit_failure = (diff.differing != 0).then(|| {
            format!(
                "frame {frame}: {} of {} pixels differ with occlusion culling (worst {}); pictures in {}",
                diff.differing,
                diff.total,
                diff.worst,
                env!("CARGO_TARGET_TMPDIR")
            )
        });

        // Exact visibility from the ID render: every building some pixel
        // shows must be among occlusion culling's draws.
        id.render_frame(&id_city).unwrap();
        let hdr = id.read_hdr(id_reference).unwrap();
        let visible: std::collections::BTreeSet<u32> =
            hdr.pixels.iter().filter_map(|p| decode_id(*p)).filter_map(|b| node_of.get(&b).copied()).collect();
        let (kept_reference, kept_occlusion) = (node_ids(&id, id_reference), node_ids(&id, id_occluded));
        let dropped: Vec<_> = visible.difference(&kept_occlusion).collect();
        assert!(
            dropped.is_empty(),
            "frame {frame}: occlusion culling dropped visible nodes {dropped:?} (visible {visible:?}, kept {kept_occlusion:?})"
        );
        assert!(kept_occlusion.is_subset(&kept_reference), "frame {frame}: occlusion kept what the frustum culled");
        if let Some(failure) = lit_failure {
            panic!("{failure}");
        }
        drawn_reference += kept_reference.len();
        drawn_occlusion += kept_occlusion.len();
        if frame < STREET_FRAMES {
            street_reference += kept_reference.len();
            street_occlusion += kept_occlusion.len();
        }
        visible_total += visible.len();
    }
    eprintln!(
        "camera path of {} frames: frustum culling drew {drawn_reference} buildings, occlusion culling \
         {drawn_occlusion} ({:.0} % fewer; at street level {:.0} % fewer); {visible_total} were visible \
         (conservative overhead: frustum {:.1}×, occlusion {:.1}×)",
        path.len(),
        100.0 * (1.0 - drawn_occlusion as f64 / drawn_reference as f64),
        100.0 * (1.0 - street_occlusion as f64 / street_reference as f64),
        drawn_reference as f64 / visible_total.max(1) as f64,
        drawn_occlusion as f64 / visible_total.max(1) as f64,
    );
    assert!(visible_total > 0, "the ID render shows no building: the test is not looking at the city");
    // Inside the city, the first buildings hide most of it.
    assert!(
        street_occlusion * 2 < street_reference,
        "at street level occlusion culling should cull at least half the draws: {street_occlusion} of {street_reference}"
    );
    // docs/performance.md, the GPU visibility's error side
    // (scripts/test-records.sh); the counts are summed over the frames.
    support::record::write(|record| {
        record
            .value("city_blocks", [16, 16])
            .value("frames", path.len())
            .value("street_frames", STREET_FRAMES)
            .value("viewport_px", [192, 128])
            .value("visible_buildings", visible_total)
            .value("frustum_kept", drawn_reference)
            .value("occlusion_kept", drawn_occlusion)
            .value("frustum_kept_over_visible", drawn_reference as f64 / visible_total as f64)
            .value("occlusion_kept_over_visible", drawn_occlusion as f64 / visible_total as f64)
            .value("street_frustum_kept", street_reference)
            .value("street_occlusion_kept", street_occlusion)
    });
}

#[test]
fn a_static_scene_uploads_under_a_kilobyte_per_frame_on_the_gpu_path() {
    let Some(mut renderer) = renderer(Visibility::GpuFrustum) else { return };
    let scene = city(12, false);
    renderer
        .register_view(look_at(Vec3::new(-80.0, 20.0, -70.0), Vec3::ZERO, UVec2::new(128, 96)), standard_render_graph)
        .unwrap();
    let first = renderer.render_frame(&scene).unwrap();
    assert!(first.uploaded_bytes > 10_000, "the first frame uploads the scene: {} bytes", first.uploaded_bytes);
    for frame in 0..3 {
        let report = renderer.render_frame(&scene).unwrap();
        eprintln!("static frame {frame}: {} bytes uploaded", report.uploaded_bytes);
        assert!(report.uploaded_bytes < 1024, "static frame {frame} uploaded {} bytes", report.uploaded_bytes);
    }
}

#[test]
fn moving_one_object_uploads_only_its_records() {
    let Some(mut renderer) = renderer(Visibility::GpuFrustum) else { return };
    let mut scene = city(12, false);
    renderer
        .register_view(look_at(Vec3::new(-80.0, 20.0, -70.0), Vec3::ZERO, UVec2::new(128, 96)), standard_render_graph)
        .unwrap();
    renderer.render_frame(&scene).unwrap();
    let everything = renderer.render_frame(&scene).unwrap().uploaded_bytes;
    let (node, _) = scene.nodes().find(|(_, n)| n.name == "building 3 3").unwrap();
    let moved = Transform { translation: Vec3::new(1.0, 5.0, 2.0), rotation: Quat::IDENTITY, scale: Vec3::splat(4.0) };
    scene.set_local_transform(node, moved).unwrap();
    let report = renderer.render_frame(&scene).unwrap();
    // One world and one normal matrix, one instance record, the constants.
    eprintln!("static frame: {everything} bytes; one object moved: {} bytes", report.uploaded_bytes);
    assert!(report.uploaded_bytes < 2048, "moving one object uploaded {} bytes", report.uploaded_bytes);
}

/// On a GPU path the automatic pre-pass decides from the coverage the GPU
/// summed a frame earlier: infinite (pre-pass) until it arrives, then low
/// for boxes spread side by side (no pre-pass), high for walls stacked in
/// front of each other (pre-pass).
#[test]
fn the_gpu_paths_estimate_overdraw_for_the_automatic_pre_pass() {
    let Some(mut renderer) = renderer(Visibility::GpuFrustum) else { return };
    // Boxes in four materials on a grid, seen from above: side by side.
    let mut spread = Scene::new();
    let cube = spread.add_geometry(Geometry::cube(1.0));
    let colors =
        [Vec4::new(0.8, 0.2, 0.2, 1.0), Vec4::new(0.2, 0.8, 0.2, 1.0), Vec4::new(0.2, 0.2, 0.8, 1.0), Vec4::ONE];
    let materials: Vec<_> = colors.iter().map(|c| spread.add_material(Material::opaque("box", *c))).collect();
    for i in 0..400 {
        let node = spread
            .add_node("box", Transform::from_translation(Vec3::new((i % 20) as f32 * 2.0, 0.0, (i / 20) as f32 * 2.0)));
        spread.set_renderable(node, Renderable { geometry: cube, materials: vec![materials[i % 4]] }).unwrap();
    }
    let mut stacked = Scene::new();
    let wall = stacked.add_geometry(Geometry::cube(1.0));
    // A material per wall: each material's run is drawn front to back, but
    // runs drawn later shade pixels again.
    for i in 0..12 {
        let grey = stacked.add_material(Material::opaque(format!("wall {i}"), Vec4::splat(0.3 + i as f32 * 0.05)));
        let node = stacked.add_node(
            format!("wall {i}"),
            Transform {
                translation: Vec3::new(0.0, 0.0, -(i as f32) * 2.0),
                rotation: Quat::IDENTITY,
                scale: Vec3::new(40.0, 40.0, 0.2),
            },
        );
        stacked.set_renderable(node, Renderable { geometry: wall, materials: vec![grey] }).unwrap();
    }
    let cases = [
        (
            "spread",
            &spread,
            look_at(Vec3::new(20.0, 30.0, -10.0), Vec3::new(20.0, 0.0, 20.0), UVec2::new(128, 96)),
            false,
        ),
        (
            "stacked",
            &stacked,
            look_at(Vec3::new(0.0, 0.0, 10.0), Vec3::new(0.0, 0.0, -10.0), UVec2::new(128, 96)),
            true,
        ),
    ];
    for (name, scene, camera, wants_pre_pass) in cases {
        let view = renderer.register_view(camera, standard_render_graph).unwrap();
        let passes =
            |report: &FrameReport| report.views.iter().find(|v| v.view == view).unwrap().recorded.render_passes;
        // The first frame has no readback yet: it runs the pre-pass.
        let first = renderer.render_frame(scene).unwrap();
        let with_pre_pass = passes(&first);
        renderer.read_color(view).unwrap(); // waits for the GPU
        let mut last = first;
        for _ in 0..3 {
            last = renderer.render_frame(scene).unwrap();
            renderer.read_color(view).unwrap();
        }
        let estimate = renderer.gpu_visibility().and_then(|v| v.estimated_overdraw(view));
        let cpu_view = renderer
            .register_view(ViewDesc::new(camera).with_visibility(Visibility::Cpu), standard_render_graph)
            .unwrap();
        renderer.render_frame(scene).unwrap();
        let cpu_estimate = renderer.prepared_frame(cpu_view).unwrap().estimated_overdraw();
        renderer.unregister_view(cpu_view).unwrap();
        eprintln!("{name}: estimated overdraw {estimate:?}, CPU path {cpu_estimate}");
        assert!(estimate.is_some_and(f32::is_finite), "{name}: no coverage read back after four frames");
        let expected = if wants_pre_pass { with_pre_pass } else { with_pre_pass - 1 };
        assert_eq!(
            passes(&last),
            expected,
            "{name}: the pre-pass should {}run",
            if wants_pre_pass { "" } else { "not " }
        );
        renderer.unregister_view(view).unwrap();
    }
}
