//! Which lights light the world, on screen: a light with `affects_world`
//! off, or baked, adds nothing; the same light switched on does.

mod support;

use oxygen::core::{Mobility, Scene};
use oxygen::glam::{Quat, Vec4};
use oxygen::prelude::*;
use support::gpu_renderer;

/// A grey floor lit dimly by a sun, and a point light just above it.
fn render(lamp: Option<Light>) -> image::RgbaImage {
    render_with_camera(lamp, Vec3::new(0.0, 6.0, 0.01))
}

fn render_with_camera(lamp: Option<Light>, eye: Vec3) -> image::RgbaImage {
    let mut scene = Scene::new();
    let grey = scene.add_material(Material::opaque("floor", Vec4::new(0.6, 0.6, 0.6, 1.0)));
    let floor = scene.add_geometry(Geometry::plane(10.0));
    let node = scene.add_node("floor", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry: floor, materials: vec![grey] }).unwrap();
    let sun = scene.add_node(
        "sun",
        Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::new(0.2, -1.0, 0.1).normalize())),
    );
    scene.set_light(sun, Some(Light::directional(0.3))).unwrap();
    if let Some(light) = lamp {
        let lamp = scene.add_node("lamp", Transform::from_translation(Vec3::new(0.0, 1.0, 0.0)));
        scene.set_light(lamp, Some(light)).unwrap();
    }
    let camera =
        LookAtResolver::new(Camera::perspective(60f32.to_radians(), 0.1, None), eye, Vec3::ZERO, UVec2::new(64, 64))
            .unwrap();
    let mut renderer = gpu_renderer();
    let view = renderer.register_view(camera, standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    support::read_lit_color(&renderer, view)
}

fn centre_luma(image: &image::RgbaImage) -> u8 {
    image.get_pixel(image.width() / 2, image.height() / 2).0[1]
}

fn max_difference(a: &image::RgbaImage, b: &image::RgbaImage) -> u8 {
    a.pixels().zip(b.pixels()).flat_map(|(p, q)| (0..3).map(move |c| p.0[c].abs_diff(q.0[c]))).max().unwrap_or(0)
}

#[test]
fn a_light_that_does_not_affect_the_world_adds_nothing_and_the_same_light_on_does() {
    let without = render(None);
    let lamp = Light::point(20.0, Some(10.0));
    let off = render(Some(Light { affects_world: false, ..lamp.clone() }));
    let baked = render(Some(Light { mobility: Mobility::Baked, ..lamp.clone() }));
    let on = render(Some(lamp));
    assert!(max_difference(&without, &off) <= 1, "affects_world = false still lit the floor");
    assert!(max_difference(&without, &baked) <= 1, "a baked light was added to real-time shading");
    assert!(
        centre_luma(&on) > centre_luma(&without) + 40,
        "the lamp itself must light the floor: {} against {}",
        centre_luma(&on),
        centre_luma(&without)
    );
}

#[test]
fn a_positional_light_ends_at_its_range() {
    // Seen from straight above: the floor at the centre is 1 from the lamp,
    // the image's corners are more than 4 away.
    let eye = Vec3::new(0.0, 5.0, 0.01);
    let lamp = Light::point(20.0, Some(2.5));
    let without = render_with_camera(None, eye);
    let with = render_with_camera(Some(lamp), eye);
    let corner = |image: &image::RgbaImage| image.get_pixel(1, 1).0[1];
    assert!(centre_luma(&with) > centre_luma(&without) + 40, "the lamp must light the floor under it");
    assert!(
        corner(&with).abs_diff(corner(&without)) <= 1,
        "past its range the lamp still lights the floor: {} against {}",
        corner(&with),
        corner(&without)
    );
}
