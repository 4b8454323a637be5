//! Image-based lighting on lavapipe: a rough white dielectric sphere under a
//! uniform environment shows the environment's radiance (a white furnace),
//! the environment is drawn behind the scene, a metal sphere reflects the
//! sky instead of going black, and multisampled views draw it too. The
//! prefiltering itself is tested without a GPU (`oxygen-core`'s
//! `environment` module: uniform in, uniform out; irradiance π L; continuous
//! across face seams).

mod support;

use oxygen::core::Environment;
use oxygen::prelude::*;

fn sphere_scene(metallic: f32, roughness: f32, sun: bool) -> Scene {
    let mut scene = Scene::new();
    let material = scene.add_material(Material {
        metallic,
        roughness,
        ..Material::opaque("sphere", Vec4::new(1.0, 1.0, 1.0, 1.0))
    });
    let geometry = scene.add_geometry(Geometry::uv_sphere(1.0, 48, 24));
    let node = scene.add_node("sphere", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
    if sun {
        let light = scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_x(-0.8)));
        scene.set_light(light, Some(Light::directional(2.5))).unwrap();
    }
    scene
}

fn camera() -> LookAtResolver {
    LookAtResolver {
        camera: Camera::perspective(40f32.to_radians(), 0.1, None),
        eye: Vec3::new(0.0, 0.0, 4.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        viewport: UVec2::new(96, 96),
    }
}

/// The HDR image of `scene` lit by `environment`, with `msaa`.
fn render(scene: &Scene, environment: Option<&Environment>, msaa: Msaa) -> oxygen::core::gpu::HdrImage {
    let mut renderer = support::gpu_renderer();
    renderer.set_prefiltered_environment(environment.map(|e| e.prefilter(32, 6, 64)).as_ref());
    let view = renderer.register_view(ViewDesc::new(camera()).with_msaa(msaa), standard_render_graph).unwrap();
    renderer.render_frame(scene).unwrap();
    support::assert_hdr_finite(&renderer, view);
    renderer.read_hdr(view).unwrap()
}

fn at(image: &oxygen::core::gpu::HdrImage, x: u32, y: u32) -> Vec3 {
    let p = image.pixels[(y * image.width + x) as usize];
    Vec3::new(p[0], p[1], p[2])
}

#[test]
fn a_rough_white_sphere_in_a_uniform_environment_shows_the_environment() {
    let radiance = Vec3::new(0.6, 0.5, 0.4);
    let image = render(&sphere_scene(0.0, 1.0, false), Some(&Environment::Uniform(radiance)), Msaa::Off);
    // Diffuse albedo 1 reflects exactly the radiance; the rough dielectric's
    // specular adds a few percent (the environment BRDF at F0 = 0.04).
    for (x, y) in [(48, 48), (40, 56), (58, 40)] {
        let p = at(&image, x, y);
        let ratio = p / radiance;
        assert!(ratio.min_element() > 0.95 && ratio.max_element() < 1.2, "({x}, {y}): {p} against {radiance}");
    }
    // Behind the sphere: the environment itself (f16 precision).
    let corner = at(&image, 2, 2);
    assert!((corner - radiance).abs().max_element() < 2e-3, "background {corner}");
    // Without it, the constant ambient term (0.03) lights the sphere.
    let plain = render(&sphere_scene(0.0, 1.0, false), None, Msaa::Off);
    assert!(at(&plain, 48, 48).x < 0.05, "{}", at(&plain, 48, 48));
}

#[test]
fn a_metal_sphere_reflects_the_sky_instead_of_going_black() {
    // The sky of a sun travelling down and away from the camera.
    let sun_direction = Quat::from_rotation_x(-0.8) * Vec3::NEG_Z;
    let sky = Environment::sky_for_sun(sun_direction);
    // No light but the environment: what a metal shows is what it reflects.
    let scene = sphere_scene(1.0, 0.25, false);
    let lit = render(&scene, Some(&sky), Msaa::Off);
    let plain = render(&scene, None, Msaa::Off);
    // Over the sphere's disc the metal reflects the sky and the ground
    // instead of the 0.03 ambient alone.
    let disc_mean = |image: &oxygen::core::gpu::HdrImage| {
        let mut sum = Vec3::ZERO;
        let mut n = 0.0;
        for y in 20..76u32 {
            for x in 20..76u32 {
                let (dx, dy) = (x as f32 - 48.0, y as f32 - 48.0);
                if dx * dx + dy * dy < 26.0 * 26.0 {
                    sum += at(image, x, y).min(Vec3::splat(1.0));
                    n += 1.0;
                }
            }
        }
        sum / n
    };
    let (mean_lit, mean_plain) = (disc_mean(&lit), disc_mean(&plain));
    assert!(mean_lit.z > 2.0 * mean_plain.z, "{mean_lit} vs {mean_plain}");
    // Its upper half reflects the bluer sky above the horizon.
    let above = at(&lit, 48, 30);
    assert!(above.z > above.x, "the upper half reflects blue sky: {above}");
}

#[test]
fn multisampled_views_draw_the_environment_too() {
    let radiance = Vec3::new(0.2, 0.3, 0.5);
    let image = render(&sphere_scene(0.0, 1.0, false), Some(&Environment::Uniform(radiance)), Msaa::X4);
    assert!((at(&image, 2, 2) - radiance).abs().max_element() < 2e-3);
    let ratio = at(&image, 48, 48) / radiance;
    assert!(ratio.min_element() > 0.95 && ratio.max_element() < 1.2, "{ratio}");
}

/// A Radiance `.hdr` file loads as an equirectangular environment: its
/// centre column looks along −Z, its top row up; a missing file is named.
#[test]
fn an_hdr_file_loads_as_an_equirectangular_environment() {
    let (width, height) = (16u32, 8u32);
    let texels: Vec<image::Rgb<f32>> = (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            // Red towards −Z (the centre columns), blue in the top rows.
            let red = if (6..10).contains(&x) { 4.0 } else { 0.1 };
            let blue = if y < 2 { 3.0 } else { 0.1 };
            image::Rgb([red, 0.2, blue])
        })
        .collect();
    let path = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("environment_test.hdr");
    let file = std::fs::File::create(&path).unwrap();
    image::codecs::hdr::HdrEncoder::new(std::io::BufWriter::new(file))
        .encode(&texels, width as usize, height as usize)
        .unwrap();
    let environment = oxygen::load_hdr_environment(&path).unwrap();
    let forward = environment.radiance(Vec3::NEG_Z);
    let back = environment.radiance(Vec3::Z);
    let up = environment.radiance(Vec3::Y);
    assert!(forward.x > 3.0 && back.x < 0.5, "−Z {forward}, +Z {back}");
    assert!(up.z > 2.0, "up {up}");
    let missing = oxygen::load_hdr_environment("/nonexistent/sky.hdr").unwrap_err().to_string();
    assert!(missing.contains("/nonexistent/sky.hdr"), "{missing}");
}

/// Found in review: an 8-bit panorama was taken as linear radiance. Its
/// sRGB texels are decoded: 128 of 255 is 0.216, not 0.5.
#[test]
fn an_8_bit_panorama_is_decoded_from_srgb() {
    let path = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("environment_test.png");
    image::RgbImage::from_pixel(8, 4, image::Rgb([128, 128, 128])).save(&path).unwrap();
    let environment = oxygen::load_hdr_environment(&path).unwrap();
    let r = environment.radiance(Vec3::NEG_Z);
    assert!((r.x - 0.2158).abs() < 0.002, "{r}");
}
