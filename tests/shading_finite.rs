//! Shading never produces a non-finite value for finite inputs (issue 17).
//!
//! The scene of the report: the shipped `Cubes.glb` on a large lit ground
//! under a sun, seen from above. One pixel of lit ground used to be black:
//! the sun's hot spot, where the view direction equals the light direction,
//! v·h rounded to just above 1 and Schlick's `pow(1 - v·h, 5)` took a
//! negative base to NaN, which the tone map shows as black.
//!
//! Then the shading functions themselves, run on the GPU over grazing and
//! degenerate inputs.

mod support;

use std::path::PathBuf;

use oxygen::bindless::TexturePath;
use oxygen::core::CascadeSettings;
use oxygen::glam::{Quat, Vec4};
use oxygen::prelude::*;
use oxygen::views::ViewContext;

/// The issue's scene: `Cubes.glb`, a 40 × 0.5 × 40 grey ground box whose
/// top is the floor of the file's bounds, and a sun; and its camera, from
/// above the bounds' centre. Also the sun's hot spot on the ground: the
/// point seen looking straight down the light's direction.
fn cubes_on_lit_ground() -> (Scene, LookAtResolver, Vec3) {
    let mut scene = Scene::new();
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/Cubes/Cubes.glb");
    let import = import_gltf(&mut scene, path, &SceneChoice::Default).unwrap();
    let bounds = import.bounds.expect("Cubes.glb has something to draw");
    let center = bounds.center();

    let ground_material = scene.add_material(Material::opaque("ground", Vec4::splat(0.7)));
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let top = bounds.min.y;
    let ground = scene.add_node(
        "ground",
        Transform::from_translation(Vec3::new(center.x, top - 0.25, center.z)).with_scale(Vec3::new(40.0, 0.5, 40.0)),
    );
    scene.set_renderable(ground, Renderable { geometry: cube, materials: vec![ground_material] }).unwrap();

    let travelling = Vec3::new(-0.4, -1.0, -0.3).normalize();
    let sun =
        scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, travelling)));
    scene.set_light(sun, Some(Light::directional(3.0))).unwrap();

    let camera = LookAtResolver::new(
        Camera::perspective(50f32.to_radians(), 0.1, Some(100.0)),
        center + Vec3::new(0.0, 12.0, 0.5),
        center,
        UVec2::new(640, 360),
    )
    .unwrap();
    let hot_spot = camera.eye + travelling * (top - camera.eye.y) / travelling.y;
    (scene, camera, hot_spot)
}

/// Where the report saw the black pixel.
const REPORTED_PIXEL: (u32, u32) = (167, 81);

/// Every pixel of the picture is lit ground, a cube or the clear colour,
/// all of which get at least the ambient term: none is black.
fn assert_nothing_black(image: &image::RgbaImage, what: &str) {
    let black: Vec<_> =
        image.enumerate_pixels().filter(|(_, _, p)| p.0[..3].iter().all(|&c| c <= 2)).map(|(x, y, _)| (x, y)).collect();
    let p = image.get_pixel(REPORTED_PIXEL.0, REPORTED_PIXEL.1).0;
    assert!(black.is_empty(), "{what}: {} black pixels, first {:?}", black.len(), &black[..black.len().min(8)]);
    // The reported pixel is lit ground: as bright as its neighbourhood.
    let around = support::region_mean(image, REPORTED_PIXEL, 3);
    let luma = support::Rgb::new(p[0], p[1], p[2]).luma();
    assert!(
        (luma - around).abs() < 12.0,
        "{what}: pixel {REPORTED_PIXEL:?} has luma {luma:.1}, its neighbours {around:.1}"
    );
}

#[test]
fn lit_ground_beside_the_cubes_has_no_black_pixel() {
    let (scene, camera, hot_spot) = cubes_on_lit_ground();
    let mut renderer = support::gpu_renderer();
    let view = renderer.register_view(camera, standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    let resolved = camera.resolve(&ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 }, &scene).unwrap();
    assert_eq!(support::pixel_of(&resolved, hot_spot), REPORTED_PIXEL, "the reported pixel is the sun's hot spot");
    let image = support::read_lit_color(&renderer, view);
    assert_nothing_black(&image, "standard graph");
}

#[test]
fn lit_ground_beside_the_cubes_has_no_black_pixel_under_shadow_cascades() {
    let (scene, camera, _) = cubes_on_lit_ground();
    let mut renderer = support::gpu_renderer();
    let desc = ViewDesc::new(camera).with_sun_shadows(CascadeSettings::default());
    let view = renderer.register_view(desc, standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    assert!(!renderer.sun_cascades(view).is_empty(), "the sun casts shadows");
    let image = support::read_lit_color(&renderer, view);
    assert_nothing_black(&image, "shadow cascades");
}

// The shading functions on the GPU. The compute entry point below is
// appended to the shading pass's own WGSL, so it calls exactly the functions
// the fragment stages call: no CPU copy that could drift from the shader.

/// Inputs per case: `CASE_VEC4S` vec4s (see the WGSL for the fields).
const CASE_VEC4S: usize = 11;
/// Outputs per case.
const RESULT_VEC4S: usize = 6;

const PROPERTY_WGSL: &str = r#"
@group(0) @binding(100) var<storage, read> shading_cases: array<vec4<f32>>;
@group(0) @binding(101) var<storage, read_write> shading_results: array<vec4<f32>>;

@compute @workgroup_size(64)
fn shading_properties(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&shading_results) / 6u {
        return;
    }
    let c = i * 11u;
    let n = shading_cases[c].xyz;
    let metallic = shading_cases[c].w;
    let v = shading_cases[c + 1u].xyz;
    let roughness = shading_cases[c + 1u].w;
    let l = shading_cases[c + 2u].xyz;
    let flip = shading_cases[c + 2u].w != 0.0;
    let albedo = shading_cases[c + 3u].xyz;
    let normal_scale = shading_cases[c + 3u].w;
    let world_normal = shading_cases[c + 4u].xyz;
    let brightness = shading_cases[c + 4u].w;
    let uv_d = UvDerivatives(shading_cases[c + 7u].xy, shading_cases[c + 7u].zw, shading_cases[c + 7u].xy, shading_cases[c + 7u].zw);
    let d = Derivatives(shading_cases[c + 5u].xyz, shading_cases[c + 6u].xyz, uv_d);
    let to_viewer = shading_cases[c + 8u].xyz;
    let texel = shading_cases[c + 9u].xyz;
    let spot = shading_cases[c + 10u].xyz;

    // The BRDF on its own, over every (n, v, l) of the grid.
    let direct = brdf_cosine(n, v, l, albedo, metallic, roughness);
    // The fragment stage's chain: vertex normal -> shading normal -> view
    // direction -> normal map -> BRDF.
    let shading = shading_normal(world_normal, flip, d, to_viewer);
    let view = view_direction(to_viewer, shading);
    let at = TexCoord(vec2<f32>(0.0), d.uv.dx0, d.uv.dy0);
    let mapped = perturb_normal(shading, d, at, tangent_space_normal(texel, normal_scale));
    let chained = brdf_cosine(mapped, view, l, albedo, metallic, roughness);
    let r = i * 6u;
    shading_results[r] = vec4<f32>(direct, 0.0);
    shading_results[r + 1u] = vec4<f32>(shading, 0.0);
    shading_results[r + 2u] = vec4<f32>(view, 0.0);
    shading_results[r + 3u] = vec4<f32>(mapped, 0.0);
    shading_results[r + 4u] = vec4<f32>(chained, 0.0);
    // Lights bright enough to overflow the HDR target, or f32 itself,
    // fitted into the target.
    shading_results[r + 5u] = vec4<f32>(spot_cone(spot.x, spot.y, spot.z), fit_hdr(direct * brightness * brightness));
}
"#;

/// A deterministic scatter of unit directions (xorshift; no dependency).
fn scattered_directions(count: usize) -> Vec<Vec3> {
    let mut state = 0x9e37_79b9_u32;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state as f32 / u32::MAX as f32 * 2.0 - 1.0
    };
    (0..count).map(|_| Vec3::new(next(), next(), next()).normalize()).collect()
}

/// Unit directions where shading is delicate: the axes (normal and light
/// parallel or opposite), the issue's sun, its mirror image about the
/// ground and directions a hair away from it (view and light almost equal),
/// grazing ones a hair above and below the ground, and a zero vector.
fn directions() -> Vec<Vec3> {
    let sun = Vec3::new(0.4, 1.0, 0.3).normalize();
    let tilted = |angle: f32| Quat::from_axis_angle(Vec3::X, angle) * sun;
    let mut all = vec![
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        sun,
        -sun,
        Vec3::new(-sun.x, sun.y, -sun.z),
        tilted(1e-7),
        tilted(1e-5),
        tilted(1e-3),
        Vec3::new(1.0, 1e-7, 0.0).normalize(),
        Vec3::new(1.0, -1e-7, 0.0).normalize(),
        Vec3::new(0.0, 1e-4, 1.0).normalize(),
        Vec3::ONE.normalize(),
        Vec3::ZERO,
    ];
    all.extend(scattered_directions(8));
    all
}

/// One shading case: every field the compute entry point reads.
struct Case {
    n: Vec3,
    v: Vec3,
    l: Vec3,
    albedo: Vec3,
    metallic: f32,
    roughness: f32,
    flip: bool,
    normal_scale: f32,
    world_normal: Vec3,
    /// dp/dx, dp/dy, duv/dx, duv/dy.
    derivatives: (Vec3, Vec3, [f32; 2], [f32; 2]),
    to_viewer: Vec3,
    texel: Vec3,
    /// cos outer, cos inner, cos of the angle to the axis.
    spot: Vec3,
    /// Square root of a light intensity that `fit_hdr` brings into range.
    brightness: f32,
}

impl Case {
    fn words(&self) -> [[f32; 4]; CASE_VEC4S] {
        let (dp_dx, dp_dy, duv_dx, duv_dy) = self.derivatives;
        [
            self.n.extend(self.metallic).to_array(),
            self.v.extend(self.roughness).to_array(),
            self.l.extend(if self.flip { 1.0 } else { 0.0 }).to_array(),
            self.albedo.extend(self.normal_scale).to_array(),
            self.world_normal.extend(self.brightness).to_array(),
            dp_dx.extend(0.0).to_array(),
            dp_dy.extend(0.0).to_array(),
            [duv_dx[0], duv_dx[1], duv_dy[0], duv_dy[1]],
            self.to_viewer.extend(0.0).to_array(),
            self.texel.extend(0.0).to_array(),
            self.spot.extend(0.0).to_array(),
        ]
    }
}

/// Every (n, v, l) of [`directions`] × roughness {0, 0.001, 0.045, 0.3, 1}
/// × metallic {0, 1}; the per-fragment inputs (vertex normals, derivatives,
/// normal-map texels, spot cones) cycle through their own degenerate lists
/// at co-prime periods, so each meets many (n, v, l) and materials.
fn cases() -> Vec<Case> {
    let dirs = directions();
    let world_normals = [
        Vec3::Y,
        Vec3::ZERO,                   // zero in the vertex data
        Vec3::new(1e-8, 0.0, -1e-8),  // opposite normals interpolated across a triangle
        Vec3::new(0.0, -1e-35, 0.0),  // shorter than any normal f32 squared length
        Vec3::new(3e38, -3e38, 1e38), // squared length overflows f32
        Vec3::new(0.3, -0.2, 0.9),
        Vec3::new(0.0, 1e-31, 0.0), // below has_direction's threshold
    ];
    let derivatives = [
        (Vec3::new(0.01, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.01), [0.01, 0.0], [0.0, 0.01]),
        (Vec3::ZERO, Vec3::ZERO, [0.0, 0.0], [0.0, 0.0]),
        (Vec3::new(0.01, 0.0, 0.0), Vec3::new(0.02, 0.0, 0.0), [0.01, 0.0], [0.02, 0.0]), // parallel: no facet
        (Vec3::new(1e-20, 0.0, 0.0), Vec3::new(0.0, 1e-20, 0.0), [1e-20, 0.0], [0.0, 1e-20]),
        (Vec3::new(0.01, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.01), [0.0, 0.0], [0.0, 0.0]), // no UV change
        (Vec3::new(1e6, 0.0, 0.0), Vec3::new(0.0, 1e6, 0.0), [1e6, 0.0], [0.0, -1e6]),
    ];
    let to_viewers = [
        Vec3::new(0.0, 5.0, 1.0),
        Vec3::ZERO, // the camera on the surface point
        Vec3::new(1e-31, 0.0, 0.0),
        Vec3::new(1e7, -1e7, 1e7),
        Vec3::new(0.0, -3.0, 0.0),
    ];
    let texels = [
        Vec3::new(0.5, 0.5, 1.0), // flat
        Vec3::new(0.5, 0.5, 0.5), // decodes to zero
        Vec3::ZERO,
        Vec3::new(1.0, 0.5, 0.5), // along the tangent, no z
        Vec3::new(0.5, 0.5, 0.0), // into the surface
        Vec3::new(0.9, 0.1, 0.7),
    ];
    let normal_scales = [1.0, 0.0, -1.0, 1e4];
    let spots = [
        Vec3::new(1.0, 1.0, 1.0), // a cone so narrow both cosines round to 1
        Vec3::new(1.0, 1.0, 0.5),
        Vec3::new(0.9, 0.95, 0.93),
        Vec3::new(-1.0, 1.0, 0.0),
        Vec3::new(0.5, 0.5, 0.5),
    ];
    // Squared: 1, beyond the HDR target's range, beyond f32's.
    let brightnesses = [1.0, 1e3, 1e15, f32::MAX];
    let albedos = [Vec3::splat(0.7), Vec3::ONE, Vec3::ZERO, Vec3::new(0.9, 0.1, 0.05)];
    let mut out = Vec::new();
    for &n in &dirs {
        for &v in &dirs {
            for &l in &dirs {
                for roughness in [0.0, 0.001, 0.045, 0.3, 1.0] {
                    for metallic in [0.0, 1.0] {
                        let k = out.len();
                        out.push(Case {
                            n,
                            v,
                            l,
                            albedo: albedos[k % albedos.len()],
                            metallic,
                            roughness,
                            flip: k % 2 == 1,
                            normal_scale: normal_scales[k / 3 % normal_scales.len()],
                            world_normal: world_normals[k % world_normals.len()],
                            derivatives: derivatives[k / 7 % derivatives.len()],
                            to_viewer: to_viewers[k / 11 % to_viewers.len()],
                            texel: texels[k / 13 % texels.len()],
                            spot: spots[k % spots.len()],
                            brightness: brightnesses[k / 5 % brightnesses.len()],
                        });
                    }
                }
            }
        }
    }
    out
}

/// Runs [`PROPERTY_WGSL`] over `cases` and returns `RESULT_VEC4S` vec4s per case.
fn run_shading_functions(cases: &[Case]) -> Vec<[f32; 4]> {
    use wgpu::util::DeviceExt;
    let renderer = support::gpu_renderer();
    let gpu = renderer.gpu();
    let source = format!(
        "{}\n{PROPERTY_WGSL}",
        oxygen::passes::testing::shader_source(oxygen::passes::PassKind::Shading, TexturePath::GroupedArrays)
    );
    let module = gpu.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("shading properties"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = gpu.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("shading properties"),
        layout: None,
        module: &module,
        entry_point: Some("shading_properties"),
        compilation_options: Default::default(),
        cache: None,
    });
    let words: Vec<[f32; 4]> = cases.iter().flat_map(|c| c.words()).collect();
    let input = gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("shading cases"),
        contents: bytemuck::cast_slice(&words),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let size = (cases.len() * RESULT_VEC4S * 16) as u64;
    let output = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("shading results"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("shading results readback"),
        size,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("shading properties"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 100, resource: input.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 101, resource: output.as_entire_binding() },
        ],
    });
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups((cases.len() as u32).div_ceil(64), 1, 1);
    }
    encoder.copy_buffer_to_buffer(&output, 0, &staging, 0, size);
    gpu.queue.submit([encoder.finish()]);
    staging.slice(..).map_async(wgpu::MapMode::Read, |r| r.expect("map the results"));
    gpu.device.poll(wgpu::PollType::wait_indefinitely()).expect("wait for the GPU");
    let mapped = staging.slice(..).get_mapped_range().expect("read the mapped results");
    bytemuck::cast_slice::<u8, [f32; 4]>(&mapped).to_vec()
}

/// Over grazing and degenerate inputs — normal and light parallel, view and
/// light equal and opposite, roughness 0 and 1, metallic 0 and 1, zero and
/// overflowing normals from the vertex data, a camera on the surface, a
/// normal-map texel that encodes no direction, a spot cone of zero width —
/// every shading function returns finite values, its normals unit length.
#[test]
fn shading_functions_stay_finite_over_degenerate_inputs() {
    let cases = cases();
    let results = run_shading_functions(&cases);
    assert_eq!(results.len(), cases.len() * RESULT_VEC4S);
    let names = [
        "brdf_cosine",
        "shading_normal",
        "view_direction",
        "perturb_normal",
        "chained brdf_cosine",
        "spot_cone, fit_hdr",
    ];
    let mut failures = Vec::new();
    let mut failing = [0usize; RESULT_VEC4S];
    for (case, result) in cases.iter().zip(results.chunks(RESULT_VEC4S)) {
        for (index, (name, value)) in names.iter().zip(result).enumerate() {
            let finite = value.iter().all(|c| c.is_finite());
            let length = Vec3::from_slice(&value[..3]).length();
            let ok = finite
                && match *name {
                    "brdf_cosine" | "chained brdf_cosine" => value[..3].iter().all(|&c| c >= 0.0),
                    "shading_normal" | "view_direction" | "perturb_normal" => (length - 1.0).abs() < 1e-4,
                    _ => (0.0..=1.0).contains(&value[0]) && value[1..].iter().all(|&c| c <= 65504.0),
                };
            if !ok {
                failing[index] += 1;
                failures.push(format!(
                    "{name} = {value:?} for n {} v {} l {} roughness {} metallic {} world normal {} to viewer {} texel {} spot {}",
                    case.n,
                    case.v,
                    case.l,
                    case.roughness,
                    case.metallic,
                    case.world_normal,
                    case.to_viewer,
                    case.texel,
                    case.spot
                ));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} results are wrong ({:?}); first:\n{}",
        failures.len(),
        results.len(),
        names.iter().zip(failing).filter(|(_, count)| *count > 0).collect::<Vec<_>>(),
        failures[..failures.len().min(8)].join("\n")
    );
}
