//! Exposure scales radiance before the tone map, on screen: a quarter of
//! the exposure darkens a lit surface, black stays black; the forward pass
//! tone-mapping in place applies the same exposure as the tone-map pass.

mod support;

use oxygen::core::Scene;
use oxygen::glam::Vec4;
use oxygen::prelude::*;
use support::{gpu_renderer, read_lit_color};

/// How the picture is tone-mapped: by the tone-map pass after shading, or
/// by the shading pass itself (`MeshPass::tone_mapped`).
#[derive(Clone, Copy)]
enum ToneMap {
    Pass,
    InPass,
}

fn render(exposure: f32) -> image::RgbaImage {
    render_with(exposure, ToneMap::Pass)
}

fn render_with(exposure: f32, tone_map: ToneMap) -> image::RgbaImage {
    let mut scene = Scene::new();
    let grey = scene.add_material(Material::opaque("grey", Vec4::splat(0.6)));
    let quad = scene.add_geometry(Geometry::quad(1.0));
    let node = scene.add_node("quad", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry: quad, materials: vec![grey] }).unwrap();
    let sun = scene.add_node("sun", Transform::IDENTITY);
    scene.set_light(sun, Some(Light::directional(2.0))).unwrap();
    let camera = LookAtResolver::new(
        Camera::orthographic(1.0, 0.1, 20.0),
        Vec3::new(0.0, 0.0, 5.0),
        Vec3::ZERO,
        UVec2::splat(32),
    )
    .unwrap();
    let mut renderer = gpu_renderer();
    let graph = async move |ctx: &RenderContext<'_>, rec: &mut CommandRecorder| {
        let config =
            ForwardLitConfig { clear_color: wgpu::Color::BLACK, depth_from_pre_pass: false, ..Default::default() };
        match tone_map {
            ToneMap::Pass => {
                MeshPass::forward_lit(config).run(ctx, rec).await?;
                TonemapPass::new(exposure).run(ctx, rec).await
            }
            ToneMap::InPass => MeshPass::forward_lit(config).tone_mapped(exposure).run(ctx, rec).await,
        }
    };
    let view = renderer.register_view(camera, graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    match tone_map {
        ToneMap::Pass => read_lit_color(&renderer, view),
        // No HDR image to check: the shading pass wrote display colour.
        ToneMap::InPass => renderer.read_color(view).unwrap(),
    }
}

#[test]
fn a_lower_exposure_darkens_lit_surfaces_and_leaves_black_black() {
    let full = render(1.0);
    let quarter = render(0.25);
    let centre = |image: &image::RgbaImage| image.get_pixel(16, 16).0[1];
    assert!(
        centre(&full) > centre(&quarter) + 40,
        "exposure 0.25 must darken: {} vs {}",
        centre(&full),
        centre(&quarter)
    );
    assert!(centre(&quarter) > 10, "exposure 0.25 still shows the surface");
    assert_eq!(full.get_pixel(0, 0).0[..3], [0, 0, 0], "the black clear colour stays black");
    assert_eq!(quarter.get_pixel(0, 0).0[..3], [0, 0, 0]);
}

/// The shading pass tone-mapping in place (what the standard graph does when
/// nothing reads the HDR image) scales by the exposure as the tone-map pass
/// does: at a quarter exposure the two pictures match (the same operator on
/// the same radiance: equal to rounding, at most a level apart), and
/// differ from full exposure.
#[test]
fn tone_mapping_in_the_shading_pass_applies_the_exposure() {
    let separate = render_with(0.25, ToneMap::Pass);
    let in_pass = render_with(0.25, ToneMap::InPass);
    let c = support::golden::compare(&in_pass, &separate, 1);
    eprintln!("in-pass against separate tone map: worst channel difference {}", c.worst);
    assert_eq!(c.differing, 0, "in-pass against separate tone map at exposure 0.25 (worst {})", c.worst);
    let full = render_with(1.0, ToneMap::InPass);
    let centre = |image: &image::RgbaImage| image.get_pixel(16, 16).0[1];
    assert!(
        centre(&full) > centre(&in_pass) + 40,
        "exposure 0.25 must darken the in-pass tone map: {} vs {}",
        centre(&full),
        centre(&in_pass)
    );
}
