//! The time side of the shadow knobs: cascade count and map resolution.
//!
//! ```text
//! cargo run --release --example shadow_bench [CUBES]   # default 10 000
//! ```
//!
//! A field of CUBES boxes of varied heights under a low sun, one 960 × 540
//! camera looking across it. For no shadows and for every cascade count
//! (1, 2, 4) × map resolution (512, 1024, 2048), it renders 3 warm-up and
//! 10 measured frames, each waited for on the GPU, and reports the median
//! frame time and its ratio to the frame without shadows, measured in the
//! same run. The error side is `shadow_map_resolution_trades_edge_error`
//! in `tests/shadow_cascades.rs`.
//!
//! With `OXYGEN_RECORD_DIR` set, the table (with every frame's time) is
//! appended as one record to `$OXYGEN_RECORD_DIR/shadow_bench.jsonl`
//! (`oxygen_demo::record`).

use std::time::Instant;

use oxygen::core::CascadeSettings;
use oxygen::glam::Vec4;
use oxygen::prelude::*;
use oxygen_demo::record::{Record, Row};

const WARM_UP: usize = 3;
const MEASURED: usize = 10;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let count: usize = std::env::args().nth(1).map(|a| a.parse()).transpose()?.unwrap_or(10_000);
    let (scene, extent) = oxygen_demo::field_of_boxes(count, &[Vec4::new(0.8, 0.7, 0.6, 1.0)]);
    let camera = LookAtResolver::new(
        Camera::perspective(60f32.to_radians(), 0.1, Some(extent * 1.5)),
        Vec3::new(-5.0, 12.0, -5.0),
        Vec3::new(extent * 0.4, 0.0, extent * 0.4),
        UVec2::new(960, 540),
    )
    .unwrap();
    let mut configs = vec![None];
    for cascades in [1, 2, 4] {
        for resolution in [512, 1024, 2048] {
            configs.push(Some((cascades, resolution)));
        }
    }
    println!("| cascades | map resolution | frame ms (CPU + GPU, waited) | × no shadows |");
    println!("|---:|---:|---:|---:|");
    let mut baseline = None;
    let mut adapter = String::new();
    let mut record = Record::new("shadow_bench")
        .value("boxes", count)
        .value("viewport_px", [960, 540])
        .value("warm_up_frames", WARM_UP)
        .value("measured_frames", MEASURED);
    for config in configs {
        let mut renderer = Renderer::new_headless()?;
        adapter = renderer.gpu().describe();
        record.set_adapter(&renderer.gpu().adapter_info);
        let desc = match config {
            Some((count, resolution)) => {
                let settings = CascadeSettings { count, resolution, max_distance: 60.0, ..Default::default() };
                ViewDesc::new(camera).with_sun_shadows(settings)
            }
            None => ViewDesc::new(camera),
        };
        renderer.register_view(desc, standard_render_graph)?;
        let mut times = Vec::with_capacity(MEASURED);
        for frame in 0..WARM_UP + MEASURED {
            let start = Instant::now();
            renderer.render_frame(&scene)?;
            renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
            if frame >= WARM_UP {
                times.push(start.elapsed().as_secs_f64() * 1e3);
            }
        }
        let samples = times.clone();
        times.sort_by(f64::total_cmp);
        let median = times[times.len() / 2];
        let base = *baseline.get_or_insert(median);
        let (cascades, resolution) =
            config.map_or(("0".to_owned(), "—".to_owned()), |(c, r)| (c.to_string(), r.to_string()));
        println!("| {cascades} | {resolution} | {median:.2} | {:.2} |", median / base);
        record.push_row(
            Row::new()
                .value("cascades", config.map_or(0, |(c, _)| c))
                .value("map_resolution_px", config.map(|(_, r)| r))
                .value("frame_ms_median", median)
                .value("ratio_to_no_shadows", median / base)
                .value("frame_ms_samples", samples),
        );
    }
    println!();
    println!("adapter: {adapter}; {count} boxes; medians of {MEASURED} frames after {WARM_UP} warm-up frames");
    record.write()?;
    Ok(())
}
