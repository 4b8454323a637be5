//! Debug mode: every draw record carries its range's generation and the
//! shader paints a draw read through a stale range magenta.

mod support;

use futures::executor::block_on;
use oxygen::bindless::{BindlessHeap, CameraConstants, SceneConstantsBuffer, TexturePath};
use oxygen::gpu::{GpuContext, GpuOptions, ViewTargets};
use oxygen::passes::{DrawPath, FrameProgress, LightingResources, Pipelines, Shading, ViewInputs};
use oxygen::prelude::*;
use oxygen::sceneprep::{ScenePrep, ViewRequest};
use oxygen::views::ViewContext;
use oxygen_demo::{main_camera, multi_view_scene};

fn magenta_pixels(image: &image::RgbaImage) -> usize {
    image.pixels().filter(|p| p.0[0] > 220 && p.0[2] > 220 && p.0[1] < 40).count()
}

#[test]
fn debug_generations_flag_nothing_when_slots_are_current() {
    // keep_hdr: the test reads the HDR target to check it is finite.
    let options = RendererOptions { debug_generations: true, keep_hdr: true, ..Default::default() };
    let mut renderer = Renderer::new_headless_with(options).unwrap();
    let demo = multi_view_scene();
    let view = renderer.register_view(main_camera(UVec2::new(96, 64)), standard_render_graph).unwrap();
    for _ in 0..3 {
        renderer.render_frame(&demo.scene).unwrap();
    }
    let frame = renderer.prepared_frame(view).unwrap();
    assert!(frame.draws().iter().all(|d| d.generation == frame.slots().draw_metadata.generation()));
    assert_eq!(magenta_pixels(&support::read_lit_color(&renderer, view)), 0);
}

#[test]
fn a_stale_draw_range_is_painted_magenta() {
    let gpu_options = GpuOptions { optional_features: Renderer::OPTIONAL_FEATURES, ..Default::default() };
    let gpu = GpuContext::new_headless(&gpu_options).unwrap();
    let texture_path = TexturePath::best_for(gpu.features, &gpu.device.limits());
    let mut heap = BindlessHeap::new(&gpu.device, &gpu.queue, texture_path);
    let lighting = LightingResources::new(&gpu.device, &gpu.queue);
    let pipelines = Pipelines::new(&gpu.device, &heap, &lighting);
    let demo = multi_view_scene();
    let resolver = main_camera(UVec2::new(96, 64));
    let view = resolver
        .resolve(
            &ViewContext { view_id: oxygen::core::ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 },
            &demo.scene,
        )
        .unwrap();

    let mut prep = ScenePrep::new();
    prep.set_debug_generations(true);
    prep.prepare(&demo.scene, &[ViewRequest { view: &view, options: Default::default() }], &mut heap.slots).unwrap();
    prep.upload(&mut heap, &gpu.device, &gpu.queue).unwrap();
    let frame = &prep.frames()[0];

    // The view's constants name a generation its records do not carry, as if
    // they pointed at a range that was freed and handed to someone else.
    let mut constants = SceneConstantsBuffer::new(&gpu.device, heap.scene_constants_layout(), "stale view");
    constants.set_camera(
        &gpu.queue,
        &CameraConstants::new(
            view.view,
            view.projection,
            view.view_projection,
            view.inverse_view_projection,
            view.camera_position,
        ),
    );
    let mut renderer_constants = frame.renderer_constants(0.0);
    renderer_constants.draw_metadata_generation += 1;
    constants.set_renderer(&gpu.queue, &renderer_constants);

    let targets = ViewTargets::new(&gpu.device, 96, 64, "stale view");
    let ctx = RenderContext {
        gpu: &gpu,
        view: &view,
        prepared: frame,
        scene_constants: &constants,
        heap: &heap,
        targets: &targets,
        pipelines: &pipelines,
        lighting: &lighting,
        draw_path: DrawPath::Direct,
        inputs: ViewInputs::default(),
        progress: &FrameProgress::new([]),
        origin: glam::DVec3::ZERO,
        hdr_read_by_others: false,
        shading: Shading::ALL,
        time_seconds: 0.0,
        overlay: None,
    };
    let mut recorder = CommandRecorder::new(&gpu.device, "stale view");
    // Driven by hand under `block_on`: with no recording thread attached,
    // the pipelines compile inline.
    block_on(async {
        MeshPass::depth_pre_pass().run(&ctx, &mut recorder).await?;
        MeshPass::forward_lit(ForwardLitConfig::default()).run(&ctx, &mut recorder).await?;
        TonemapPass::default().run(&ctx, &mut recorder).await
    })
    .unwrap();
    gpu.queue.submit([recorder.finish().0]);
    let color = targets.color.as_ref().unwrap();
    support::assert_hdr_image_finite(&gpu.read_rgba16_float(&color.hdr).unwrap(), "stale view");
    let image = gpu.read_rgba8(color.color.as_ref().unwrap()).unwrap();
    let flagged = magenta_pixels(&image);
    assert!(flagged > 96 * 64 / 4, "only {flagged} pixels flagged");
}

/// The GPU culling path writes its draws itself, and stamps each with its
/// range's generation as the CPU path does: in debug mode a GPU-culled
/// view paints nothing magenta, and every draw it read back carries the
/// generation (found by the WGSL mutant `generation-not-stamped-by-cull`,
/// which no test caught: the tests above draw on the CPU path).
#[test]
fn debug_generations_flag_nothing_on_the_gpu_culling_path() {
    use oxygen::sceneprep::Visibility;
    let options = RendererOptions { debug_generations: true, ..Default::default() };
    let Some(mut renderer) = support::gpu_visibility_renderer(options) else { return };
    let demo = multi_view_scene();
    let desc = ViewDesc::new(main_camera(UVec2::new(96, 64))).with_visibility(Visibility::GpuFrustum);
    let view = renderer.register_view(desc, standard_render_graph).unwrap();
    for _ in 0..3 {
        renderer.render_frame(&demo.scene).unwrap();
    }
    let generation = renderer.prepared_frame(view).unwrap().slots().draw_metadata.generation();
    let draws: Vec<_> = renderer.view_draws(view).unwrap().into_iter().flat_map(|(_, draws)| draws).collect();
    assert!(!draws.is_empty(), "the view draws the scene");
    assert!(draws.iter().all(|d| d.generation == generation), "every GPU-written draw carries generation {generation}");
    assert_eq!(magenta_pixels(&support::read_lit_color(&renderer, view)), 0);
}
