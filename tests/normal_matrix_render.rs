//! Normals under a non-uniform scale, on screen: a cube turned inside a
//! parent stretched 3× along X is lit by its true surface normal (the inverse
//! transpose), not by the stretched one.

mod support;

use oxygen::core::Scene;
use oxygen::glam::{Quat, Vec4};
use oxygen::prelude::*;
use oxygen::views::ViewContext;
use support::{gpu_renderer, pixel_of};

const TURN_DEGREES: f32 = 30.0;
const STRETCH: Vec3 = Vec3::new(3.0, 1.0, 1.0);

/// The world normal of the child's local +X face, by hand:
/// `normalize(S⁻¹ · R · x̂)` (R is a rotation, so R⁻ᵀ = R).
fn analytic_normal() -> Vec3 {
    let turned = Quat::from_rotation_y(TURN_DEGREES.to_radians()) * Vec3::X;
    (turned / STRETCH).normalize()
}

/// What the bug would give: `normalize(S · R · x̂)`.
fn stretched_normal() -> Vec3 {
    (Quat::from_rotation_y(TURN_DEGREES.to_radians()) * Vec3::X * STRETCH).normalize()
}

#[test]
fn a_face_under_a_rotated_non_uniform_scale_is_lit_by_its_analytic_normal() {
    let n = analytic_normal();
    let wrong = stretched_normal();
    assert!(n.dot(wrong) < 0.9, "the scene must separate the two normals");
    let mut scene = Scene::new();
    // Light arriving along −L with L between the two candidate normals'
    // N·L of about 0.83 (analytic) against 0.18 (stretched).
    let to_light = Vec3::new(0.0, 0.3, -1.0).normalize();
    let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, -to_light)));
    scene.set_light(sun, Some(Light::directional(2.0))).unwrap();
    let grey =
        scene.add_material(Material { roughness: 1.0, ..Material::opaque("grey", Vec4::new(0.6, 0.6, 0.6, 1.0)) });

    let parent = scene.add_node("stretch", Transform::IDENTITY.with_scale(STRETCH));
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let child = scene
        .add_child(
            parent,
            "turned cube",
            Transform::IDENTITY.with_rotation(Quat::from_rotation_y(TURN_DEGREES.to_radians())),
        )
        .unwrap();
    scene.set_renderable(child, Renderable { geometry: cube, materials: vec![grey] }).unwrap();
    let face_centre = STRETCH * (Quat::from_rotation_y(TURN_DEGREES.to_radians()) * Vec3::new(0.5, 0.0, 0.0));

    // Two reference quads, turned rigidly (no scale) to face along the
    // analytic and the stretched normal, beside the cube.
    let quad = scene.add_geometry(Geometry::quad(0.8));
    let mut reference = |name: &str, normal: Vec3, offset: Vec3| {
        let at = face_centre + offset;
        let node = scene
            .add_node(name, Transform::from_translation(at).with_rotation(Quat::from_rotation_arc(Vec3::Z, normal)));
        scene.set_renderable(node, Renderable { geometry: quad, materials: vec![grey] }).unwrap();
        at
    };
    let side = n.cross(Vec3::Y).normalize();
    let analytic_at = reference("analytic reference", n, Vec3::Y * 1.2);
    let stretched_at = reference("stretched reference", wrong, Vec3::Y * -1.2 + side * 0.2);

    // An orthographic camera looking against the analytic normal: the same
    // view direction for every pixel, so only N·L differs.
    let camera = LookAtResolver::new(
        Camera::orthographic(2.5, 0.1, 50.0),
        face_centre + n * 10.0,
        face_centre,
        UVec2::new(128, 128),
    )
    .unwrap();
    let mut renderer = gpu_renderer();
    let view = renderer.register_view(camera, standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    let image = support::read_lit_color(&renderer, view);
    let resolved = camera.resolve(&ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 }, &scene).unwrap();
    let sample = |at: Vec3| {
        let (x, y) = pixel_of(&resolved, at);
        let p = image.get_pixel(x, y).0;
        [p[0], p[1], p[2]]
    };
    let face = sample(face_centre);
    let analytic = sample(analytic_at);
    let stretched = sample(stretched_at);
    let diff = |a: [u8; 3], b: [u8; 3]| (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap_or(0);
    assert!(diff(analytic, stretched) > 30, "the references must differ: {analytic:?} vs {stretched:?}");
    assert!(
        diff(face, analytic) <= 4,
        "face {face:?} is not lit like its analytic normal {analytic:?} (stretched normal would give {stretched:?})"
    );
}
