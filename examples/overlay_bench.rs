//! What the overlay costs: COUNT mixed primitives drawn anew every frame
//! over one view, a selection outline and picking with and without
//! instance labels, and depth-tested shapes on a multisampled view, timed
//! in one run on whatever adapter is found (docs/performance.md says
//! which):
//!
//! ```text
//! cargo run --release --example overlay_bench [COUNT] [SIZE] [FRAMES]   # default 10000, 1280 and 20
//! ```
//!
//! One SIZE × SIZE/16·9 view of a lit floor with a box
//! (`oxygen_demo::floor_with_box`), rendered in turn as these cases, each
//! by a renderer of its own:
//!
//! * `no overlay`;
//! * `overlay`: COUNT primitives on its immediate canvas each frame, in
//!   equal shares rectangles, lines 2 px wide, circles, ring arcs, 8-letter
//!   labels and depth-tested world lines (an editor's mix);
//! * `instance labels`: the view draws instance labels, no overlay (what
//!   the next case is compared with);
//! * `outline from labels`: the view draws instance labels; the box is
//!   outlined 3 px wide (a jump flood of the labels), and 20 pixels are
//!   picked after the frames (one texel of the labels read each);
//! * `outline from an ID render`: the same without labels: the outline
//!   floods an ID render of the view (its opaque draws once more), each
//!   pick draws one pixel;
//! * `MSAA ×4, a line on top` and `MSAA ×4, a tested line`: a
//!   multisampled view with one world line, drawn on top or tested against
//!   the single-sampled depth drawn for it.
//!
//! Each renders 3 warm-up frames and FRAMES measured ones, waiting for the
//! GPU after each. Per frame: the CPU time of the canvas calls, the CPU
//! time of the whole `render_frame` (which tessellates and uploads), the
//! GPU time from timestamps where the adapter writes them (else the wall
//! clock); medians, the vertices drawn, and the wall time of a pick.
//!
//! With `OXYGEN_RECORD_DIR` set, the run's figures are appended to
//! `$OXYGEN_RECORD_DIR/overlay_bench.jsonl` (`oxygen_demo::record`).

use std::time::Instant;

use oxygen::glam::{DVec3, Vec2};
use oxygen::overlay::{Canvas, DepthMode, Outline, Rgba};
use oxygen::prelude::*;
use oxygen_demo::record::{Record, Row};

const WARM_UP: usize = 3;

/// Primitive `i` of `count` over a `width × height` view.
fn draw(canvas: &mut Canvas<'_>, i: usize, count: usize, (width, height): (f32, f32)) {
    // A deterministic scatter over the view.
    let t = i as f32 / count.max(1) as f32;
    let x = (i as f32 * 37.77).rem_euclid(width);
    let y = (i as f32 * 19.31 + t * 7.0).rem_euclid(height);
    let color = Rgba::new(t, 1.0 - t, 0.5, 0.8);
    let at = Vec2::new(x, y);
    match i % 6 {
        0 => {
            canvas.rect(at, at + Vec2::new(12.0, 8.0), color);
        }
        1 => {
            canvas.line(at, at + Vec2::new(20.0, 9.0), 2.0, color);
        }
        2 => {
            canvas.circle(at, 5.0, color);
        }
        3 => {
            canvas.arc(at, 7.0, 2.0, t * 6.0, 4.0, color);
        }
        4 => {
            canvas.text(at, 12.0, color, "label 42");
        }
        _ => {
            let p = DVec3::new(f64::from(x / width) * 8.0 - 4.0, 0.05, -f64::from(y / height) * 8.0);
            canvas.world_line(p, p + DVec3::new(0.3, 0.2, 0.0), 1.5, color, DepthMode::Tested);
        }
    }
}

/// What a case draws over its view.
#[derive(Clone, Copy, PartialEq)]
enum Shapes {
    None,
    /// The COUNT primitives of [`draw`].
    Mix,
    /// One world line across the box.
    Line(DepthMode),
}

/// One configuration of the view and its overlay.
struct Case {
    name: &'static str,
    shapes: Shapes,
    labels: bool,
    outline: bool,
    msaa: oxygen::gpu::Msaa,
    /// The case whose GPU time this one is compared with.
    baseline: &'static str,
}

const fn case(name: &'static str, shapes: Shapes, baseline: &'static str) -> Case {
    Case { name, shapes, labels: false, outline: false, msaa: oxygen::gpu::Msaa::Off, baseline }
}

const PICKS: u32 = 20;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    use oxygen::gpu::Msaa;
    let mut args = std::env::args().skip(1);
    let count: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(10_000);
    let width: u32 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(1280);
    let frames: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(20);
    let height = (width * 9 / 16).max(1);
    let scene = oxygen_demo::floor_with_box(0.6);
    let camera = oxygen_demo::floor_with_box_camera(UVec2::new(width, height))?;
    let box_node = scene
        .nodes()
        .find(|(_, n)| n.name == "box")
        .map(|(k, _)| oxygen::core::scene::node_index(k))
        .ok_or("the scene has no box")?;
    let cases = [
        case("no overlay", Shapes::None, "no overlay"),
        case("overlay", Shapes::Mix, "no overlay"),
        Case { labels: true, ..case("instance labels", Shapes::None, "no overlay") },
        Case { labels: true, outline: true, ..case("outline from labels", Shapes::None, "instance labels") },
        Case { outline: true, ..case("outline from an ID render", Shapes::None, "no overlay") },
        Case {
            msaa: Msaa::X4,
            ..case("MSAA ×4, a line on top", Shapes::Line(DepthMode::OnTop), "MSAA ×4, a line on top")
        },
        Case {
            msaa: Msaa::X4,
            ..case("MSAA ×4, a tested line", Shapes::Line(DepthMode::Tested), "MSAA ×4, a line on top")
        },
    ];
    let mut record = Record::new("overlay_bench")
        .value("primitives", count)
        .value("viewport_px", [width, height])
        .value("warm_up_frames", WARM_UP)
        .value("measured_frames", frames)
        .value("picks", PICKS);
    println!("{count} primitives over {width}x{height}, {frames} frames each");
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let mut medians: Vec<(&str, f64)> = Vec::new();
    for case in &cases {
        let mut renderer = Renderer::new_headless()?;
        record.set_adapter(&renderer.gpu().adapter_info);
        let mut desc = ViewDesc::new(camera).with_msaa(case.msaa);
        if case.labels {
            desc = desc.with_label_planes(oxygen::gpu::LabelSet::of(&[oxygen::gpu::Label::Instance]));
        }
        let view = renderer.register_view(desc, standard_render_graph)?;
        if case.outline {
            let outline = Outline { nodes: vec![box_node], width: 3.0, color: Rgba::rgb(1.0, 0.6, 0.1) };
            renderer.overlay(view)?.set_outline(Some(outline));
        }
        if let Shapes::Line(depth) = case.shapes {
            let (a, b) = (DVec3::new(-3.0, 0.5, -1.0), DVec3::new(3.0, 0.5, -1.0));
            renderer.overlay(view)?.retained().world_line(a, b, 2.0, Rgba::rgb(1.0, 0.0, 0.0), depth);
        }
        let (mut gpu, mut wall, mut drawing, mut cpu) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut vertices = 0u64;
        for frame in 0..WARM_UP + 2 + frames {
            let started = Instant::now();
            if case.shapes == Shapes::Mix {
                let overlay = renderer.overlay(view)?;
                let mut canvas = overlay.immediate();
                for i in 0..count {
                    draw(&mut canvas, i, count, (width as f32, height as f32));
                }
            }
            let drawn = started.elapsed().as_secs_f64() * 1e3;
            let report = renderer.render_frame(&scene)?;
            let recorded = started.elapsed().as_secs_f64() * 1e3;
            renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
            // A report carries an earlier frame's GPU time: skip two more.
            if frame >= WARM_UP + 2 {
                wall.push(started.elapsed().as_secs_f64() * 1e3);
                drawing.push(drawn);
                cpu.push(recorded - drawn);
                gpu.extend(report.gpu_seconds.map(|s| s * 1e3));
                vertices = report.views.iter().map(|v| v.recorded.overlay_vertices).sum();
            }
        }
        // Picks over a diagonal of the view (the first one, which may
        // compile the ID render's pipelines, not counted).
        let mut picks = Vec::new();
        if case.outline {
            for i in 0..=PICKS {
                let (x, y) = (i * (width - 1) / PICKS, i * (height - 1) / PICKS);
                let started = Instant::now();
                renderer.pick(view, x, y)?;
                if i > 0 {
                    picks.push(started.elapsed().as_secs_f64() * 1e3);
                }
            }
        }
        let timed_on_gpu = gpu.len() == wall.len();
        let ms = median(if timed_on_gpu { gpu.clone() } else { wall.clone() });
        let (drawing_ms, frame_cpu_ms) = (median(drawing), median(cpu));
        let base = medians.iter().find(|(name, _)| *name == case.baseline).map_or(ms, |(_, ms)| *ms);
        medians.push((case.name, ms));
        let pick_ms = (!picks.is_empty()).then(|| median(picks));
        println!(
            "{:<28} GPU {ms:7.3} ms ({}) {:+.3} over {}; canvas calls {drawing_ms:.3} ms; render_frame CPU {frame_cpu_ms:.3} ms; {vertices} vertices{}",
            case.name,
            if timed_on_gpu { "timestamps" } else { "wall clock" },
            ms - base,
            case.baseline,
            pick_ms.map_or(String::new(), |ms| format!("; a pick {ms:.3} ms")),
        );
        let mut row = Row::new()
            .value("case", case.name)
            .value("gpu_ms_median", ms)
            .value("timed_on_gpu", timed_on_gpu)
            .value("baseline", case.baseline)
            .value("gpu_ms_over_baseline", ms - base)
            .value("canvas_calls_ms_median", drawing_ms)
            .value("render_frame_cpu_ms_median", frame_cpu_ms)
            .value("overlay_vertices", vertices)
            .value("samples_ms", &if timed_on_gpu { gpu } else { wall });
        if let Some(pick_ms) = pick_ms {
            row = row.value("pick_ms_median", pick_ms);
        }
        record.push_row(row);
    }
    record.write()?;
    Ok(())
}
