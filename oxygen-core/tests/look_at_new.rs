//! `LookAtResolver::new` and `with_up`: a bad camera or pose is refused where
//! it is made, and a good one resolves exactly like the struct literal.

use oxygen_core::glam::{UVec2, Vec3};
use oxygen_core::{Camera, CameraError, LookAtResolver, Scene, ViewContext, ViewIds, ViewResolver};

fn ctx() -> ViewContext {
    ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 }
}

fn camera() -> Camera {
    Camera::perspective(1.0, 0.1, Some(100.0))
}

#[test]
fn new_builds_the_same_resolver_as_the_literal_with_y_up() {
    let eye = Vec3::new(1.0, 2.0, 3.0);
    let viewport = UVec2::new(64, 48);
    let made = LookAtResolver::new(camera(), eye, Vec3::ZERO, viewport).unwrap();
    let literal = LookAtResolver { camera: camera(), eye, target: Vec3::ZERO, up: Vec3::Y, viewport };
    assert_eq!(made, literal);
    assert_eq!(made.resolve(&ctx(), &Scene::new()), literal.resolve(&ctx(), &Scene::new()));
}

#[test]
fn new_refuses_a_zero_near_plane_before_any_frame() {
    let err = LookAtResolver::new(Camera::perspective(1.0, 0.0, Some(100.0)), Vec3::Z, Vec3::ZERO, UVec2::new(8, 8))
        .unwrap_err();
    assert_eq!(err, CameraError::BadDepthRange { near: 0.0, far: Some(100.0) });
    assert!(err.to_string().contains("near 0, far 100"), "{err}");
}

#[test]
fn new_refuses_an_empty_viewport() {
    let err = LookAtResolver::new(camera(), Vec3::Z, Vec3::ZERO, UVec2::new(0, 8)).unwrap_err();
    assert_eq!(err, CameraError::EmptyViewport { width: 0, height: 8 });
    assert!(err.to_string().contains("0x8"), "{err}");
}

#[test]
fn new_refuses_an_eye_on_its_target_or_a_non_finite_position() {
    let viewport = UVec2::new(8, 8);
    for (eye, target) in [(Vec3::ONE, Vec3::ONE), (Vec3::NAN, Vec3::ZERO), (Vec3::Z, Vec3::splat(f32::INFINITY))] {
        assert!(
            matches!(LookAtResolver::new(camera(), eye, target, viewport), Err(CameraError::DegenerateLookAt { .. })),
            "eye {eye}, target {target}"
        );
    }
}

#[test]
fn a_camera_looking_straight_down_gets_a_usable_up() {
    let r = LookAtResolver::new(camera(), Vec3::new(0.0, 10.0, 0.0), Vec3::ZERO, UVec2::new(8, 8)).unwrap();
    assert_eq!(r.up, Vec3::NEG_Z);
    assert!(r.resolve(&ctx(), &Scene::new()).is_ok());
}

#[test]
fn with_up_replaces_up_and_refuses_one_parallel_to_the_view() {
    let r = LookAtResolver::new(camera(), Vec3::Z * 5.0, Vec3::ZERO, UVec2::new(8, 8)).unwrap();
    assert_eq!(r.with_up(Vec3::X).unwrap().up, Vec3::X);
    for up in [Vec3::Z, Vec3::ZERO, Vec3::NAN] {
        assert!(matches!(r.with_up(up), Err(CameraError::DegenerateLookAt { .. })), "up {up}");
    }
}
