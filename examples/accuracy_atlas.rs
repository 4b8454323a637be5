//! The accuracy atlas: every speed/accuracy knob of the raster path, timed
//! and measured against the path-traced reference of the same scene.
//!
//! ```text
//! cargo run --release --example accuracy_atlas [OUT_DIR] [SIZE] [SAMPLES]   # defaults: docs/accuracy 160 512
//! ```
//!
//! For each knob setting it renders the raster view (warm-up, then the
//! median of 10 frames' GPU time, from timestamps where the adapter has
//! them, else of the wall time of each frame waited for) and compares
//! its HDR image with the reference: the same scene traced with the raster
//! path's light transport ([`ReferenceSettings::RASTER_MODEL`]: direct light,
//! exact shadows, the raster's ambient term, SAMPLES paths per pixel), so
//! that what is left is the knob's approximation, not a lighting model the
//! raster path does not have. Errors: RMSE of linear radiance (each channel
//! clamped to 4, so that a highlight's peak does not swamp it), and SSIM of
//! the tone-mapped sRGB luma (1 = identical; 8 × 8 windows, stride 4).
//!
//! Each reference is traced twice, with two seeds: the two images differ
//! only by their noise, and their RMSE over √2 estimates one reference's
//! own RMSE against the converged picture (tests/reference_view.rs checks
//! that estimate, unclamped). It is the scene's noise floor, measured in
//! the same clamped RMSE as the rows and printed beside each: a knob's
//! error near it is below what the reference can resolve.
//!
//! `accuracy_atlas --chart atlas.csv atlas.png` redraws the chart from a
//! run's CSV. `ATLAS_KNOBS="probe parallax,PCF radius"` runs the named
//! knobs only (their scenes' references alone are traced); its CSV, chart
//! and record hold those rows, and the record says which knobs it ran.
//!
//! Writes `OUT_DIR/atlas.csv` (one row per setting, with its scene's
//! reference noise), `OUT_DIR/atlas.png`
//! (time against RMSE, one curve per knob), and per setting an error map
//! `OUT_DIR/error_<knob>_<setting>.png` (|raster − reference| luminance,
//! ×8, white = 1/8 or more), and each scene's reference picture
//! `OUT_DIR/reference_<scene>.png`. docs/accuracy.md explains how to read
//! them.
//!
//! Knobs: sun-shadow resolution, cascade count, PCF radius, texture path,
//! render origin (the scene 30 000 units from the world origin), reflection
//! probe resolution and update interval (a mirror ball with a box moving
//! past it; the reference is the last frame), the probe's parallax box
//! (none, or the room around a mirror ball), light culling (every light, or
//! clustered: a street of 1 000 lamps; it must cost no accuracy), the sun
//! shadow filter (PCF or PCSS, a pole under a sun of 5° and of 0.5°),
//! ambient occlusion (off, each quality level, the default radius, the
//! temporal step: a corner and a crevice under the ambient light alone),
//! contact shadows (off, three lengths, more steps, the default thickness:
//! a pole 4 cm across under a sun, one coarse cascade), the spot shadow
//! filter (PCF or PCSS, a pole under a spot of 0.5 m and of 0.1 m radius),
//! screen-space reflections (off, 16 to 128 steps, a thinner surface: a
//! polished metal floor of roughness 0.05 and 0.25 with objects on it,
//! under a sun and its sky),
//! the LOD bias (spheres with two
//! coarser levels; the reference traces the full meshes), visibility (CPU,
//! GPU frustum, GPU occlusion: each must cost no accuracy), and the render
//! origin once more on the numerical extremes (a million units out, near
//! plane 1e-4, objects of 1e-3 and 1e4, a grazing sun).
//!
//! With `OXYGEN_RECORD_DIR` set, the atlas's rows (the CSV's figures at
//! full precision, and whether each time came from GPU timestamps) and the
//! references' times are also appended as one record to
//! `$OXYGEN_RECORD_DIR/accuracy_atlas.jsonl` (`oxygen_demo::record`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use oxygen::RenderOrigin;
use oxygen::bindless::TexturePath;
use oxygen::core::LodLevel;
use oxygen::core::NodeKey;
use oxygen::glam::{Quat, Vec4};
use oxygen::graph::{ReferenceGraph, lit_render_graph};
use oxygen::lighting::{
    AmbientOcclusion, AoQuality, CascadeSettings, ClusterGrid, ContactShadows, Environment, LightCulling, ProbeUpdate,
    ReflectionProbe, ScreenSpaceReflections,
};
use oxygen::passes::{ReferenceSettings, ShadowFilter};
use oxygen::prelude::*;
use oxygen::sceneprep::{ViewPrepOptions, Visibility};
use oxygen_demo::record::{Record, Row as RecordRow};
use plotters::prelude::*;

const WARM_UP: usize = 3;
const MEASURED: usize = 10;

/// One scene with its camera.
struct Stage {
    name: &'static str,
    scene: Scene,
    camera: LookAtResolver,
    /// Sun cascades of its raster view by default.
    cascades: CascadeSettings,
    /// A node the stage moves every frame (its position is a function of
    /// the frame's number, so every run of the stage sees the same frames).
    moving: Option<NodeKey>,
    /// How its reference is traced.
    reference: ReferenceSettings,
    /// The renderer's environment (its raster views' and reference's).
    environment: Option<Environment>,
}

/// Frames each raster run renders: warm-up, two frames for the GPU times to
/// arrive, the measured ones. The reference shows the last.
const FRAMES: usize = WARM_UP + 2 + MEASURED;

/// Where a stage's moving node is on frame `frame`.
fn move_to_frame(scene: &mut Scene, node: NodeKey, frame: usize) {
    let at = Vec3::new(2.2, 0.0, -1.2 + 0.1 * frame as f32);
    // The node was made by this program; it cannot be missing.
    let _ = scene.set_local_transform(node, Transform::from_translation(at));
}

/// One raster configuration.
struct Setting {
    knob: &'static str,
    value: String,
    stage: usize,
    options: RendererOptions,
    cascades: Option<CascadeSettings>,
    pcf_radius: u32,
    visibility: Option<Visibility>,
    /// A reflection probe at the origin: face resolution and update policy.
    probe: Option<(u32, ProbeUpdate)>,
    /// The probe's parallax box (`ReflectionProbe::set_parallax_box`).
    parallax: Option<oxygen::core::Aabb>,
    /// ScenePrep's LOD bias (`ViewPrepOptions::lod_bias`).
    lod_bias: f32,
    /// How shading finds a pixel's positional lights.
    light_culling: LightCulling,
    /// How the sun's shadow is filtered.
    shadow_filter: ShadowFilter,
    /// Screen-space ambient occlusion.
    ambient_occlusion: Option<AmbientOcclusion>,
    /// Contact shadows.
    contact_shadows: Option<ContactShadows>,
    /// Screen-space reflections.
    screen_space_reflections: Option<ScreenSpaceReflections>,
}

struct Row {
    knob: &'static str,
    value: String,
    stage: &'static str,
    ms: f64,
    rmse: f64,
    ssim: f64,
    /// The scene's reference noise (RMSE; 0 read from an older CSV).
    noise: f64,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1).peekable();
    // `--chart atlas.csv out.png`: redraw a chart from a run's CSV (for
    // runs on machines without the font).
    if args.peek().map(String::as_str) == Some("--chart") {
        let (csv, png) = (args.nth(1).ok_or("--chart CSV PNG")?, args.next().ok_or("--chart CSV PNG")?);
        return chart(&read_csv(&std::fs::read_to_string(csv)?)?, Path::new(&png));
    }
    let out = PathBuf::from(args.next().unwrap_or_else(|| "docs/accuracy".into()));
    let size: u32 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(160);
    let samples: u32 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(512);
    std::fs::create_dir_all(&out)?;
    let viewport = UVec2::new(size, size * 9 / 16);
    let mut stages = stages(viewport)?;
    // ATLAS_KNOBS="probe parallax,PCF radius" runs those knobs only (and
    // traces only their scenes' references); the record names them.
    let knobs: Option<Vec<String>> =
        std::env::var("ATLAS_KNOBS").ok().map(|v| v.split(',').map(|k| k.trim().to_string()).collect());
    let settings: Vec<Setting> = settings()
        .into_iter()
        .filter(|s| knobs.as_ref().is_none_or(|knobs| knobs.iter().any(|k| k == s.knob)))
        .collect();
    if settings.is_empty() {
        return Err(format!("ATLAS_KNOBS={knobs:?} names no knob of the atlas").into());
    }

    let mut record = Record::new("accuracy_atlas")
        .value("viewport_px", [viewport.x, viewport.y])
        .value("reference_samples_per_pixel", samples)
        .value("warm_up_frames", WARM_UP)
        .value("measured_frames", MEASURED)
        .value("rmse_clamp", oxygen_demo::RADIANCE_RMSE_CLAMP);
    if let Some(knobs) = &knobs {
        record = record.value("knobs_only", knobs.clone());
    }

    // The references, one per stage, each traced with two seeds: the
    // first is the reference, the pair measures its noise.
    let mut references = Vec::new();
    for (i, stage) in stages.iter_mut().enumerate() {
        if !settings.iter().any(|s| s.stage == i) {
            references.push(None);
            continue;
        }
        if let Some(node) = stage.moving {
            move_to_frame(&mut stage.scene, node, FRAMES - 1);
        }
        let started = Instant::now();
        let (hdr, srgb, adapter) = reference(stage, samples, ReferenceSettings::DEFAULT_SEED)?;
        srgb.save(out.join(format!("reference_{}.png", file_name(stage.name))))?;
        let seconds = started.elapsed().as_secs_f64();
        let (other, _, _) = reference(stage, samples, ReferenceSettings::DEFAULT_SEED.wrapping_add(1))?;
        let noise = oxygen_demo::radiance_rmse(&hdr, &other) / std::f64::consts::SQRT_2;
        eprintln!(
            "[atlas] reference of {}: {samples} samples per pixel in {seconds:.1} s on {}, noise RMSE {noise:.5}",
            stage.name, adapter.name
        );
        record.set_adapter(&adapter);
        record.push_row_to(
            "reference_rows",
            RecordRow::new().value("scene", stage.name).value("trace_seconds", seconds).value("noise_rmse", noise),
        );
        references.push(Some((hdr, srgb, noise)));
    }

    let mut rows = Vec::new();
    for (i, setting) in settings.iter().enumerate() {
        let stage = &mut stages[setting.stage];
        let (hdr, srgb, ms, timed_on_gpu) = raster(stage, setting)?;
        let (reference_hdr, reference_srgb, noise) =
            references[setting.stage].as_ref().ok_or("a setting's scene has no reference")?;
        let rmse = oxygen_demo::radiance_rmse(&hdr, reference_hdr);
        let ssim = ssim(&srgb, reference_srgb);
        let name = format!("{}_{}", file_name(setting.knob), file_name(&setting.value));
        error_map(&hdr, reference_hdr, srgb.dimensions()).save(out.join(format!("error_{name}.png")))?;
        // ATLAS_RASTER_IMAGES=1 keeps each raster picture too (for looking
        // at a curve's points; not in the docs).
        if std::env::var_os("ATLAS_RASTER_IMAGES").is_some() {
            srgb.save(out.join(format!("raster_{name}.png")))?;
        }
        eprintln!(
            "[atlas] {}/{} {} = {}: {ms:.2} ms, RMSE {rmse:.5} (reference noise {noise:.5}), SSIM {ssim:.4}",
            i + 1,
            settings.len(),
            setting.knob,
            setting.value
        );
        let stage_name = stages[setting.stage].name;
        record.push_row(
            RecordRow::new()
                .value("knob", setting.knob)
                .value("setting", &setting.value)
                .value("scene", stage_name)
                .value("frame_ms", ms)
                .value("frame_ms_from", if timed_on_gpu { "gpu timestamps" } else { "wall clock, waited" })
                .value("rmse_linear", rmse)
                .value("reference_noise_rmse", *noise)
                .value("ssim", ssim),
        );
        rows.push(Row {
            knob: setting.knob,
            value: setting.value.clone(),
            stage: stage_name,
            ms,
            rmse,
            ssim,
            noise: *noise,
        });
    }

    let mut csv = String::from("knob,setting,scene,frame_ms,rmse_linear,ssim,reference_noise_rmse\n");
    for r in &rows {
        // Names never hold the separator.
        let cell = |s: &str| s.replace(',', ";");
        csv.push_str(&format!(
            "{},{},{},{:.4},{:.6},{:.5},{:.6}\n",
            cell(r.knob),
            cell(&r.value),
            cell(r.stage),
            r.ms,
            r.rmse,
            r.ssim,
            r.noise
        ));
    }
    std::fs::write(out.join("atlas.csv"), csv)?;
    chart(&rows, &out.join("atlas.png"))?;
    eprintln!("[atlas] wrote {}", out.display());
    record.write()?;
    Ok(())
}

/// A name as a file name: letters, digits and underscores.
fn file_name(name: &str) -> String {
    name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '.' { c } else { '_' }).collect()
}

/// Rows back from `atlas.csv`.
fn read_csv(text: &str) -> Result<Vec<Row>, Box<dyn std::error::Error>> {
    let mut rows = Vec::new();
    for line in text.lines().skip(1).filter(|l| !l.trim().is_empty()) {
        let mut cells: Vec<&str> = line.split(',').collect();
        // Older CSVs have no noise column.
        let noise = if cells.len() == 7 { cells.pop().unwrap_or("0") } else { "0" };
        let [knob, value, stage, ms, rmse, ssim] = cells[..] else {
            return Err(format!("not a row of the atlas: {line}").into());
        };
        // Knob and scene names live as long as the program.
        let leak = |s: &str| -> &'static str { Box::leak(s.to_owned().into_boxed_str()) };
        rows.push(Row {
            knob: leak(knob),
            value: value.to_owned(),
            stage: leak(stage),
            ms: ms.parse()?,
            rmse: rmse.parse()?,
            ssim: ssim.parse()?,
            noise: noise.parse()?,
        });
    }
    Ok(rows)
}

fn stages(viewport: UVec2) -> Result<Vec<Stage>, Box<dyn std::error::Error>> {
    // A box on a floor under a low sun: long shadows, the shadow knobs'
    // scene.
    let shadows = Stage {
        name: "box on a floor",
        scene: oxygen_demo::floor_with_box(0.6),
        camera: LookAtResolver::new(
            Camera::perspective(60f32.to_radians(), 0.1, None),
            Vec3::new(0.0, 3.0, 5.0),
            Vec3::new(0.0, 0.0, -1.0),
            viewport,
        )
        .unwrap(),
        cascades: CascadeSettings { count: 1, resolution: 1024, ..Default::default() },
        moving: None,
        environment: None,
        reference: ReferenceSettings::RASTER_MODEL,
    };
    // The shipped textured box, at the origin and 30 000 units out.
    let textured = |offset: Vec3, name| -> Result<Stage, Box<dyn std::error::Error>> {
        let mut scene = Scene::new();
        let root = scene.add_node("offset", Transform::from_translation(offset));
        // The repository's copy; relative to the working directory when
        // the binary runs elsewhere than it was built.
        let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/BoxTextured/BoxTextured.glb");
        let path = if shipped.exists() { shipped } else { PathBuf::from("assets/BoxTextured/BoxTextured.glb") };
        let import = import_gltf(&mut scene, &path, &SceneChoice::Default)?;
        for node in import.roots {
            scene.set_parent(node, Some(root))?;
        }
        oxygen_demo::add_default_sun(&mut scene);
        let floor = scene.add_geometry(Geometry::plane(6.0));
        let grey = scene.add_material(Material::opaque("floor", Vec4::splat(0.5)));
        let node = scene.add_node("floor", Transform::from_translation(offset + Vec3::new(0.0, -0.5, 0.0)));
        scene.set_renderable(node, Renderable { geometry: floor, materials: vec![grey] })?;
        Ok(Stage {
            name,
            scene,
            camera: LookAtResolver::new(
                Camera::perspective(50f32.to_radians(), 0.05, None),
                offset + Vec3::new(1.6, 1.2, 2.0),
                offset,
                viewport,
            )
            .unwrap(),
            cascades: CascadeSettings { count: 1, resolution: 2048, ..Default::default() },
            moving: None,
            environment: None,
            reference: ReferenceSettings::RASTER_MODEL,
        })
    };
    // A mirror ball at the origin (where the probe sits) and a red box
    // moving past it: the probe knobs' scene.
    let mirror = {
        let mut scene = Scene::new();
        let chrome =
            scene.add_material(Material { metallic: 1.0, roughness: 0.05, ..Material::opaque("mirror", Vec4::ONE) });
        let sphere = scene.add_geometry(Geometry::uv_sphere(1.0, 64, 32));
        let ball = scene.add_node("mirror ball", Transform::IDENTITY);
        scene.set_renderable(ball, Renderable { geometry: sphere, materials: vec![chrome] })?;
        let red = scene.add_material(Material::opaque("red box", Vec4::new(0.9, 0.05, 0.05, 1.0)));
        let cube = scene.add_geometry(Geometry::cube(1.5));
        let box_node = scene.add_node("red box", Transform::IDENTITY);
        scene.set_renderable(box_node, Renderable { geometry: cube, materials: vec![red] })?;
        oxygen_demo::add_default_sun(&mut scene);
        Stage {
            name: "mirror ball and moving box",
            scene,
            camera: LookAtResolver::new(
                Camera::perspective(40f32.to_radians(), 0.1, None),
                Vec3::new(0.0, 0.5, 4.5),
                Vec3::ZERO,
                viewport,
            )
            .unwrap(),
            cascades: CascadeSettings { count: 1, resolution: 1024, ..Default::default() },
            moving: Some(box_node),
            environment: None,
            // The raster model with exact reflections: what a perfect
            // probe would show.
            reference: ReferenceSettings::RASTER_MODEL_WITH_REFLECTIONS,
        }
    };
    // Spheres from near to far, each with two coarser LODs: the LOD knob's
    // scene (the reference traces the full mesh everywhere).
    let lods = {
        let mut scene = Scene::new();
        let fine = scene.add_geometry(Geometry::uv_sphere(0.5, 64, 32));
        let medium = scene.add_geometry(Geometry::uv_sphere(0.5, 16, 8));
        let coarse = scene.add_geometry(Geometry::uv_sphere(0.5, 6, 3));
        let grey =
            scene.add_material(Material { roughness: 0.4, ..Material::opaque("ball", Vec4::new(0.7, 0.6, 0.5, 1.0)) });
        for i in 0..24 {
            let at = Vec3::new(((i % 6) as f32 - 2.5) * 1.3, 0.0, -(i / 6) as f32 * 2.5 - 1.0 - (i % 2) as f32);
            let node = scene.add_node(format!("ball {i}"), Transform::from_translation(at));
            scene.set_renderable(node, Renderable { geometry: fine, materials: vec![grey] })?;
            scene.set_lods(
                node,
                vec![
                    LodLevel { geometry: medium, below_screen_fraction: 0.25 },
                    LodLevel { geometry: coarse, below_screen_fraction: 0.08 },
                ],
            )?;
        }
        oxygen_demo::add_default_sun(&mut scene);
        Stage {
            name: "spheres with LODs",
            scene,
            camera: LookAtResolver::new(
                Camera::perspective(55f32.to_radians(), 0.1, None),
                Vec3::new(0.0, 1.5, 3.0),
                Vec3::new(0.0, 0.0, -5.0),
                viewport,
            )
            .unwrap(),
            cascades: CascadeSettings { count: 2, resolution: 1024, ..Default::default() },
            moving: None,
            environment: None,
            reference: ReferenceSettings::RASTER_MODEL,
        }
    };
    // The numerical extremes in one view, a million units out: a near
    // plane of 1e-4, a cube of 1e-3 a centimetre from the eye, a 1e4 ground
    // slab and a 10-unit box under a grazing sun (3° above the horizon).
    let extremes = {
        let far = Vec3::new(1.0e6, 0.0, -1.0e6);
        let mut scene = Scene::new();
        let root = scene.add_node("far away", Transform::from_translation(far));
        let white = scene.add_material(Material::opaque("white", Vec4::splat(0.8)));
        let orange = scene.add_material(Material::opaque("orange", Vec4::new(0.9, 0.4, 0.1, 1.0)));
        let ground = scene.add_geometry(Geometry::cube(1.0e4));
        let node = scene.add_child(root, "ground", Transform::from_translation(Vec3::new(0.0, -5.0e3, 0.0)))?;
        scene.set_renderable(node, Renderable { geometry: ground, materials: vec![white] })?;
        let big = scene.add_geometry(Geometry::cube(10.0));
        let node = scene.add_child(root, "box", Transform::from_translation(Vec3::new(0.0, 5.0, -40.0)))?;
        scene.set_renderable(node, Renderable { geometry: big, materials: vec![orange] })?;
        let tiny = scene.add_geometry(Geometry::cube(1.0e-3));
        let node = scene.add_child(root, "speck", Transform::from_translation(Vec3::new(0.0, 2.0, -0.01)))?;
        // White, in front of the orange box.
        scene.set_renderable(node, Renderable { geometry: tiny, materials: vec![white] })?;
        let grazing = Vec3::new(-0.6, -(3f32.to_radians().sin()), -0.8).normalize();
        let sun = scene
            .add_node("grazing sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, grazing)));
        scene.set_light(sun, Some(Light::directional(3.0)))?;
        Stage {
            name: "extremes 1e6 out",
            scene,
            camera: LookAtResolver::new(
                Camera::perspective(60f32.to_radians(), 1.0e-4, None),
                far + Vec3::new(0.0, 2.0, 0.0),
                far + Vec3::new(0.0, 2.0, -1.0),
                viewport,
            )
            .unwrap(),
            cascades: CascadeSettings { count: 4, resolution: 2048, ..Default::default() },
            moving: None,
            environment: None,
            reference: ReferenceSettings::RASTER_MODEL,
        }
    };
    // The mirror ball inside a closed room of six unlit walls, each its own
    // colour, two to three units from its surface: the probe parallax
    // knob's scene (a probe without a box takes the walls as infinitely
    // far and misplaces the seams between them in the reflection).
    let room = {
        let mut scene = Scene::new();
        let chrome =
            scene.add_material(Material { metallic: 1.0, roughness: 0.05, ..Material::opaque("mirror", Vec4::ONE) });
        let sphere = scene.add_geometry(Geometry::uv_sphere(1.0, 64, 32));
        let ball = scene.add_node("mirror ball", Transform::IDENTITY);
        scene.set_renderable(ball, Renderable { geometry: sphere, materials: vec![chrome] })?;
        oxygen_demo::add_room_walls(&mut scene, ROOM.max.x);
        Stage {
            name: "mirror ball in a room",
            scene,
            camera: LookAtResolver::new(
                Camera::perspective(50f32.to_radians(), 0.1, None),
                Vec3::new(0.0, 0.6, 2.6),
                Vec3::ZERO,
                viewport,
            )
            .unwrap(),
            cascades: CascadeSettings { count: 1, resolution: 1024, ..Default::default() },
            moving: None,
            environment: None,
            reference: ReferenceSettings::RASTER_MODEL_WITH_REFLECTIONS,
        }
    };
    // A street of 1 000 lamps of 7 m range: the light culling knob's scene
    // (clustered culling must cost no accuracy).
    let street = Stage {
        name: "a street of 1 000 lamps",
        scene: oxygen_demo::lamp_street(1000),
        camera: oxygen_demo::lamp_street_camera(viewport),
        cascades: CascadeSettings { count: 1, resolution: 1024, ..Default::default() },
        moving: None,
        environment: None,
        reference: ReferenceSettings::RASTER_MODEL,
    };
    // A pole under a sun of 5° and of 0.5° (its angular radius): the sun
    // shadow filter's scenes (the reference traces the disc).
    let pole = |degrees: f32, name: &'static str| Stage {
        name,
        scene: oxygen_demo::pole_under_sun(degrees),
        camera: oxygen_demo::pole_camera(viewport),
        cascades: CascadeSettings { count: 1, resolution: 1024, max_distance: 20.0, ..Default::default() },
        moving: None,
        environment: None,
        reference: ReferenceSettings::RASTER_MODEL,
    };
    let glossy = |roughness: f32, name: &'static str| Stage {
        name,
        scene: oxygen_demo::glossy_floor_with_objects(roughness),
        camera: oxygen_demo::glossy_floor_camera(viewport),
        cascades: CascadeSettings::default(),
        moving: None,
        environment: Some(Environment::sky_for_sun(oxygen_demo::GLOSSY_FLOOR_SUN)),
        reference: ReferenceSettings::RASTER_MODEL_WITH_REFLECTIONS,
    };
    Ok(vec![
        shadows,
        textured(Vec3::ZERO, "textured box")?,
        textured(Vec3::new(30_000.0, 0.0, 0.0), "textured box 3e4 out")?,
        mirror,
        lods,
        extremes,
        room,
        street,
        pole(5.0, "a pole under a sun of 5°"),
        pole(0.5, "a pole under a sun of 0.5°"),
        // A corner and a crevice under the ambient light alone: ambient
        // occlusion's scene. The reference traces one bounce into a sky of
        // the raster's ambient level, so a point gets the sky it sees.
        Stage {
            name: "a corner and a crevice",
            scene: oxygen_demo::corner_and_crevice(),
            camera: oxygen_demo::corner_camera(viewport),
            cascades: CascadeSettings::default(),
            moving: None,
            environment: None,
            reference: ReferenceSettings { max_bounces: 1, environment: [0.03; 3], ..ReferenceSettings::DEFAULT },
        },
        // A pole 4 cm across under a sun, one coarse cascade (4 cm texels):
        // contact shadows' scene.
        Stage {
            name: "a thin pole under a sun",
            scene: oxygen_demo::thin_pole_under_sun(),
            camera: oxygen_demo::thin_pole_camera(viewport),
            cascades: CascadeSettings { count: 1, resolution: 256, max_distance: 10.0, ..Default::default() },
            moving: None,
            environment: None,
            reference: ReferenceSettings::RASTER_MODEL,
        },
        // A pole under a spot light of 0.5 m and of 0.1 m radius: the spot
        // shadow filter's scenes (the reference traces the light's disc).
        Stage {
            name: "a pole under a spot of 0.5 m",
            scene: oxygen_demo::pole_under_spot(0.5),
            camera: oxygen_demo::pole_spot_camera(viewport),
            cascades: CascadeSettings::default(),
            moving: None,
            environment: None,
            reference: ReferenceSettings::RASTER_MODEL,
        },
        Stage {
            name: "a pole under a spot of 0.1 m",
            scene: oxygen_demo::pole_under_spot(0.1),
            camera: oxygen_demo::pole_spot_camera(viewport),
            cascades: CascadeSettings::default(),
            moving: None,
            environment: None,
            reference: ReferenceSettings::RASTER_MODEL,
        },
        // A polished metal floor with objects on it, under a sun and its
        // sky, mirror-like and glossy: screen-space reflections' scenes.
        // The reference is the raster model with perfect reflections.
        glossy(0.05, "a polished floor of roughness 0.05"),
        glossy(0.25, "a polished floor of roughness 0.25"),
    ])
}

/// The room around the parallax knob's mirror ball.
const ROOM: oxygen::core::Aabb = oxygen::core::Aabb { min: Vec3::splat(-3.0), max: Vec3::splat(3.0) };

fn settings() -> Vec<Setting> {
    let base = |knob, value: String, stage| Setting {
        knob,
        value,
        stage,
        options: RendererOptions { keep_hdr: true, ..Default::default() },
        cascades: None,
        pcf_radius: 1,
        visibility: Some(Visibility::Cpu),
        probe: None,
        parallax: None,
        lod_bias: 1.0,
        light_culling: LightCulling::EveryLight,
        shadow_filter: ShadowFilter::Pcf,
        ambient_occlusion: None,
        contact_shadows: None,
        screen_space_reflections: None,
    };
    let mut all = Vec::new();
    for resolution in [256, 512, 1024, 2048, 4096] {
        let mut s = base("shadow resolution", resolution.to_string(), 0);
        s.cascades = Some(CascadeSettings { count: 1, resolution, ..Default::default() });
        all.push(s);
    }
    for count in 1..=4 {
        let mut s = base("cascade count", count.to_string(), 0);
        s.cascades = Some(CascadeSettings { count, resolution: 1024, ..Default::default() });
        all.push(s);
    }
    for radius in 0..=3 {
        let mut s = base("PCF radius", radius.to_string(), 0);
        s.pcf_radius = radius;
        all.push(s);
    }
    for (name, path) in [("binding array", TexturePath::BindingArray), ("grouped arrays", TexturePath::GroupedArrays)] {
        let mut s = base("texture path", name.to_string(), 1);
        s.options.texture_path = Some(path);
        all.push(s);
    }
    for (name, origin) in
        [("absolute", RenderOrigin::Absolute), ("follow the camera", RenderOrigin::FollowFirstView { grid: 64.0 })]
    {
        let mut s = base("render origin", name.to_string(), 2);
        s.options.origin = origin;
        all.push(s);
    }
    for resolution in [16, 32, 64, 128, 256] {
        let mut s = base("probe resolution", resolution.to_string(), 3);
        s.probe = Some((resolution, ProbeUpdate::EveryFrame));
        all.push(s);
    }
    for interval in [1, 4, 8, 16] {
        let mut s = base("probe update interval", format!("{interval} frames"), 3);
        s.probe = Some((128, ProbeUpdate::EveryNthFrame(interval)));
        all.push(s);
    }
    for (name, parallax) in [("none", None), ("the room", Some(ROOM))] {
        let mut s = base("probe parallax", name.to_string(), 6);
        s.probe = Some((128, ProbeUpdate::EveryFrame));
        s.parallax = parallax;
        all.push(s);
    }
    for (name, culling) in
        [("every light", LightCulling::EveryLight), ("clustered", LightCulling::Clustered(ClusterGrid::DEFAULT))]
    {
        let mut s = base("light culling", name.to_string(), 7);
        s.light_culling = culling;
        all.push(s);
    }
    for (stage, sun) in [(8, "5°"), (9, "0.5°")] {
        let pcss = |taps: u32| ShadowFilter::Pcss { search_taps: taps, filter_taps: taps, max_penumbra_texels: 16.0 };
        for (name, filter) in [
            ("PCF", ShadowFilter::Pcf),
            ("PCSS 4×4", pcss(4)),
            ("PCSS 6×6", pcss(6)),
            ("PCSS 8×8 (the default)", ShadowFilter::PCSS),
        ] {
            let mut s = base("sun shadow filter", format!("{name}, sun {sun}"), stage);
            s.shadow_filter = filter;
            all.push(s);
        }
    }
    // Ambient occlusion: off, each quality level at the room's size (4 m),
    // the default radius (1 m), and the temporal step.
    let occlusion = |quality, radius, temporal| Some(AmbientOcclusion { quality, radius, temporal });
    for (name, settings) in [
        ("none", None),
        ("Low, 4 m", occlusion(AoQuality::Low, 4.0, false)),
        ("Medium, 4 m", occlusion(AoQuality::Medium, 4.0, false)),
        ("High, 4 m", occlusion(AoQuality::High, 4.0, false)),
        ("Ultra, 4 m", occlusion(AoQuality::Ultra, 4.0, false)),
        ("Medium, 1 m (the default)", occlusion(AoQuality::Medium, 1.0, false)),
        ("Medium, 4 m, temporal", occlusion(AoQuality::Medium, 4.0, true)),
    ] {
        let mut s = base("ambient occlusion", name.to_string(), 10);
        s.ambient_occlusion = settings;
        all.push(s);
    }
    // Contact shadows: off, three lengths as thick as the pole, more
    // steps, and the default thickness.
    let contact = |length, thickness, steps| Some(ContactShadows { length, thickness, steps });
    for (name, settings) in [
        ("none", None),
        ("0.5 m", contact(0.5, 0.04, 16)),
        ("1 m", contact(1.0, 0.04, 16)),
        ("2 m", contact(2.0, 0.04, 16)),
        ("1 m, 32 steps", contact(1.0, 0.04, 32)),
        ("1 m, 5 cm thick (the default)", contact(1.0, 0.05, 16)),
    ] {
        let mut s = base("contact shadows", name.to_string(), 11);
        s.contact_shadows = settings;
        all.push(s);
    }
    // Spot shadows: PCF (3 × 3 taps) and PCSS under spots with a radius,
    // one local shadow map of 1024².
    for (stage, radius) in [(12, "0.5 m"), (13, "0.1 m")] {
        let pcss = |taps: u32| ShadowFilter::Pcss { search_taps: taps, filter_taps: taps, max_penumbra_texels: 16.0 };
        for (name, filter) in
            [("PCF", ShadowFilter::Pcf), ("PCSS 4×4", pcss(4)), ("PCSS 8×8 (the default)", ShadowFilter::PCSS)]
        {
            let mut s = base("spot shadow filter", format!("{name}, spot {radius}"), stage);
            s.options.local_shadows =
                Some(oxygen::lighting::LocalShadowSettings { resolution: 1024, ..Default::default() });
            s.shadow_filter = filter;
            all.push(s);
        }
    }
    // Screen-space reflections: off, three march lengths, a thinner
    // surface, on a mirror-like and a glossy floor.
    for (stage, floor) in [(14, "floor 0.05"), (15, "floor 0.25")] {
        let reflections = |steps, thickness| Some(ScreenSpaceReflections { steps, thickness, ..Default::default() });
        for (name, settings) in [
            ("none", None),
            ("16 steps", reflections(16, 0.3)),
            ("48 steps (the default)", reflections(48, 0.3)),
            ("128 steps", reflections(128, 0.3)),
            ("48 steps, 0.1 m thick", reflections(48, 0.1)),
        ] {
            let mut s = base("screen-space reflections", format!("{name}, {floor}"), stage);
            s.screen_space_reflections = settings;
            all.push(s);
        }
    }
    for bias in [0.25f32, 0.5, 1.0, 2.0, 4.0] {
        let mut s = base("LOD bias", bias.to_string(), 4);
        s.lod_bias = bias;
        all.push(s);
    }
    for (name, origin) in
        [("absolute", RenderOrigin::Absolute), ("follow the camera", RenderOrigin::FollowFirstView { grid: 64.0 })]
    {
        let mut s = base("render origin, extremes", name.to_string(), 5);
        s.options.origin = origin;
        all.push(s);
    }
    for (name, visibility) in
        [("CPU", Visibility::Cpu), ("GPU frustum", Visibility::GpuFrustum), ("GPU occlusion", Visibility::GpuOcclusion)]
    {
        let mut s = base("visibility", name.to_string(), 1);
        s.visibility = Some(visibility);
        all.push(s);
    }
    all
}

/// The stage's reference traced with `seed`: HDR and tone-mapped images,
/// and the adapter.
fn reference(
    stage: &Stage,
    samples: u32,
    seed: u32,
) -> Result<(HdrPixels, image::RgbaImage, wgpu::AdapterInfo), Box<dyn std::error::Error>> {
    let mut renderer = Renderer::new_headless_with(RendererOptions {
        keep_hdr: true,
        // Camera-relative: the reference must not inherit the precision
        // loss the render-origin knob measures.
        origin: RenderOrigin::FollowFirstView { grid: 1.0 },
        ..Default::default()
    })?;
    renderer.set_environment(stage.environment.as_ref());
    let settings = ReferenceSettings { samples_per_frame: 16, max_samples: samples, seed, ..stage.reference };
    let view = renderer
        .register_view(ViewDesc::new(stage.camera).path_traced(), ReferenceGraph { settings, exposure: 1.0 })?;
    while renderer.reference_samples(view) < samples {
        renderer.render_frame(&stage.scene)?;
        renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
    }
    let hdr = renderer.read_hdr(view)?;
    let adapter = renderer.gpu().adapter_info.clone();
    Ok((hdr.pixels, renderer.read_color(view)?, adapter))
}

type HdrPixels = Vec<[f32; 4]>;

/// The raster view of `setting`: HDR and tone-mapped images, its GPU
/// milliseconds per frame (the median; the mean for the probe's update
/// interval, whose cost comes every Nth frame), and whether they came from
/// GPU timestamps (else from the wall clock).
fn raster(
    stage: &mut Stage,
    setting: &Setting,
) -> Result<(HdrPixels, image::RgbaImage, f64, bool), Box<dyn std::error::Error>> {
    let mut renderer = Renderer::new_headless_with(setting.options)?;
    renderer.set_environment(stage.environment.as_ref());
    let mut probe = match setting.probe {
        Some((resolution, update)) => {
            Some(ReflectionProbe::register(&mut renderer, Vec3::ZERO, resolution, (0.05, 50.0), update)?)
        }
        None => None,
    };
    let options = ViewPrepOptions { lod_bias: setting.lod_bias, ..Default::default() };
    let mut desc =
        ViewDesc::new(stage.camera).with_options(options).with_sun_shadows(setting.cascades.unwrap_or(stage.cascades));
    if let Some(visibility) = setting.visibility {
        desc = desc.with_visibility(visibility);
    }
    if let Some(probe) = &probe {
        probe.set_parallax_box(&mut renderer, setting.parallax)?;
        desc = desc.reads(probe.cube());
    }
    let config = ForwardLitConfig {
        shadow_pcf_radius: setting.pcf_radius,
        light_culling: setting.light_culling,
        shadow_filter: setting.shadow_filter,
        ambient_occlusion: setting.ambient_occlusion,
        contact_shadows: setting.contact_shadows,
        screen_space_reflections: setting.screen_space_reflections,
        ..ForwardLitConfig::default()
    };
    let view = renderer.register_view(desc, lit_render_graph(config))?;
    // GPU time between the frame's timestamps where the adapter writes
    // them (a report carries an earlier frame's), else the wall clock of
    // the frame waited for.
    let (mut gpu_times, mut wall_times) = (Vec::new(), Vec::new());
    for frame in 0..FRAMES {
        if let Some(node) = stage.moving {
            move_to_frame(&mut stage.scene, node, frame);
        }
        if let Some(probe) = probe.as_mut() {
            probe.before_frame(&mut renderer)?;
        }
        let started = Instant::now();
        let report = renderer.render_frame(&stage.scene)?;
        renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
        if frame == 0 && !report.warnings.is_empty() {
            eprintln!("[atlas] {}: {:?}", stage.name, report.warnings);
        }
        if frame >= WARM_UP + 2 {
            wall_times.push(started.elapsed().as_secs_f64() * 1e3);
            gpu_times.extend(report.gpu_seconds.map(|s| s * 1e3));
        }
    }
    let timed_on_gpu = gpu_times.len() == wall_times.len();
    let mut times = if timed_on_gpu { gpu_times } else { wall_times };
    let ms = if setting.knob == "probe update interval" {
        times.iter().sum::<f64>() / times.len().max(1) as f64
    } else {
        times.sort_by(f64::total_cmp);
        times[times.len() / 2]
    };
    let hdr = renderer.read_hdr(view)?;
    Ok((hdr.pixels, renderer.read_color(view)?, ms, timed_on_gpu))
}

fn luma(p: &image::Rgba<u8>) -> f64 {
    (0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])) / 255.0
}

/// Mean SSIM of the luma over 8 × 8 windows at a stride of 4.
fn ssim(a: &image::RgbaImage, b: &image::RgbaImage) -> f64 {
    const C1: f64 = 0.01 * 0.01;
    const C2: f64 = 0.03 * 0.03;
    let (w, h) = a.dimensions();
    let (mut total, mut windows) = (0.0, 0usize);
    for y in (0..h.saturating_sub(7)).step_by(4) {
        for x in (0..w.saturating_sub(7)).step_by(4) {
            let (mut sa, mut sb, mut saa, mut sbb, mut sab) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for dy in 0..8 {
                for dx in 0..8 {
                    let (p, q) = (luma(a.get_pixel(x + dx, y + dy)), luma(b.get_pixel(x + dx, y + dy)));
                    sa += p;
                    sb += q;
                    saa += p * p;
                    sbb += q * q;
                    sab += p * q;
                }
            }
            let n = 64.0;
            let (ma, mb) = (sa / n, sb / n);
            let (va, vb, cov) = (saa / n - ma * ma, sbb / n - mb * mb, sab / n - ma * mb);
            total += ((2.0 * ma * mb + C1) * (2.0 * cov + C2)) / ((ma * ma + mb * mb + C1) * (va + vb + C2));
            windows += 1;
        }
    }
    if windows == 0 { 1.0 } else { total / windows as f64 }
}

/// |raster − reference| in luminance, ×8, as a grey image (white: 1/8 or more).
fn error_map(a: &[[f32; 4]], b: &[[f32; 4]], (width, height): (u32, u32)) -> image::GrayImage {
    image::GrayImage::from_fn(width, height, |x, y| {
        let i = (y * width + x) as usize;
        let l = |p: &[f32; 4]| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
        let d = a.get(i).zip(b.get(i)).map_or(0.0, |(p, q)| (l(p) - l(q)).abs());
        image::Luma([(d * 8.0 * 255.0).clamp(0.0, 255.0) as u8])
    })
}

/// Time against RMSE, one curve per knob, labelled by setting.
fn chart(rows: &[Row], path: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let font = ["/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", "/usr/share/fonts/TTF/DejaVuSans.ttf"]
        .iter()
        .find_map(|p| std::fs::read(p).ok());
    let Some(font) = font else {
        eprintln!("[atlas] no DejaVuSans.ttf found (apt-get install fonts-dejavu-core): the chart is skipped");
        return Ok(());
    };
    // plotters keeps registered fonts for the process.
    let font: &'static [u8] = Box::leak(font.into_boxed_slice());
    plotters::style::register_font("sans-serif", FontStyle::Normal, font).map_err(|_| "the font does not load")?;
    let (width, height) = (1200u32, 800u32);
    let mut pixels = vec![255u8; (width * height * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (width, height)).into_drawing_area();
        root.fill(&WHITE)?;
        // Both axes logarithmic: the times run from under a millisecond to
        // a light loop's hundreds, the errors over two decades.
        let positive = |v: f64| if v.is_finite() && v > 0.0 { Some(v) } else { None };
        let span = |values: &mut dyn Iterator<Item = f64>| {
            let (lo, hi) = values.filter_map(positive).fold((f64::MAX, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
            if hi > 0.0 { (lo / 1.3, hi * 1.3) } else { (1e-3, 1.0) }
        };
        let (ms_lo, ms_hi) = span(&mut rows.iter().map(|r| r.ms));
        let (rmse_lo, rmse_hi) = span(&mut rows.iter().map(|r| r.rmse));
        let mut chart = ChartBuilder::on(&root)
            .caption("Accuracy atlas: frame time against RMSE to the path-traced reference", ("sans-serif", 24))
            .margin(20)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d((ms_lo..ms_hi).log_scale(), (rmse_lo..rmse_hi).log_scale())?;
        chart.configure_mesh().x_desc("frame ms (GPU), log scale").y_desc("RMSE, linear radiance, log scale").draw()?;
        // One curve per knob and scene (a knob measured on two scenes draws
        // two curves, each named with its scene).
        let mut curves: Vec<(&str, &str)> = rows.iter().map(|r| (r.knob, r.stage)).collect();
        curves.dedup();
        for (k, (knob, stage)) in curves.iter().enumerate() {
            let color = Palette99::pick(k).to_rgba();
            let points: Vec<(f64, f64, String)> = rows
                .iter()
                .filter(|r| {
                    r.knob == *knob && r.stage == *stage && positive(r.ms).is_some() && positive(r.rmse).is_some()
                })
                .map(|r| (r.ms, r.rmse, r.value.clone()))
                .collect();
            let scenes = curves.iter().filter(|(other, _)| other == knob).count();
            let name = if scenes > 1 { format!("{knob} ({stage})") } else { knob.to_string() };
            chart
                .draw_series(LineSeries::new(points.iter().map(|p| (p.0, p.1)), color.stroke_width(2)))?
                .label(name)
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2)));
            chart.draw_series(points.iter().map(|p| {
                EmptyElement::at((p.0, p.1))
                    + Circle::new((0, 0), 4, color.filled())
                    + Text::new(p.2.clone(), (6, -14), ("sans-serif", 13))
            }))?;
        }
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
        root.present()?;
    }
    image::RgbImage::from_raw(width, height, pixels).ok_or("chart buffer")?.save(path)?;
    Ok(())
}
