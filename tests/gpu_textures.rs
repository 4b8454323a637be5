//! Textures addressed by slot render on both texture paths, with the same
//! picture (per-pixel tolerance, a cap on differing pixels).

mod support;

use oxygen::bindless::TexturePath;
use oxygen::core::{Filter, Sampling, TextureImage, Wrap};
use oxygen::glam::{Quat, Vec4};
use oxygen::prelude::*;
use oxygen::views::{ResolvedView, ViewContext};
use support::{Rgb, assert_region, pixel_of, texture_paths};

const RED: [u8; 4] = [230, 20, 20, 255];
const BLUE: [u8; 4] = [20, 40, 230, 255];

/// A 2 × 2 quad facing +Z, textured with a 4 × 4 red/blue checker of `texels` texels.
fn checker_scene(texels: u32) -> Scene {
    sampled_checker_scene(texels, 4, Sampling::default())
}

/// As [`checker_scene`], with `cells` × `cells` cells and a chosen sampling.
fn sampled_checker_scene(texels: u32, cells: u32, sampling: Sampling) -> Scene {
    let mut scene = Scene::new();
    let texture = scene.add_texture(TextureImage::checker("checker", texels, cells, RED, BLUE).with_sampling(sampling));
    let quad = scene.add_geometry(Geometry::quad(2.0));
    let material =
        scene.add_material(Material { base_color_texture: Some(texture), ..Material::opaque("checkered", Vec4::ONE) });
    let node = scene.add_node("quad", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry: quad, materials: vec![material] }).unwrap();
    let sun = scene.add_node("sun", Transform::IDENTITY);
    scene.set_light(sun, Some(Light::directional(3.0))).unwrap();
    scene
}

/// The world point of the quad at texture coordinate (u, v).
fn at_uv(u: f32, v: f32) -> Vec3 {
    Vec3::new((u - 0.5) * 2.0, (0.5 - v) * 2.0, 0.0)
}

fn render(scene: &Scene, path: TexturePath) -> (image::RgbaImage, ResolvedView) {
    let options = RendererOptions { texture_path: Some(path), keep_hdr: true, ..Default::default() };
    let mut renderer = Renderer::new_headless_with(options).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    assert_eq!(renderer.texture_path(), path);
    let camera = support::looking_at_origin(60.0, Vec3::new(0.0, 0.0, 2.0), UVec2::new(96, 96));
    let view = renderer.register_view(camera, standard_render_graph).unwrap();
    renderer.render_frame(scene).unwrap();
    let ctx = ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 };
    (support::read_lit_color(&renderer, view), camera.resolve(&ctx, scene).unwrap())
}

fn is_red(p: Rgb) -> bool {
    p.r > 120 && p.r as i32 > p.b as i32 + 60
}
fn is_blue(p: Rgb) -> bool {
    p.b > 120 && p.b as i32 > p.r as i32 + 60
}

#[test]
fn a_checker_texture_shows_its_cells_on_both_paths_and_they_agree() {
    // 64 texels: a size class of its own, so the grouped path stores it unresampled.
    let scene = checker_scene(64);
    let mut images = Vec::new();
    for path in texture_paths() {
        let (image, view) = render(&scene, path);
        // Cell centres: (0,0) red, (1,0) blue, (0,1) blue, (1,1) red.
        for (u, v, red) in [(0.125, 0.125, true), (0.375, 0.125, false), (0.125, 0.375, false), (0.375, 0.375, true)] {
            let what = format!("{path:?} cell at uv ({u}, {v})");
            let check: fn(Rgb) -> bool = if red { is_red } else { is_blue };
            assert_region(&image, pixel_of(&view, at_uv(u, v)), 2, check, 0, &what);
        }
        images.push(image);
    }
    // Where both paths exist, they agree.
    for pair in images.windows(2) {
        let differing = pair[0]
            .pixels()
            .zip(pair[1].pixels())
            .filter(|(a, b)| a.0.iter().zip(b.0.iter()).any(|(x, y)| x.abs_diff(*y) > 2))
            .count();
        assert!(differing == 0, "{differing} pixels differ by more than 2 levels between the paths");
    }
}

#[test]
fn a_texture_of_another_size_is_resampled_on_the_grouped_path() {
    // 48 texels go to the 64 size class: cell centres keep their colour.
    let scene = checker_scene(48);
    for path in texture_paths() {
        let (image, view) = render(&scene, path);
        assert_region(&image, pixel_of(&view, at_uv(0.125, 0.125)), 2, is_red, 0, &format!("{path:?} red cell"));
        assert_region(&image, pixel_of(&view, at_uv(0.625, 0.125)), 2, is_red, 0, &format!("{path:?} red cell 2"));
        assert_region(&image, pixel_of(&view, at_uv(0.375, 0.125)), 2, is_blue, 0, &format!("{path:?} blue cell"));
    }
}

#[test]
fn the_sampler_table_applies_nearest_and_linear_filtering() {
    // A 2 × 2 texel checker: at u = 0.4 (a fifth of a texel from the middle)
    // nearest filtering gives pure red, linear a red-blue mix.
    let nearest = Sampling::new(Wrap::Repeat, Filter::Nearest);
    let linear = Sampling::new(Wrap::ClampToEdge, Filter::Linear);
    for path in texture_paths() {
        let (image, view) = render(&sampled_checker_scene(2, 2, nearest), path);
        assert_region(&image, pixel_of(&view, at_uv(0.4, 0.25)), 0, is_red, 0, &format!("{path:?} nearest"));
        let (image, view) = render(&sampled_checker_scene(2, 2, linear), path);
        let mixed = |p: Rgb| p.r > 60 && p.b > 60;
        assert_region(&image, pixel_of(&view, at_uv(0.4, 0.25)), 0, mixed, 0, &format!("{path:?} linear"));
    }
}

#[test]
fn wrap_modes_repeat_clamp_and_mirror_outside_the_unit_square() {
    // A quad whose u runs 0..2: beyond u = 1 the wrap mode decides.
    let vertices = Geometry::quad(2.0)
        .vertices()
        .iter()
        .map(|v| oxygen::core::Vertex { uv: [v.uv[0] * 2.0, v.uv[1]], ..*v })
        .collect();
    let wide = Geometry::new(
        "wide uv quad",
        vertices,
        vec![0, 1, 2, 0, 2, 3],
        vec![oxygen::core::Submesh { first_index: 0, index_count: 6 }],
    )
    .unwrap();
    // The quad's world x for a given u (0..2 across its width of 2).
    let at = |u: f32, v: f32| Vec3::new(u - 1.0, (0.5 - v) * 2.0, 0.0);
    let expected =
        [(Wrap::Repeat, [true, false]), (Wrap::ClampToEdge, [false, false]), (Wrap::MirroredRepeat, [false, true])];
    for path in texture_paths() {
        for (wrap, red_at) in expected {
            let mut scene = sampled_checker_scene(2, 2, Sampling::new(wrap, Filter::Nearest));
            let geometry = scene.add_geometry(wide.clone());
            let (node, renderable) =
                scene.nodes().find_map(|(k, n)| n.renderable.clone().map(|r| (k, r))).expect("the quad node");
            scene.set_renderable(node, Renderable { geometry, ..renderable }).unwrap();
            let (image, view) = render(&scene, path);
            for (u, red) in [1.25, 1.75].into_iter().zip(red_at) {
                let check: fn(Rgb) -> bool = if red { is_red } else { is_blue };
                let what = format!("{path:?} {wrap:?} at u = {u}");
                assert_region(&image, pixel_of(&view, at(u, 0.25)), 1, check, 0, &what);
            }
        }
    }
}

/// glTF's wrapS and wrapT are independent: each axis wraps its own way
/// (the binding-array path's table sampler wraps u, the shader v; the
/// grouped path's shader both), with either filter, on both paths.
#[test]
fn each_axis_wraps_its_own_way() {
    // A quad whose u and v both run 0..2.
    let vertices = Geometry::quad(2.0)
        .vertices()
        .iter()
        .map(|v| oxygen::core::Vertex { uv: [v.uv[0] * 2.0, v.uv[1] * 2.0], ..*v })
        .collect();
    let big = Geometry::new(
        "uv 0..2 quad",
        vertices,
        vec![0, 1, 2, 0, 2, 3],
        vec![oxygen::core::Submesh { first_index: 0, index_count: 6 }],
    )
    .unwrap();
    let at = |u: f32, v: f32| Vec3::new(u - 1.0, 1.0 - v, 0.0);
    // Along one axis, at 1.25 and 1.75 (the other at 0.25, in the red
    // cell's row or column): red where the mode lands in cell 0.
    let red_at = |wrap: Wrap| match wrap {
        Wrap::Repeat => [true, false],
        Wrap::ClampToEdge => [false, false],
        Wrap::MirroredRepeat => [false, true],
    };
    let pairs = [
        (Wrap::Repeat, Wrap::ClampToEdge),
        (Wrap::ClampToEdge, Wrap::Repeat),
        (Wrap::MirroredRepeat, Wrap::Repeat),
        (Wrap::Repeat, Wrap::MirroredRepeat),
        (Wrap::ClampToEdge, Wrap::MirroredRepeat),
    ];
    for path in texture_paths() {
        for filter in [Filter::Nearest, Filter::Linear] {
            for (wrap_u, wrap_v) in pairs {
                let mut scene = sampled_checker_scene(2, 2, Sampling { wrap_u, wrap_v, filter });
                let geometry = scene.add_geometry(big.clone());
                let (node, renderable) =
                    scene.nodes().find_map(|(k, n)| n.renderable.clone().map(|r| (k, r))).expect("the quad node");
                scene.set_renderable(node, Renderable { geometry, ..renderable }).unwrap();
                let (image, view) = render(&scene, path);
                for (i, x) in [1.25, 1.75].into_iter().enumerate() {
                    for (axis, point, red) in
                        [("u", at(x, 0.25), red_at(wrap_u)[i]), ("v", at(0.25, x), red_at(wrap_v)[i])]
                    {
                        let check: fn(Rgb) -> bool = if red { is_red } else { is_blue };
                        let what = format!("{path:?} {filter:?} u {wrap_u:?} v {wrap_v:?}: {axis} = {x}");
                        assert_region(&image, pixel_of(&view, point), 1, check, 0, &what);
                    }
                }
            }
        }
    }
}

/// A finely chequered texture seen ten times minified: with a linear filter
/// it is sampled from its mip chain, so every pixel shows the cells' average
/// (an even purple); a nearest-filtered texture keeps one level and aliases
/// into red and blue speckle. Both texture paths. The printed spread is the
/// error the nearest filter costs here.
#[test]
fn minified_textures_are_filtered_through_their_mip_chain() {
    let linear = Sampling::new(Wrap::Repeat, Filter::Linear);
    let nearest = Sampling::new(Wrap::Repeat, Filter::Nearest);
    let camera = support::looking_at_origin(60.0, Vec3::new(0.0, 0.0, 6.9), UVec2::new(96, 96));
    // The quad covers about 24 × 24 pixels: 256 texels, 64 cells across it.
    let centre = |image: &image::RgbaImage| -> Vec<Rgb> {
        let rgb = |x, y| {
            let [r, g, b, _] = image.get_pixel(x, y).0;
            Rgb::new(r, g, b)
        };
        (42..54).flat_map(|y| (42..54).map(move |x| (x, y))).map(|(x, y)| rgb(x, y)).collect()
    };
    for path in texture_paths() {
        let mut spreads = Vec::new();
        for sampling in [linear, nearest] {
            let scene = sampled_checker_scene(256, 64, sampling);
            let options = RendererOptions { texture_path: Some(path), keep_hdr: true, ..Default::default() };
            let mut renderer = Renderer::new_headless_with(options).unwrap_or_else(|e| panic!("{path:?}: {e}"));
            let view = renderer.register_view(camera, standard_render_graph).unwrap();
            renderer.render_frame(&scene).unwrap();
            let pixels = centre(&support::read_lit_color(&renderer, view));
            let red: Vec<f32> = pixels.iter().map(|p| p.r as f32).collect();
            let mean = red.iter().sum::<f32>() / red.len() as f32;
            let spread = (red.iter().map(|r| (r - mean).powi(2)).sum::<f32>() / red.len() as f32).sqrt();
            spreads.push(spread);
            if sampling == linear {
                assert!(
                    pixels.iter().all(|p| !is_red(*p) && !is_blue(*p) && p.r > 40 && p.b > 40),
                    "{path:?}: mipmapped cells should blend to purple: {:?}",
                    &pixels[..4]
                );
            }
        }
        eprintln!(
            "{path:?}: red-channel spread over 144 minified pixels: linear + mips {:.1}, nearest {:.1}",
            spreads[0], spreads[1]
        );
        assert!(spreads[0] < 6.0, "{path:?}: mipmapped texture still varies by {:.1}", spreads[0]);
        assert!(spreads[1] > 4.0 * spreads[0].max(1.0), "{path:?}: nearest sampling should alias ({:.1})", spreads[1]);
    }
}

/// An occlusion texture dims indirect light only: two white quads lit from
/// behind (so only the ambient term reaches the camera's side), one with a
/// fully occluding texture at strength 1, one at strength 0.5, one without.
/// Then the same quads lit from the front: the direct light is unchanged.
#[test]
fn occlusion_textures_dim_ambient_light_but_not_direct_light() {
    use oxygen::core::ColorSpace;
    let render = |sun_travelling: Vec3| {
        let mut scene = Scene::new();
        let occluded = scene.add_texture(
            TextureImage::new("black occlusion", 4, 4, ColorSpace::Linear, [0u8, 0, 0, 255].repeat(16)).unwrap(),
        );
        let quad = scene.add_geometry(Geometry::quad(0.9));
        for (i, strength) in [Some(1.0), Some(0.5), None].into_iter().enumerate() {
            let material = scene.add_material(Material {
                occlusion_texture: strength.map(|_| occluded),
                occlusion_strength: strength.unwrap_or(1.0),
                ..Material::opaque(format!("white {i}"), Vec4::ONE)
            });
            let node = scene.add_node("quad", Transform::from_translation(Vec3::new(i as f32 - 1.0, 0.0, 0.0)));
            scene.set_renderable(node, Renderable { geometry: quad, materials: vec![material] }).unwrap();
        }
        let sun = scene.add_node(
            "sun",
            Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, sun_travelling.normalize())),
        );
        scene.set_light(sun, Some(Light::directional(2.0))).unwrap();
        let mut renderer = support::gpu_renderer();
        let camera = support::looking_at_origin(60.0, Vec3::new(0.0, 0.0, 2.5), UVec2::new(120, 60));
        let view = renderer.register_view(camera, standard_render_graph).unwrap();
        renderer.render_frame(&scene).unwrap();
        let image = support::read_lit_color(&renderer, view);
        let resolved =
            camera.resolve(&ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 }, &scene).unwrap();
        [-1.0f32, 0.0, 1.0].map(|x| support::region_mean(&image, pixel_of(&resolved, Vec3::new(x, 0.0, 0.0)), 2))
    };
    // The sun travels away from the camera's side of the quads (+Z): lit
    // from behind, the visible faces get ambient light only.
    let [full, half, none] = render(Vec3::Z);
    eprintln!("ambient only: occluded {full:.1}, half {half:.1}, unoccluded {none:.1}");
    assert!(none > 10.0, "the ambient term should show: {none:.1}");
    assert!(full < 0.25 * none, "full occlusion should remove the ambient: {full:.1} against {none:.1}");
    assert!(
        half > full + 3.0 && half < none - 3.0,
        "half strength should lie between: {full:.1} < {half:.1} < {none:.1}"
    );
    // Lit from the front: the direct light dominates and occlusion leaves it alone.
    let [full, _, none] = render(Vec3::NEG_Z);
    assert!(full > 0.85 * none, "direct light must not be occluded: {full:.1} against {none:.1}");
}

/// A normal map turns the shading normal the way glTF says: a texel
/// leaning to +X (red above half) leans the normal towards the texture's
/// +u, and one leaning to +Y (green above half) towards the image's up
/// (−v). On a quad facing +Z whose u runs along +x and v down along −y, a
/// light from the lean's side brightens it and a light from the other side
/// darkens it, against the same quad without the map. Both texture paths.
/// (Regression: the frame built from screen derivatives had both axes
/// turned around, which NormalTangentTest shows as bowls instead of bumps.)
#[test]
fn a_normal_map_leans_the_normal_the_way_gltf_says() {
    let lean = |rgb: [u8; 3]| {
        TextureImage::new("lean", 4, 4, oxygen::core::ColorSpace::Linear, [rgb[0], rgb[1], rgb[2], 255].repeat(16))
            .unwrap()
    };
    let brightness = |path: TexturePath, map: Option<[u8; 3]>, light_from: Vec3| -> f32 {
        let mut scene = Scene::new();
        let normal_texture = map.map(|rgb| scene.add_texture(lean(rgb)));
        let material = scene.add_material(Material { normal_texture, ..Material::opaque("grey", Vec4::splat(0.7)) });
        let quad = scene.add_geometry(Geometry::quad(2.0));
        let node = scene.add_node("quad", Transform::IDENTITY);
        scene.set_renderable(node, Renderable { geometry: quad, materials: vec![material] }).unwrap();
        let sun = scene.add_node(
            "sun",
            Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, -light_from.normalize())),
        );
        scene.set_light(sun, Some(Light::directional(2.0))).unwrap();
        let (image, view) = render(&scene, path);
        support::region_mean(&image, pixel_of(&view, Vec3::ZERO), 4)
    };
    // Tangent-space (0.6, 0, 0.8) and (0, 0.6, 0.8), encoded.
    let enc = |v: f32| ((v * 0.5 + 0.5) * 255.0).round() as u8;
    let towards_u = [enc(0.6), enc(0.0), enc(0.8)];
    let towards_up = [enc(0.0), enc(0.6), enc(0.8)];
    for path in texture_paths() {
        for (map, side, what) in [(towards_u, Vec3::X, "+u (+x)"), (towards_up, Vec3::Y, "up (+y)")] {
            let light_on_lean = side + Vec3::Z * 0.5;
            let light_against = -side + Vec3::Z * 0.5;
            let flat_on = brightness(path, None, light_on_lean);
            let flat_against = brightness(path, None, light_against);
            let mapped_on = brightness(path, Some(map), light_on_lean);
            let mapped_against = brightness(path, Some(map), light_against);
            assert!(
                mapped_on > flat_on + 5.0 && mapped_against < flat_against - 5.0,
                "{path:?}: a normal leaning {what}: lit from that side {mapped_on} (flat {flat_on}), from the other {mapped_against} (flat {flat_against})"
            );
        }
    }
}
