//! A model wrapped in a node a million or thirty million units from the
//! origin looks, through the viewer's framing camera, exactly as it does at
//! the origin: its bounds are kept in f64 (`GltfImport::precise_bounds`)
//! and the orbit camera builds its view in f64 (`DLookAtResolver`). With
//! the f32 bounds and camera the framing moved by whole units thirty
//! million out (1–7 % of pixels differed a million out, 12–38 % thirty
//! million out, in a user's report).

mod support;

use oxygen::core::DAabb;
use oxygen::glam::DVec3;
use oxygen::import::ImportOptions;
use oxygen::import::import_gltf_slice;
use oxygen::prelude::*;
use oxygen_demo::OrbitCamera;
use support::far::{assert_framed_alike, wrapped_glb};
use support::golden::compare;
use support::gpu_renderer;

const SIZE: u32 = 96;
const ORIENTATION_TEST: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/OrientationTest/OrientationTest.glb");

/// The viewer's default view of the model at `offset`; with `f32_bounds`,
/// framed on the f32 bounds instead (the way it was, as a control).
fn framed_with(offset: [f64; 3], f32_bounds: bool) -> (image::RgbaImage, DAabb) {
    let mut scene = Scene::new();
    let import =
        import_gltf_slice(&mut scene, &wrapped_glb(ORIENTATION_TEST, offset), "wrapped.glb", &ImportOptions::default())
            .unwrap();
    oxygen_demo::add_default_sun(&mut scene);
    let mut bounds = import.precise_bounds.expect("the model has bounds");
    if f32_bounds {
        // What f32 corners (rounded to nearest) and an f32 centre give.
        let b = import.bounds.expect("the model has bounds");
        let center = b.center().as_dvec3();
        let half = b.half_extents().as_dvec3();
        bounds = DAabb::new(center - half, center + half);
    }
    let mut renderer = gpu_renderer();
    let view = renderer
        .register_view(OrbitCamera::framing(&bounds).resolver(UVec2::splat(SIZE)), standard_render_graph)
        .unwrap();
    renderer.render_frame(&scene).unwrap();
    (renderer.read_color(view).unwrap(), bounds)
}

fn framed(offset: [f64; 3]) -> (image::RgbaImage, DAabb) {
    framed_with(offset, false)
}

#[test]
fn the_viewer_frames_a_far_model_as_it_frames_it_at_the_origin() {
    let (at_origin, bounds) = framed([0.0; 3]);
    for offset in [[1.0e6, 0.0, -1.0e6], [3.0e7, 1.0e3, 3.0e7]] {
        let (far, far_bounds) = framed(offset);
        // The bounds moved by the offset, to well under a millimetre.
        let shift = far_bounds.center() - bounds.center() - DVec3::from_array(offset);
        assert!(shift.length() < 1e-6, "bounds centre off by {shift:?} at {offset:?}");
        // Rounded outward, the f32 bounds still hold the f64 ones.
        let outward = far_bounds.to_f32_outward();
        assert!(
            outward.min.as_dvec3().cmple(far_bounds.min).all() && outward.max.as_dvec3().cmpge(far_bounds.max).all()
        );
        assert_framed_alike(&far, &at_origin, &format!("{offset:?}"));
    }
    // The control: framed on f32 bounds thirty million units out, the
    // picture moves, so the comparison above can fail.
    let (f32_framed, _) = framed_with([3.0e7, 1.0e3, 3.0e7], true);
    let control = compare(&f32_framed, &at_origin, 8);
    eprintln!("f32 framing 3e7 out: {} of {} pixels differ", control.differing, control.total);
    assert!(control.differing * 200 > control.total, "the f32 framing should have moved the picture");
}
