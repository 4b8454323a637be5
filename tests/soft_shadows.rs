//! Soft sun shadows (`ShadowFilter::Pcss`) against the path-traced
//! reference, which samples the same sun disc (`Light::source_radius`): a
//! pole on a floor under a sun of 5° and of 0.5°
//! (`oxygen_demo::pole_under_sun`). With the wide disc
//! PCSS must bring the picture closer to the reference than PCF does; with
//! the narrow one it must not be worse by more than the reference's noise.
//! The same for a spot light with a radius over a pole
//! (`oxygen_demo::pole_under_spot`): the reference traces to points of the
//! light's disc, PCSS widens the spot's penumbra by its radius.

mod support;

use oxygen::gpu::HdrImage;
use oxygen::graph::StandardGraph;
use oxygen::lighting::CascadeSettings;
use oxygen::passes::{ReferenceSettings, ShadowFilter};
use oxygen::prelude::*;
use oxygen_demo::record::Row;

const SIZE: UVec2 = UVec2::new(96, 64);
/// Reference samples per pixel (16 a frame).
const SAMPLES: u32 = 256;

/// The scene's reference (raster model: direct light, exact shadows of the
/// light's disc) and the raster images with PCF (radius 1) and PCSS, all
/// through `desc` (the raster views registered together).
fn render(mut renderer: Renderer, scene: &Scene, desc: impl Fn() -> ViewDesc) -> (HdrImage, HdrImage, HdrImage) {
    let raster = |renderer: &mut Renderer, filter: ShadowFilter| {
        let config = ForwardLitConfig { shadow_filter: filter, ..ForwardLitConfig::DEFAULT };
        renderer.register_view(desc(), StandardGraph::new(config)).unwrap()
    };
    let pcf = raster(&mut renderer, ShadowFilter::Pcf);
    let pcss = raster(&mut renderer, ShadowFilter::PCSS);
    let settings = ReferenceSettings { samples_per_frame: 16, max_samples: SAMPLES, ..ReferenceSettings::RASTER_MODEL };
    let reference = support::reference_hdr(&mut renderer, scene, desc(), settings);
    let read = |view| {
        let image = renderer.read_hdr(view).unwrap();
        support::assert_hdr_image_finite(&image, "soft shadows");
        image
    };
    (reference, read(pcf), read(pcss))
}

/// The sun scene through one cascade of 1024² over 20 m.
fn render_sun(scene: &Scene) -> (HdrImage, HdrImage, HdrImage) {
    let cascades = CascadeSettings { count: 1, resolution: 1024, max_distance: 20.0, ..Default::default() };
    render(support::gpu_renderer(), scene, || ViewDesc::new(oxygen_demo::pole_camera(SIZE)).with_sun_shadows(cascades))
}

#[test]
fn soft_shadows_follow_the_suns_disc_toward_the_reference() {
    let mut rows = Vec::new();
    for degrees in [5.0f32, 0.5] {
        let (reference, pcf, pcss) = render_sun(&oxygen_demo::pole_under_sun(degrees));
        let (pcf_error, pcss_error) =
            (support::radiance_rmse(&pcf, &reference), support::radiance_rmse(&pcss, &reference));
        eprintln!("sun of {degrees}°: RMSE against the reference: PCF {pcf_error:.5}, PCSS {pcss_error:.5}");
        rows.push(
            Row::new()
                .value("sun_degrees", degrees)
                .value("rmse_pcf", pcf_error)
                .value("rmse_pcss", pcss_error)
                .value("reference_samples", SAMPLES),
        );
        let allowed = if degrees >= 5.0 { 0.8 } else { 1.02 };
        assert!(pcss_error < allowed * pcf_error, "sun of {degrees}°: PCSS {pcss_error} against PCF {pcf_error}");
    }
    support::record::write(|mut record| {
        rows.into_iter().for_each(|row| record.push_row(row));
        record
    });
}

/// The spot scene through one local shadow map of 1024².
fn render_spot(scene: &Scene) -> (HdrImage, HdrImage, HdrImage) {
    let options = RendererOptions {
        local_shadows: Some(oxygen::lighting::LocalShadowSettings { resolution: 1024, ..Default::default() }),
        ..Default::default()
    };
    render(support::gpu_renderer_with(options), scene, || ViewDesc::new(oxygen_demo::pole_spot_camera(SIZE)))
}

#[test]
fn soft_spot_shadows_follow_the_lights_radius_toward_the_reference() {
    for (radius, bound) in [(0.3f32, 0.9), (0.5, 0.8)] {
        let (reference, pcf, pcss) = render_spot(&oxygen_demo::pole_under_spot(radius));
        let (pcf, pcss) = (support::radiance_rmse(&pcf, &reference), support::radiance_rmse(&pcss, &reference));
        eprintln!("spot of {radius} m: RMSE PCF {pcf:.6}, PCSS {pcss:.6} ({:.3} of it)", pcss / pcf);
        assert!(pcss < bound * pcf, "a spot of {radius} m: PCSS {pcss:.6} against PCF {pcf:.6}");
    }
}
