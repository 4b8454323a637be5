//! A sensor rig, as a robotics or simulation user starts one: a ring of
//! cameras around a glTF scene, all of them one batch, every frame
//! streaming back each camera's colour, depth and segmentation, written to
//! files named after the camera and the frame, with a progress line.
//!
//! ```text
//! cargo run --release --example sensor_rig -- [FILE] [OUT_DIR] [--cameras N] [--size WxH] [--frames N] [--deferred]
//! ```
//!
//! FILE defaults to the shipped `assets/AlphaBlendModeTest/AlphaBlendModeTest.glb`,
//! OUT_DIR to `out/rig`, 8 cameras of 128 × 128, 4 frames. The ring turns
//! a little every frame (the cameras move without being registered again).
//! Per camera and frame it writes `NAME_fFFFF.color.png`,
//! `NAME_fFFFF.depth.png` (linear depth as 16-bit grey, millimetres up to
//! 65.5 m; 0 where nothing was drawn) and `NAME_fFFFF.segmentation.png`
//! (16-bit grey: the semantic class, here each glTF node's position in
//! the file's node order + 1, so every object has its own value). The
//! images arrive through the batch's stream (`Renderer::stream_batch`): one
//! copy of the atlas a frame of colour and of the label planes the GPU
//! wrote with it, linear depth and semantic classes
//! (`BatchDesc::with_label_planes`), tagged with the frame number. Where the adapter
//! runs GPU visibility the cameras cull on the GPU (the whole rig in one
//! dispatch), else on the CPU; the first line says which. `--deferred`
//! shades the rig in a compute pass after a visibility pass
//! (`BatchShading::Deferred`: faster where pixels have lighting to do;
//! refused, with the reason, on an adapter that cannot); each frame then
//! says how many cameras it shaded that way (a scene with blended
//! surfaces, as the default file has, is shaded forward). With
//! `OXYGEN_RECORD_DIR` set, the run's rate is appended to
//! `$OXYGEN_RECORD_DIR/sensor_rig.jsonl` (`oxygen_demo::record`).

use std::path::PathBuf;
use std::time::Instant;

use oxygen::batch::{BatchDesc, BatchGraph, BatchShading, StreamOptions};
use oxygen::glam::{DVec3, Quat};
use oxygen::gpu::{Label, LabelSet};
use oxygen::prelude::*;
use oxygen::views::{DLookAtResolver, ViewContext, ViewError, ViewResolver};

const USAGE: &str = "usage: sensor_rig [FILE] [OUT_DIR] [--cameras N] [--size WxH] [--frames N] [--deferred]";

/// A ring camera: its place on the ring turns with the frame number.
struct RingCamera {
    center: DVec3,
    radius: f64,
    index: usize,
    count: usize,
    size: UVec2,
}

impl ViewResolver for RingCamera {
    fn resolve(&self, ctx: &ViewContext, scene: &Scene) -> Result<oxygen::views::ResolvedView, ViewError> {
        let turn = (self.index as f64 + ctx.frame_index as f64 * 0.05) / self.count as f64 * std::f64::consts::TAU;
        let eye = self.center + DVec3::new(turn.cos(), 0.45, turn.sin()) * self.radius;
        DLookAtResolver {
            camera: Camera::perspective(60f32.to_radians(), (self.radius * 0.01) as f32, None),
            eye,
            target: self.center,
            up: Vec3::Y,
            viewport: self.size,
        }
        .resolve(ctx, scene)
    }
}

struct Args {
    file: PathBuf,
    out: PathBuf,
    cameras: usize,
    size: UVec2,
    frames: u64,
    deferred: bool,
}

fn parse(mut args: impl Iterator<Item = String>) -> Result<Args, String> {
    let mut parsed = Args {
        file: PathBuf::from("assets/AlphaBlendModeTest/AlphaBlendModeTest.glb"),
        out: PathBuf::from("out/rig"),
        cameras: 8,
        size: UVec2::new(128, 128),
        frames: 4,
        deferred: false,
    };
    let mut positional = 0;
    while let Some(arg) = args.next() {
        let mut value = |name: &str| args.next().ok_or(format!("{name} needs a value\n{USAGE}"));
        match arg.as_str() {
            "--cameras" => parsed.cameras = value("--cameras")?.parse().map_err(|e| format!("--cameras: {e}"))?,
            "--frames" => parsed.frames = value("--frames")?.parse().map_err(|e| format!("--frames: {e}"))?,
            "--size" => {
                let size = value("--size")?;
                let (w, h) = size.split_once('x').ok_or(format!("--size {size}: use WxH"))?;
                parsed.size = UVec2::new(
                    w.parse().map_err(|e| format!("--size: {e}"))?,
                    h.parse().map_err(|e| format!("--size: {e}"))?,
                );
            }
            "--deferred" => parsed.deferred = true,
            "-h" | "--help" => return Err(USAGE.to_owned()),
            other if other.starts_with("--") => return Err(format!("unknown option {other}\n{USAGE}")),
            other => {
                match positional {
                    0 => parsed.file = PathBuf::from(other),
                    1 => parsed.out = PathBuf::from(other),
                    _ => return Err(format!("unexpected argument {other}\n{USAGE}")),
                }
                positional += 1;
            }
        }
    }
    if parsed.cameras == 0 || parsed.frames == 0 || parsed.size.x == 0 || parsed.size.y == 0 {
        return Err(format!("cameras, frames and size must be above zero\n{USAGE}"));
    }
    Ok(parsed)
}

fn main() {
    let args = match parse(std::env::args().skip(1)) {
        Ok(args) => args,
        Err(message) => {
            eprintln!("{message}");
            std::process::exit(2);
        }
    };
    if let Err(e) = run(args) {
        eprintln!("sensor_rig: {e}");
        std::process::exit(1);
    }
}

fn run(args: Args) -> Result<(), Box<dyn std::error::Error>> {
    let Args { file, out, cameras, size, frames, deferred } = args;
    std::fs::create_dir_all(&out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let mut scene = Scene::new();
    let import = import_gltf(&mut scene, &file, &SceneChoice::Default)?;
    let bounds = import.precise_bounds.ok_or("the scene has nothing to draw")?;
    if import.lights == 0 {
        let sun = scene.add_node(
            "rig sun",
            Transform::IDENTITY
                .with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::new(-0.3, -0.8, -0.5).normalize())),
        );
        scene.set_light(sun, Some(Light::directional(2.5)))?;
    }
    // Each node its own class: its place in the scene's node order + 1.
    let nodes: Vec<_> = scene.nodes().map(|(key, _)| key).collect();
    for (i, node) in nodes.iter().enumerate() {
        scene.set_semantic_class(*node, i as u32 + 1)?;
    }

    let mut renderer = Renderer::new_headless()?;
    // The planes the files need, written by the shading pass with the colour.
    let planes = LabelSet::of(&[Label::Semantic, Label::LinearDepth]);
    let shading = if deferred { BatchShading::Deferred } else { BatchShading::Forward };
    let graph = BatchGraph { shading, ..oxygen::batch::standard_batch_graph };
    let rig = renderer.register_batch(BatchDesc::new("rig", size).with_label_planes(planes).with_graph(graph))?;
    let (center, radius) = (bounds.center(), bounds.half_extents().length().max(1e-3) * 2.5);
    // Where the adapter can, the cameras cull on the GPU: the whole rig in
    // one dispatch, and nothing per camera for the CPU to emit.
    let visibility = if renderer.gpu_visibility_supported() {
        oxygen::sceneprep::Visibility::GpuFrustum
    } else {
        oxygen::sceneprep::Visibility::Cpu
    };
    println!("{}: culling on the {}", renderer.gpu().describe(), if visibility.on_gpu() { "GPU" } else { "CPU" });
    for index in 0..cameras {
        let camera = RingCamera { center, radius, index, count: cameras, size };
        let desc = ViewDesc::new(camera).named(format!("cam{index:03}")).with_visibility(visibility);
        renderer.add_camera(rig, desc)?;
    }
    let stream = StreamOptions { depth: false, semantic: true, linear_depth: true, ..Default::default() };
    renderer.stream_batch(rig, Some(stream))?;
    println!(
        "{}: {} cameras of {}x{} in one batch on {}",
        file.display(),
        cameras,
        size.x,
        size.y,
        renderer.gpu().describe()
    );

    let started = Instant::now();
    let mut written = 0usize;
    for frame in 1..=frames {
        let report = renderer.render_frame(&scene)?;
        for warning in &report.warnings {
            println!("  frame {frame}: {warning}");
        }
        if deferred {
            let shaded: u32 = report.views.iter().map(|v| v.recorded.deferred_views).sum();
            println!("  frame {frame}: {shaded} of {cameras} cameras shaded deferred");
        }
        for streamed in renderer.wait_streamed()? {
            for camera in streamed.cameras() {
                let name = renderer.view_name(camera.view).unwrap_or("camera").to_owned();
                let stem = out.join(format!("{name}_f{:04}", streamed.frame));
                if let Some(color) = camera.color_image() {
                    color.save(stem.with_extension("color.png"))?;
                }
                if let Some(linear) = camera.linear_depth {
                    // Metres to millimetres; 0 (nothing drawn) stays 0.
                    let mm = linear.iter().map(|d| (d * 1000.0).clamp(0.0, 65535.0) as u16);
                    let image = oxygen::image::ImageBuffer::<oxygen::image::Luma<u16>, _>::from_raw(
                        size.x,
                        size.y,
                        mm.collect::<Vec<_>>(),
                    )
                    .ok_or("depth image size")?;
                    image.save(stem.with_extension("depth.png"))?;
                }
                if let Some(classes) = camera.semantic {
                    let values: Vec<u16> = classes.iter().map(|c| (*c).min(u32::from(u16::MAX)) as u16).collect();
                    let image =
                        oxygen::image::ImageBuffer::<oxygen::image::Luma<u16>, _>::from_raw(size.x, size.y, values)
                            .ok_or("segmentation image size")?;
                    image.save(stem.with_extension("segmentation.png"))?;
                }
                written += 3;
            }
            // Its buffers take a later frame: no fresh memory per frame.
            renderer.recycle_streamed(streamed);
        }
        let seconds = started.elapsed().as_secs_f64();
        println!(
            "frame {frame}/{frames}: {} view-frames in {:.2} s ({:.0} view-frames/s), {written} files",
            frame as usize * cameras,
            seconds,
            (frame as usize * cameras) as f64 / seconds
        );
    }
    println!("wrote {written} files to {}", out.display());
    let seconds = started.elapsed().as_secs_f64();
    oxygen_demo::record::Record::new("sensor_rig")
        .adapter(&renderer.gpu().adapter_info)
        .value("file", file.display().to_string())
        .value("cameras", cameras)
        .value("size_px", [size.x, size.y])
        .value("frames", frames)
        .value("shading", format!("{shading:?}"))
        .value("seconds", seconds)
        .value("view_frames_per_second", (frames as usize * cameras) as f64 / seconds)
        .value("files_written", written)
        .write()?;
    Ok(())
}
