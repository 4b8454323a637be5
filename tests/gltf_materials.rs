//! glTF attributes and material extensions on lavapipe: `COLOR_0` in every
//! encoding glTF allows, `TEXCOORD_1`, `KHR_texture_transform`,
//! `KHR_materials_unlit` and `KHR_mesh_quantization`.
//!
//! Each feature is checked by what it must mean, not only by a golden: a
//! vertex colour is the same as that colour in the base-colour factor, an
//! unlit surface ignores the light, quantized positions land where the
//! float ones do, a texture transform or second UV set changes what the
//! shipped test files show. The purpose-built scene and the shipped files
//! also have goldens (checked by eye against the files' reference
//! screenshots when written).

mod support;

use oxygen::bindless::TexturePath;
use oxygen::core::{Material, UvTransform};
use oxygen::glam::{Quat, Vec2};
use oxygen::import::ImportOptions;
use oxygen::prelude::*;
use support::encode::data_uri;
use support::golden::{Tolerance, assert_golden, compare};
use support::texture_paths;

/// A quad's vertex-colour encoding (or none).
#[derive(Clone, Copy, Debug)]
enum Colors {
    None,
    /// One colour on every vertex, as float VEC3.
    FloatRgb([f32; 3]),
    /// One colour on every vertex, as normalized u8 VEC4.
    Unorm8Rgba([u8; 4]),
    /// One colour on every vertex, as normalized u16 VEC3.
    Unorm16Rgb([u16; 3]),
    /// Red, green, blue and white corners, as float VEC4.
    Corners,
}

impl Colors {
    /// The linear colour the encoding stands for (one-colour encodings).
    fn linear(self) -> Option<[f32; 3]> {
        match self {
            Colors::FloatRgb(c) => Some(c),
            Colors::Unorm8Rgba(c) => Some([c[0] as f32 / 255.0, c[1] as f32 / 255.0, c[2] as f32 / 255.0]),
            Colors::Unorm16Rgb(c) => Some(c.map(|v| v as f32 / 65535.0)),
            Colors::None | Colors::Corners => None,
        }
    }
}

/// One quad of the purpose-built scene.
#[derive(Clone, Copy, Debug)]
struct Quad {
    at: [f32; 2],
    colors: Colors,
    base_color: [f32; 3],
    unlit: bool,
    /// Positions as normalized i16 (±1) under a node scale of 0.5, normals
    /// as normalized i8, texture coordinates as normalized u16.
    quantized: bool,
}

impl Quad {
    fn new(at: [f32; 2]) -> Self {
        Quad { at, colors: Colors::None, base_color: [1.0; 3], unlit: false, quantized: false }
    }
}

/// The binary part of a glTF file being built: one buffer, its views and
/// accessors as JSON text.
#[derive(Default)]
struct Buffers {
    bin: Vec<u8>,
    views: Vec<String>,
    accessors: Vec<String>,
}

impl Buffers {
    /// Adds a vertex accessor of `count` elements whose bytes are already
    /// padded to a stride that is a multiple of 4 (glTF aligns vertex
    /// elements), with its own buffer view.
    fn vertex(
        &mut self,
        bytes: Vec<u8>,
        component: u32,
        ty: &str,
        count: usize,
        normalized: bool,
        extra: &str,
    ) -> usize {
        let stride = bytes.len() / count;
        assert_eq!(stride % 4, 0, "vertex elements are padded to 4 bytes");
        self.view_and_accessor(bytes, &format!(r#","byteStride":{stride}"#), component, ty, count, normalized, extra)
    }

    /// Adds an index accessor (u16).
    fn indices(&mut self, indices: &[u16]) -> usize {
        let bytes = indices.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.view_and_accessor(bytes, "", 5123, "SCALAR", indices.len(), false, "")
    }

    #[allow(clippy::too_many_arguments)]
    fn view_and_accessor(
        &mut self,
        bytes: Vec<u8>,
        view_extra: &str,
        component: u32,
        ty: &str,
        count: usize,
        normalized: bool,
        extra: &str,
    ) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views.push(format!(
            r#"{{"buffer":0,"byteOffset":{},"byteLength":{}{view_extra}}}"#,
            self.bin.len(),
            bytes.len()
        ));
        self.bin.extend(bytes);
        self.accessors.push(format!(
            r#"{{"bufferView":{},"componentType":{component},"count":{count},"type":"{ty}","normalized":{normalized}{extra}}}"#,
            self.views.len() - 1
        ));
        self.accessors.len() - 1
    }
}

fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// Each element's bytes followed by zeros up to `stride`.
fn padded(elements: impl IntoIterator<Item = Vec<u8>>, stride: usize) -> Vec<u8> {
    elements
        .into_iter()
        .flat_map(|mut e| {
            e.resize(stride, 0);
            e
        })
        .collect()
}

/// A glTF file (JSON, one data-URI buffer) with one unit quad per entry,
/// in the XY plane facing +Z. `declare_quantization`: whether the file
/// lists `KHR_mesh_quantization` among the extensions it uses.
fn quads_file(quads: &[Quad], declare_quantization: bool) -> Vec<u8> {
    let mut b = Buffers::default();
    let corners = [[-0.5f32, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]];
    let indices = b.indices(&[0, 1, 2, 0, 2, 3]);
    let (mut meshes, mut materials, mut nodes) = (Vec::new(), Vec::new(), Vec::new());
    for (i, q) in quads.iter().enumerate() {
        let (position, normal, uv) = if q.quantized {
            // ±32767 is ±1.0; the node's scale of 0.5 makes it the unit quad.
            let p = padded(
                corners.iter().map(|c| {
                    [(c[0] * 2.0 * 32767.0) as i16, (c[1] * 2.0 * 32767.0) as i16, 0]
                        .iter()
                        .flat_map(|v| v.to_le_bytes())
                        .collect()
                }),
                8,
            );
            let position = b.vertex(p, 5122, "VEC3", 4, true, r#","min":[-1,-1,0],"max":[1,1,0]"#);
            let normal = b.vertex(padded((0..4).map(|_| vec![0u8, 0, 127]), 4), 5120, "VEC3", 4, true, "");
            let t = corners
                .iter()
                .flat_map(|c| [((c[0] + 0.5) * 65535.0) as u16, ((0.5 - c[1]) * 65535.0) as u16])
                .flat_map(|v| v.to_le_bytes())
                .collect();
            (position, normal, b.vertex(t, 5123, "VEC2", 4, true, ""))
        } else {
            let p: Vec<f32> = corners.iter().flat_map(|c| [c[0], c[1], 0.0]).collect();
            let position = b.vertex(f32_bytes(&p), 5126, "VEC3", 4, false, r#","min":[-0.5,-0.5,0],"max":[0.5,0.5,0]"#);
            let normal = b.vertex(f32_bytes(&[0.0, 0.0, 1.0].repeat(4)), 5126, "VEC3", 4, false, "");
            let t: Vec<f32> = corners.iter().flat_map(|c| [c[0] + 0.5, 0.5 - c[1]]).collect();
            (position, normal, b.vertex(f32_bytes(&t), 5126, "VEC2", 4, false, ""))
        };
        let color = match q.colors {
            Colors::None => None,
            Colors::FloatRgb(c) => Some(b.vertex(f32_bytes(&c.repeat(4)), 5126, "VEC3", 4, false, "")),
            Colors::Unorm8Rgba(c) => Some(b.vertex(c.repeat(4), 5121, "VEC4", 4, true, "")),
            Colors::Unorm16Rgb(c) => {
                let element: Vec<u8> = c.iter().flat_map(|v| v.to_le_bytes()).collect();
                Some(b.vertex(padded((0..4).map(|_| element.clone()), 8), 5123, "VEC3", 4, true, ""))
            }
            Colors::Corners => {
                let c = [1.0f32, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
                Some(b.vertex(f32_bytes(&c), 5126, "VEC4", 4, false, ""))
            }
        };
        let color = color.map(|c| format!(r#","COLOR_0":{c}"#)).unwrap_or_default();
        meshes.push(format!(
            r#"{{"primitives":[{{"attributes":{{"POSITION":{position},"NORMAL":{normal},"TEXCOORD_0":{uv}{color}}},"indices":{indices},"material":{i}}}]}}"#
        ));
        let [r, g, bl] = q.base_color;
        let unlit = if q.unlit { r#","extensions":{"KHR_materials_unlit":{}}"# } else { "" };
        materials.push(format!(
            r#"{{"pbrMetallicRoughness":{{"baseColorFactor":[{r},{g},{bl},1],"metallicFactor":0,"roughnessFactor":0.8}}{unlit}}}"#
        ));
        let scale = if q.quantized { r#","scale":[0.5,0.5,0.5]"# } else { "" };
        nodes.push(format!(r#"{{"mesh":{i},"translation":[{},{},0]{scale}}}"#, q.at[0], q.at[1]));
    }
    let mut extensions = vec![r#""KHR_materials_unlit""#];
    if declare_quantization {
        extensions.push(r#""KHR_mesh_quantization""#);
    }
    let node_list: Vec<String> = (0..quads.len()).map(|i| i.to_string()).collect();
    format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":[{}],"scene":0,"scenes":[{{"nodes":[{}]}}],"nodes":[{}],"meshes":[{}],"materials":[{}],"accessors":[{}],"bufferViews":[{}],"buffers":[{{"byteLength":{},"uri":"{}"}}]}}"#,
        extensions.join(","),
        node_list.join(","),
        nodes.join(","),
        meshes.join(","),
        materials.join(","),
        b.accessors.join(","),
        b.views.join(","),
        b.bin.len(),
        data_uri("application/octet-stream", &b.bin)
    )
    .into_bytes()
}

const VIEWPORT: UVec2 = UVec2::new(320, 200);
/// Half the orthographic view's height in world units (its width is 1.6×).
const HALF_HEIGHT: f32 = 2.5;

/// Looking down -Z at the quads, orthographic, so every quad is seen alike.
fn front_view() -> LookAtResolver {
    LookAtResolver::new(Camera::orthographic(HALF_HEIGHT, 0.1, 20.0), Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, VIEWPORT)
        .unwrap()
}

/// The pixel a point of the z = 0 plane lands on in [`front_view`].
fn pixel(x: f32, y: f32) -> (u32, u32) {
    let half_width = HALF_HEIGHT * VIEWPORT.x as f32 / VIEWPORT.y as f32;
    let px = (x / half_width * 0.5 + 0.5) * VIEWPORT.x as f32;
    let py = (0.5 - y / HALF_HEIGHT * 0.5) * VIEWPORT.y as f32;
    (px as u32, py as u32)
}

/// Imports `bytes` and adds a sun of `sun` lux shining at the quads' fronts.
fn scene_of(bytes: &[u8], sun: f32) -> Scene {
    let mut scene = Scene::new();
    oxygen::import::import_gltf_slice(&mut scene, bytes, "quads.gltf", &ImportOptions::default())
        .expect("the file imports");
    let light = scene.add_node(
        "sun",
        Transform::IDENTITY
            .with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::new(-0.3, -0.4, -1.0).normalize())),
    );
    scene.set_light(light, Some(Light::directional(sun))).unwrap();
    scene
}

fn render(scene: &Scene, resolver: LookAtResolver) -> image::RgbaImage {
    let mut renderer = support::gpu_renderer();
    let view = renderer.register_view(resolver, standard_render_graph).unwrap();
    renderer.render_frame(scene).unwrap();
    support::read_lit_color(&renderer, view)
}

/// The mean colour of the 5 × 5 pixels around `at`.
fn mean_rgb(image: &image::RgbaImage, at: (u32, u32)) -> [f32; 3] {
    let mut sum = [0.0f32; 3];
    for y in at.1 - 2..=at.1 + 2 {
        for x in at.0 - 2..=at.0 + 2 {
            let p = image.get_pixel(x, y).0;
            for c in 0..3 {
                sum[c] += p[c] as f32 / 25.0;
            }
        }
    }
    sum
}

fn max_difference(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max)
}

/// The one-colour encodings, each at its own place in the top row.
const ENCODINGS: [Colors; 3] = [
    Colors::FloatRgb([0.9, 0.2, 0.1]),
    Colors::Unorm8Rgba([26, 230, 51, 255]),
    Colors::Unorm16Rgb([6554, 13107, 58982]),
];

fn encoding_quads(with_attributes: bool) -> Vec<Quad> {
    ENCODINGS
        .iter()
        .enumerate()
        .map(|(i, colors)| {
            let mut q = Quad::new([-3.0 + 1.5 * i as f32, 0.8]);
            if with_attributes {
                q.colors = *colors;
            } else {
                q.base_color = colors.linear().expect("a one-colour encoding");
            }
            q
        })
        .collect()
}

#[test]
fn a_vertex_colour_is_the_same_as_that_colour_in_the_base_colour_factor_in_every_encoding() {
    let with = render(&scene_of(&quads_file(&encoding_quads(true), false), 2.5), front_view());
    let factor = render(&scene_of(&quads_file(&encoding_quads(false), false), 2.5), front_view());
    let white = render(&scene_of(&quads_file(&[Quad::new([-3.0, 0.8])], false), 2.5), front_view());
    let grey = mean_rgb(&white, pixel(-3.0, 0.8));
    for (i, colors) in ENCODINGS.iter().enumerate() {
        let at = pixel(-3.0 + 1.5 * i as f32, 0.8);
        let (a, b) = (mean_rgb(&with, at), mean_rgb(&factor, at));
        assert!(max_difference(a, b) <= 2.0, "{colors:?}: vertex colour {a:?}, factor {b:?}");
        // And the colour shows: not the grey of a quad without one.
        assert!(max_difference(a, grey) > 40.0, "{colors:?}: {a:?} is the uncoloured {grey:?}");
    }
}

#[test]
fn vertex_colours_are_interpolated_across_the_triangle() {
    let mut q = Quad::new([0.0, 0.0]);
    q.colors = Colors::Corners;
    let image = render(&scene_of(&quads_file(&[q], false), 2.5), front_view());
    // Near each corner its own colour dominates: red, green, blue, white.
    let near = |x: f32, y: f32| mean_rgb(&image, pixel(x * 0.4, y * 0.4));
    let [r, g, b] = [near(-1.0, -1.0), near(1.0, -1.0), near(1.0, 1.0)];
    assert!(r[0] > 2.0 * r[1] && r[0] > 2.0 * r[2], "bottom left is red: {r:?}");
    assert!(g[1] > 2.0 * g[0] && g[1] > 2.0 * g[2], "bottom right is green: {g:?}");
    assert!(b[2] > 2.0 * b[0] && b[2] > 2.0 * b[1], "top right is blue: {b:?}");
    let w = near(-1.0, 1.0);
    assert!(max_difference(w, [w[0]; 3]) < 25.0 && w[0] > 100.0, "top left is near white: {w:?}");
}

#[test]
fn an_unlit_surface_shows_its_colour_whatever_the_light() {
    let mut unlit = Quad::new([-1.0, 0.0]);
    unlit.unlit = true;
    unlit.base_color = [0.2, 0.5, 0.8];
    let mut unlit_coloured = Quad::new([0.5, 0.0]);
    unlit_coloured.unlit = true;
    unlit_coloured.colors = Colors::Unorm8Rgba([255, 128, 0, 255]);
    let lit = Quad::new([2.0, 0.0]);
    let file = quads_file(&[unlit, unlit_coloured, lit], false);
    let bright = render(&scene_of(&file, 4.0), front_view());
    let dim = render(&scene_of(&file, 0.5), front_view());
    for (what, x) in [("unlit", -1.0), ("unlit with vertex colours", 0.5)] {
        let (a, b) = (mean_rgb(&bright, pixel(x, 0.0)), mean_rgb(&dim, pixel(x, 0.0)));
        assert!(max_difference(a, b) <= 1.0, "{what}: {a:?} under a bright sun, {b:?} under a dim one");
    }
    let (a, b) = (mean_rgb(&bright, pixel(2.0, 0.0)), mean_rgb(&dim, pixel(2.0, 0.0)));
    assert!(max_difference(a, b) > 30.0, "the lit control must follow the light: {a:?} vs {b:?}");
    // The vertex colour multiplies into an unlit base colour too: orange.
    let orange = mean_rgb(&bright, pixel(0.5, 0.0));
    assert!(orange[0] > orange[1] && orange[1] > orange[2] + 20.0, "{orange:?}");
}

#[test]
fn quantized_positions_normals_and_uvs_land_where_the_float_ones_do() {
    let mut quantized = Quad::new([-1.0, 0.0]);
    quantized.quantized = true;
    let float = Quad::new([-1.0, 0.0]);
    let q = render(&scene_of(&quads_file(&[quantized], true), 2.5), front_view());
    let f = render(&scene_of(&quads_file(&[float], true), 2.5), front_view());
    let c = compare(&q, &f, 2);
    assert!(c.differing <= 8, "{} of {} pixels differ between quantized and float quads", c.differing, c.total);
    // Not an empty picture: the quad is there.
    assert!(mean_rgb(&q, pixel(-1.0, 0.0))[0] > 60.0);
}

#[test]
fn quantized_attributes_without_the_extension_are_refused_naming_the_accessor() {
    let mut q = Quad::new([0.0, 0.0]);
    q.quantized = true;
    let mut scene = Scene::new();
    let err =
        oxygen::import::import_gltf_slice(&mut scene, &quads_file(&[q], false), "q.gltf", &ImportOptions::default())
            .expect_err("i16 positions need KHR_mesh_quantization");
    let text = err.to_string();
    assert!(text.contains("accessor") && text.contains("Position"), "{text}");
}

#[test]
fn golden_vertex_colours_unlit_and_quantized() {
    let mut quads = encoding_quads(true);
    let mut corners = Quad::new([1.5, 0.8]);
    corners.colors = Colors::Corners;
    quads.push(corners);
    quads.push(Quad::new([3.0, 0.8]));
    let mut unlit = Quad::new([-3.0, -0.9]);
    unlit.unlit = true;
    unlit.colors = Colors::Corners;
    quads.push(unlit);
    let mut quantized = Quad::new([-1.5, -0.9]);
    quantized.quantized = true;
    quantized.colors = Colors::Unorm8Rgba([200, 120, 255, 255]);
    quads.push(quantized);
    let image = render(&scene_of(&quads_file(&quads, true), 2.5), front_view());
    assert_golden("vertex_colours", &image, Tolerance::default());
}

/// A shipped file with a sun, seen from the front by a perspective camera
/// framing its bounds.
fn shipped(file: &str) -> (Scene, LookAtResolver) {
    let (scene, bounds) = support::shipped_with_sun(file);
    let radius = bounds.half_extents().length();
    let resolver = LookAtResolver::new(
        Camera::perspective(45f32.to_radians(), radius * 0.01, None),
        bounds.center() + Vec3::new(0.0, 0.0, 1.0) * radius * 2.2,
        bounds.center(),
        UVec2::new(240, 180),
    )
    .unwrap();
    (scene, resolver)
}

/// Every material of `scene` with `edit` applied.
fn edit_materials(scene: &mut Scene, edit: impl Fn(&mut Material)) {
    let materials: Vec<_> = scene.materials().map(|(h, m)| (h, m.clone())).collect();
    for (handle, mut material) in materials {
        edit(&mut material);
        scene.set_material(handle, material).unwrap();
    }
}

/// Pixels that are clearly yellow (the test file's "not applied" colour).
fn yellow_pixels(image: &image::RgbaImage) -> usize {
    image.pixels().filter(|p| p.0[0] > 150 && p.0[1] > 150 && p.0[2] < 80).count()
}

#[test]
fn texture_transforms_move_the_test_files_offsets_off_their_yellow_quarter() {
    let (scene, resolver) = shipped("TextureTransformTest/TextureTransformTest.gltf");
    let (mut plain, _) = shipped("TextureTransformTest/TextureTransformTest.gltf");
    edit_materials(&mut plain, |m| m.uvs = Default::default());
    for path in texture_paths() {
        let transformed = render_on(&scene, resolver, path);
        let untransformed = render_on(&plain, resolver, path);
        // The file's top row reads the yellow quarter of its UV texture when
        // the offsets are ignored; the markers below are yellow either way.
        let (with, without) = (yellow_pixels(&transformed), yellow_pixels(&untransformed));
        assert!(without > with + 2000, "{path:?}: yellow pixels: {with} with transforms, {without} without");
        assert_golden(&golden_name("texture_transform_test", path), &transformed, Tolerance::default());
    }
}

/// One golden per texture path for the shipped test files, whose thin
/// texture borders the grouped path resamples and clamps in the shader
/// (docs/bindless.md): both checked by eye against the reference
/// screenshots; on GL only the grouped one runs.
fn golden_name(name: &str, path: TexturePath) -> String {
    match path {
        TexturePath::BindingArray => name.to_owned(),
        TexturePath::GroupedArrays => format!("{name}_grouped"),
    }
}

fn render_on(scene: &Scene, resolver: LookAtResolver, path: TexturePath) -> image::RgbaImage {
    let options = RendererOptions { texture_path: Some(path), keep_hdr: true, ..Default::default() };
    let mut renderer = Renderer::new_headless_with(options).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    let view = renderer.register_view(resolver, standard_render_graph).unwrap();
    renderer.render_frame(scene).unwrap();
    support::read_lit_color(&renderer, view)
}

#[test]
fn uv_transform_rows_follow_the_extension_order_translate_rotate_scale() {
    let t = UvTransform { uv_set: 0, offset: Vec2::new(0.5, -0.25), rotation: 0.3, scale: Vec2::new(1.5, 2.0) };
    let uv = Vec2::new(0.2, 0.7);
    // Scale, then rotate (u' = cos u + sin v, v' = -sin u + cos v), then offset.
    let s = uv * t.scale;
    let (sin, cos) = t.rotation.sin_cos();
    let expected = Vec2::new(cos * s.x + sin * s.y, -sin * s.x + cos * s.y) + t.offset;
    assert!((t.apply(uv) - expected).length() < 1e-6, "{} vs {expected}", t.apply(uv));
}

#[test]
fn a_texture_reads_the_uv_set_its_material_names() {
    let (scene, resolver) = shipped("MultiUVTest/MultiUVTest.glb");
    let emissive_set = scene.materials().map(|(_, m)| m.uvs.emissive.uv_set).max();
    assert_eq!(emissive_set, Some(1), "the file's emissive texture reads TEXCOORD_1");
    let two_sets = render(&scene, resolver);
    let (mut first_set_only, _) = shipped("MultiUVTest/MultiUVTest.glb");
    edit_materials(&mut first_set_only, |m| m.uvs.emissive.uv_set = 0);
    let one_set = render(&first_set_only, resolver);
    let c = compare(&two_sets, &one_set, 10);
    assert!(c.differing > c.total / 20, "reading set 1 must change the picture: {} of {}", c.differing, c.total);
    assert_golden("multi_uv_test", &two_sets, Tolerance::default());
}

/// TextureSettingsTest: every row's "Test" cell must look like its "Sample
/// pass" cell, which needs wrapS and wrapT to be applied separately (clamp
/// along one axis, repeat or mirror along the other). A golden per texture
/// path, each checked by eye against the file's reference screenshot.
#[test]
fn golden_texture_settings_test_on_both_texture_paths() {
    let (scene, resolver) = shipped("TextureSettingsTest/TextureSettingsTest.glb");
    for path in texture_paths() {
        let image = render_on(&scene, resolver, path);
        assert_golden(&golden_name("texture_settings_test", path), &image, Tolerance::default());
    }
}

/// `KHR_materials_emissive_strength` multiplies the emissive factor (glTF
/// clamps the factor to 1; the strength carries brighter emission), and
/// `KHR_materials_unlit` and texture transforms land in the material.
#[test]
fn material_extensions_are_read_into_the_material() {
    let mut b = Buffers::default();
    let p = b.vertex(
        f32_bytes(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]),
        5126,
        "VEC3",
        3,
        false,
        r#","min":[0,0,0],"max":[1,1,0]"#,
    );
    let file = format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["KHR_materials_emissive_strength","KHR_materials_unlit"],
        "scene":0,"scenes":[{{"nodes":[0,1]}}],"nodes":[{{"mesh":0}},{{"mesh":1}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}},"material":0}}]}},{{"primitives":[{{"attributes":{{"POSITION":{p}}},"material":1}}]}}],
        "materials":[{{"emissiveFactor":[1,0.5,0],"extensions":{{"KHR_materials_emissive_strength":{{"emissiveStrength":4}}}}}},
                     {{"extensions":{{"KHR_materials_unlit":{{}}}}}}],
        "accessors":[{}],"bufferViews":[{}],"buffers":[{{"byteLength":{},"uri":"{}"}}]}}"#,
        b.accessors.join(","),
        b.views.join(","),
        b.bin.len(),
        data_uri("application/octet-stream", &b.bin)
    );
    let mut scene = Scene::new();
    oxygen::import::import_gltf_slice(&mut scene, file.as_bytes(), "m.gltf", &ImportOptions::default()).unwrap();
    let materials: Vec<Material> = scene.materials().map(|(_, m)| m.clone()).collect();
    let emissive = materials.iter().find(|m| m.emissive != Vec3::ZERO).expect("the emissive material");
    assert_eq!(emissive.emissive, Vec3::new(4.0, 2.0, 0.0));
    assert!(!emissive.unlit);
    assert!(materials.iter().any(|m| m.unlit), "the unlit material");
}

/// NormalTangentTest: each pair shows a real bump beside a normal-mapped
/// quad in five UV orientations; with tangents built right, both cells of a
/// pair look alike (checked by eye against the file's reference; the
/// direction itself is tested in `gpu_textures.rs`). The golden guards
/// the look; without its normal maps the picture must change.
#[test]
fn golden_normal_tangent_test() {
    let (scene, mut resolver) = shipped("NormalTangentTest/NormalTangentTest.glb");
    resolver.viewport = UVec2::new(240, 180);
    let mapped = render(&scene, resolver);
    let (mut flat, _) = shipped("NormalTangentTest/NormalTangentTest.glb");
    edit_materials(&mut flat, |m| m.normal_texture = None);
    let c = compare(&mapped, &render(&flat, resolver), 10);
    assert!(c.differing > c.total / 50, "the normal maps must show: {} of {} differ", c.differing, c.total);
    assert_golden("normal_tangent_test", &mapped, Tolerance::default());
}
