//! The anti-aliasing knob, timed in one run on whatever adapter is found:
//!
//! ```text
//! cargo run --release --example msaa_bench [SIZE] [BOXES] [FRAMES]   # default 1920, 2500, 30
//! ```
//!
//! One SIZE × SIZE/16·9 view over oxygen-demo's field of BOXES boxes (a
//! silhouette edge at every box), rendered with 1, 2 and 4 samples per pixel
//! (`ViewDesc::with_msaa`; the samples the adapter actually gives are
//! printed). Each renders 3 warm-up frames and FRAMES measured ones, waiting
//! for the GPU after each, and reports the median wall time of a frame, the
//! median GPU time between the frame's timestamps (where the adapter has
//! them), the targets' memory and the ratio against 1 sample. The edge
//! error each setting leaves is measured by `tests/msaa.rs`. BOXES 0 draws
//! the ground alone: what is left is the cost of the multisampled targets
//! (clear, store, resolve) and of shading one full-screen surface.
//!
//! `MSAA_BENCH_GRAPH` takes the frame apart to find where the samples cost:
//! `full` (the standard graph, default), `no-pre-pass` (shading writes
//! depth itself), `pre-pass` (the depth pre-pass alone), `unlit` (pre-pass,
//! then shading that clears and draws nothing: the colour target's clear,
//! store and resolve alone; `MSAA_BENCH_REPEAT=N` records that pass N
//! times, which tells a per-pass cost from a per-frame one). Another value
//! of either variable (a typo, a repeat that is not a whole number ≥ 1, a
//! repeat above 1 without `unlit`) ends the run with an error naming the
//! accepted ones; the record keeps `graph` and `repeat`.
//!
//! With `OXYGEN_RECORD_DIR` set, the run's figures (and every frame's
//! times) are appended to `$OXYGEN_RECORD_DIR/msaa_bench.jsonl`
//! (`oxygen_demo::record`).

use std::time::Instant;

use oxygen::glam::Vec4;
use oxygen::gpu::Msaa;
use oxygen::graph::PrePass;
use oxygen::prelude::*;
use oxygen_demo::record::{Record, Row};

/// What `MSAA_BENCH_GRAPH` renders (see the top comment).
#[derive(Clone, Copy)]
enum Graph {
    Full,
    NoPrePass,
    PrePass,
    Unlit,
}

impl Graph {
    const ALL: [Graph; 4] = [Graph::Full, Graph::NoPrePass, Graph::PrePass, Graph::Unlit];

    fn name(self) -> &'static str {
        match self {
            Graph::Full => "full",
            Graph::NoPrePass => "no-pre-pass",
            Graph::PrePass => "pre-pass",
            Graph::Unlit => "unlit",
        }
    }

    /// `MSAA_BENCH_GRAPH`, `full` when unset; an error naming the accepted
    /// values for any other.
    fn from_env() -> Result<Graph, String> {
        let Some(value) = env_var("MSAA_BENCH_GRAPH")? else {
            return Ok(Graph::Full);
        };
        Graph::ALL.into_iter().find(|g| g.name() == value).ok_or_else(|| {
            let names: Vec<&str> = Graph::ALL.iter().map(|g| g.name()).collect();
            format!("MSAA_BENCH_GRAPH={value:?}: expected one of {}", names.join(", "))
        })
    }
}

/// `MSAA_BENCH_REPEAT`, 1 when unset; an error for anything but a whole
/// number ≥ 1.
fn repeat_from_env() -> Result<usize, String> {
    let Some(value) = env_var("MSAA_BENCH_REPEAT")? else {
        return Ok(1);
    };
    value
        .parse::<usize>()
        .ok()
        .filter(|&n| n >= 1)
        .ok_or_else(|| format!("MSAA_BENCH_REPEAT={value:?}: expected a whole number of 1 or more"))
}

/// The variable's value, `None` when it is unset; an error when it is not
/// Unicode.
fn env_var(name: &str) -> Result<Option<String>, String> {
    match std::env::var(name) {
        Ok(value) => Ok(Some(value)),
        Err(std::env::VarError::NotPresent) => Ok(None),
        Err(std::env::VarError::NotUnicode(value)) => Err(format!("{name}={value:?} is not Unicode")),
    }
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(f64::NAN)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Both variables are read once, before anything runs: a bad value ends
    // the run here, not after it recorded a graph it did not render.
    let (graph, repeat) = match (Graph::from_env(), repeat_from_env()) {
        (Ok(graph), Ok(repeat)) if repeat > 1 && !matches!(graph, Graph::Unlit) => {
            eprintln!(
                "msaa_bench: MSAA_BENCH_REPEAT={repeat} repeats the unlit graph's pass: set MSAA_BENCH_GRAPH=unlit"
            );
            std::process::exit(2);
        }
        (Ok(graph), Ok(repeat)) => (graph, repeat),
        (Err(error), _) | (_, Err(error)) => {
            eprintln!("msaa_bench: {error}");
            std::process::exit(2);
        }
    };
    let mut args = std::env::args().skip(1);
    let width: u32 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(1920);
    let boxes: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(2500);
    let frames: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(30);
    let height = (width * 9 / 16).max(1);
    let colors = [Vec4::new(0.8, 0.3, 0.2, 1.0), Vec4::new(0.2, 0.5, 0.8, 1.0), Vec4::new(0.9, 0.8, 0.3, 1.0)];
    // `MSAA_BENCH_BOXES=0`-like control: with BOXES 0 only the ground plane
    // is drawn, which leaves the targets' clear, store and resolve.
    let (scene, side) = oxygen_demo::field_of_boxes(boxes, &colors);
    let side = side.max(20.0);
    let camera = LookAtResolver::new(
        Camera::perspective(50f32.to_radians(), 0.1, None),
        Vec3::new(-side * 0.2, side * 0.35, -side * 0.2),
        Vec3::new(side * 0.5, 0.0, side * 0.5),
        UVec2::new(width, height),
    )
    .unwrap();
    println!("{width}x{height}, {boxes} boxes, {frames} frames each");
    let mut baseline = None;
    let mut record = Record::new("msaa_bench")
        .value("viewport_px", [width, height])
        .value("boxes", boxes)
        .value("warm_up_frames", 3)
        .value("measured_frames", frames)
        .value("graph", graph.name())
        .value("repeat", repeat);
    for msaa in [Msaa::Off, Msaa::X2, Msaa::X4] {
        let mut renderer = Renderer::new_headless()?;
        record.set_adapter(&renderer.gpu().adapter_info);
        let samples = renderer.msaa_samples(msaa);
        let desc = ViewDesc::new(camera).with_msaa(msaa);
        match graph {
            Graph::NoPrePass => renderer.register_view(desc, StandardGraph::default().with_pre_pass(PrePass::Off))?,
            Graph::PrePass => {
                renderer.register_view(desc, async |ctx: &RenderContext<'_>, rec: &mut CommandRecorder| {
                    MeshPass::depth_pre_pass().run(ctx, rec).await
                })?
            }
            Graph::Unlit => {
                renderer.register_view(desc, async move |ctx: &RenderContext<'_>, rec: &mut CommandRecorder| {
                    MeshPass::depth_pre_pass().run(ctx, rec).await?;
                    let nothing = oxygen::sceneprep::PassMask::empty();
                    // Its empty shading pass `repeat` times: the cost of one
                    // more clear, store and resolve of the colour target.
                    for _ in 0..repeat {
                        MeshPass::forward_lit(ForwardLitConfig::default())
                            .with_masks(nothing, nothing)
                            .run(ctx, rec)
                            .await?;
                    }
                    Ok(())
                })?
            }
            Graph::Full => renderer.register_view(desc, standard_render_graph)?,
        };
        let (mut wall, mut gpu) = (Vec::new(), Vec::new());
        for i in 0..frames + 3 {
            let start = Instant::now();
            let report = renderer.render_frame(&scene)?;
            renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
            if i >= 3 {
                wall.push(start.elapsed().as_secs_f64() * 1e3);
                gpu.extend(report.gpu_seconds.map(|s| s * 1e3));
            }
        }
        let row = Row::new()
            .value("msaa", format!("{msaa:?}"))
            .value("samples_per_pixel", samples)
            .value("frame_ms_samples", &wall)
            .value("gpu_ms_samples", &gpu);
        let ms = median(&mut wall);
        let gpu_ms = median(&mut gpu);
        let base = *baseline.get_or_insert(ms);
        println!(
            "{msaa:?} ({samples} samples): frame {ms:8.2} ms  ×{:.2}  GPU {}  targets {:.1} MiB",
            ms / base,
            if gpu_ms.is_nan() { "n/a".to_owned() } else { format!("{gpu_ms:.2} ms") },
            renderer.target_memory() as f64 / (1 << 20) as f64,
        );
        record.push_row(
            row.value("frame_ms_median", ms)
                .value("ratio_to_one_sample", ms / base)
                .value("gpu_ms_median", (!gpu_ms.is_nan()).then_some(gpu_ms))
                .value("target_memory_bytes", renderer.target_memory()),
        );
    }
    record.write()?;
    Ok(())
}
