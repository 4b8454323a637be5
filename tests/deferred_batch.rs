//! Deferred shading of a batch (`BatchShading::Deferred`): every camera's
//! image is the forward-shaded batch's within a few levels (the same
//! shading code, fed from a rebuilt surface point instead of the
//! rasterizer's varyings), the label planes are the forward pass's, the
//! frames it cannot take are shaded forward, and an adapter whose compute
//! stage cannot bind its inputs refuses it with a reason.

mod support;

use oxygen::batch::{BatchDesc, BatchGraph, BatchShading, standard_batch_graph};
use oxygen::core::Environment;
use oxygen::image::RgbaImage;
use oxygen::prelude::*;
use oxygen::sceneprep::Visibility;
use oxygen::{LabelImage, RenderError};
use support::golden::compare;

/// A shipped file with a sun, and a ring of `n` cameras of `size` around
/// its bounds, each at its own angle and height.
fn shipped(file: &str, n: usize, size: UVec2) -> (Scene, Vec<LookAtResolver>) {
    let (scene, bounds) = support::shipped_with_sun(file);
    let radius = bounds.half_extents().length().max(1e-3);
    (scene, ring(n, size, bounds.center(), radius * 2.4))
}

fn ring(n: usize, size: UVec2, target: Vec3, distance: f32) -> Vec<LookAtResolver> {
    (0..n)
        .map(|i| {
            let angle = i as f32 / n as f32 * std::f32::consts::TAU + 0.3;
            let height = (i as f32 / n as f32 - 0.4) * distance;
            let eye = target + Vec3::new(distance * angle.cos(), height, distance * angle.sin());
            LookAtResolver::new(Camera::perspective(50f32.to_radians(), distance * 0.01, None), eye, target, size)
                .expect("ring cameras are valid")
        })
        .collect()
}

/// Each camera's colour and labels, and the cameras the frame shaded
/// deferred, rendered as one batch shaded `shading`.
fn render(scene: &Scene, cameras: &[LookAtResolver], size: UVec2, shading: BatchShading) -> Batch {
    render_with(scene, cameras, size, shading, &Setup::default())
}

/// What a batch may have beyond its cameras.
#[derive(Default)]
struct Setup {
    /// The cameras' visibility path.
    visibility: Option<Visibility>,
    /// The environment behind and around the scene.
    environment: Option<Environment>,
    /// Pages no larger than this many pixels a side.
    max_page_side: Option<u32>,
    /// No label planes: the visibility pass's own vertex stage, which
    /// writes nothing but the position and the surface id.
    no_labels: bool,
}

/// [`render`] with the batch's [`Setup`].
fn render_with(scene: &Scene, cameras: &[LookAtResolver], size: UVec2, shading: BatchShading, setup: &Setup) -> Batch {
    // Not `support::gpu_renderer_with`, which keeps every HDR image: a
    // batch whose HDR image is read after shading is shaded forward.
    let mut renderer = Renderer::new_headless().expect("GPU tests need an adapter");
    if let Some(environment) = &setup.environment {
        renderer.set_environment(Some(environment));
    }
    let graph = BatchGraph { shading, ..standard_batch_graph };
    let desc = BatchDesc::new("ring", size).with_graph(graph);
    let desc = if setup.no_labels { desc } else { desc.with_labels() };
    let desc = match setup.max_page_side {
        Some(side) => desc.with_max_page_side(side),
        None => desc,
    };
    let batch = renderer.register_batch(desc).unwrap();
    let ids: Vec<ViewId> = cameras
        .iter()
        .map(|c| {
            let desc = ViewDesc::new(*c);
            let desc = match setup.visibility {
                Some(v) => desc.with_visibility(v),
                None => desc,
            };
            renderer.add_camera(batch, desc).unwrap()
        })
        .collect();
    let report = renderer.render_frame(scene).unwrap();
    let deferred = report.views.iter().map(|v| v.recorded.deferred_views).sum();
    // Deferred shading writes the display colour alone: the HDR image is
    // reported as not written, as after a forward pass that tone-maps in
    // place.
    if deferred as usize == ids.len() {
        for id in &ids {
            let hdr = renderer.read_hdr(*id);
            assert!(matches!(hdr, Err(RenderError::HdrNotWritten(_))), "{id}: {:?}", hdr.err());
        }
    }
    Batch {
        colors: ids.iter().map(|id| renderer.read_color(*id).unwrap()).collect(),
        labels: if setup.no_labels {
            Vec::new()
        } else {
            ids.iter().map(|id| renderer.read_labels(*id).unwrap()).collect()
        },
        deferred,
    }
}

struct Batch {
    colors: Vec<RgbaImage>,
    /// Empty without label planes.
    labels: Vec<LabelImage>,
    deferred: u32,
}

/// Whether this adapter can shade deferred (a deferred batch registers);
/// records the skip when not, with the renderer's reason.
fn deferred_here() -> bool {
    let mut renderer = Renderer::new_headless().expect("GPU tests need an adapter");
    let graph = BatchGraph { shading: BatchShading::Deferred, ..standard_batch_graph };
    match renderer.register_batch(BatchDesc::new("probe", UVec2::new(8, 8)).with_graph(graph)) {
        Ok(_) => true,
        Err(e) => {
            support::skip::skip(format!("{}: {e}", renderer.gpu().adapter_info.name));
            false
        }
    }
}

/// Deferred against forward for `scene`: (worst channel error, pixels
/// differing by more than 2 levels, pixels in all), with the label planes
/// checked on the way.
fn deferred_against_forward(scene: &Scene, cameras: &[LookAtResolver], size: UVec2, what: &str) -> (u8, usize, usize) {
    deferred_against_forward_with(scene, cameras, size, what, &Setup::default())
}

/// [`deferred_against_forward`] with the batches' [`Setup`].
fn deferred_against_forward_with(
    scene: &Scene,
    cameras: &[LookAtResolver],
    size: UVec2,
    what: &str,
    setup: &Setup,
) -> (u8, usize, usize) {
    let forward = render_with(scene, cameras, size, BatchShading::Forward, setup);
    let deferred = render_with(scene, cameras, size, BatchShading::Deferred, setup);
    assert_eq!(forward.deferred, 0, "{what}: the forward batch shades forward");
    assert_eq!(deferred.deferred as usize, cameras.len(), "{what}: every camera is shaded deferred");
    let (mut worst, mut differing, mut total) = (0u8, 0usize, 0usize);
    for (i, (d, f)) in deferred.colors.iter().zip(&forward.colors).enumerate() {
        let c = compare(d, f, 2);
        worst = worst.max(c.worst);
        differing += c.differing;
        total += c.total;
        if setup.no_labels {
            continue;
        }
        let (dl, fl) = (&deferred.labels[i], &forward.labels[i]);
        // The same rasterizer decided which surface each pixel shows.
        assert_eq!(dl.instances, fl.instances, "{what}: camera {i}'s instance labels");
        assert_eq!(dl.classes, fl.classes, "{what}: camera {i}'s semantic classes");
        assert_eq!(dl.linear_depth, fl.linear_depth, "{what}: camera {i}'s linear depth");
        assert_eq!(dl.normals, fl.normals, "{what}: camera {i}'s normals");
    }
    // The picture is not empty: something covers the camera.
    let background = forward.colors[0].get_pixel(0, 0);
    assert!(forward.colors.iter().any(|c| c.pixels().any(|p| p != background)), "{what}: no camera sees anything");
    eprintln!("{what}: deferred against forward: worst {worst}, {differing} of {total} pixels over 2 levels");
    (worst, differing, total)
}

#[test]
fn deferred_cameras_render_what_forward_cameras_render() {
    if !deferred_here() {
        return;
    }
    let size = UVec2::new(96, 72);
    // Untextured boxes under a sun: the bench's scene. Measured on
    // lavapipe: worst 1 level, no pixel over 2.
    let grid = oxygen_demo::box_grid(36);
    let cameras = ring(6, size, Vec3::ZERO, grid.side * 1.2);
    let (worst, differing, total) = deferred_against_forward(&grid.scene, &cameras, size, "box grid");
    assert!(worst <= 2 && differing == 0, "box grid: worst {worst}, {differing} of {total}");
    // Culled on the GPU (each camera's draws and their count written by a
    // compute pass): the same pictures as the CPU path's deferred batch.
    let cpu = render(&grid.scene, &cameras, size, BatchShading::Deferred);
    let on_gpu = Setup { visibility: Some(Visibility::GpuFrustum), ..Setup::default() };
    let gpu = render_with(&grid.scene, &cameras, size, BatchShading::Deferred, &on_gpu);
    assert_eq!(gpu.deferred as usize, cameras.len(), "GPU-culled cameras are shaded deferred");
    for (i, (g, c)) in gpu.colors.iter().zip(&cpu.colors).enumerate() {
        let c = compare(g, c, 2);
        // Measured: 0 pixels over 2 levels.
        assert!(c.differing == 0, "GPU-culled camera {i}: {} pixels differ, worst {}", c.differing, c.worst);
    }
    // Three pages of two cameras (a dispatch and a copy each), under an
    // environment: the sky where nothing is drawn, its light on the boxes.
    // Measured: worst 1 level, no pixel over 2.
    let setup = Setup {
        environment: Some(Environment::sky_for_sun(Vec3::new(0.6, -0.5, 0.4).normalize())),
        max_page_side: Some(200),
        ..Setup::default()
    };
    let (worst, differing, total) =
        deferred_against_forward_with(&grid.scene, &cameras, size, "box grid, pages and sky", &setup);
    assert!(worst <= 2 && differing == 0, "pages and sky: worst {worst}, {differing} of {total}");
    // Base colour and normal textures (their level of detail from the
    // rebuilt derivatives: one pixel over, where the fragment stage takes
    // its 2 × 2 quad's differences, so a texel at a mip level's edge can
    // blend otherwise), skins, morphs, a double-sided plane seen from both
    // sides. The bounds: measured on lavapipe (worst level, pixels over 2
    // levels of 27 648) with a quarter more.
    let mut results = Vec::new();
    for (file, most_worst, most_differing) in [
        ("NormalTangentTest/NormalTangentTest.glb", 13, 13), // measured 10 and 10
        ("BoxTextured/BoxTextured.glb", 35, 200),            // 28 and 158, on the texture's border lines
        ("RiggedSimple/RiggedSimple.glb", 2, 0),             // 1 and 0
        ("SimpleMorph/SimpleMorph.gltf", 2, 0),              // 1 and 0
        ("TwoSidedPlane/TwoSidedPlane.gltf", 9, 7),          // 7 and 5
    ] {
        let (scene, cameras) = shipped(file, 4, size);
        results.push((file, most_worst, most_differing, deferred_against_forward(&scene, &cameras, size, file)));
    }
    for (file, most_worst, most_differing, (worst, differing, total)) in results {
        assert!(
            worst <= most_worst && differing <= most_differing,
            "{file}: worst {worst} (at most {most_worst}), {differing} of {total} over 2 levels (at most {most_differing})"
        );
    }
}

#[test]
fn a_frame_deferred_shading_cannot_take_is_shaded_forward() {
    if !deferred_here() {
        return;
    }
    // Blended surfaces need the HDR image after shading: forward, the
    // same pixels as a forward batch.
    let size = UVec2::new(64, 48);
    let (scene, cameras) = shipped("AlphaBlendModeTest/AlphaBlendModeTest.glb", 3, size);
    let forward = render(&scene, &cameras, size, BatchShading::Forward);
    let deferred = render(&scene, &cameras, size, BatchShading::Deferred);
    assert_eq!(deferred.deferred, 0, "blended surfaces are shaded forward");
    for (i, (d, f)) in deferred.colors.iter().zip(&forward.colors).enumerate() {
        assert!(d == f, "camera {i}: the fallback is the forward pass");
    }
}

/// A mesh whose triangles share their first corners: degenerate triangles
/// take corners 1 to 6 first (5 and 6 twice), so that the three real ones all
/// start at corner 0 (the table's turn gives each the least used corner)
/// and the compute pass must choose among them. Seen from the front: a
/// far triangle facing the camera, a nearer one facing away over it (culled,
/// single-sided: the far one shows through) and a nearer one facing the
/// camera over part of it (it shows). Each real triangle's far corners
/// have normals of their own, so taking the wrong one shades otherwise.
/// `masked`: the second triangle faces the camera too, in an alpha-tested
/// material whose vertex alpha fades from 1 at corner 0 to 0 at its far
/// corners, so that its far part is cut out and the far triangle shows
/// there.
fn fan_sharing_a_first_corner(masked: bool) -> Scene {
    use oxygen::core::{Submesh, Vertex};
    use oxygen::glam::{Vec2, Vec4};
    let vertex = |p: [f32; 3], n: Vec3| Vertex::new(Vec3::from(p), n.normalize(), Vec2::ZERO);
    let vertices = vec![
        vertex([0.0, 0.0, 0.0], Vec3::Z),
        vertex([1.0, 0.0, 0.0], Vec3::Z),
        vertex([0.0, 1.0, 0.0], Vec3::Z),
        vertex([1.0, 0.3, 0.6], Vec3::new(1.0, 0.0, 0.3)),
        vertex([0.3, 1.0, 0.6], Vec3::new(1.0, 0.0, 0.3)),
        vertex([0.8, 0.1, 0.3], Vec3::new(0.0, -1.0, 0.4)),
        vertex([0.5, 0.5, 0.3], Vec3::new(0.0, -1.0, 0.4)),
    ];
    #[rustfmt::skip]
    let mut indices = vec![
        1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4, 5, 5, 5, 5, 5, 5, 6, 6, 6, 6, 6, 6,
        0, 1, 2, // far, facing the camera
        0, 4, 3, // near, facing away: culled (facing the camera when masked)
        0, 5, 6, // near, facing the camera over part of the far one
    ];
    if masked {
        indices.splice(indices.len() - 5..indices.len() - 3, [3, 4]);
    }
    let count = indices.len() as u32;
    let fan = Geometry::new("fan", vertices, indices, vec![Submesh { first_index: 0, index_count: count }]).unwrap();
    let mut scene = Scene::new();
    let fan = if masked {
        let alpha = [1.0, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0];
        let attributes = alpha.map(|a| oxygen::core::VertexAttributes::new(Vec4::new(1.0, 1.0, 1.0, a), Vec2::ZERO));
        fan.with_attributes(attributes.to_vec()).unwrap()
    } else {
        fan
    };
    let mut white = Material::opaque("white", Vec4::new(0.8, 0.8, 0.8, 1.0));
    if masked {
        white.alpha_mode = oxygen::core::AlphaMode::Mask { cutoff: 0.5 };
    }
    let white = scene.add_material(white);
    let geometry = scene.add_geometry(fan);
    let node = scene.add_node("fan", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry, materials: vec![white] }).unwrap();
    let sun = scene.add_node(
        "sun",
        Transform::IDENTITY
            .with_rotation(oxygen::glam::Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::new(-0.5, -0.3, -0.8).normalize())),
    );
    scene.set_light(sun, Some(Light::directional(2.5))).unwrap();
    scene
}

#[test]
fn each_pixel_shades_the_triangle_the_rasterizer_kept_among_those_sharing_its_first_corner() {
    if !deferred_here() {
        return;
    }
    let size = UVec2::new(64, 64);
    let camera = |eye: Vec3| {
        LookAtResolver::new(Camera::perspective(40f32.to_radians(), 0.05, None), eye, Vec3::new(0.4, 0.4, 0.2), size)
            .expect("a valid camera")
    };
    let cameras = [camera(Vec3::new(0.4, 0.4, 3.0)), camera(Vec3::new(0.9, 0.1, 2.5))];
    let setup = Setup { no_labels: true, ..Setup::default() };
    for masked in [false, true] {
        let scene = fan_sharing_a_first_corner(masked);
        let what = format!("a fan sharing its first corner (masked: {masked})");
        let (worst, differing, total) = deferred_against_forward_with(&scene, &cameras, size, &what, &setup);
        // Measured on lavapipe: worst 1, 0 of 8 192 over 2 levels.
        assert!(worst <= 2 && differing == 0, "{what}: worst {worst}, {differing} of {total} pixels over 2 levels");
    }
}

/// Meshes get their triangle tables only once a batch shades deferred: a
/// renderer that drew frames without one uploads its meshes anew when a
/// deferred batch arrives, whose cameras then render what a renderer
/// that had tables from its first frame renders.
#[test]
fn a_deferred_batch_registered_after_frames_without_one_gets_its_triangle_tables() {
    if !deferred_here() {
        return;
    }
    let size = UVec2::new(64, 64);
    let camera = LookAtResolver::new(
        Camera::perspective(40f32.to_radians(), 0.05, None),
        Vec3::new(0.4, 0.4, 3.0),
        Vec3::new(0.4, 0.4, 0.2),
        size,
    )
    .expect("a valid camera");
    let scene = fan_sharing_a_first_corner(false);
    let setup = Setup { no_labels: true, ..Setup::default() };
    let reference = render_with(&scene, &[camera], size, BatchShading::Deferred, &setup);
    let mut renderer = Renderer::new_headless().expect("GPU tests need an adapter");
    let early = renderer.register_batch(BatchDesc::new("forward", size)).unwrap();
    renderer.add_camera(early, ViewDesc::new(camera)).unwrap();
    for _ in 0..2 {
        renderer.render_frame(&scene).unwrap();
    }
    let graph = BatchGraph { shading: BatchShading::Deferred, ..standard_batch_graph };
    let late = renderer.register_batch(BatchDesc::new("late", size).with_graph(graph)).unwrap();
    let id = renderer.add_camera(late, ViewDesc::new(camera)).unwrap();
    let report = renderer.render_frame(&scene).unwrap();
    let deferred: u32 = report.views.iter().map(|v| v.recorded.deferred_views).sum();
    assert_eq!(deferred, 1, "the late batch's camera is shaded deferred");
    let c = compare(&renderer.read_color(id).unwrap(), &reference.colors[0], 0);
    // Measured: the same bytes.
    assert!(c.differing == 0, "{} of {} pixels differ, worst {}", c.differing, c.total, c.worst);
}

#[test]
fn an_adapter_that_cannot_shade_deferred_refuses_the_batch_with_a_reason() {
    let deferred = BatchGraph { shading: BatchShading::Deferred, ..standard_batch_graph };
    let desc = || BatchDesc::new("rig", UVec2::new(8, 8)).with_graph(deferred.clone());
    // No optional feature is needed (a pixel's triangle is found from its
    // first corner, not the primitive index): registered where the
    // device's per-stage limits bind the compute pass's inputs (Vulkan on
    // lavapipe), refused with the limit named where not (GL's 16 sampled
    // textures a stage), and then the same batch shaded forward registers.
    let mut renderer = Renderer::new_headless().expect("GPU tests need an adapter");
    match renderer.register_batch(desc()) {
        Ok(_) => assert_ne!(renderer.gpu().adapter_info.backend, oxygen::wgpu::Backend::Gl),
        Err(e) => {
            let error = e.to_string();
            assert!(error.contains("rig") && error.contains("limit"), "{error}");
            assert!(renderer.register_batch(BatchDesc::new("rig", UVec2::new(8, 8))).is_ok());
        }
    }
}
