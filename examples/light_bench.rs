//! What clustered light culling buys, timed in one run on whatever adapter
//! is found (docs/performance.md says which):
//!
//! ```text
//! cargo run --release --example light_bench [WIDTH] [FRAMES] [LAMPS]   # default 1280, 30, 1,16,256,1000
//! ```
//!
//! The street of `oxygen_demo::lamp_street` (LAMPS lamps of 7 m range,
//! plus one unbounded light far away) seen down the road by one
//! WIDTH × WIDTH/16·9 view, shaded two ways: every pixel looping over every
//! light (`LightCulling::EveryLight`, today's default) and from each
//! pixel's cluster (`LightCulling::Clustered` with `ClusterGrid::DEFAULT`).
//! The two renderers' frames are interleaved, each followed by a wait for
//! the GPU; after 5 warm-up rounds it reports, per lamp count and mode, the
//! median GPU time of the frame (`FrameReport::gpu_seconds`, timestamps
//! around the view's command buffers, the cluster pass included) and of
//! the whole frame on the CPU clock, and the clustered frame's GPU time
//! against the every-light frame's.
//!
//! With `OXYGEN_RECORD_DIR` set, the run's figures are appended to
//! `$OXYGEN_RECORD_DIR/light_bench.jsonl` (`oxygen_demo::record`).

use std::time::Instant;

use oxygen::lighting::{ClusterGrid, LightCulling};
use oxygen::prelude::*;
use oxygen_demo::record::{Record, Row};

const WARM_UP: usize = 5;

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(f64::NAN)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let width: u32 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(1280);
    let frames: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(30);
    let lamps: Vec<usize> = match args.next() {
        Some(list) => list.split(',').map(str::parse).collect::<Result<_, _>>()?,
        None => vec![1, 16, 256, 1000],
    };
    let height = (width * 9 / 16).max(1);
    let modes =
        [("every light", LightCulling::EveryLight), ("clustered", LightCulling::Clustered(ClusterGrid::DEFAULT))];
    let grid = ClusterGrid::DEFAULT;
    let mut record = Record::new("light_bench")
        .value("viewport_px", [width, height])
        .value("warm_up_rounds", WARM_UP)
        .value("measured_frames", frames)
        .value(
            "grid",
            format!("{} px tiles, {} slices over {} m", grid.tile_pixels, grid.depth_slices, grid.depth_range),
        );
    println!("{width}x{height}, {frames} interleaved frames per mode after {WARM_UP} warm-up rounds");
    println!("{:>6} {:<12} {:>10} {:>10} {:>10}", "lamps", "mode", "GPU ms", "frame ms", "× every");
    for &count in &lamps {
        let scene = oxygen_demo::lamp_street(count);
        let mut renderers = Vec::new();
        for (_, culling) in modes {
            let mut renderer = Renderer::new_headless()?;
            record.set_adapter(&renderer.gpu().adapter_info);
            let graph = StandardGraph::new(ForwardLitConfig { light_culling: culling, ..ForwardLitConfig::DEFAULT });
            renderer.register_view(oxygen_demo::lamp_street_camera(UVec2::new(width, height)), graph)?;
            renderers.push(renderer);
        }
        let mut gpu_ms = vec![Vec::new(); modes.len()];
        let mut frame_ms = vec![Vec::new(); modes.len()];
        for round in 0..WARM_UP + frames {
            for (m, renderer) in renderers.iter_mut().enumerate() {
                let start = Instant::now();
                let report = renderer.render_frame(&scene)?;
                renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
                let wall = start.elapsed().as_secs_f64() * 1e3;
                if round >= WARM_UP {
                    frame_ms[m].push(wall);
                    if let Some(gpu) = report.gpu_seconds {
                        gpu_ms[m].push(gpu * 1e3);
                    }
                }
            }
        }
        let gpu: Vec<f64> = gpu_ms.iter_mut().map(|v| median(v)).collect();
        for (m, (name, _)) in modes.iter().enumerate() {
            let frame = median(&mut frame_ms[m]);
            let ratio = gpu[m] / gpu[0];
            println!("{count:>6} {name:<12} {:>10.3} {frame:>10.3} {ratio:>10.3}", gpu[m]);
            record.push_row(
                Row::new()
                    .value("lamps", count)
                    .value("positional_lights", count + 1)
                    .value("mode", *name)
                    .value("gpu_ms_median", gpu[m])
                    .value("gpu_samples", gpu_ms[m].len())
                    .value("frame_ms_median", frame)
                    .value("gpu_ratio_to_every_light", ratio),
            );
        }
    }
    record.write()?;
    Ok(())
}
