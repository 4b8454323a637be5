//! Oxygen's side of the peer benchmark against Bevy (`benches/peer-bevy`):
//! the same cubes scene, the same views, the same timing, one line each.
//!
//! ```text
//! cargo run --release --example cubes_bench N V [frames]   # frames: measured, default 30
//! scripts/peer-bench.sh                                      # both renderers, interleaved, as a table
//! ```
//!
//! The scene, identical on both sides: N unit cubes on a square grid
//! (spacing 2, in the XZ plane, centred on the origin, resting on y = 0),
//! four opaque metallic-roughness materials cycling (metallic 0, roughness
//! 0.5, four base colours), one directional light that casts no shadows, and
//! V perspective views (60° vertical field of view, near 0.1, infinite far,
//! 960 × 540, offscreen) evenly spaced on a circle around the grid, each
//! looking at its centre. The eye sits at radius 0.65 and height 0.35 of the
//! grid's side length, which keeps about 92 % of the cubes in each view;
//! the line reports the fraction Oxygen's culling kept
//! (`FrameReport::views[i].draws / N`, mean over the views).
//!
//! Each view is drawn by `standard_render_graph` — Oxygen's default frame:
//! depth pre-pass, forward lit pass into an Rgba16Float HDR target, full-screen
//! tone map, no MSAA. WARM_UP frames (the first compiles every pipeline) are
//! followed by the measured frames; each frame is `render_frame` plus a wait
//! for the GPU to finish (`device.poll(wait_indefinitely)`), timed on the wall
//! clock, so CPU preparation, recording, submission and GPU execution all count
//! and no frame overlaps the next. The Bevy side times the same span.
//!
//! Visibility is the renderer's default for the adapter (`Visibility::Cpu`
//! on lavapipe, `GpuFrustum` on a hardware GPU); `OXYGEN_VISIBILITY=cpu`,
//! `gpu` or `occlusion` forces one, and the line says which ran.
//!
//! The adapter follows `WGPU_BACKEND` and `OXYGEN_ADAPTER` (see the README);
//! `CUBES_BENCH_PNG=dir` also writes each view's last image there, to check by
//! eye that both renderers draw the same picture.
//!
//! With `OXYGEN_RECORD_DIR` set, the run's figures (and every frame's time)
//! are appended to `$OXYGEN_RECORD_DIR/cubes_bench.jsonl`
//! (`oxygen_demo::record`).

use std::time::Instant;

use oxygen::glam::{Quat, Vec4};
use oxygen::graph::PrePass;
use oxygen::prelude::*;
use oxygen::sceneprep::Visibility;
use oxygen_demo::record::Record;

const WARM_UP: usize = 5;
const DEFAULT_MEASURED: usize = 30;
const VIEWPORT: UVec2 = UVec2::new(960, 540);
/// Eye radius and height as fractions of the grid's side length; chosen so
/// that about 92 % of the cubes fall inside each view's frustum.
const EYE_RADIUS: f32 = 0.65;
const EYE_HEIGHT: f32 = 0.35;

/// The four base colours (linear RGB), in the order the cubes cycle through them.
const BASE_COLORS: [[f32; 3]; 4] = [[0.8, 0.2, 0.2], [0.2, 0.7, 0.3], [0.2, 0.3, 0.8], [0.8, 0.7, 0.2]];

/// The grid of `count` cubes and its side length in world units.
fn cube_grid(count: usize) -> (Scene, f32) {
    let mut scene = Scene::new();
    let per_row = (count as f32).sqrt().ceil() as usize;
    let half = (per_row - 1) as f32; // spacing 2: the centres span [-half, half]
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let materials: Vec<_> = BASE_COLORS
        .iter()
        .map(|&[r, g, b]| {
            scene.add_material(Material { roughness: 0.5, ..Material::opaque("cube", Vec4::new(r, g, b, 1.0)) })
        })
        .collect();
    for i in 0..count {
        let (x, z) = ((i % per_row) as f32 * 2.0 - half, (i / per_row) as f32 * 2.0 - half);
        let node = scene.add_node("cube", Transform::from_translation(Vec3::new(x, 0.5, z)));
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![materials[i % 4]] }).ok();
    }
    let sun =
        scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, sun_direction())));
    scene.set_light(sun, Some(Light { casts_shadows: false, ..Light::directional(3.0) })).ok();
    (scene, per_row as f32 * 2.0)
}

/// The direction the sun's light travels (the Bevy side uses the same).
fn sun_direction() -> Vec3 {
    Vec3::new(0.6, -0.5, 0.4).normalize()
}

/// Value at fraction `p` of the sorted samples (nearest rank).
fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "usage: cubes_bench N V [frames]";
    let mut args = std::env::args().skip(1);
    let count: usize = args.next().ok_or(usage)?.parse()?;
    let views: usize = args.next().ok_or(usage)?.parse()?;
    let measured: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(DEFAULT_MEASURED);
    if count == 0 || views == 0 || measured == 0 {
        return Err(usage.into());
    }

    let (scene, side) = cube_grid(count);
    let visibility = match std::env::var("OXYGEN_VISIBILITY").as_deref() {
        Ok("cpu") => Some(Visibility::Cpu),
        Ok("gpu") => Some(Visibility::GpuFrustum),
        Ok("occlusion") => Some(Visibility::GpuOcclusion),
        Ok(other) => return Err(format!("OXYGEN_VISIBILITY={other}: use cpu, gpu or occlusion").into()),
        Err(_) => None,
    };
    let mut renderer = Renderer::new_headless_with(RendererOptions { visibility, ..Default::default() })?;
    // Experiment knobs (not part of the peer comparison): OXYGEN_PREPASS=on|off
    // forces the depth pre-pass, OXYGEN_VIEWPORT=WxH the views' size.
    let graph = match std::env::var("OXYGEN_PREPASS").as_deref() {
        Ok("on") => standard_render_graph.with_pre_pass(PrePass::On),
        Ok("off") => standard_render_graph.with_pre_pass(PrePass::Off),
        _ => standard_render_graph,
    };
    let viewport = match std::env::var("OXYGEN_VIEWPORT") {
        Ok(size) => {
            let (w, h) = size.split_once('x').ok_or("OXYGEN_VIEWPORT=WxH")?;
            UVec2::new(w.parse()?, h.parse()?)
        }
        Err(_) => VIEWPORT,
    };
    let mut view_ids = Vec::with_capacity(views);
    for v in 0..views {
        let angle = v as f32 / views as f32 * std::f32::consts::TAU;
        let eye = Vec3::new(angle.cos() * EYE_RADIUS * side, EYE_HEIGHT * side, angle.sin() * EYE_RADIUS * side);
        let camera =
            LookAtResolver::new(Camera::try_perspective(60f32.to_radians(), 0.1, None)?, eye, Vec3::ZERO, viewport)?;
        view_ids.push(renderer.register_view(ViewDesc::new(camera), graph.clone())?);
    }

    let mut times = Vec::with_capacity(measured);
    let mut visible = 0.0;
    for frame in 0..WARM_UP + measured {
        let start = Instant::now();
        let report = renderer.render_frame(&scene)?;
        renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        if let Some(warning) = report.warnings.first() {
            return Err(format!("frame {frame}: {warning}").into());
        }
        if frame >= WARM_UP {
            times.push(ms);
            visible =
                report.views.iter().map(|v| v.draws as f64 / count as f64).sum::<f64>() / report.views.len() as f64;
        }
    }
    let samples = times.clone();
    times.sort_by(f64::total_cmp);
    if renderer.visibility().on_gpu() {
        // The GPU's draws stay on the GPU: read the last frame's back.
        let mut kept = 0.0;
        for id in &view_ids {
            kept += renderer.view_draws(*id)?.iter().map(|(_, d)| d.len()).sum::<usize>() as f64 / count as f64;
        }
        visible = kept / views as f64;
    }

    if let Some(dir) = std::env::var_os("CUBES_BENCH_PNG") {
        std::fs::create_dir_all(&dir)?;
        for (v, id) in view_ids.iter().enumerate() {
            let path = std::path::Path::new(&dir).join(format!("oxygen_N{count}_V{views}_view{v}.png"));
            renderer.read_color(*id)?.save(&path)?;
        }
    }
    // The first view's overdraw estimate, which decides the automatic pre-pass.
    let overdraw = match (renderer.gpu_visibility(), renderer.prepared_frame(view_ids[0])) {
        (Some(gpu), Some(frame)) if frame.gpu_plan().is_some() => {
            gpu.estimated_overdraw(view_ids[0]).unwrap_or(f32::NAN)
        }
        (_, Some(frame)) => frame.estimated_overdraw(),
        _ => f32::NAN,
    };
    eprintln!("oxygen overdraw estimate (view 0): {overdraw:.3}");
    println!(
        "oxygen N={count} V={views} median_ms={:.2} p10_ms={:.2} p90_ms={:.2} frames={measured} warmup={WARM_UP} visible={:.3}",
        percentile(&times, 0.5),
        percentile(&times, 0.1),
        percentile(&times, 0.9),
        visible
    );
    println!("oxygen adapter: {} visibility: {:?}", renderer.gpu().describe(), renderer.visibility());
    Record::new("cubes_bench")
        .adapter(&renderer.gpu().adapter_info)
        .value("cubes", count)
        .value("views", views)
        .value("viewport_px", [viewport.x, viewport.y])
        .value("warm_up_frames", WARM_UP)
        .value("measured_frames", measured)
        .value("visibility", format!("{:?}", renderer.visibility()))
        .value("frame_ms_median", percentile(&times, 0.5))
        .value("frame_ms_p10", percentile(&times, 0.1))
        .value("frame_ms_p90", percentile(&times, 0.9))
        .value("frame_ms_samples", samples)
        .value("visible_fraction", visible)
        .value("overdraw_estimate_view0", overdraw.is_finite().then_some(overdraw))
        .write()?;
    Ok(())
}
