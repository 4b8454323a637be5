//! Contact shadows (`ForwardLitConfig::contact_shadows`) against the
//! path-traced reference on a thin pole on the ground under a sun
//! (`oxygen_demo::thin_pole_under_sun`), whose shadow a coarse shadow map
//! washes out: the march through the view's depth must bring the picture
//! closer to the reference's exact shadow, and a view without it records
//! nothing of it.

mod support;

use oxygen::gpu::HdrImage;
use oxygen::graph::StandardGraph;
use oxygen::lighting::{CascadeSettings, ContactShadows};
use oxygen::passes::ReferenceSettings;
use oxygen::prelude::*;

const SIZE: UVec2 = UVec2::new(128, 96);
/// Reference samples per pixel (16 a frame).
const SAMPLES: u32 = 128;

/// A coarse cascade: 256² over 10 m, 4 cm texels, as wide as the pole.
fn cascades() -> CascadeSettings {
    CascadeSettings { count: 1, resolution: 256, max_distance: 10.0, ..Default::default() }
}

fn reference(renderer: &mut Renderer, scene: &Scene) -> HdrImage {
    let settings = ReferenceSettings { samples_per_frame: 16, max_samples: SAMPLES, ..ReferenceSettings::RASTER_MODEL };
    support::reference_hdr(renderer, scene, ViewDesc::new(oxygen_demo::thin_pole_camera(SIZE)), settings)
}

fn raster(renderer: &mut Renderer, scene: &Scene, contact_shadows: Option<ContactShadows>) -> HdrImage {
    let config = ForwardLitConfig { contact_shadows, ..ForwardLitConfig::DEFAULT };
    let desc = ViewDesc::new(oxygen_demo::thin_pole_camera(SIZE)).with_sun_shadows(cascades());
    support::view_hdr(renderer, scene, desc, StandardGraph::new(config), 1, "contact shadows")
}

#[test]
fn contact_shadows_move_a_thin_poles_shadow_toward_the_reference() {
    let mut renderer = support::gpu_renderer();
    let scene = oxygen_demo::thin_pole_under_sun();
    let reference = reference(&mut renderer, &scene);
    let without = support::radiance_rmse(&raster(&mut renderer, &scene, None), &reference);
    let mut errors = Vec::new();
    for length in [0.5f32, 1.0, 2.0] {
        // As thick as the pole: a thicker guess widens the shadow behind it.
        let settings = ContactShadows { length, thickness: 0.04, steps: 32 };
        errors.push((length, support::radiance_rmse(&raster(&mut renderer, &scene, Some(settings)), &reference)));
    }
    eprintln!("RMSE without contact shadows {without:.6}; with, by length: {errors:?}");
    // Measured on lavapipe: 0.92 (0.5 m), 0.86 (1 m) and 0.77 (2 m) of the
    // error without; the bound sits 3 % above the weakest.
    for (length, error) in &errors {
        assert!(*error < 0.95 * without, "length {length}: RMSE {error:.6} against {without:.6} without");
    }
}

#[test]
fn a_view_without_contact_shadows_holds_no_depth_and_bad_settings_are_refused() {
    let mut renderer = support::gpu_renderer();
    let scene = oxygen_demo::thin_pole_under_sun();
    let _ = raster(&mut renderer, &scene, None);
    assert_eq!(renderer.internals().lighting.screen_space_views(), 0, "no depth buffers for a view without the knob");
    let bad = ContactShadows { steps: 0, ..ContactShadows::DEFAULT };
    let config = ForwardLitConfig { contact_shadows: Some(bad), ..ForwardLitConfig::DEFAULT };
    let view =
        renderer.register_view(ViewDesc::new(oxygen_demo::thin_pole_camera(SIZE)), StandardGraph::new(config)).unwrap();
    let frame = renderer.render_frame(&scene).err().map(|e| e.to_string()).unwrap_or_default();
    let read = renderer.read_hdr(view).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(frame.contains("steps") || read.contains("steps"), "frame: {frame:?}, read: {read:?}");
}
