//! Clustered light culling (`LightCulling::Clustered`): a street of 1 000
//! lamps shaded from each pixel's cluster is the street shaded from every
//! light, for several grids, a perspective and an orthographic view and a
//! batch's cameras; a grid too large for one storage binding is refused
//! with the numbers.

mod support;

use oxygen::batch::BatchDesc;
use oxygen::gpu::HdrImage;
use oxygen::graph::{BatchGraph, standard_batch_graph};
use oxygen::lighting::{ClusterGrid, LightCulling};
use oxygen::prelude::*;
use support::{assert_hdr_image_finite, gpu_renderer};

const LAMPS: usize = 1000;
const SIZE: UVec2 = UVec2::new(128, 72);

fn config(culling: LightCulling) -> ForwardLitConfig {
    ForwardLitConfig { light_culling: culling, ..ForwardLitConfig::DEFAULT }
}

fn clustered(tile_pixels: u32, depth_slices: u32) -> LightCulling {
    LightCulling::Clustered(ClusterGrid { tile_pixels, depth_slices, ..ClusterGrid::DEFAULT })
}

/// The street rendered by `camera` with `culling`: its HDR image.
fn render(scene: &Scene, camera: impl ViewResolver + 'static, culling: LightCulling) -> HdrImage {
    let mut renderer = gpu_renderer();
    let view = renderer.register_view(camera, StandardGraph::new(config(culling))).expect("view");
    renderer.render_frame(scene).expect("frame");
    let hdr = renderer.read_hdr(view).expect("HDR image");
    assert_hdr_image_finite(&hdr, "street");
    hdr
}

/// The largest difference between two HDR images relative to the brighter
/// of the two pixels (at least 0.01, so black pixels compare absolutely),
/// and the pixels differing by more than `tolerance` of it.
fn difference(a: &HdrImage, b: &HdrImage, tolerance: f32) -> (f32, usize) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let mut worst = 0.0f32;
    let mut differing = 0;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        let scale = p[..3].iter().chain(&q[..3]).fold(0.01f32, |m, v| m.max(v.abs()));
        let d = (0..3).map(|c| (p[c] - q[c]).abs() / scale).fold(0.0f32, f32::max);
        worst = worst.max(d);
        differing += usize::from(d > tolerance);
    }
    (worst, differing)
}

/// Mean luminance-ish brightness (for "the lamps light the street").
fn mean(image: &HdrImage) -> f32 {
    image.pixels.iter().map(|p| (p[0] + p[1] + p[2]) / 3.0).sum::<f32>() / image.pixels.len() as f32
}

/// Tolerance of a clustered image against the every-light one, relative:
/// the same lights are summed in the same order, so what differs is only
/// the shader compiler's freedom with two loops (measured 0 on lavapipe,
/// Vulkan and GL); 1e-3 leaves room for another compiler's reassociation
/// and is far below one lamp's share of a lit pixel (a missing lamp moves
/// its pixels by 5 % or more).
const TOLERANCE: f32 = 1e-3;

#[test]
fn a_street_of_a_thousand_lamps_shades_the_same_from_its_clusters() {
    let scene = oxygen_demo::lamp_street(LAMPS);
    let every = render(&scene, oxygen_demo::lamp_street_camera(SIZE), LightCulling::EveryLight);
    let dark = render(&oxygen_demo::lamp_street(0), oxygen_demo::lamp_street_camera(SIZE), LightCulling::EveryLight);
    assert!(mean(&every) > 1.5 * mean(&dark), "the lamps light the street: {} against {}", mean(&every), mean(&dark));
    for (tile, slices) in [(32, 24), (8, 4), (16, 1), (64, 2), (5, 64)] {
        let image = render(&scene, oxygen_demo::lamp_street_camera(SIZE), clustered(tile, slices));
        let (worst, differing) = difference(&image, &every, TOLERANCE);
        eprintln!("{tile}-pixel tiles, {slices} slices: worst relative difference {worst:e}, {differing} pixels over");
        assert_eq!(differing, 0, "{tile}-pixel tiles, {slices} slices: worst relative difference {worst}");
    }
}

/// An orthographic camera above the street (its near plane at the eye):
/// the cluster boxes follow the parallel rays.
#[test]
fn an_orthographic_view_of_the_street_shades_the_same_from_its_clusters() {
    let scene = oxygen_demo::lamp_street(LAMPS);
    let camera = || {
        LookAtResolver::new(
            Camera::orthographic(12.0, 0.0, 100.0),
            Vec3::new(0.0, 40.0, -30.0),
            Vec3::new(0.0, 0.0, -30.1),
            UVec2::new(96, 96),
        )
        .expect("camera")
    };
    let every = render(&scene, camera(), LightCulling::EveryLight);
    let image = render(&scene, camera(), clustered(16, 8));
    let (worst, differing) = difference(&image, &every, TOLERANCE);
    eprintln!("orthographic: worst relative difference {worst:e}");
    assert_eq!(differing, 0, "orthographic: worst relative difference {worst}");
}

/// A batch's cameras each cull into clusters of their own: every camera's
/// tile is what the every-light batch renders.
#[test]
fn a_batch_of_cameras_shades_the_same_from_their_clusters() {
    let scene = oxygen_demo::lamp_street(LAMPS);
    let render_batch = |culling: LightCulling| -> Vec<image::RgbaImage> {
        let mut renderer = gpu_renderer();
        let graph = BatchGraph {
            lit: ForwardLitConfig { light_culling: culling, ..standard_batch_graph.lit },
            ..standard_batch_graph
        };
        let size = UVec2::new(48, 32);
        let batch = renderer.register_batch(BatchDesc::new("street", size).with_graph(graph)).expect("batch");
        let cameras: Vec<ViewId> = (0..4)
            .map(|i| {
                let eye = Vec3::new(-3.0 + 2.0 * i as f32, 1.7, 4.0 - 20.0 * i as f32);
                let target = eye + Vec3::new(0.3 - 0.2 * i as f32, 0.2, -10.0);
                let camera =
                    LookAtResolver::new(Camera::perspective(1.0, 0.1, None), eye, target, size).expect("camera");
                renderer.add_camera(batch, camera).expect("camera")
            })
            .collect();
        renderer.render_frame(&scene).expect("frame");
        cameras.iter().map(|c| renderer.read_color(*c).expect("colour")).collect()
    };
    let every = render_batch(LightCulling::EveryLight);
    let clustered = render_batch(clustered(8, 16));
    for (i, (image, reference)) in clustered.iter().zip(&every).enumerate() {
        let c = support::golden::compare(image, reference, 1);
        eprintln!("batch camera {i}: worst channel difference {}", c.worst);
        assert_eq!(c.differing, 0, "batch camera {i}: worst channel difference {}", c.worst);
    }
}

/// A grid whose light bits would not fit in one storage binding is refused
/// before anything is allocated, with its numbers and what to change.
#[test]
fn a_view_that_shades_twice_in_a_frame_sorts_its_lights_once() {
    // A graph whose forward pass runs twice (the second over the first's
    // image, as a custom graph's second lit pass would): the second pass
    // reads the bits the first one's job fills.
    let scene = oxygen_demo::lamp_street(LAMPS);
    let culling = clustered(16, 16);
    let graph = async move |ctx: &RenderContext<'_>, rec: &mut CommandRecorder| {
        let lit = ForwardLitConfig { depth_from_pre_pass: false, ..config(culling) };
        MeshPass::forward_lit(lit.clone()).run(ctx, rec).await?;
        MeshPass::forward_lit(lit).run(ctx, rec).await?;
        TonemapPass::default().run(ctx, rec).await
    };
    let mut renderer = gpu_renderer();
    let view = renderer.register_view(oxygen_demo::lamp_street_camera(SIZE), graph).expect("view");
    for frame in 0..2 {
        let report = renderer.render_frame(&scene).expect("frame");
        assert_eq!(report.views[0].recorded.light_cluster_jobs, 1, "frame {frame}: one cluster job");
    }
    let twice = renderer.read_hdr(view).expect("HDR image");
    let every = render(&scene, oxygen_demo::lamp_street_camera(SIZE), LightCulling::EveryLight);
    let (worst, differing) = difference(&twice, &every, TOLERANCE);
    assert_eq!(differing, 0, "shaded twice from one sort: worst relative difference {worst}");
    // The standard graph shades once: one job too.
    let mut renderer = gpu_renderer();
    renderer.register_view(oxygen_demo::lamp_street_camera(SIZE), StandardGraph::new(config(culling))).expect("view");
    assert_eq!(renderer.render_frame(&scene).expect("frame").views[0].recorded.light_cluster_jobs, 1);
}

#[test]
fn a_grid_too_large_for_a_storage_binding_is_refused_with_its_numbers() {
    let scene = oxygen_demo::lamp_street(LAMPS);
    let mut renderer = gpu_renderer();
    let camera = oxygen_demo::lamp_street_camera(UVec2::new(256, 256));
    renderer.register_view(camera, StandardGraph::new(config(clustered(1, 64)))).expect("view");
    let error = renderer.render_frame(&scene).expect_err("a grid of 4 million clusters × 1 000 lights").to_string();
    assert!(error.contains("light bits") && error.contains("larger tiles"), "{error}");
}
