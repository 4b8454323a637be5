//! What schedules save: a surveillance wall of V cameras, each looking
//! down at its own patch of a field of boxes, where B cameras render every
//! frame and the rest only when something they show changed, with one box
//! moving through one patch. Three walls, frames interleaved round by round:
//!
//! * `every`: every camera every frame;
//! * `scheduled`: B cameras every frame, the others `Schedule::WhenChanged`;
//! * `busy`: the B busy cameras alone.
//!
//! ```text
//! cargo run --release --example schedule_bench -- [V] [B] [frames]   # defaults 64 4 30
//! ```
//!
//! Each frame is `render_frame` and a wait for the GPU (wall clock). The
//! line per wall gives the median frame time and how many cameras rendered
//! a frame (the report's views, shadow views aside, over the measured
//! frames); the last line the ratios to `busy`. The aim (issue 30): the
//! scheduled wall within 1.5× of the busy cameras alone. With
//! `OXYGEN_RECORD_DIR` set the figures and every frame's time are appended
//! to `$OXYGEN_RECORD_DIR/schedule_bench.jsonl` (`oxygen_demo::record`).

use std::time::Instant;

use oxygen::glam::Vec4;
use oxygen::prelude::*;
use oxygen::schedule::Schedule;
use oxygen_demo::record::{Record, Row};

const WARM_UP: usize = 3;
const USAGE: &str = "usage: schedule_bench [V] [B] [frames]";
/// Boxes a patch side (a patch is PATCH × PATCH boxes, spacing 2).
const PATCH: usize = 4;
const VIEWPORT: UVec2 = UVec2::new(320, 180);

/// A field of `side × side` patches of boxes and the box that moves.
fn field(side: usize) -> (Scene, oxygen::core::NodeKey) {
    let mut scene = Scene::new();
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let grey = scene.add_material(Material::opaque("grey", Vec4::new(0.6, 0.6, 0.6, 1.0)));
    let red = scene.add_material(Material::opaque("red", Vec4::new(0.8, 0.1, 0.1, 1.0)));
    let boxes = side * PATCH;
    for i in 0..boxes * boxes {
        let (x, z) = ((i % boxes) as f32 * 2.0, (i / boxes) as f32 * 2.0);
        let node = scene.add_node("box", Transform::from_translation(Vec3::new(x, 0.5, z)));
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![grey] }).ok();
    }
    let mover = scene.add_node("mover", Transform::from_translation(Vec3::new(1.0, 1.5, 1.0)));
    scene.set_renderable(mover, Renderable { geometry: cube, materials: vec![red] }).ok();
    let down = oxygen::glam::Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::new(0.3, -1.0, 0.2).normalize());
    let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(down));
    scene.set_light(sun, Some(Light { casts_shadows: false, ..Light::directional(2.5) })).ok();
    (scene, mover)
}

/// Camera `i` of a `side × side` wall: above the centre of its patch, looking down.
fn camera(i: usize, side: usize) -> Result<LookAtResolver, Box<dyn std::error::Error>> {
    let span = PATCH as f32 * 2.0;
    let (x, z) = ((i % side) as f32 * span + span / 2.0 - 1.0, (i / side) as f32 * span + span / 2.0 - 1.0);
    let eye = Vec3::new(x, 9.0, z + 0.01);
    Ok(LookAtResolver::new(
        Camera::try_perspective(50f32.to_radians(), 0.1, None)?,
        eye,
        Vec3::new(x, 0.0, z),
        VIEWPORT,
    )?
    .with_up(Vec3::NEG_Z)?)
}

struct Wall {
    name: &'static str,
    renderer: Renderer,
    times_ms: Vec<f64>,
    rendered: usize,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let views: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(64);
    let busy: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(4);
    let frames: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(30);
    if views == 0 || busy == 0 || busy > views || frames == 0 {
        return Err(USAGE.into());
    }
    let side = (views as f64).sqrt().ceil() as usize;
    let (mut scene, mover) = field(side);
    let mut walls = Vec::new();
    for (name, count, scheduled) in [("every", views, false), ("scheduled", views, true), ("busy", busy, false)] {
        let mut renderer = Renderer::new_headless()?;
        for i in 0..count {
            // The busy cameras are the last ones: the mover's patch is the first.
            let index = if name == "busy" { views - busy + i } else { i };
            let schedule = if scheduled && index < views - busy { Schedule::WhenChanged } else { Schedule::EveryFrame };
            renderer
                .register_view(ViewDesc::new(camera(index, side)?).with_schedule(schedule), standard_render_graph)?;
        }
        walls.push(Wall { name, renderer, times_ms: Vec::new(), rendered: 0 });
    }
    let adapter = walls[0].renderer.gpu().adapter_info.clone();
    eprintln!(
        "{}: {views} cameras of {}x{}, {busy} busy, {frames} frames",
        walls[0].renderer.gpu().describe(),
        VIEWPORT.x,
        VIEWPORT.y
    );
    for frame in 0..WARM_UP + frames {
        // The mover circles inside the first patch.
        let t = frame as f32 * 0.3;
        let at = Vec3::new(3.0 + 1.5 * t.cos(), 1.5, 3.0 + 1.5 * t.sin());
        scene.set_local_transform(mover, Transform::from_translation(at))?;
        // The walls take turns going first.
        let order: Vec<usize> = (0..walls.len()).map(|k| (k + frame) % walls.len()).collect();
        for w in order {
            let wall = &mut walls[w];
            let start = Instant::now();
            let report = wall.renderer.render_frame(&scene)?;
            wall.renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
            let ms = start.elapsed().as_secs_f64() * 1e3;
            if frame >= WARM_UP {
                wall.times_ms.push(ms);
                wall.rendered += report.views.iter().filter(|v| v.why.is_some()).count();
            }
        }
    }
    let median = |times: &[f64]| {
        let mut sorted = times.to_vec();
        sorted.sort_by(f64::total_cmp);
        sorted[sorted.len() / 2]
    };
    let busy_ms = median(&walls[2].times_ms);
    let mut record = Record::new("schedule_bench")
        .adapter(&adapter)
        .value("views", views)
        .value("busy", busy)
        .value("measured_frames", frames)
        .value("viewport", [VIEWPORT.x, VIEWPORT.y]);
    let mut rows = Vec::new();
    for wall in &walls {
        let ms = median(&wall.times_ms);
        let per_frame = wall.rendered as f64 / frames as f64;
        println!(
            "{:<9} median {:8.3} ms  {:6.1} cameras rendered a frame  {:5.2}× busy",
            wall.name,
            ms,
            per_frame,
            ms / busy_ms
        );
        rows.push(
            Row::new()
                .value("wall", wall.name)
                .value("median_ms", ms)
                .value("cameras_per_frame", per_frame)
                .value("over_busy", ms / busy_ms)
                .value("ms_samples", wall.times_ms.clone()),
        );
    }
    record = record.value("rows", rows);
    record.write()?;
    Ok(())
}
