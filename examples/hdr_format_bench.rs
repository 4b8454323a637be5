//! The frame-economy knobs, timed in one run on whatever adapter is found
//! (the table in docs/performance.md says which):
//!
//! ```text
//! cargo run --release --example hdr_format_bench [SIZE] [FRAMES]   # default 1280 and 20
//! ```
//!
//! One SIZE × SIZE/16·9 view of a lit floor with a box (`oxygen_demo::floor_with_box`),
//! rendered four ways: the HDR target kept in `Rgba16Float` (shading, then
//! the tone-map pass), the same in `Rg11b10Ufloat`, the tone map done while
//! shading (no HDR write, no tone-map pass), and the fully featured shader
//! without specialisation. Each renders 3 warm-up frames and FRAMES measured
//! ones, waiting for the GPU after each, and reports milliseconds per frame
//! and the ratio against the first.
//!
//! With `OXYGEN_RECORD_DIR` set, the run's figures are appended to
//! `$OXYGEN_RECORD_DIR/hdr_format_bench.jsonl` (`oxygen_demo::record`).

use std::time::Instant;

use oxygen::gpu::HdrFormat;
use oxygen::prelude::*;
use oxygen_demo::record::{Record, Row};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let width: u32 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(1280);
    let frames: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(20);
    let height = (width * 9 / 16).max(1);
    let scene = oxygen_demo::floor_with_box(0.6);
    let camera = oxygen_demo::floor_with_box_camera(UVec2::new(width, height))?;
    let kept = RendererOptions { keep_hdr: true, ..Default::default() };
    let cases = [
        ("Rgba16Float HDR + tone-map pass", kept),
        ("Rg11b10Ufloat HDR + tone-map pass", RendererOptions { hdr_format: HdrFormat::Rg11b10Ufloat, ..kept }),
        ("tone map while shading (no HDR)", RendererOptions::default()),
        ("Rgba16Float, unspecialised shader", RendererOptions { specialize_shaders: false, ..kept }),
    ];
    let mut baseline = None;
    let mut record = Record::new("hdr_format_bench")
        .value("viewport_px", [width, height])
        .value("warm_up_frames", 3)
        .value("measured_frames", frames);
    println!("{width}x{height}, {frames} frames each");
    for (name, options) in cases {
        let mut renderer = Renderer::new_headless_with(options)?;
        record.set_adapter(&renderer.gpu().adapter_info);
        let view = renderer.register_view(camera, standard_render_graph)?;
        let frame = |renderer: &mut Renderer| -> Result<(), Box<dyn std::error::Error>> {
            renderer.render_frame(&scene)?;
            renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
            Ok(())
        };
        for _ in 0..3 {
            frame(&mut renderer)?;
        }
        let start = Instant::now();
        for _ in 0..frames {
            frame(&mut renderer)?;
        }
        let ms = start.elapsed().as_secs_f64() * 1e3 / frames.max(1) as f64;
        let base = *baseline.get_or_insert(ms);
        let bytes = renderer.target_memory();
        println!(
            "{name:<36} {ms:8.2} ms/frame  ×{:.3}  targets {:.1} MiB  (HDR format in use: {:?}, view {view})",
            ms / base,
            bytes as f64 / (1 << 20) as f64,
            renderer.hdr_format()
        );
        record.push_row(
            Row::new()
                .value("case", name)
                .value("frame_ms_mean", ms)
                .value("ratio_to_first", ms / base)
                .value("target_memory_bytes", bytes)
                .value("hdr_format_in_use", format!("{:?}", renderer.hdr_format())),
        );
    }
    record.write()?;
    Ok(())
}
