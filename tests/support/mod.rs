//! Shared helpers for GPU tests: a renderer on the test adapter, projection
//! of world points to pixels, tolerant region checks, and the check that a
//! lit view's HDR target holds only finite radiance.

#![allow(dead_code)] // Each test binary uses a different subset.

pub mod cube;
pub mod deform;
pub mod encode;
pub mod far;
pub mod golden;
pub mod record;
pub mod rng;
pub mod skip;

use std::sync::Once;

use image::RgbaImage;
use oxygen::bindless::TexturePath;
use oxygen::gpu::HdrImage;
use oxygen::prelude::*;
use oxygen::views::ResolvedView;

/// RMSE of two HDR images' linear radiance, as the accuracy atlas measures
/// it (`oxygen_demo::radiance_rmse`: each channel clamped to 4).
pub fn radiance_rmse(a: &HdrImage, b: &HdrImage) -> f64 {
    oxygen_demo::radiance_rmse(&a.pixels, &b.pixels)
}

/// The path-traced reference of `scene` seen through `desc` with
/// `settings`: a reference view registered, rendered until it has
/// `settings.max_samples` samples a pixel, read and unregistered (other
/// views registered meanwhile render along).
pub fn reference_hdr(
    renderer: &mut Renderer,
    scene: &Scene,
    desc: ViewDesc,
    settings: oxygen::passes::ReferenceSettings,
) -> HdrImage {
    let traced =
        renderer.register_view(desc.path_traced(), oxygen::graph::ReferenceGraph { settings, exposure: 1.0 }).unwrap();
    while renderer.reference_samples(traced) < settings.max_samples {
        renderer.render_frame(scene).unwrap();
    }
    let image = renderer.read_hdr(traced).unwrap();
    renderer.unregister_view(traced).unwrap();
    image
}

/// A view of `desc` recording `graph` registered, `frames` frames rendered,
/// its HDR image read (checked finite, named `what`) and the view
/// unregistered.
pub fn view_hdr(
    renderer: &mut Renderer,
    scene: &Scene,
    desc: ViewDesc,
    graph: impl oxygen::graph::RenderGraph,
    frames: u32,
    what: &str,
) -> HdrImage {
    let view = renderer.register_view(desc, graph).unwrap();
    for _ in 0..frames {
        renderer.render_frame(scene).unwrap();
    }
    let image = renderer.read_hdr(view).unwrap();
    assert_hdr_image_finite(&image, what);
    renderer.unregister_view(view).unwrap();
    image
}

/// A pixel's colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rgb {
    pub r: u8,
    pub g: u8,
    pub b: u8,
}

impl Rgb {
    pub fn new(r: u8, g: u8, b: u8) -> Self {
        Rgb { r, g, b }
    }

    /// Largest absolute difference over the three channels.
    pub fn max_channel_error(self, other: Rgb) -> u8 {
        [self.r.abs_diff(other.r), self.g.abs_diff(other.g), self.b.abs_diff(other.b)].into_iter().max().unwrap_or(0)
    }

    /// Rec. 709 luma of the stored (sRGB-encoded) values.
    pub fn luma(self) -> f32 {
        0.2126 * self.r as f32 + 0.7152 * self.g as f32 + 0.0722 * self.b as f32
    }
}

/// The sRGB encoding of a linear channel, as an 8-bit value.
pub fn linear_to_srgb8(linear: f64) -> u8 {
    let c = linear.clamp(0.0, 1.0);
    let s = if c <= 0.0031308 { c * 12.92 } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0).round() as u8
}

/// A renderer on the test adapter; logs the adapter once per test binary.
/// Fails (never skips) when there is no adapter: CI must not pass silently.
///
/// Every HDR target is kept (`RendererOptions::keep_hdr`) so that
/// [`assert_hdr_finite`] reads what shading wrote; tests/frame_economy.rs
/// covers the in-pass tone map that skips it.
pub fn gpu_renderer() -> Renderer {
    static LOG: Once = Once::new();
    match Renderer::new_headless_with(RendererOptions { keep_hdr: true, ..Default::default() }) {
        Ok(renderer) => {
            LOG.call_once(|| eprintln!("GPU tests run on: {}", renderer.gpu().describe()));
            record::note_renderer(&renderer);
            renderer
        }
        Err(e) => panic!("GPU tests need an adapter: {e}"),
    }
}

/// A renderer on the test adapter with explicit options.
/// HDR targets are kept, as in [`gpu_renderer`].
pub fn gpu_renderer_with(options: RendererOptions) -> Renderer {
    let renderer = Renderer::new_headless_with(RendererOptions { keep_hdr: true, ..options })
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    record::note_renderer(&renderer);
    renderer
}

/// Fails when the view's HDR target (linear radiance, before the tone map)
/// holds a NaN or an infinity anywhere, naming the first offenders. The
/// tone map shows such a pixel as black or white, so the sRGB image alone
/// can hide it; every test that renders a lit scene calls this.
pub fn assert_hdr_finite(renderer: &Renderer, view: ViewId) {
    let hdr = renderer.read_hdr(view).unwrap_or_else(|e| panic!("reading the HDR target of {view:?}: {e}"));
    assert_hdr_image_finite(&hdr, &format!("{view:?}"));
}

/// [`assert_hdr_finite`] for an HDR image read back some other way.
pub fn assert_hdr_image_finite(hdr: &HdrImage, what: &str) {
    let bad: Vec<_> = hdr.non_finite().collect();
    assert!(
        bad.is_empty(),
        "{what}: {} of the {}×{} HDR pixels are not finite; first: {:?}",
        bad.len(),
        hdr.width,
        hdr.height,
        &bad[..bad.len().min(4)]
    );
}

/// The view's displayable image, after [`assert_hdr_finite`]: what a test
/// of a lit scene reads instead of `read_color`.
pub fn read_lit_color(renderer: &Renderer, view: ViewId) -> RgbaImage {
    assert_hdr_finite(renderer, view);
    renderer.read_color(view).unwrap_or_else(|e| panic!("reading the colour target of {view:?}: {e}"))
}

/// A perspective camera of `fov_degrees` (near plane 0.1, no far plane) at
/// `eye` looking at the origin, rendering `viewport` pixels.
pub fn looking_at_origin(fov_degrees: f32, eye: Vec3, viewport: UVec2) -> LookAtResolver {
    LookAtResolver::new(Camera::perspective(fov_degrees.to_radians(), 0.1, None), eye, Vec3::ZERO, viewport).unwrap()
}

/// The camera the glTF sample models are looked at with: 45°, a near plane
/// of 0.05 (they are a few units across), no far plane.
pub fn model_camera(eye: Vec3, target: Vec3, viewport: UVec2) -> LookAtResolver {
    LookAtResolver::new(Camera::perspective(45f32.to_radians(), 0.05, None), eye, target, viewport).unwrap()
}

/// The pixel a world point lands on.
pub fn pixel_of(view: &ResolvedView, world: Vec3) -> (u32, u32) {
    let clip = view.view_projection * world.extend(1.0);
    let ndc = clip.truncate() / clip.w;
    let x = (ndc.x * 0.5 + 0.5) * view.viewport.x as f32;
    let y = (0.5 - ndc.y * 0.5) * view.viewport.y as f32;
    (x.clamp(0.0, view.viewport.x as f32 - 1.0) as u32, y.clamp(0.0, view.viewport.y as f32 - 1.0) as u32)
}

fn region(image: &RgbaImage, center: (u32, u32), radius: u32) -> impl Iterator<Item = ((u32, u32), Rgb)> + '_ {
    let (cx, cy) = center;
    let xs = cx.saturating_sub(radius)..=(cx + radius).min(image.width() - 1);
    let ys = cy.saturating_sub(radius)..=(cy + radius).min(image.height() - 1);
    ys.flat_map(move |y| xs.clone().map(move |x| (x, y))).map(|(x, y)| {
        let p = image.get_pixel(x, y).0;
        ((x, y), Rgb::new(p[0], p[1], p[2]))
    })
}

/// Mean luma of the square of `radius` around `center`.
pub fn region_mean(image: &RgbaImage, center: (u32, u32), radius: u32) -> f32 {
    let (sum, n) = region(image, center, radius).fold((0.0, 0), |(s, n), (_, p)| (s + p.luma(), n + 1));
    sum / n as f32
}

/// Asserts that at most `max_bad` pixels of the square around `center` fail
/// `accept`; on failure names the first offenders and saves the image.
pub fn assert_region(
    image: &RgbaImage,
    center: (u32, u32),
    radius: u32,
    accept: impl Fn(Rgb) -> bool,
    max_bad: usize,
    what: &str,
) {
    let bad: Vec<_> = region(image, center, radius).filter(|(_, p)| !accept(*p)).collect();
    if bad.len() > max_bad {
        let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
        let path = dir.join(format!("{}.actual.png", what.replace(' ', "_")));
        let saved =
            image.save(&path).map(|_| path.display().to_string()).unwrap_or_else(|e| format!("(not saved: {e})"));
        panic!(
            "{what}: {} of the pixels around {center:?} are wrong (allowed {max_bad}); first: {:?}; image: {saved}",
            bad.len(),
            &bad[..bad.len().min(4)]
        );
    }
}

/// Both texture paths, except on wgpu's GL backend, which has no binding
/// arrays (docs/backends.md): there only the grouped arrays, and the
/// binding-array half of the test is counted as skipped
/// (`binary::test[BindingArray]`). Every other backend the tests run on
/// must offer both.
pub fn texture_paths() -> Vec<TexturePath> {
    if std::env::var("WGPU_BACKEND").is_ok_and(|b| b.eq_ignore_ascii_case("gl")) {
        skip::skip_part("BindingArray", "GL has no binding arrays: only TexturePath::GroupedArrays is tested");
        return vec![TexturePath::GroupedArrays];
    }
    vec![TexturePath::BindingArray, TexturePath::GroupedArrays]
}

/// A renderer with `options` that can run GPU visibility, or `None` after
/// counting the calling test as skipped (the adapter lacks
/// multi-draw-indirect with counts: GL).
#[allow(dead_code)]
pub fn gpu_visibility_renderer(options: oxygen::RendererOptions) -> Option<oxygen::Renderer> {
    let renderer = gpu_renderer_with(options);
    if renderer.gpu_visibility_supported() {
        return Some(renderer);
    }
    skip::skip(format_args!(
        "{} cannot run GPU visibility (needs multi-draw-indirect with counts)",
        renderer.gpu().describe()
    ));
    None
}

/// A shipped file (`assets/` relative path) in a scene of its own, with a
/// sun shining down and into it, and the bounds of what it draws.
pub fn shipped_with_sun(relative: &str) -> (Scene, oxygen::core::Aabb) {
    let path = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets").join(relative);
    let mut scene = Scene::new();
    let import = oxygen::import::import_gltf(&mut scene, path, &oxygen::import::SceneChoice::Default)
        .unwrap_or_else(|e| panic!("{relative}: {e}"));
    let bounds = import.bounds.unwrap_or_else(|| panic!("{relative}: nothing to draw"));
    let direction = Vec3::new(-0.2, -0.3, -1.0).normalize();
    let sun = scene.add_node(
        "sun",
        Transform::IDENTITY.with_rotation(oxygen::glam::Quat::from_rotation_arc(Vec3::NEG_Z, direction)),
    );
    scene.set_light(sun, Some(Light::directional(2.5))).expect("a sun");
    (scene, bounds)
}
