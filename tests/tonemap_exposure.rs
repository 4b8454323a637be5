//! Exposure scales radiance before the tone map, on screen: a quarter of
//! the exposure darkens a lit surface, black stays black.

mod support;

use oxygen::core::Scene;
use oxygen::glam::Vec4;
use oxygen::prelude::*;
use support::{gpu_renderer, read_lit_color};

fn render(exposure: f32) -> image::RgbaImage {
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
        MeshPass::forward_lit(config).run(ctx, rec).await?;
        TonemapPass::new(exposure).run(ctx, rec).await
    };
    let view = renderer.register_view(camera, graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    read_lit_color(&renderer, view)
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
