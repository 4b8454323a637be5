//! Views shown in windows, without a display: offscreen windows compose
//! exactly what a surface would get. Each view's rectangle of the window
//! must equal the view rendered alone at that size; windows follow resizes
//! (targets and aspect ratio) and skip their views while minimised.

mod support;

use oxygen::glam::{Quat, Vec4};
use oxygen::lighting::CascadeSettings;
use oxygen::prelude::*;
use oxygen::windows::WindowRect;
use support::golden::compare;
use support::gpu_renderer;

fn scene() -> Scene {
    let mut scene = Scene::new();
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let floor = scene.add_geometry(Geometry::plane(20.0));
    let red = scene.add_material(Material::opaque("red", Vec4::new(0.8, 0.15, 0.1, 1.0)));
    let grey = scene.add_material(Material::opaque("grey", Vec4::splat(0.5)));
    let node = scene.add_node("cube", Transform::from_translation(Vec3::new(0.0, 0.5, 0.0)));
    scene.set_renderable(node, Renderable { geometry: cube, materials: vec![red] }).unwrap();
    let ground = scene.add_node("floor", Transform::IDENTITY);
    scene.set_renderable(ground, Renderable { geometry: floor, materials: vec![grey] }).unwrap();
    let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_x(-0.9)));
    scene.set_light(sun, Some(Light::directional(3.0))).unwrap();
    scene
}

fn camera(eye: Vec3) -> LookAtResolver {
    LookAtResolver { camera: Camera::perspective(60f32.to_radians(), 0.1, None), ..orthographic(eye) }
}

/// An editor's axis view from `eye` (an orthographic camera).
fn orthographic(eye: Vec3) -> LookAtResolver {
    LookAtResolver {
        camera: Camera::orthographic(2.5, 0.1, 20.0),
        eye,
        target: Vec3::new(0.0, 0.5, 0.0),
        up: Vec3::Y,
        // Deliberately not the window's size: a view shown in a window
        // takes its rectangle's.
        viewport: UVec2::new(17, 31),
    }
}

const EYES: [Vec3; 4] =
    [Vec3::new(3.0, 2.0, 3.0), Vec3::new(-3.0, 2.0, 3.0), Vec3::new(0.0, 6.0, 0.01), Vec3::new(4.0, 0.6, 0.0)];

/// An editor's 2 × 2 layout: the perspective view, then orthographic
/// front, side and top views.
fn editor_cell(i: usize) -> LookAtResolver {
    const AXIS_EYES: [Vec3; 3] = [Vec3::new(0.0, 0.5, 6.0), Vec3::new(6.0, 0.5, 0.0), Vec3::new(0.0, 6.0, 0.01)];
    if i == 0 { camera(EYES[0]) } else { orthographic(AXIS_EYES[i - 1]) }
}

/// The rectangle `origin`, `size` of `image`.
fn crop(image: &oxygen::image::RgbaImage, origin: UVec2, size: UVec2) -> oxygen::image::RgbaImage {
    oxygen::image::imageops::crop_imm(image, origin.x, origin.y, size.x, size.y).to_image()
}

/// An editor's layout (perspective + orthographic front, side, top): each
/// cell equals its view rendered alone at the cell's size, and each shows
/// the red cube.
#[test]
fn a_two_by_two_layout_shows_each_view_in_its_cell() {
    let scene = scene();
    let mut renderer = gpu_renderer();
    let window = renderer.add_offscreen_window(UVec2::new(257, 193));
    let views: Vec<ViewId> = (0..4)
        .map(|i| {
            let rect = WindowRect::grid(2, 2, i as u32 % 2, i as u32 / 2);
            renderer.register_view(ViewDesc::new(editor_cell(i)).shown_in(window, rect), standard_render_graph).unwrap()
        })
        .collect();
    let report = renderer.render_frame(&scene).unwrap();
    assert_eq!(report.windows_presented, 1);
    let composed = renderer.read_window(window).unwrap();
    assert_eq!(composed.dimensions(), (257, 193));
    // The same views alone, at their cells' sizes.
    let mut alone = gpu_renderer();
    for (i, &shown_view) in views.iter().enumerate() {
        let (origin, size) = WindowRect::grid(2, 2, i as u32 % 2, i as u32 / 2).pixels(UVec2::new(257, 193));
        let reference =
            alone.register_view(LookAtResolver { viewport: size, ..editor_cell(i) }, standard_render_graph).unwrap();
        alone.render_frame(&scene).unwrap();
        let expected = alone.read_color(reference).unwrap();
        let shown = renderer.read_color(shown_view).unwrap();
        assert_eq!(shown.dimensions(), (size.x, size.y), "view {i} takes its cell's size");
        let diff = compare(&crop(&composed, origin, size), &expected, 2);
        assert_eq!(
            diff.differing, 0,
            "cell {i}: {} of {} pixels differ (worst {})",
            diff.differing, diff.total, diff.worst
        );
        let red = expected.pixels().filter(|p| i32::from(p[0]) > i32::from(p[1]) + 30).count();
        // The side cell sees the unlit face, dark red.
        assert!(red > 20, "cell {i} shows the cube ({red} red pixels)");
        alone.unregister_view(reference).unwrap();
    }
}

#[test]
fn views_follow_a_resized_window_and_skip_a_minimised_one() {
    let scene = scene();
    let mut renderer = gpu_renderer();
    let window = renderer.add_offscreen_window(UVec2::new(160, 90));
    let main = renderer
        .register_view(ViewDesc::new(camera(EYES[0])).shown_in(window, WindowRect::FULL), standard_render_graph)
        .unwrap();
    let inset = WindowRect { x: 0.7, y: 0.05, width: 0.25, height: 0.25 };
    let pip =
        renderer.register_view(ViewDesc::new(camera(EYES[2])).shown_in(window, inset), standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    assert_eq!(renderer.read_color(main).unwrap().dimensions(), (160, 90));
    let wide = renderer.prepared_frame(main).map(|f| f.view_id());
    assert_eq!(wide, Some(main));

    // Resized: the view's target and aspect follow.
    renderer.resize_window(window, UVec2::new(90, 160)).unwrap();
    let report = renderer.render_frame(&scene).unwrap();
    assert_eq!(renderer.read_color(main).unwrap().dimensions(), (90, 160));
    assert_eq!(renderer.read_window(window).unwrap().dimensions(), (90, 160));
    assert_eq!(report.windows_presented, 1);
    // The picture-in-picture is composed over the main view.
    let composed = renderer.read_window(window).unwrap();
    let (origin, size) = inset.pixels(UVec2::new(90, 160));
    let diff = compare(&crop(&composed, origin, size), &renderer.read_color(pip).unwrap(), 2);
    assert_eq!(diff.differing, 0, "the inset shows the second view");

    // Minimised: nothing rendered, nothing presented, no warning.
    renderer.resize_window(window, UVec2::ZERO).unwrap();
    let report = renderer.render_frame(&scene).unwrap();
    assert_eq!(report.windows_presented, 0);
    assert!(report.views.iter().all(|v| v.view != main && v.view != pip), "a minimised window's views are skipped");
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);

    // Restored.
    renderer.resize_window(window, UVec2::new(120, 80)).unwrap();
    let report = renderer.render_frame(&scene).unwrap();
    assert_eq!(report.windows_presented, 1);
    assert_eq!(renderer.read_window(window).unwrap().dimensions(), (120, 80));
}

#[test]
fn unknown_windows_are_errors_not_panics() {
    let mut renderer = gpu_renderer();
    let window = renderer.add_offscreen_window(UVec2::new(8, 8));
    assert!(matches!(renderer.read_window(window), Err(RenderError::NothingPresented(_))));
    renderer.remove_window(window).unwrap();
    assert!(matches!(renderer.resize_window(window, UVec2::ONE), Err(RenderError::NoSuchWindow(_))));
    assert!(matches!(renderer.read_window(window), Err(RenderError::NoSuchWindow(_))));
}

/// A view's shadow cascades, depth-only views the renderer creates, shown
/// in small rectangles: grey depth (near white), with the caster visible.
#[test]
fn shadow_cascades_can_be_shown_as_grey_depth() {
    let scene = scene();
    let mut renderer = gpu_renderer();
    let window = renderer.add_offscreen_window(UVec2::new(200, 150));
    let cascades = CascadeSettings { count: 2, resolution: 256, ..Default::default() };
    let desc = ViewDesc::new(camera(EYES[0])).shown_in(window, WindowRect::FULL).with_sun_shadows(cascades);
    let main = renderer.register_view(desc, standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    let ids = renderer.sun_cascades(main);
    assert_eq!(ids.len(), 2);
    let rects: Vec<WindowRect> =
        (0..2).map(|i| WindowRect { x: 0.02 + i as f32 * 0.5, y: 0.6, width: 0.4, height: 0.38 }).collect();
    for (id, rect) in ids.iter().zip(&rects) {
        renderer.show_in_window(*id, window, *rect).unwrap();
    }
    renderer.render_frame(&scene).unwrap();
    let composed = renderer.read_window(window).unwrap();
    for rect in &rects {
        let (origin, size) = rect.pixels(UVec2::new(200, 150));
        let cell = crop(&composed, origin, size);
        assert!(cell.pixels().all(|p| p[0] == p[1] && p[1] == p[2]), "a depth view is shown as grey");
        let (lo, hi) = cell.pixels().fold((255u8, 0u8), |(lo, hi), p| (lo.min(p[0]), hi.max(p[0])));
        assert!(hi > lo + 20, "the cascade shows its casters (grey levels {lo}..{hi})");
    }
    // Near is white: the grey follows the cascade's device depth (reverse-Z,
    // larger is nearer), so the texels nearest the light are the lightest.
    // Each pixel of the rectangle shows the texel under its centre.
    for (id, rect) in ids.iter().zip(&rects) {
        let depth = renderer.read_depth(*id).unwrap();
        let (origin, size) = rect.pixels(UVec2::new(200, 150));
        let cell = crop(&composed, origin, size);
        let mut samples: Vec<(f32, u8)> = cell
            .enumerate_pixels()
            .map(|(x, y, p)| {
                let tx = ((x as f32 + 0.5) / size.x as f32 * depth.width as f32) as u32;
                let ty = ((y as f32 + 0.5) / size.y as f32 * depth.height as f32) as u32;
                (depth.get(tx.min(depth.width - 1), ty.min(depth.height - 1)), p[0])
            })
            .collect();
        samples.sort_by(|a, b| a.0.total_cmp(&b.0));
        let tenth = samples.len() / 10;
        let mean = |s: &[(f32, u8)]| s.iter().map(|(_, g)| f32::from(*g)).sum::<f32>() / s.len() as f32;
        let (far, near) = (mean(&samples[..tenth]), mean(&samples[samples.len() - tenth..]));
        // Measured: 11.9 against 0.0 in the far cascade (inverted, the
        // nearest would be the darkest).
        assert!(near > far + 5.0, "{id:?}: nearest tenth grey {near:.1}, farthest tenth {far:.1}");
    }
    renderer.hide_from_window(ids[0]);
    let gone = renderer.add_offscreen_window(UVec2::ONE);
    renderer.remove_window(gone).unwrap();
    assert!(matches!(renderer.show_in_window(ids[0], gone, WindowRect::FULL), Err(RenderError::NoSuchWindow(_))));
}

/// The viewer's title shows the GPU time of recent frames: reported once a
/// frame's timestamps have been read back, where the device has them.
#[test]
fn frames_report_their_gpu_time() {
    let scene = scene();
    let mut renderer = gpu_renderer();
    if !renderer.gpu().features.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS) {
        support::skip::skip(format_args!("{} has no timestamps inside encoders", renderer.gpu().describe()));
        return;
    }
    let view = renderer
        .register_view(LookAtResolver { viewport: UVec2::new(64, 48), ..camera(EYES[0]) }, standard_render_graph)
        .unwrap();
    let first = renderer.render_frame(&scene).unwrap();
    assert_eq!(first.gpu_seconds, None, "nothing has been read back before the first frame");
    let mut reported = None;
    for _ in 0..4 {
        renderer.read_color(view).unwrap(); // waits for the GPU
        reported = renderer.render_frame(&scene).unwrap().gpu_seconds;
    }
    let seconds = reported.expect("a frame time within four frames");
    assert!(seconds.is_finite() && seconds > 0.0 && seconds < 10.0, "{seconds} s");
}
