//! Views as coroutines: typed links order recording whatever the
//! registration order, a link that would close a cycle is refused, a graph
//! reading an output it is not linked to fails clearly, shadow views follow
//! the lights of each frame, and recording on several threads draws exactly
//! what recording on one does.

mod support;

use oxygen::ViewRole;
use oxygen::core::NodeKey;
use oxygen::glam::{Quat, Vec4};
use oxygen::lighting::{CascadeSettings, LocalShadowSettings, ProbeUpdate, ReflectionProbe};
use oxygen::passes::PassError;
use oxygen::prelude::*;
use oxygen::views::Views;

/// A sun, a spot and a point light (all casting shadows), a mirror ball, a
/// red box and a ground plane.
fn lit_scene() -> (Scene, NodeKey, NodeKey, NodeKey) {
    let mut scene = Scene::new();
    let grey = scene.add_material(Material::opaque("ground", Vec4::splat(0.6)));
    let plane = scene.add_geometry(Geometry::plane(20.0));
    let ground = scene.add_node("ground", Transform::IDENTITY);
    scene.set_renderable(ground, Renderable { geometry: plane, materials: vec![grey] }).unwrap();
    let red = scene.add_material(Material::opaque("red", Vec4::new(0.85, 0.1, 0.08, 1.0)));
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let boxed = scene.add_node("red box", Transform::from_translation(Vec3::new(2.0, 0.5, 0.0)));
    scene.set_renderable(boxed, Renderable { geometry: cube, materials: vec![red] }).unwrap();
    let mirror =
        scene.add_material(Material { metallic: 1.0, roughness: 0.03, ..Material::opaque("mirror", Vec4::ONE) });
    let sphere = scene.add_geometry(Geometry::uv_sphere(1.0, 32, 16));
    let ball = scene.add_node("mirror ball", Transform::from_translation(Vec3::new(0.0, 1.0, 0.0)));
    scene.set_renderable(ball, Renderable { geometry: sphere, materials: vec![mirror] }).unwrap();
    let travelling = Vec3::new(-0.5, -1.0, -0.35).normalize();
    let sun =
        scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, travelling)));
    scene.set_light(sun, Some(Light::directional(2.0))).unwrap();
    let spot_at = Vec3::new(-4.0, 4.0, 2.0);
    let aim = (Vec3::new(0.0, 0.0, 0.0) - spot_at).normalize();
    let spot = scene.add_node(
        "spot",
        Transform::from_translation(spot_at).with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, aim)),
    );
    scene.set_light(spot, Some(Light::spot(200.0, Some(25.0), 0.3, 0.45))).unwrap();
    let lamp = scene.add_node("lamp", Transform::from_translation(Vec3::new(3.0, 1.5, 1.5)));
    scene.set_light(lamp, Some(Light::point(20.0, Some(10.0)))).unwrap();
    (scene, sun, spot, lamp)
}

fn camera() -> LookAtResolver {
    LookAtResolver::new(
        Camera::perspective(50f32.to_radians(), 0.1, Some(60.0)),
        Vec3::new(0.5, 4.0, 7.0),
        Vec3::new(0.0, 0.6, 0.0),
        UVec2::new(128, 96),
    )
    .unwrap()
}

fn cascades() -> CascadeSettings {
    CascadeSettings { count: 2, resolution: 256, max_distance: 30.0, ..Default::default() }
}

fn local_shadows() -> Option<LocalShadowSettings> {
    Some(LocalShadowSettings { resolution: 256, ..Default::default() })
}

fn pixels_differing(a: &image::RgbaImage, b: &image::RgbaImage, tolerance: u8) -> usize {
    a.pixels().zip(b.pixels()).filter(|(p, q)| p.0.iter().zip(q.0).any(|(x, y)| x.abs_diff(y) > tolerance)).count()
}

/// The main view registered before its probe gives the same image as after
/// it: the renderer records it after the probe's faces and its own shadow
/// views either way, and the first frame already shows the reflection.
#[test]
fn registering_the_main_view_first_gives_the_same_image() {
    let (scene, ..) = lit_scene();
    let render = |main_first: bool| {
        let options = RendererOptions { local_shadows: local_shadows(), ..Default::default() };
        let mut renderer = support::gpu_renderer_with(options);
        let desc = || ViewDesc::new(camera()).with_sun_shadows(cascades());
        let (main, probe) = if main_first {
            let main = renderer.register_view(desc(), standard_render_graph).unwrap();
            let probe =
                ReflectionProbe::register(&mut renderer, Vec3::Y, 64, (0.05, 40.0), ProbeUpdate::EveryFrame).unwrap();
            renderer.link(main, probe.cube()).unwrap();
            (main, probe)
        } else {
            let probe =
                ReflectionProbe::register(&mut renderer, Vec3::Y, 64, (0.05, 40.0), ProbeUpdate::EveryFrame).unwrap();
            (renderer.register_view(desc().reads(probe.cube()), standard_render_graph).unwrap(), probe)
        };
        let report = renderer.render_frame(&scene).unwrap();
        // Cascades, local shadows and probe faces all record before the main view.
        let main_at = report.views.iter().position(|v| v.view == main).unwrap();
        assert_eq!(main_at, report.views.len() - 1, "main_first {main_first}: {:?}", renderer.last_frame_views());
        assert_eq!(report.views.iter().filter(|v| matches!(v.role, ViewRole::SunCascade { .. })).count(), 2);
        assert_eq!(report.views.iter().filter(|v| matches!(v.role, ViewRole::LocalShadow { .. })).count(), 7);
        assert_eq!(report.views.iter().filter(|v| matches!(v.role, ViewRole::ProbeFace { .. })).count(), 6);
        assert!(probe.faces().iter().all(|f| report.views.iter().any(|v| v.view == *f)));
        support::assert_hdr_finite(&renderer, main);
        support::read_lit_color(&renderer, main)
    };
    let after = render(false);
    let before = render(true);
    let differing = pixels_differing(&before, &after, 2);
    assert_eq!(differing, 0, "{differing} pixels differ between the two registration orders");
    // The mirror ball reflects the red box: the probe's faces were there on frame 1.
    let red = after.pixels().filter(|p| p.0[0] > 120 && p.0[0] as i32 > p.0[1] as i32 + 60).count();
    assert!(red > 50, "hardly any red in the image ({red} pixels)");
}

#[test]
fn a_link_that_closes_a_cycle_is_refused() {
    let mut renderer = support::gpu_renderer();
    let a = renderer.register_view(camera(), standard_render_graph).unwrap();
    let b = renderer.register_view(ViewDesc::new(camera()).reads(a.hdr()), standard_render_graph).unwrap();
    let c = renderer.register_view(ViewDesc::new(camera()).reads(b.depth()), standard_render_graph).unwrap();
    let err = renderer.link(a, c.hdr()).unwrap_err();
    assert!(matches!(err, oxygen::RenderError::LinkCycle { view, .. } if view == a), "{err}");
    assert!(err.to_string().contains("cycle"), "{err}");
    assert!(matches!(renderer.link(a, a.depth()), Err(oxygen::RenderError::LinkCycle { .. })));
    // A link to a view that does not exist is refused too.
    let gone = renderer.register_view(camera(), standard_render_graph).unwrap();
    renderer.unregister_view(gone).unwrap();
    assert!(matches!(renderer.link(a, gone.depth()), Err(oxygen::RenderError::NoSuchView(v)) if v == gone));
    assert!(renderer.register_view(ViewDesc::new(camera()).reads(gone.hdr()), standard_render_graph).is_err());
}

/// A picture-in-picture view reads another view's HDR image through a typed
/// link: it records after it, whatever the ids, and finds it in its inputs.
#[test]
fn a_graph_reads_a_linked_output_and_fails_clearly_on_an_unlinked_one() {
    let (scene, ..) = lit_scene();
    let mut renderer = support::gpu_renderer();
    // Registered first, so its id is lower: only the link puts it second.
    let reader_desc = |source: ViewId| ViewDesc::new(camera()).reads(source.hdr());
    let placeholder = renderer.register_view(camera(), standard_render_graph).unwrap();
    let source = renderer.register_view(camera(), standard_render_graph).unwrap();
    renderer.unregister_view(placeholder).unwrap();
    let hdr = source.hdr();
    let reader = renderer
        .register_view(reader_desc(source), async move |ctx: &RenderContext<'_>, rec: &mut CommandRecorder| {
            let (view, texture) = ctx.input(hdr).await?;
            assert_eq!(view.viewport, UVec2::new(128, 96));
            let _ = texture;
            standard_render_graph.record(ctx, rec).await
        })
        .unwrap();
    renderer.link(source, reader.depth()).unwrap_err(); // reader already reads source
    let report = renderer.render_frame(&scene).unwrap();
    let order: Vec<ViewId> = report.views.iter().map(|v| v.view).collect();
    assert_eq!(order, vec![source, reader]);

    let other = renderer.register_view(camera(), standard_render_graph).unwrap();
    let depth = other.depth();
    let unlinked = renderer
        .register_view(camera(), async move |ctx: &RenderContext<'_>, _rec: &mut CommandRecorder| {
            ctx.input(depth).await.map(|_| ())
        })
        .unwrap();
    match renderer.render_frame(&scene) {
        Err(oxygen::RenderError::Pass { view, source: PassError::UndeclaredInput { output, from }, .. }) => {
            assert_eq!(view, unlinked);
            assert_eq!((output, from), ("depth", other.to_string()));
        }
        other => panic!("expected an undeclared-input error, got {other:?}"),
    }
}

/// Local shadow views follow the lights of each frame: a light added,
/// removed or made shadow-casting after the views were registered gets or
/// loses its shadow views, with no call from the application.
#[test]
fn shadow_views_follow_the_lights_of_each_frame() {
    let (mut scene, sun, spot, lamp) = lit_scene();
    let spot_light = scene.node(spot).unwrap().light.clone().unwrap();
    let lamp_light = scene.node(lamp).unwrap().light.clone().unwrap();
    let sun_light = scene.node(sun).unwrap().light.clone().unwrap();
    for node in [sun, spot, lamp] {
        scene.set_light(node, None).unwrap();
    }
    let options = RendererOptions { local_shadows: local_shadows(), ..Default::default() };
    let mut renderer = support::gpu_renderer_with(options);
    let main =
        renderer.register_view(ViewDesc::new(camera()).with_sun_shadows(cascades()), standard_render_graph).unwrap();
    let mut frame = |scene: &Scene| {
        let report = renderer.render_frame(scene).unwrap();
        support::assert_hdr_finite(&renderer, main);
        let count = |f: fn(&ViewRole) -> bool| report.views.iter().filter(|v| f(&v.role)).count();
        let cascades = count(|r| matches!(r, ViewRole::SunCascade { .. }));
        let local = count(|r| matches!(r, ViewRole::LocalShadow { .. }));
        (cascades, local, renderer.shadow_views().len())
    };
    assert_eq!(frame(&scene), (0, 0, 0), "no light, no shadow view");
    scene.set_light(spot, Some(spot_light.clone())).unwrap();
    assert_eq!(frame(&scene), (0, 1, 1), "a spot added: one view");
    scene.set_light(lamp, Some(lamp_light.clone())).unwrap();
    assert_eq!(frame(&scene), (0, 7, 7), "a point light added: six more");
    scene.set_light(sun, Some(sun_light)).unwrap();
    assert_eq!(frame(&scene), (2, 7, 9), "a sun added: the view's two cascades");
    scene.set_light(spot, None).unwrap();
    assert_eq!(frame(&scene), (2, 6, 8), "the spot removed");
    scene.set_light(lamp, Some(Light { casts_shadows: false, ..lamp_light })).unwrap();
    assert_eq!(frame(&scene), (2, 0, 2), "the point light stops casting");
    // The cascades belong to the view: unregistering it removes them.
    renderer.unregister_view(main).unwrap();
    assert!(renderer.sun_cascades(main).is_empty());
    assert!(renderer.shadow_views().is_empty());
    let report = renderer.render_frame(&scene).unwrap();
    assert!(report.views.is_empty(), "nothing left to render: {:?}", report.views);
}

/// Recording on every worker thread gives exactly the image of recording on
/// one, for many views with shadows and a probe.
#[test]
fn concurrent_recording_draws_what_one_thread_draws() {
    let (scene, ..) = lit_scene();
    let render = |threads: usize| {
        let options =
            RendererOptions { prep_threads: Some(threads), local_shadows: local_shadows(), ..Default::default() };
        let mut renderer = support::gpu_renderer_with(options);
        let probe =
            ReflectionProbe::register(&mut renderer, Vec3::Y, 32, (0.05, 40.0), ProbeUpdate::EveryFrame).unwrap();
        let views: Vec<ViewId> = (0..4)
            .map(|i| {
                let eye = Quat::from_rotation_y(i as f32 * 0.6) * Vec3::new(0.5, 4.0, 7.0);
                let desc =
                    ViewDesc::new(LookAtResolver { eye, ..camera() }).with_sun_shadows(cascades()).reads(probe.cube());
                renderer.register_view(desc, standard_render_graph).unwrap()
            })
            .collect();
        let report = renderer.render_frame(&scene).unwrap();
        assert_eq!(report.record_threads, threads.min(report.views.len()));
        let created = renderer.internals().pipelines.pipelines_created();
        renderer.render_frame(&scene).unwrap();
        assert_eq!(renderer.internals().pipelines.pipelines_created(), created, "no pipeline created after frame 1");
        views.iter().map(|v| support::read_lit_color(&renderer, *v)).collect::<Vec<_>>()
    };
    let one = render(1);
    let two = render(2);
    for (i, (a, b)) in one.iter().zip(&two).enumerate() {
        assert_eq!(pixels_differing(a, b, 1), 0, "view {i} differs between 1 and 2 recording threads");
    }
}

/// `Views::prepare` gives, without a GPU, the prepared frame the renderer
/// prepares for the same registered view.
#[test]
fn a_registered_view_prepares_without_a_gpu_as_the_renderer_does() {
    let demo = oxygen_demo::multi_view_scene();
    let mut views = Views::new();
    let main = views.register(oxygen_demo::main_camera(UVec2::new(96, 64)), standard_render_graph).unwrap();
    let cpu_dump = views.prepare(&demo.scene, main).unwrap().dump();
    let options = oxygen::gpu::GpuOptions { optional_features: Renderer::OPTIONAL_FEATURES, ..Default::default() };
    let gpu = oxygen::gpu::GpuContext::new_headless(&options).unwrap();
    let mut renderer = Renderer::with_views(gpu, RendererOptions::default(), views).unwrap();
    renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(renderer.prepared_frame(main).unwrap().dump(), cpu_dump);
}
