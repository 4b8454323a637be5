//! What the tone map's effects cost, timed in one run on whatever adapter
//! is found (docs/performance.md says which):
//!
//! ```text
//! cargo run --release --example tone_map_effects_bench [SIZE] [FRAMES]   # default 1280 and 20
//! ```
//!
//! One SIZE × SIZE/16·9 view of a lit floor with a box
//! (`oxygen_demo::floor_with_box`), the HDR image kept (so every case has
//! the tone-map pass), rendered five ways: no effect, bloom of 3 and of 6
//! levels, automatic exposure, and bloom of 6 levels with automatic
//! exposure. Each renders 3 warm-up frames and FRAMES measured ones,
//! waiting for the GPU after each; the frame's GPU time from timestamps
//! where the adapter writes them (else the wall clock), median.
//!
//! With `OXYGEN_RECORD_DIR` set, the run's figures are appended to
//! `$OXYGEN_RECORD_DIR/tone_map_effects_bench.jsonl` (`oxygen_demo::record`).

use std::time::Instant;

use oxygen::graph::StandardGraph;
use oxygen::lighting::{AutoExposure, Bloom};
use oxygen::prelude::*;
use oxygen_demo::record::{Record, Row};

const WARM_UP: usize = 3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let width: u32 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(1280);
    let frames: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(20);
    let height = (width * 9 / 16).max(1);
    let scene = oxygen_demo::floor_with_box(0.6);
    let camera = oxygen_demo::floor_with_box_camera(UVec2::new(width, height))?;
    let bloom = |levels| Some(Bloom { levels, ..Bloom::DEFAULT });
    let auto = Some(AutoExposure::DEFAULT);
    let cases = [
        ("no effect", None, None),
        ("bloom, 3 levels", bloom(3), None),
        ("bloom, 6 levels", bloom(6), None),
        ("automatic exposure", None, auto),
        ("bloom, 6 levels, and automatic exposure", bloom(6), auto),
    ];
    let mut record = Record::new("tone_map_effects_bench")
        .value("viewport_px", [width, height])
        .value("warm_up_frames", WARM_UP)
        .value("measured_frames", frames);
    println!("{width}x{height}, {frames} frames each");
    let mut first = None;
    for (name, bloom, auto_exposure) in cases {
        let mut renderer = Renderer::new_headless_with(RendererOptions { keep_hdr: true, ..Default::default() })?;
        record.set_adapter(&renderer.gpu().adapter_info);
        let graph = StandardGraph::default().with_bloom(bloom).with_auto_exposure(auto_exposure);
        renderer.register_view(camera, graph)?;
        let (mut gpu, mut wall) = (Vec::new(), Vec::new());
        for frame in 0..WARM_UP + 2 + frames {
            let started = Instant::now();
            let report = renderer.render_frame(&scene)?;
            renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
            // A report carries an earlier frame's GPU time: skip two more.
            if frame >= WARM_UP + 2 {
                wall.push(started.elapsed().as_secs_f64() * 1e3);
                gpu.extend(report.gpu_seconds.map(|s| s * 1e3));
            }
        }
        let timed_on_gpu = gpu.len() == wall.len();
        let mut times = if timed_on_gpu { gpu } else { wall };
        times.sort_by(f64::total_cmp);
        let ms = times[times.len() / 2];
        let base = *first.get_or_insert(ms);
        println!("{name:<42} {ms:8.3} ms ({})  +{:.3} ms", if timed_on_gpu { "GPU" } else { "wall clock" }, ms - base);
        record.push_row(
            Row::new()
                .value("case", name)
                .value("ms_median", ms)
                .value("timed_on_gpu", timed_on_gpu)
                .value("ms_over_no_effect", ms - base)
                .value("samples_ms", &times),
        );
    }
    record.write()?;
    Ok(())
}
