//! Shadow quality knobs, each shown to matter on screen:
//!
//! * PCF radius: the penumbra (pixels strictly between the shadowed and lit
//!   plateaus) widens from radius 0 to radius 2;
//! * acne: a large plane with no occluder, lit at a grazing angle by a
//!   directional, a spot and a point light with shadows on, is nowhere darker
//!   than the same plane without shadows — and the test can tell: removing
//!   the shadow map's depth bias, or separately the normal offset, darkens it.

mod support;

use oxygen::core::{NodeKey, Scene};
use oxygen::glam::{Quat, Vec4};
use oxygen::lighting::{CascadeSettings, LocalShadowSettings};
use oxygen::passes::DepthBias;
use oxygen::prelude::*;
use oxygen::views::ViewContext;
use support::{gpu_renderer, gpu_renderer_with, read_lit_color};

/// The two guards against acne, together.
#[derive(Clone, Copy, Debug)]
struct Guards {
    raster_bias: DepthBias,
    normal_offset: f32,
}

const DEFAULT_GUARDS: Guards = Guards { raster_bias: DepthBias::SHADOW_DEFAULT, normal_offset: 1.5 };
const NO_BIAS: Guards = Guards { raster_bias: DepthBias::NONE, ..DEFAULT_GUARDS };
const NO_NORMAL_OFFSET: Guards = Guards { normal_offset: 0.0, ..DEFAULT_GUARDS };

fn ground(scene: &mut Scene, size: f32) -> NodeKey {
    let grey = scene.add_material(Material { roughness: 0.9, ..Material::opaque("ground", Vec4::splat(0.7)) });
    let plane = scene.add_geometry(Geometry::plane(size));
    let node = scene.add_node("ground", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry: plane, materials: vec![grey] }).unwrap();
    node
}

fn look_down(eye: Vec3, target: Vec3, size: u32) -> LookAtResolver {
    LookAtResolver {
        camera: Camera::perspective(60f32.to_radians(), 0.1, Some(200.0)),
        eye,
        target,
        up: Vec3::Z,
        viewport: UVec2::splat(size),
    }
}

fn luma(p: &image::Rgba<u8>) -> f32 {
    0.2126 * p.0[0] as f32 + 0.7152 * p.0[1] as f32 + 0.0722 * p.0[2] as f32
}

/// Which light lights the plane in an acne case.
#[derive(Clone, Copy, Debug)]
enum Grazing {
    /// A sun 8° above the horizon, through two cascades.
    Sun,
    /// A spot 0.6 above the plane aiming 10° down.
    Spot,
    /// A point light 0.4 above the plane: every face but the lowest sees the
    /// plane edge-on far from the light.
    Point,
}

/// Renders the grazing-light plane, with shadows through `guards` or
/// without shadows at all.
fn grazing_plane(light: Grazing, guards: Option<Guards>) -> image::RgbaImage {
    let mut scene = Scene::new();
    ground(&mut scene, 60.0);
    let camera = look_down(Vec3::new(0.0, 9.0, -3.0), Vec3::new(0.0, 0.0, 2.0), 96);
    let lamp = match light {
        Grazing::Sun => {
            let travelling = Vec3::new(0.3, -(8f32.to_radians().tan()), 1.0).normalize();
            let node = scene.add_node(
                "low sun",
                Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, travelling)),
            );
            scene.set_light(node, Some(Light::directional(3.0))).unwrap();
            node
        }
        Grazing::Spot => {
            let aim = Vec3::new(0.0, -(10f32.to_radians().tan()), 1.0).normalize();
            let node = scene.add_node(
                "low spot",
                Transform::from_translation(Vec3::new(0.0, 0.6, -2.0))
                    .with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, aim)),
            );
            scene.set_light(node, Some(Light::spot(40.0, Some(30.0), 0.5, 0.7))).unwrap();
            node
        }
        Grazing::Point => {
            let node = scene.add_node("low lamp", Transform::from_translation(Vec3::new(0.0, 0.4, 2.0)));
            scene.set_light(node, Some(Light::point(15.0, Some(30.0)))).unwrap();
            node
        }
    };
    let mut config = ForwardLitConfig::default();
    let mut options = RendererOptions::default();
    let mut desc = ViewDesc::new(camera);
    if let Some(g) = guards {
        config.shadow_normal_offset = g.normal_offset;
        options.shadow_bias = g.raster_bias;
        match light {
            Grazing::Sun => {
                let settings = CascadeSettings { count: 2, resolution: 512, max_distance: 30.0, ..Default::default() };
                desc = desc.with_sun_shadows(settings);
            }
            Grazing::Spot | Grazing::Point => {
                options.local_shadows = Some(LocalShadowSettings { resolution: 512, near: 0.05, far: 100.0 });
            }
        }
    } else if !matches!(light, Grazing::Sun) {
        // Without shadow views the light still gets an atlas tile from the
        // frame phase; a light that does not cast shadows gets none.
        let mut l = scene.node(lamp).and_then(|n| n.light.clone()).unwrap();
        l.casts_shadows = false;
        scene.set_light(lamp, Some(l)).unwrap();
    }
    let mut renderer = gpu_renderer_with(options);
    let view = renderer.register_view(desc, oxygen::graph::lit_render_graph(config)).unwrap();
    renderer.render_frame(&scene).unwrap();
    read_lit_color(&renderer, view)
}

/// Pixels of `shadowed` darker than `unshadowed` by more than 3 levels of
/// luma, among those the light visibly reaches.
fn darker_pixels(shadowed: &image::RgbaImage, unshadowed: &image::RgbaImage) -> (usize, usize) {
    let lit: Vec<(f32, f32)> = shadowed
        .pixels()
        .zip(unshadowed.pixels())
        .map(|(s, u)| (luma(s), luma(u)))
        .filter(|(_, u)| *u > 20.0)
        .collect();
    (lit.iter().filter(|(s, u)| *s < *u - 3.0).count(), lit.len())
}

fn acne_case(light: Grazing) {
    let unshadowed = grazing_plane(light, None);
    let (darker, lit) = darker_pixels(&grazing_plane(light, Some(DEFAULT_GUARDS)), &unshadowed);
    assert!(lit > 1000, "{light:?}: the light must reach most of the view ({lit} lit pixels)");
    assert_eq!(darker, 0, "{light:?}: {darker} of {lit} lit pixels are darker with shadows on (acne)");
    let (without_bias, _) = darker_pixels(&grazing_plane(light, Some(NO_BIAS)), &unshadowed);
    let (without_offset, _) = darker_pixels(&grazing_plane(light, Some(NO_NORMAL_OFFSET)), &unshadowed);
    eprintln!(
        "{light:?}: acne pixels of {lit} lit: {darker} with every guard, {without_bias} without the depth bias, \
         {without_offset} without the normal offset"
    );
    assert!(without_bias > lit / 100, "{light:?}: removing the depth bias must show acne ({without_bias} pixels)");
    assert!(
        without_offset > lit / 100,
        "{light:?}: removing the normal offset must show acne ({without_offset} pixels)"
    );
}

#[test]
fn a_plane_under_a_grazing_sun_has_no_acne_and_needs_both_guards() {
    acne_case(Grazing::Sun);
}

#[test]
fn a_plane_under_a_grazing_spot_has_no_acne_and_needs_both_guards() {
    acne_case(Grazing::Spot);
}

#[test]
fn a_plane_under_a_low_point_light_has_no_acne_and_needs_both_guards() {
    acne_case(Grazing::Point);
}

/// A cube on the ground under a steep sun, seen from straight above through
/// one 256² cascade; returns (penumbra pixels, shadow plateau, lit plateau).
fn penumbra(pcf_radius: u32) -> (usize, f32, f32) {
    let mut scene = Scene::new();
    ground(&mut scene, 30.0);
    let red = scene.add_material(Material::opaque("box", Vec4::new(0.8, 0.2, 0.2, 1.0)));
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let boxed = scene.add_node("box", Transform::from_translation(Vec3::new(0.0, 1.5, 0.0)));
    scene.set_renderable(boxed, Renderable { geometry: cube, materials: vec![red] }).unwrap();
    let travelling = Vec3::new(0.5, -1.0, 0.2).normalize();
    let sun =
        scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, travelling)));
    scene.set_light(sun, Some(Light::directional(3.0))).unwrap();
    let camera = LookAtResolver {
        camera: Camera::orthographic(2.5, 0.1, 50.0),
        eye: Vec3::new(0.75, 10.0, 0.3),
        target: Vec3::new(0.75, 0.0, 0.3),
        up: Vec3::Z,
        viewport: UVec2::splat(128),
    };
    let mut renderer = gpu_renderer();
    let settings = CascadeSettings { count: 1, resolution: 256, max_distance: 20.0, ..Default::default() };
    let config = ForwardLitConfig { shadow_pcf_radius: pcf_radius, ..Default::default() };
    let desc = ViewDesc::new(camera).with_sun_shadows(settings);
    let view = renderer.register_view(desc, oxygen::graph::lit_render_graph(config)).unwrap();
    renderer.render_frame(&scene).unwrap();
    let image = read_lit_color(&renderer, view);
    // The shadow falls at +X (the sun travels towards +X and down); the box
    // itself covers the middle. Plateaus: deep in the shadow, and far off.
    let resolved = camera.resolve(&ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 }, &scene).unwrap();
    let at = |p: Vec3| {
        let (x, y) = support::pixel_of(&resolved, p);
        luma(image.get_pixel(x, y))
    };
    let shadow = at(Vec3::new(1.2, 0.0, 0.3));
    let lit = at(Vec3::new(-1.5, 0.0, -1.5));
    assert!(lit > shadow + 40.0, "radius {pcf_radius}: no visible shadow (lit {lit}, shadow {shadow})");
    let grey = |p: &image::Rgba<u8>| p.0[0].abs_diff(p.0[1]) < 12; // the ground, not the red box
    let between = image.pixels().filter(|p| grey(p)).map(luma).filter(|l| *l > shadow + 6.0 && *l < lit - 6.0).count();
    (between, shadow, lit)
}

#[test]
fn a_wider_pcf_kernel_widens_the_penumbra() {
    let (hard, ..) = penumbra(0);
    let (soft, shadow, lit) = penumbra(2);
    eprintln!("penumbra pixels: {hard} at radius 0, {soft} at radius 2 (plateaus {shadow:.0} and {lit:.0})");
    assert!(hard > 0, "even one bilinear comparison leaves some penumbra");
    assert!(soft as f32 > hard as f32 * 1.8, "radius 2 must widen the penumbra: {hard} -> {soft} pixels");
}
