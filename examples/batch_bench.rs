//! What a view costs, one view at a time against one batch: a ring of V
//! cameras around a grid of boxes, each camera registered as a view of its
//! own (`standard_render_graph`, today's path) or as a camera of one batch
//! (`oxygen::batch`), with and without reading every camera's colour and
//! depth back each frame.
//!
//! ```text
//! cargo run --release --example batch_bench BOXES WxH V[,V..] [frames]
//! cargo run --release --example batch_bench 1000 128x128 1,16,64,256,1024 20
//! ```
//!
//! The scene: BOXES unit boxes on a square grid (spacing 2, four colours),
//! one sun without shadows. Camera `i` of V sits on a circle around the
//! grid (radius 0.65, height 0.35 of the grid's side, as `cubes_bench`) at
//! angle i / V of a turn, looking at the centre, 60° vertical field of
//! view, W × H pixels. Both paths decide visibility the same way:
//! `BATCH_BENCH_VISIBILITY=cpu` (the default: ScenePrep culls and emits
//! every camera's draws) or `gpu` (GPU frustum culling, a dispatch per
//! camera; where the adapter cannot, the bench refuses) or `occlusion`
//! (two-phase GPU occlusion culling; a batch's cameras are then culled one
//! by one). `BATCH_BENCH_DETERMINISTIC=1` turns the deterministic mode on
//! (`RendererOptions::deterministic`): its cost is the difference between
//! runs with and without it, made alternately.
//!
//! For each V the two paths run one after the other, in alternating order
//! from one V to the next (`BATCH_BENCH_MODES=views` or `batch` runs one):
//! WARM_UP frames, then the measured frames, each `render_frame` (its
//! wall-clock time is the CPU figure) then a wait for the GPU (the whole
//! frame); the GPU's own time comes from timestamps where the adapter has
//! them. With `BATCH_BENCH_READBACK=1` every camera's colour, depth and
//! instance labels are read back each frame (the cameras then draw labels
//! too): the lone views with `read_color`, `read_depth` and `read_labels`
//! (blocking copies each), the batch by streaming (one copy of its atlas'
//! pages a frame, taken each frame, waited for at the end of the frame).
//!
//! Each line also splits the CPU time into the frame's prepare step
//! (ScenePrep, uploads, targets and constants) and record step (`FrameReport`).
//!
//! Then the same number of frames runs again back to back, as a stream
//! would: no wait between frames (the batch's streamed images taken as
//! they arrive, the rest waited for after the last frame; lone views with
//! readback wait as before, their reads block), so the CPU of one frame
//! overlaps the GPU of the last. Its view-frames per second (V × frames ÷
//! the whole stretch) is the throughput column: it includes the first
//! frame's latency and the last one's drain, a large share of a short run.
//! A streamed batch's line adds the rate at which its frames arrived (the
//! stream's steady rate: the slope of a line through the arrival times) and
//! the median time from a frame's `render_frame` call to its images in
//! hand (its latency).
//! `BATCH_BENCH_SPANS=1` also adds up the time inside each of Oxygen's
//! `tracing` spans over the measured frames (`oxygen_demo::span_times`)
//! and prints the largest per frame: where the CPU time goes, on any
//! machine. The spans cost time of their own: compare figures of runs
//! with spans only with each other. `BATCH_BENCH_TRUST_INDIRECT=1` turns
//! wgpu's validation of indirect draws off (`RendererOptions::trust_indirect_args`);
//! `BATCH_BENCH_IN_FLIGHT=N` streams through a ring of N staging buffers
//! (`StreamOptions::frames_in_flight`, default 2);
//! `BATCH_BENCH_PLANES=color,depth,instances` picks what the batch streams
//! (those three by default; `semantic` and `linear_depth` are the GPU's
//! class and distance planes), and the batch draws only the label planes
//! it streams. `BATCH_BENCH_FLOOR_RECORD=raster_floor.jsonl`
//! compares each line's GPU time with the vertex floor of its draws (the
//! frame's draws × the per-cube time of that file's last `raster_floor`
//! run on this adapter, its storage-pulled line): run `raster_floor` on
//! the same machine first. `BATCH_BENCH_TARGET_BUDGET_MIB` raises the
//! targets' budget (`RendererOptions::target_budget_bytes`);
//! `BATCH_BENCH_TURN_DEGREES=D` turns the ring about the grid by D degrees
//! a frame, so that every camera has a new pose every frame (a rig on a
//! moving robot); by default the cameras stand still.
//! `BATCH_BENCH_SHADING=deferred` shades the batch in a compute pass after
//! a visibility pass (`BatchShading::Deferred`; the bench fails if a frame
//! falls back to forward shading); lone views shade forward.
//! `BATCH_BENCH_LIGHTS=N` adds N point lights without shadows over the
//! grid (each reaching every pixel: shading work per pixel).
//! `BATCH_BENCH_PRE_PASS=1` gives the batch a depth pre-pass
//! (`BatchGraph`'s `lit.depth_from_pre_pass`; lone views keep the standard
//! graph's). `BATCH_BENCH_MAX_PAGE_SIDE=S` caps the atlas' pages at S pixels
//! (`BatchDesc::with_max_page_side`): at the cameras' size, one camera a
//! page and a render pass per camera, which is what array layers cost
//! without multiview.
//! `BATCH_BENCH_INTERLEAVE=1` sets up one renderer per V and renders
//! them in turn, five frames each (the last three measured), V = 1, then
//! 256, then 1 024, then 1 again, …, so that a host whose speed drifts or
//! jumps while the bench runs slows every V alike instead of skewing the
//! slope below; it skips the back-to-back frames and cannot be combined
//! with spans.
//! Each line gives view-frames per second (V ÷ the median frame time); at
//! the end the slope of the median times against V (least squares over the
//! V list) is the per-view cost, CPU and whole frame, per path. With
//! `OXYGEN_RECORD_DIR` set, everything is appended to
//! `$OXYGEN_RECORD_DIR/batch_bench.jsonl` (`oxygen_demo::record`).

use std::time::Instant;

use oxygen::batch::{BatchDesc, BatchShading, StreamOptions, StreamedFrame};
use oxygen::core::ViewContext;

use oxygen::gpu::{Label, LabelSet};
use oxygen::prelude::*;
use oxygen::sceneprep::Visibility;
use oxygen_demo::record::{Record, Row};
use oxygen_demo::span_times::SpanTimes;

const WARM_UP: usize = 3;
const DEFAULT_MEASURED: usize = 10;
/// Spans printed per line with `BATCH_BENCH_SPANS=1` (all are recorded).
const SPANS_SHOWN: usize = 24;

/// The grid of `count` boxes and its side length, with `lights` point
/// lights without shadows (every one reaching every pixel: no range) on a
/// ring over it.
fn box_grid(count: usize, lights: usize) -> Result<(Scene, f32), String> {
    let mut grid = oxygen_demo::box_grid(count);
    for i in 0..lights {
        let angle = i as f32 / lights as f32 * std::f32::consts::TAU;
        let at = Vec3::new(angle.cos() * grid.side * 0.3, 3.0, angle.sin() * grid.side * 0.3);
        let node = grid.scene.add_node("lamp", Transform::from_translation(at));
        let light = Light { casts_shadows: false, ..Light::point(20.0, None) };
        grid.scene.set_light(node, Some(light)).map_err(|e| format!("a lamp: {e}"))?;
    }
    Ok((grid.scene, grid.side))
}

/// Camera `i` of `n` on the ring, turning about the vertical axis by
/// `turn` radians a frame (0: standing still).
fn ring_camera(i: usize, n: usize, side: f32, size: UVec2, turn: f32) -> Result<ViewDesc, Box<dyn std::error::Error>> {
    let eye = oxygen_demo::ring_eye(i, n, side);
    let look = LookAtResolver::new(Camera::try_perspective(60f32.to_radians(), 0.1, None)?, eye, Vec3::ZERO, size)?;
    if turn == 0.0 {
        return Ok(ViewDesc::new(look));
    }
    // A new pose every frame, as a rig's cameras on a moving robot have.
    Ok(ViewDesc::new(move |ctx: &ViewContext, scene: &Scene| {
        let rotation = glam::Quat::from_rotation_y(turn * ctx.frame_index as f32);
        LookAtResolver { eye: rotation * eye, ..look }.resolve(ctx, scene)
    }))
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Mode {
    Views,
    Batch,
}

/// One measured configuration.
struct Run {
    cpu_ms: Vec<f64>,
    /// The frame's prepare and record steps (`FrameReport`), CPU.
    prepare_ms: Vec<f64>,
    record_ms: Vec<f64>,
    frame_ms: Vec<f64>,
    gpu_ms: Vec<f64>,
    read_bytes: u64,
    /// Draws of every view of each measured frame (visible boxes, summed
    /// over the cameras: the vertex work).
    draws: Vec<f64>,
    /// View-frames per second of the frames run back to back.
    pipelined_per_second: f64,
    /// View-frames per second at which the streamed frames arrived while
    /// running back to back ([`arrival_period`]: the stream's steady rate,
    /// without the first frame's latency and the last one's drain); NaN
    /// without streaming.
    steady_per_second: f64,
    /// Milliseconds from a streamed frame's `render_frame` call to its
    /// images in hand, back to back (median); NaN without streaming.
    latency_ms: f64,
    /// Milliseconds per measured frame inside each span, largest first
    /// (`BATCH_BENCH_SPANS=1`).
    spans: Vec<(&'static str, f64)>,
    /// The same for the frames run back to back.
    back_to_back_spans: Vec<(&'static str, f64)>,
}

/// The span totals since the last take, in milliseconds per frame of
/// `frames`, largest first.
fn span_ms_per_frame(spans: &SpanTimes, frames: usize) -> Vec<(&'static str, f64)> {
    spans.take().into_iter().map(|(name, time, _)| (name, time.as_secs_f64() * 1e3 / frames as f64)).collect()
}

/// Bytes of every camera image of `frames`.
/// Bytes of `frames`' images, handing each back to `renderer` (its buffers
/// take a later frame, as a stream reader should).
fn streamed_bytes(renderer: &mut Renderer, frames: Vec<StreamedFrame>) -> u64 {
    let mut bytes = 0;
    for frame in frames {
        bytes += frame.bytes();
        renderer.recycle_streamed(frame);
    }
    bytes
}

/// Seconds between a stream's frames in its steady state: the slope of a
/// least-squares line through the arrival times, frame after frame (frames
/// are seen arriving only between `render_frame` calls, some late, a few
/// at once; the line spreads that over all of them). `None` for fewer than
/// three arrivals or no time between them.
fn arrival_period(arrived: &[(u64, Instant)], start: Instant) -> Option<f64> {
    if arrived.len() < 3 {
        return None;
    }
    let n = arrived.len() as f64;
    let times: Vec<f64> = arrived.iter().map(|(_, at)| at.duration_since(start).as_secs_f64()).collect();
    let mean_i = (n - 1.0) / 2.0;
    let mean_t = times.iter().sum::<f64>() / n;
    let (mut covariance, mut variance) = (0.0, 0.0);
    for (i, t) in times.iter().enumerate() {
        let di = i as f64 - mean_i;
        covariance += di * (t - mean_t);
        variance += di * di;
    }
    let slope = covariance / variance;
    (slope > 0.0).then_some(slope)
}

fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted[sorted.len() / 2]
}

/// What every measured configuration of a run shares.
struct Setup<'a> {
    side: f32,
    size: UVec2,
    mode: Mode,
    readback: bool,
    visibility: Visibility,
    options: &'a RendererOptions,
    in_flight: u32,
    planes: StreamOptions,
    max_page_side: Option<u32>,
    graph: &'a oxygen::batch::BatchGraph,
    turn: f32,
}

/// A renderer with V cameras registered, as `setup` says.
struct Rig {
    renderer: Renderer,
    ids: Vec<ViewId>,
    batch: Option<oxygen::batch::BatchId>,
    views: usize,
}

/// What one measured frame took.
struct Sample {
    cpu_ms: f64,
    prepare_ms: f64,
    record_ms: f64,
    frame_ms: f64,
    gpu_ms: Option<f64>,
    read_bytes: u64,
    draws: f64,
}

impl Run {
    fn new() -> Self {
        Run {
            cpu_ms: Vec::new(),
            prepare_ms: Vec::new(),
            record_ms: Vec::new(),
            frame_ms: Vec::new(),
            gpu_ms: Vec::new(),
            read_bytes: 0,
            draws: Vec::new(),
            pipelined_per_second: f64::NAN,
            steady_per_second: f64::NAN,
            latency_ms: f64::NAN,
            spans: Vec::new(),
            back_to_back_spans: Vec::new(),
        }
    }

    fn push(&mut self, sample: Sample) {
        self.cpu_ms.push(sample.cpu_ms);
        self.prepare_ms.push(sample.prepare_ms);
        self.record_ms.push(sample.record_ms);
        self.frame_ms.push(sample.frame_ms);
        self.gpu_ms.extend(sample.gpu_ms);
        self.read_bytes += sample.read_bytes;
        self.draws.push(sample.draws);
    }
}

/// A renderer with `views` cameras on the ring, as `setup` says.
fn rig(setup: &Setup<'_>, views: usize) -> Result<Rig, Box<dyn std::error::Error>> {
    let mut renderer = Renderer::new_headless_with(*setup.options)?;
    if setup.visibility.on_gpu() && !renderer.gpu_visibility_supported() {
        return Err(format!("{} cannot run GPU visibility", renderer.gpu().describe()).into());
    }
    let readback = setup.readback;
    let mut ids = Vec::with_capacity(views);
    // With readback every camera also draws the label planes streamed
    // (the lone views: instance ids), read back with its colour and depth.
    let batch = match setup.mode {
        Mode::Batch => {
            let desc = BatchDesc::new("ring", setup.size);
            let desc = if readback { desc.with_label_planes(streamed_labels(&setup.planes)) } else { desc };
            let desc = match setup.max_page_side {
                Some(side) => desc.with_max_page_side(side),
                None => desc,
            };
            Some(renderer.register_batch(desc.with_graph(setup.graph.clone()))?)
        }
        Mode::Views => None,
    };
    for i in 0..views {
        let desc = ring_camera(i, views, setup.side, setup.size, setup.turn)?.with_visibility(setup.visibility);
        let desc =
            if readback && batch.is_none() { desc.with_label_planes(LabelSet::of(&[Label::Instance])) } else { desc };
        ids.push(match batch {
            Some(batch) => renderer.add_camera(batch, desc)?,
            None => renderer.register_view(desc, standard_render_graph)?,
        });
    }
    if let (Some(batch), true) = (batch, readback) {
        let planes = StreamOptions { frames_in_flight: setup.in_flight, ..setup.planes };
        renderer.stream_batch(batch, Some(planes))?;
    }
    Ok(Rig { renderer, ids, batch, views })
}

/// Renders frame `frame` of `rig` and waits for the GPU: `render_frame`'s
/// wall-clock time is the CPU figure, to the end of the wait the whole
/// frame's.
fn measure_frame(
    rig: &mut Rig,
    setup: &Setup<'_>,
    scene: &Scene,
    frame: usize,
) -> Result<Sample, Box<dyn std::error::Error>> {
    let renderer = &mut rig.renderer;
    let start = Instant::now();
    let report = renderer.render_frame(scene)?;
    let cpu = start.elapsed().as_secs_f64() * 1e3;
    if let Some(warning) = report.warnings.first() {
        return Err(format!("frame {frame}: {warning}").into());
    }
    let deferred: u32 = report.views.iter().map(|v| v.recorded.deferred_views).sum();
    if setup.mode == Mode::Batch && setup.graph.shading == BatchShading::Deferred && deferred as usize != rig.views {
        return Err(format!("frame {frame}: {deferred} of {} cameras shaded deferred (see the log)", rig.views).into());
    }
    let mut bytes = 0u64;
    if setup.readback {
        match rig.batch {
            Some(_) => {
                let frames = renderer.wait_streamed()?;
                bytes += streamed_bytes(renderer, frames);
            }
            None => {
                for id in &rig.ids {
                    bytes += renderer.read_color(*id)?.len() as u64;
                    bytes += 4 * renderer.read_depth(*id)?.depth.len() as u64;
                    bytes += 4 * renderer.read_labels(*id)?.instances.len() as u64;
                }
            }
        }
    }
    renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
    Ok(Sample {
        cpu_ms: cpu,
        prepare_ms: report.prepare_seconds * 1e3,
        record_ms: report.record_seconds * 1e3,
        frame_ms: start.elapsed().as_secs_f64() * 1e3,
        gpu_ms: report.gpu_seconds.map(|s| s * 1e3),
        read_bytes: bytes,
        draws: report.views.iter().map(|v| v.draws as f64).sum(),
    })
}

/// The configurations `counts` measured in turn (`BATCH_BENCH_INTERLEAVE=1`):
/// one rig per V, then short blocks of frames of each V after the other
/// (V = counts[0], counts[1], …, counts[0] again) until each has `frames`
/// measured. A machine whose speed drifts or jumps while the bench runs (a
/// shared host's) then slows every V alike, instead of whichever V was
/// running, which skews a slope of time against V measured one V after the
/// other. The first frames of a block are not measured: they would pay
/// for the caches the other rigs' frames took (a V = 1 frame after a
/// thousand cameras' runs twice as long), which would bend the slope the
/// other way. No back-to-back frames in this mode.
fn run_interleaved(
    scene: &Scene,
    setup: &Setup<'_>,
    counts: &[usize],
    frames: usize,
) -> Result<Vec<Run>, Box<dyn std::error::Error>> {
    /// Frames of one rig in a row, and how many of them warm up again.
    const BLOCK: usize = 5;
    const REWARM: usize = 2;
    let mut rigs: Vec<Rig> = counts.iter().map(|v| rig(setup, *v)).collect::<Result<_, _>>()?;
    for rig in &mut rigs {
        for frame in 0..WARM_UP {
            measure_frame(rig, setup, scene, frame)?;
        }
    }
    let mut runs: Vec<Run> = counts.iter().map(|_| Run::new()).collect();
    let mut frame = WARM_UP;
    while runs.iter().any(|r| r.cpu_ms.len() < frames) {
        for (rig, run) in rigs.iter_mut().zip(&mut runs) {
            for k in 0..BLOCK {
                let sample = measure_frame(rig, setup, scene, frame)?;
                frame += 1;
                if k >= REWARM && run.cpu_ms.len() < frames {
                    run.push(sample);
                }
            }
        }
    }
    Ok(runs)
}

/// Renders `frames` measured frames of `views` cameras as `setup` says,
/// then as many back to back.
fn run(
    scene: &Scene,
    setup: &Setup<'_>,
    views: usize,
    frames: usize,
    spans: Option<&SpanTimes>,
) -> Result<Run, Box<dyn std::error::Error>> {
    let mut rig = rig(setup, views)?;
    let mut result = Run::new();
    for frame in 0..WARM_UP + frames {
        if frame == WARM_UP
            && let Some(spans) = spans
        {
            spans.take();
        }
        let sample = measure_frame(&mut rig, setup, scene, frame)?;
        if frame >= WARM_UP {
            result.push(sample);
        }
    }
    if let Some(spans) = spans {
        result.spans = span_ms_per_frame(spans, frames);
    }
    let (readback, batch) = (setup.readback, rig.batch);
    let renderer = &mut rig.renderer;
    // Back to back: the lone views' reads block, so only the batch (or
    // no readback) runs without waiting between frames.
    if !readback || batch.is_some() {
        let start = Instant::now();
        // When each frame was asked for, and when its images were in hand.
        let mut asked: Vec<(u64, Instant)> = Vec::with_capacity(frames);
        let mut arrived: Vec<(u64, Instant)> = Vec::with_capacity(frames);
        let mut note = |frames: &[StreamedFrame]| {
            let now = Instant::now();
            arrived.extend(frames.iter().map(|f| (f.frame, now)));
        };
        for _ in 0..frames {
            let called = Instant::now();
            let report = renderer.render_frame(scene)?;
            asked.push((report.frame_index, called));
            if readback {
                let frames = renderer.take_streamed()?;
                note(&frames);
                streamed_bytes(renderer, frames);
            }
        }
        if readback {
            let frames = renderer.wait_streamed()?;
            note(&frames);
            streamed_bytes(renderer, frames);
        }
        renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
        result.pipelined_per_second = (views * frames) as f64 / start.elapsed().as_secs_f64();
        if let Some(seconds_per_frame) = arrival_period(&arrived, start) {
            result.steady_per_second = views as f64 / seconds_per_frame;
            let latencies: Vec<f64> = arrived
                .iter()
                .filter_map(|(frame, at)| {
                    let called = asked.iter().find(|(f, _)| f == frame)?.1;
                    Some(at.duration_since(called).as_secs_f64() * 1e3)
                })
                .collect();
            result.latency_ms = median(&latencies);
        }
        if let Some(spans) = spans {
            result.back_to_back_spans = span_ms_per_frame(spans, frames);
        }
    }
    Ok(result)
}

/// The vertex floor of one cube on this adapter, milliseconds: the last
/// `raster_floor` record in `path` from an adapter of this name, its
/// `colour, pulled from storage` line (Oxygen's way of reading vertices)
/// divided by its cubes.
fn floor_ms_per_cube(path: &str, adapter: &str) -> Result<f64, Box<dyn std::error::Error>> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("BATCH_BENCH_FLOOR_RECORD={path}: {e}"))?;
    let mut found = None;
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let record: serde_json::Value = serde_json::from_str(line)?;
        if record["bench"] != "raster_floor" || record["adapter"]["name"] != adapter {
            continue;
        }
        let cubes = record["values"]["cubes"].as_f64().filter(|c| *c > 0.0);
        let rows = record["values"]["rows"].as_array();
        let pulled = rows.and_then(|rows| rows.iter().find(|r| r["way"] == "colour, pulled from storage"));
        if let (Some(cubes), Some(ms)) = (cubes, pulled.and_then(|r| r["gpu_ms_median"].as_f64())) {
            found = Some(ms / cubes);
        }
    }
    found.ok_or_else(|| format!("{path} holds no raster_floor record of {adapter} with a pulled line").into())
}

/// Least-squares slope and intercept of `y` against `x`.
fn fit(points: &[(f64, f64)]) -> (f64, f64) {
    let n = points.len() as f64;
    let (sx, sy) = points.iter().fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let sxx: f64 = points.iter().map(|(x, _)| (x - mx) * (x - mx)).sum();
    let sxy: f64 = points.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let slope = if sxx > 0.0 { sxy / sxx } else { f64::NAN };
    (slope, my - slope * mx)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "usage: batch_bench BOXES WxH V[,V..] [frames]";
    let mut args = std::env::args().skip(1);
    let boxes: usize = args.next().ok_or(usage)?.parse()?;
    let (w, h) = args.next().ok_or(usage)?.split_once('x').ok_or(usage).map(|(w, h)| (w.to_owned(), h.to_owned()))?;
    let size = UVec2::new(w.parse()?, h.parse()?);
    let counts: Vec<usize> = args.next().ok_or(usage)?.split(',').map(str::parse).collect::<Result<_, _>>()?;
    let frames: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(DEFAULT_MEASURED);
    if boxes == 0 || size.x == 0 || size.y == 0 || frames == 0 || counts.contains(&0) || counts.is_empty() {
        return Err(usage.into());
    }
    let readback = match std::env::var("BATCH_BENCH_READBACK").as_deref() {
        Ok("1") => true,
        Ok("0") | Err(_) => false,
        Ok(other) => return Err(format!("BATCH_BENCH_READBACK={other}: use 0 or 1").into()),
    };
    let visibility = match std::env::var("BATCH_BENCH_VISIBILITY").as_deref() {
        Ok("cpu") | Err(_) => Visibility::Cpu,
        Ok("gpu") => Visibility::GpuFrustum,
        Ok("occlusion") => Visibility::GpuOcclusion,
        Ok(other) => return Err(format!("BATCH_BENCH_VISIBILITY={other}: use cpu, gpu or occlusion").into()),
    };
    // The deterministic mode (`RendererOptions::deterministic`): run the
    // bench once with it and once without, alternately, to see its cost.
    let deterministic = match std::env::var("BATCH_BENCH_DETERMINISTIC").as_deref() {
        Ok("1") => true,
        Ok("0") | Err(_) => false,
        Ok(other) => return Err(format!("BATCH_BENCH_DETERMINISTIC={other}: use 0 or 1").into()),
    };
    let modes = match std::env::var("BATCH_BENCH_MODES").as_deref() {
        Ok("views") => vec![Mode::Views],
        Ok("batch") => vec![Mode::Batch],
        Ok("both") | Err(_) => vec![Mode::Views, Mode::Batch],
        Ok(other) => return Err(format!("BATCH_BENCH_MODES={other}: use views, batch or both").into()),
    };

    // Every V's frames in turn, one rig per V (see `run_interleaved`).
    let interleave = match std::env::var("BATCH_BENCH_INTERLEAVE").as_deref() {
        Ok("1") => true,
        Ok("0") | Err(_) => false,
        Ok(other) => return Err(format!("BATCH_BENCH_INTERLEAVE={other}: use 0 or 1").into()),
    };
    let spans = match std::env::var("BATCH_BENCH_SPANS").as_deref() {
        Ok("1") => Some(SpanTimes::install().ok_or("BATCH_BENCH_SPANS=1: a tracing subscriber is already set")?),
        Ok("0") | Err(_) => None,
        Ok(other) => return Err(format!("BATCH_BENCH_SPANS={other}: use 0 or 1").into()),
    };
    if interleave && spans.is_some() {
        return Err("BATCH_BENCH_INTERLEAVE=1 with BATCH_BENCH_SPANS=1: spans add up every rig's frames together; \
                    use one or the other"
            .into());
    }
    // wgpu's check of every indirect draw's arguments (a compute pass of
    // its own, recorded per indirect draw), on by default.
    let trust_indirect_args = match std::env::var("BATCH_BENCH_TRUST_INDIRECT").as_deref() {
        Ok("1") => true,
        Ok("0") | Err(_) => false,
        Ok(other) => return Err(format!("BATCH_BENCH_TRUST_INDIRECT={other}: use 0 or 1").into()),
    };
    let mut options = RendererOptions { trust_indirect_args, deterministic, ..RendererOptions::default() };
    // 1 024 cameras of 640 × 360 take more than the default target budget.
    if let Ok(mib) = std::env::var("BATCH_BENCH_TARGET_BUDGET_MIB") {
        let mib: u64 = mib.parse().map_err(|_| format!("BATCH_BENCH_TARGET_BUDGET_MIB={mib}: a count of MiB"))?;
        options.target_budget_bytes = mib << 20;
    }
    let in_flight: u32 = match std::env::var("BATCH_BENCH_IN_FLIGHT") {
        Ok(n) => n.parse().ok().filter(|n| *n > 0).ok_or(format!("BATCH_BENCH_IN_FLIGHT={n}: a count of 1 or more"))?,
        Err(_) => StreamOptions::default().frames_in_flight,
    };
    // Pages no larger than this (one camera a page at the camera's size: a
    // render pass per camera, what array layers would need without
    // multiview).
    let max_page_side = match std::env::var("BATCH_BENCH_MAX_PAGE_SIDE") {
        Ok(side) => Some(side.parse::<u32>().map_err(|_| format!("BATCH_BENCH_MAX_PAGE_SIDE={side}: pixels"))?),
        Err(_) => None,
    };
    // A depth pre-pass before the batch's shading (`BatchGraph::lit`'s
    // `depth_from_pre_pass`): each pixel shaded once, the vertices drawn twice.
    let pre_pass = match std::env::var("BATCH_BENCH_PRE_PASS").as_deref() {
        Ok("1") => true,
        Ok("0") | Err(_) => false,
        Ok(other) => return Err(format!("BATCH_BENCH_PRE_PASS={other}: use 0 or 1").into()),
    };
    // Where the batch's pixels are shaded (`BatchGraph::shading`).
    let shading = match std::env::var("BATCH_BENCH_SHADING").as_deref() {
        Ok("forward") | Err(_) => BatchShading::Forward,
        Ok("deferred") => BatchShading::Deferred,
        Ok(other) => return Err(format!("BATCH_BENCH_SHADING={other}: use forward or deferred").into()),
    };
    let mut graph = oxygen::batch::standard_batch_graph;
    graph.lit.depth_from_pre_pass = pre_pass;
    graph.shading = shading;
    // Cameras turning about the grid by this many degrees a frame: a new
    // pose for every camera every frame (0: standing still).
    let turn = match std::env::var("BATCH_BENCH_TURN_DEGREES") {
        Ok(degrees) => match degrees.parse::<f32>() {
            Ok(d) if d.is_finite() => d.to_radians(),
            _ => return Err(format!("BATCH_BENCH_TURN_DEGREES={degrees}: a finite number of degrees").into()),
        },
        Err(_) => 0.0,
    };
    // The batch's streamed planes (the lone views read all three).
    let planes = match std::env::var("BATCH_BENCH_PLANES") {
        Ok(list) => {
            let mut planes = StreamOptions { color: false, depth: false, instances: false, ..StreamOptions::default() };
            for plane in list.split(',') {
                match plane {
                    "color" => planes.color = true,
                    "depth" => planes.depth = true,
                    "instances" => planes.instances = true,
                    "semantic" => planes.semantic = true,
                    "linear_depth" => planes.linear_depth = true,
                    other => {
                        return Err(format!(
                            "BATCH_BENCH_PLANES: {other}? use color, depth, instances, semantic, linear_depth"
                        )
                        .into());
                    }
                }
            }
            planes
        }
        Err(_) => StreamOptions { instances: true, ..StreamOptions::default() },
    };
    // Point lights over the grid (shading work per pixel; none by default).
    let lights: usize = match std::env::var("BATCH_BENCH_LIGHTS") {
        Ok(n) => n.parse().map_err(|_| format!("BATCH_BENCH_LIGHTS={n}: a count"))?,
        Err(_) => 0,
    };
    let (scene, side) = box_grid(boxes, lights)?;
    let adapter = Renderer::new_headless()?.gpu().adapter_info.clone();
    // The vertex floor of the same work, from a raster_floor run of this
    // adapter: the GPU time is compared with draws × the floor per cube.
    let floor = match std::env::var("BATCH_BENCH_FLOOR_RECORD") {
        Ok(path) => Some((floor_ms_per_cube(&path, &adapter.name)?, path)),
        Err(_) => None,
    };
    let mut record = Record::new("batch_bench")
        .adapter(&adapter)
        .value("boxes", boxes)
        .value("size_px", [size.x, size.y])
        .value("warm_up_frames", WARM_UP)
        .value("measured_frames", frames)
        .value("readback", readback)
        .value("visibility", format!("{visibility:?}"))
        .value("spans", spans.is_some())
        .value("interleaved", interleave)
        .value("trust_indirect_args", trust_indirect_args)
        .value("deterministic", deterministic)
        .value("floor_ms_per_cube", floor.as_ref().map(|f| f.0))
        .value("floor_record", floor.as_ref().map(|f| &f.1))
        .value("target_budget_bytes", options.target_budget_bytes)
        .value("max_page_side", max_page_side)
        .value("pre_pass", pre_pass)
        .value("shading", format!("{shading:?}"))
        .value("lights", lights)
        .value("frames_in_flight", in_flight)
        .value(
            "streamed_planes",
            [planes.color, planes.depth, planes.instances, planes.semantic, planes.linear_depth].map(u8::from),
        );
    println!("adapter: {} {}", adapter.name, adapter.driver_info);
    println!(
        "| path | V | CPU ms | prepare ms | record ms | frame ms | GPU ms | view-frames/s | back to back vf/s | read MB/s |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut points: Vec<(Mode, f64, f64, f64)> = Vec::new();
    let setup_of = |mode| Setup {
        side,
        size,
        mode,
        readback,
        visibility,
        options: &options,
        in_flight,
        planes,
        max_page_side,
        graph: &graph,
        turn,
    };
    // Every configuration's measured frames, in the order they are printed.
    let mut measured: Vec<(usize, Mode, Run)> = Vec::new();
    if interleave {
        for mode in &modes {
            let runs = run_interleaved(&scene, &setup_of(*mode), &counts, frames)?;
            measured.extend(counts.iter().zip(runs).map(|(views, run)| (*views, *mode, run)));
        }
    } else {
        for (k, views) in counts.iter().enumerate() {
            let mut order = modes.clone();
            if k % 2 == 1 {
                order.reverse();
            }
            for mode in order {
                measured.push((*views, mode, run(&scene, &setup_of(mode), *views, frames, spans.as_ref())?));
            }
        }
    }
    for (views, mode, r) in measured {
        let (cpu, whole, gpu) = (median(&r.cpu_ms), median(&r.frame_ms), median(&r.gpu_ms));
        let per_second = views as f64 / (whole / 1e3);
        let seconds: f64 = r.frame_ms.iter().sum::<f64>() / 1e3;
        let read_mb_s = r.read_bytes as f64 / 1e6 / seconds;
        let (prepare, recording) = (median(&r.prepare_ms), median(&r.record_ms));
        let draws = median(&r.draws);
        let floor_ms = floor.as_ref().map(|(per_cube, _)| per_cube * draws);
        let over_floor = floor_ms.filter(|f| *f > 0.0 && gpu.is_finite()).map(|f| gpu / f);
        if let (Some(floor_ms), Some(over)) = (floor_ms, over_floor) {
            println!("    vertex floor of its {draws:.0} draws: {floor_ms:.3} ms; GPU time {over:.2}× it");
        }
        let pipelined = r.pipelined_per_second;
        println!(
            "| {mode:?} | {views} | {cpu:.3} | {prepare:.3} | {recording:.3} | {whole:.3} | {gpu:.3} | {per_second:.0} | {pipelined:.0} | {read_mb_s:.1} |"
        );
        if r.steady_per_second.is_finite() {
            println!(
                "    streamed back to back: {:.0} view-frames/s steady (arrivals' slope), {:.1} ms from render_frame to images in hand",
                r.steady_per_second, r.latency_ms
            );
        }
        for (name, ms) in r.spans.iter().take(SPANS_SHOWN) {
            println!("    span {name}: {ms:.3} ms a frame");
        }
        for (name, ms) in r.back_to_back_spans.iter().take(SPANS_SHOWN) {
            println!("    back to back, span {name}: {ms:.3} ms a frame");
        }
        points.push((mode, views as f64, cpu, whole));
        record.push_row(
            Row::new()
                .value("path", format!("{mode:?}"))
                .value("views", views)
                .value("cpu_ms_median", cpu)
                .value("prepare_ms_median", prepare)
                .value("record_ms_median", recording)
                .value("frame_ms_median", whole)
                .value("gpu_ms_median", gpu.is_finite().then_some(gpu))
                .value("view_frames_per_second", per_second)
                .value("draws_per_frame_median", draws)
                .value("vertex_floor_ms", floor_ms)
                .value("gpu_over_vertex_floor", over_floor)
                .value("back_to_back_view_frames_per_second", pipelined.is_finite().then_some(pipelined))
                .value(
                    "streamed_steady_view_frames_per_second",
                    r.steady_per_second.is_finite().then_some(r.steady_per_second),
                )
                .value("streamed_latency_ms_median", r.latency_ms.is_finite().then_some(r.latency_ms))
                .value("span_ms_per_frame", r.spans.iter().fold(Row::new(), |row, (name, ms)| row.value(name, *ms)))
                .value(
                    "back_to_back_span_ms_per_frame",
                    r.back_to_back_spans.iter().fold(Row::new(), |row, (name, ms)| row.value(name, *ms)),
                )
                .value("read_bytes", r.read_bytes)
                .value("read_mb_per_second", read_mb_s)
                .value("cpu_ms_samples", r.cpu_ms)
                .value("prepare_ms_samples", r.prepare_ms)
                .value("record_ms_samples", r.record_ms)
                .value("frame_ms_samples", r.frame_ms)
                .value("gpu_ms_samples", r.gpu_ms),
        );
    }
    if counts.len() > 1 {
        for mode in &modes {
            let of = |pick: fn(&(Mode, f64, f64, f64)) -> f64| -> Vec<(f64, f64)> {
                points.iter().filter(|p| p.0 == *mode).map(|p| (p.1, pick(p))).collect()
            };
            let (cpu_slope, _) = fit(&of(|p| p.2));
            let (frame_slope, frame_intercept) = fit(&of(|p| p.3));
            println!(
                "{mode:?}: per view {:.1} µs CPU, {:.1} µs whole frame (intercept {frame_intercept:.3} ms)",
                cpu_slope * 1e3,
                frame_slope * 1e3
            );
            record.push_row(
                Row::new()
                    .value("path", format!("{mode:?}"))
                    .value("per_view_cpu_us", cpu_slope * 1e3)
                    .value("per_view_frame_us", frame_slope * 1e3)
                    .value("frame_intercept_ms", frame_intercept),
            );
        }
    }
    record.write()?;
    Ok(())
}

/// The label planes a batch draws to stream `planes`: only those.
fn streamed_labels(planes: &StreamOptions) -> LabelSet {
    let wanted = [
        (planes.instances, Label::Instance),
        (planes.semantic, Label::Semantic),
        (planes.linear_depth, Label::LinearDepth),
    ];
    wanted.into_iter().filter(|(on, _)| *on).fold(LabelSet::NONE, |set, (_, label)| set.with(label))
}
