//! Issue 15, items 2 and 3: no full-screen pass a view does not need, the
//! HDR format as a knob with a measured error, and shaders specialised to
//! what each view has this frame. Every image comparison counts pixels
//! differing by more than a per-channel tolerance; none compares bytes.

mod support;

use image::RgbaImage;
use oxygen::FrameReport;
use oxygen::glam::Quat;
use oxygen::gpu::HdrFormat;
use oxygen::lighting::LocalShadowSettings;
use oxygen::passes::{PassKind, PipelineKey};
use oxygen::prelude::*;
use oxygen_demo::record::Row;

const SIZE: u32 = 96;

/// A grey floor under a sun at a grazing angle and a point light close
/// above it: a smooth radial gradient from bright to dark, and a box for
/// an edge and a shadow.
fn gradient_scene() -> Scene {
    let mut scene = oxygen_demo::floor_with_box(0.8);
    let lamp = scene.add_node("lamp", Transform::from_translation(Vec3::new(-1.0, 1.2, 0.0)));
    scene.set_light(lamp, Some(Light::point(6.0, None))).expect("a node");
    scene
}

fn camera() -> LookAtResolver {
    LookAtResolver::new(
        Camera::perspective(60f32.to_radians(), 0.1, None),
        Vec3::new(0.0, 3.0, 5.0),
        Vec3::new(0.0, 0.0, -1.0),
        UVec2::splat(SIZE),
    )
    .unwrap()
}

fn renderer(options: RendererOptions) -> Renderer {
    Renderer::new_headless_with(options).unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"))
}

/// Pixels whose channels differ by more than `tolerance` levels, and the
/// largest difference of any channel.
fn differing_pixels(a: &RgbaImage, b: &RgbaImage, tolerance: u8) -> (usize, u8) {
    assert_eq!(a.dimensions(), b.dimensions());
    let mut count = 0;
    let mut largest = 0;
    for (p, q) in a.pixels().zip(b.pixels()) {
        let diff = (0..3).map(|c| p[c].abs_diff(q[c])).max().unwrap_or(0);
        largest = largest.max(diff);
        if diff > tolerance {
            count += 1;
        }
    }
    (count, largest)
}

fn render_once(options: RendererOptions, scene: &Scene) -> (Renderer, ViewId, FrameReport) {
    let mut renderer = renderer(options);
    let view = renderer.register_view(camera(), standard_render_graph).expect("a valid view");
    let report = renderer.render_frame(scene).expect("the frame renders");
    (renderer, view, report)
}

#[test]
fn tone_mapping_while_shading_matches_the_tone_map_pass_with_one_pass_fewer() {
    let scene = gradient_scene();
    let (two_pass, two_view, two_report) =
        render_once(RendererOptions { keep_hdr: true, ..Default::default() }, &scene);
    let (in_pass, in_view, in_report) = render_once(RendererOptions::default(), &scene);

    let two = two_report.views.iter().find(|v| v.view == two_view).expect("the view rendered").recorded;
    let one = in_report.views.iter().find(|v| v.view == in_view).expect("the view rendered").recorded;
    assert!(!two.tone_mapped_in_pass && one.tone_mapped_in_pass);
    assert_eq!(one.render_passes + 1, two.render_passes, "the tone-map pass is gone");
    assert!(matches!(in_pass.read_hdr(in_view), Err(oxygen::RenderError::HdrNotWritten(_))));

    // The two paths differ only by the HDR target's f16 rounding between
    // shading and the operator: at most one level, on few pixels.
    let (a, b) = (support::read_lit_color(&two_pass, two_view), in_pass.read_color(in_view).expect("an image"));
    let (count, largest) = differing_pixels(&a, &b, 1);
    eprintln!("in-pass vs two-pass tone map: {count} pixels differ by more than 1 level, largest {largest}");
    assert_eq!(count, 0, "largest difference {largest}");
}

#[test]
fn a_view_whose_hdr_another_view_reads_keeps_the_tone_map_pass() {
    let scene = gradient_scene();
    let mut renderer = renderer(RendererOptions::default());
    let main = renderer.register_view(camera(), standard_render_graph).expect("a valid view");
    let reader =
        renderer.register_view(ViewDesc::new(camera()).reads(main.hdr()), standard_render_graph).expect("a valid view");
    let report = renderer.render_frame(&scene).expect("the frame renders");
    let stats = |id: ViewId| report.views.iter().find(|v| v.view == id).expect("rendered").recorded;
    assert!(!stats(main).tone_mapped_in_pass, "its HDR is read by {reader:?}");
    assert!(stats(reader).tone_mapped_in_pass, "nobody reads the reader's HDR");
    assert!(renderer.read_hdr(main).is_ok());
}

/// Distinct values of channel `c` over the image: fewer means coarser steps.
fn distinct_levels(image: &RgbaImage, c: usize) -> usize {
    let mut seen = [false; 256];
    image.pixels().for_each(|p| seen[p[c] as usize] = true);
    seen.iter().filter(|s| **s).count()
}

#[test]
fn rg11b10_hdr_stays_within_its_documented_error_and_shows_coarser_steps() {
    let scene = gradient_scene();
    // The HDR target is only used on the two-pass path: keep it.
    let options = RendererOptions { keep_hdr: true, ..Default::default() };
    let (wide, wide_view, _) = render_once(options, &scene);
    let (packed, packed_view, _) =
        render_once(RendererOptions { hdr_format: HdrFormat::Rg11b10Ufloat, ..options }, &scene);
    if packed.hdr_format() != HdrFormat::Rg11b10Ufloat {
        support::skip::skip("the adapter cannot render Rg11b10Ufloat; the renderer fell back, nothing to compare");
        return;
    }
    // Relative error of the stored radiance: 5 mantissa bits in blue, so
    // truncation costs at most 2^-5 of the value (plus the reference's own
    // f16 rounding, 2^-11); tiny values below 2^-14 compare absolutely.
    let (a, b) = (wide.read_hdr(wide_view).expect("kept"), packed.read_hdr(packed_view).expect("kept"));
    let mut worst = 0f32;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        for c in 0..3 {
            let error = (p[c] - q[c]).abs() / p[c].max(f32::powi(2.0, -14));
            worst = worst.max(error);
        }
    }
    eprintln!("Rg11b10Ufloat: worst relative HDR error {worst:.4}");
    assert!(worst <= 1.0 / 32.0 + 1.0 / 2048.0, "worst relative error {worst}");

    // On screen: small per-pixel differences, on a bounded share of pixels.
    let (x, y) = (support::read_lit_color(&wide, wide_view), support::read_lit_color(&packed, packed_view));
    let (count, largest) = differing_pixels(&x, &y, 2);
    let levels: Vec<_> = (0..3).map(|c| (distinct_levels(&x, c), distinct_levels(&y, c))).collect();
    eprintln!(
        "Rg11b10Ufloat on screen: {count} pixels differ by more than 2 levels, largest {largest}; \
         distinct levels (Rgba16Float, Rg11b10Ufloat) per channel: {levels:?}"
    );
    // Measured on lavapipe: 3 pixels, largest 3 levels (GL cannot render
    // the format: skipped there). Allowed: 1.5 × each, rounded down.
    assert!(largest <= 4, "largest difference {largest} levels");
    assert!(count <= 4, "{count} pixels differ by more than 2 levels");
    // The banding: the packed format's gradient has fewer distinct steps in
    // blue (5 mantissa bits) than the half-float one.
    assert!(levels[2].1 < levels[2].0, "blue levels {:?}", levels[2]);
    // docs/performance.md, "Frame economy" (scripts/test-records.sh).
    support::record::write_on(&packed.gpu().adapter_info, |mut record| {
        record.insert("viewport_px", [SIZE, SIZE]);
        record.insert("pixels", x.width() * x.height());
        record.insert("worst_relative_hdr_error", worst);
        record.insert("worst_relative_hdr_error_max", 1.0 / 32.0 + 1.0 / 2048.0);
        record.insert("pixels_over_2_levels", count);
        record.insert("pixels_over_2_levels_max", 4);
        record.insert("largest_difference_levels", largest);
        record.insert("largest_difference_levels_max", 4);
        for (channel, (wide, packed)) in ["red", "green", "blue"].into_iter().zip(&levels) {
            let row = Row::new()
                .value("channel", channel)
                .value("rgba16float_levels", *wide)
                .value("rg11b10ufloat_levels", *packed);
            record.push_row(row);
        }
        record
    });
}

fn forward_keys(renderer: &Renderer) -> Vec<PipelineKey> {
    renderer
        .internals()
        .pipelines
        .used_this_frame()
        .into_iter()
        .filter(|k| matches!(k.pass, PassKind::ShadingAfterPrePass | PassKind::Shading))
        .collect()
}

#[test]
fn shading_pipelines_follow_the_lights_of_each_frame() {
    let mut scene = gradient_scene();
    // Start without positional lights: only the sun.
    let lamp = scene.nodes().find(|(_, n)| n.name == "lamp").map(|(k, _)| k).expect("the lamp");
    scene.set_light(lamp, None).expect("a node");
    let shadows = Some(LocalShadowSettings::default());
    let mut special = renderer(RendererOptions { local_shadows: shadows, ..Default::default() });
    let mut full =
        renderer(RendererOptions { local_shadows: shadows, specialize_shaders: false, ..Default::default() });
    let view = special.register_view(camera(), standard_render_graph).expect("a valid view");
    let full_view = full.register_view(camera(), standard_render_graph).expect("a valid view");
    let compare = |special: &Renderer, full: &Renderer, state: &str| {
        let a = special.read_color(view).expect("an image");
        let b = full.read_color(full_view).expect("an image");
        let (count, largest) = differing_pixels(&a, &b, 1);
        assert_eq!(count, 0, "{state}: specialised image differs from the full shader's by up to {largest}");
    };

    special.render_frame(&scene).expect("frame 1");
    full.render_frame(&scene).expect("frame 1");
    let first = forward_keys(&special);
    assert!(!first.is_empty());
    assert!(first.iter().all(|k| !k.features.local_lights && !k.features.local_shadows && !k.features.textures));
    compare(&special, &full, "sun only");
    let created = special.internals().pipelines.pipelines_created();

    // A shadow-casting spot: pipelines with the positional-light loop and
    // the atlas lookups.
    let spot = scene.add_node(
        "spot",
        Transform::from_translation(Vec3::new(0.0, 3.0, 0.0))
            .with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::NEG_Y)),
    );
    let light = Light { casts_shadows: true, ..Light::spot(20.0, None, 0.3, 0.5) };
    scene.set_light(spot, Some(light)).expect("a node");
    let report = special.render_frame(&scene).expect("frame 2");
    full.render_frame(&scene).expect("frame 2");
    let second = forward_keys(&special);
    assert!(second.iter().all(|k| k.features.local_lights && k.features.local_shadows));
    assert!(report.pipelines_created > 0, "new combinations compile");
    compare(&special, &full, "with a shadowed spot");

    // The spot goes: back to the first pipelines, none created.
    scene.set_light(spot, None).expect("a node");
    let report = special.render_frame(&scene).expect("frame 3");
    full.render_frame(&scene).expect("frame 3");
    let mut third = forward_keys(&special);
    let mut first_sorted = first.clone();
    let order = |k: &PipelineKey| format!("{k:?}");
    third.sort_by_key(order);
    first_sorted.sort_by_key(order);
    assert_eq!(third, first_sorted);
    assert_eq!(report.pipelines_created, 0);
    assert!(special.internals().pipelines.pipelines_created() > created);
    compare(&special, &full, "the spot removed");
    eprintln!(
        "pipelines: {} created in all, {} used by the last frame",
        special.internals().pipelines.pipelines_created(),
        report.pipelines_used
    );
}
