//! What the skinning and morph-target tests share: a deformed mesh is
//! checked against the rigid mesh drawn where the deformation should put
//! it, from the same camera under the same sun.

use image::RgbaImage;
use oxygen::glam::Quat;
use oxygen::prelude::*;

use super::golden::compare;

/// Size of the deformation tests' views.
pub const VIEWPORT: UVec2 = UVec2::new(160, 100);

/// A camera 4 units in front of `target` and a little above.
pub fn camera(target: Vec3) -> LookAtResolver {
    LookAtResolver {
        camera: Camera::perspective(50f32.to_radians(), 0.1, None),
        eye: target + Vec3::new(0.0, 0.5, 4.0),
        target,
        up: Vec3::Y,
        viewport: VIEWPORT,
    }
}

/// Adds the tests' sun.
pub fn with_sun(scene: &mut Scene) {
    let sun = scene.add_node(
        "sun",
        Transform::IDENTITY
            .with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::new(-0.3, -0.5, -0.8).normalize())),
    );
    scene.set_light(sun, Some(Light::directional(3.0))).unwrap();
}

/// The two pictures are the same: at most 1 pixel in 500 differs by more
/// than 3 levels.
pub fn assert_same(a: &RgbaImage, b: &RgbaImage, what: &str) {
    let c = compare(a, b, 3);
    assert!(c.differing <= c.total / 500, "{what}: {} of {} pixels differ (worst {})", c.differing, c.total, c.worst);
}

/// Renders `scene` from [`camera`] at `target` on a fresh renderer: the
/// lit picture and how many draws the view recorded.
pub fn render(scene: &Scene, target: Vec3) -> (RgbaImage, usize) {
    let mut renderer = super::gpu_renderer();
    let view = renderer.register_view(camera(target), standard_render_graph).unwrap();
    let report = renderer.render_frame(scene).unwrap();
    let draws = report.views.iter().find(|v| v.view == view).map_or(0, |v| v.draws);
    (super::read_lit_color(&renderer, view), draws)
}
