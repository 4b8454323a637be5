//! What the sort and the partitions mean on screen: transparent draws blend
//! back to front whatever order they were added in, and a double-sided draw
//! next to a single-sided one of the same class keeps its back face.

mod support;

use oxygen::core::AlphaMode;
use oxygen::core::{MaterialHandle, NodeKey, Scene};
use oxygen::glam::{Quat, Vec4};
use oxygen::prelude::*;
use oxygen::views::ViewContext;
use support::{gpu_renderer, pixel_of};

/// A sun shining straight along −Z, onto quads that face +Z.
fn add_front_light(scene: &mut Scene) {
    let sun = scene.add_node("sun", Transform::IDENTITY);
    scene.set_light(sun, Some(Light::directional(3.0))).unwrap();
}

fn add_quad(scene: &mut Scene, name: &str, at: Vec3, rotation: Quat, material: MaterialHandle) -> NodeKey {
    let geometry = scene.add_geometry(Geometry::quad(2.0));
    let node = scene.add_node(name, Transform::from_translation(at).with_rotation(rotation));
    scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
    node
}

fn front_camera() -> LookAtResolver {
    LookAtResolver::new(Camera::orthographic(2.0, 0.1, 50.0), Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, UVec2::new(96, 96))
        .unwrap()
}

fn glass(scene: &mut Scene, name: &str, rgb: Vec3) -> MaterialHandle {
    scene.add_material(Material { alpha_mode: AlphaMode::Blend, ..Material::opaque(name, rgb.extend(0.5)) })
}

/// Renders two half-transparent quads, red behind blue, overlapping in the
/// middle, added to the scene in the given order; returns the overlap pixel.
fn overlap_colour(red_first: bool) -> [u8; 3] {
    let mut scene = Scene::new();
    add_front_light(&mut scene);
    let red = glass(&mut scene, "red glass", Vec3::new(1.0, 0.0, 0.0));
    let blue = glass(&mut scene, "blue glass", Vec3::new(0.0, 0.0, 1.0));
    let back = (Vec3::new(-0.5, 0.0, 0.0), red, "red, behind");
    let front = (Vec3::new(0.5, 0.0, 1.0), blue, "blue, in front");
    let order = if red_first { [back, front] } else { [front, back] };
    for (at, material, name) in order {
        add_quad(&mut scene, name, at, Quat::IDENTITY, material);
    }
    let mut renderer = gpu_renderer();
    let view = renderer.register_view(front_camera(), standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    let resolved =
        front_camera().resolve(&ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 }, &scene).unwrap();
    let (x, y) = pixel_of(&resolved, Vec3::new(0.0, 0.0, 1.0));
    let p = support::read_lit_color(&renderer, view).get_pixel(x, y).0;
    [p[0], p[1], p[2]]
}

#[test]
fn transparent_quads_blend_back_to_front_in_either_insertion_order() {
    let a = overlap_colour(true);
    let b = overlap_colour(false);
    // Back to front, the blue quad is blended last: over the overlap it keeps
    // half its weight while the red one behind it keeps a quarter.
    for (order, [r, _, b]) in [("red added first", a), ("blue added first", b)] {
        assert!(u32::from(b) > u32::from(r) + 20, "{order}: overlap ({r}, _, {b}) is not blue over red");
    }
    let diff = a.iter().zip(&b).map(|(x, y)| x.abs_diff(*y)).max().unwrap_or(0);
    assert!(diff <= 2, "insertion order changed the overlap: {a:?} vs {b:?}");
}

#[test]
fn a_double_sided_draw_next_to_a_single_sided_one_shows_its_back_face() {
    let mut scene = Scene::new();
    add_front_light(&mut scene);
    // Both quads turned away from the camera: it sees their back faces.
    let away = Quat::from_rotation_y(std::f32::consts::PI);
    let single = scene.add_material(Material::opaque("single-sided", Vec4::new(0.9, 0.9, 0.1, 1.0)));
    let double = scene.add_material(Material {
        double_sided: true,
        ..Material::opaque("double-sided", Vec4::new(0.1, 0.9, 0.1, 1.0))
    });
    add_quad(&mut scene, "single", Vec3::new(-1.0, 0.0, 0.0), away, single);
    add_quad(&mut scene, "double", Vec3::new(1.0, 0.0, 0.0), away, double);
    let mut renderer = gpu_renderer();
    let view = renderer.register_view(front_camera(), standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    let image = support::read_lit_color(&renderer, view);
    let resolved =
        front_camera().resolve(&ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 }, &scene).unwrap();
    let at = |x: f32| {
        let (px, py) = pixel_of(&resolved, Vec3::new(x, 0.0, 0.0));
        image.get_pixel(px, py).0
    };
    let [r, g, b, _] = at(1.0);
    assert!(g > 30 && g > 2 * r && g > 2 * b, "the double-sided back face is missing: ({r}, {g}, {b})");
    let background = image.get_pixel(2, 2).0;
    let culled = at(-1.0);
    let diff = (0..3).map(|c| culled[c].abs_diff(background[c])).max().unwrap_or(0);
    assert!(diff <= 2, "the single-sided back face was drawn: {culled:?} against background {background:?}");
    let frame = renderer.prepared_frame(view).unwrap();
    assert_eq!(frame.partitions().len(), 2, "one partition per variant: {:?}", frame.partitions());
}
