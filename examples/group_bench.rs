//! What spreading views over devices buys: a ring of V cameras around a
//! grid of boxes, one box moving every frame, rendered by a
//! [`RendererGroup`](oxygen::group::RendererGroup) of D devices (one per
//! GPU of the machine, or D devices of its one GPU), for each D of the list.
//!
//! ```text
//! cargo run --release --example group_bench BOXES WxH V D[,D..] [frames]
//! cargo run --release --example group_bench 1000 128x128 256 1,2 20
//! ```
//!
//! The scene and cameras are `batch_bench`'s (boxes on a grid of spacing
//! 2, cameras on a circle around it at 60° vertical field of view), each
//! camera a lone view with the standard graph; the group places them by
//! measured cost. Each measured frame moves one box (so a delta goes to
//! every replica), renders (`RendererGroup::render_frame`, which returns
//! when every member has recorded and submitted), then waits for every
//! member's GPU: that is the frame time. With `GROUP_BENCH_READBACK=1` it
//! then reads every view's colour back (`gather_colors`: one blocking copy
//! per view, from whichever device rendered it), timed on its own as the
//! gather; the frame plus the gather is the latency from a scene change to
//! every output in hand. `GROUP_BENCH_DETERMINISTIC=1` renders in the
//! deterministic mode. `GROUP_BENCH_ONE_GPU=1` puts every device on one GPU
//! (`RendererGroup::new_headless_spread`): what the members' CPU threads
//! alone gain, to tell from what more GPUs gain. Each line's adapters are
//! the members' PCI bus ids.
//!
//! Each line: D, the median frame time, view-frames per second (V ÷ it),
//! the speed-up over the first D of the list and its efficiency (speed-up ÷
//! D ÷ the first D), the delta's bytes a frame, the time making and applying
//! it, the gather's time, and the views each member ended with. With
//! `OXYGEN_RECORD_DIR` set everything is appended to
//! `$OXYGEN_RECORD_DIR/group_bench.jsonl` (`oxygen_demo::record`).

use std::time::Instant;

use oxygen::group::RendererGroup;
use oxygen::prelude::*;
use oxygen_demo::record::{Record, Row};

const WARM_UP: usize = 3;

/// The grid of `count` boxes, its side length and the box that moves.
fn box_grid(count: usize) -> (Scene, f32, oxygen::core::NodeKey) {
    let grid = oxygen_demo::box_grid(count);
    (grid.scene, grid.side, grid.first_box)
}

fn ring_camera(i: usize, n: usize, side: f32, size: UVec2) -> LookAtResolver {
    let eye = oxygen_demo::ring_eye(i, n, side);
    // A constant camera: valid by construction.
    LookAtResolver::new(Camera::perspective(60f32.to_radians(), 0.1, None), eye, Vec3::ZERO, size)
        .unwrap_or_else(|_| unreachable!("the ring's cameras are valid"))
}

fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted.get(sorted.len() / 2).copied().unwrap_or(f64::NAN)
}

fn flag(name: &str) -> Result<bool, String> {
    match std::env::var(name).as_deref() {
        Ok("1") => Ok(true),
        Ok("0") | Err(_) => Ok(false),
        Ok(other) => Err(format!("{name}={other}: use 0 or 1")),
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "usage: group_bench BOXES WxH V D[,D..] [frames]";
    let mut args = std::env::args().skip(1);
    let boxes: usize = args.next().ok_or(usage)?.parse()?;
    let size = args.next().ok_or(usage)?;
    let (w, h) = size.split_once('x').ok_or(usage)?;
    let size = UVec2::new(w.parse()?, h.parse()?);
    let views: usize = args.next().ok_or(usage)?.parse()?;
    let devices: Vec<usize> = args.next().ok_or(usage)?.split(',').map(str::parse).collect::<Result<_, _>>()?;
    let frames: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(10);
    if boxes == 0 || size.x == 0 || size.y == 0 || views == 0 || frames == 0 || devices.contains(&0) {
        return Err(usage.into());
    }
    let readback = flag("GROUP_BENCH_READBACK")?;
    let deterministic = flag("GROUP_BENCH_DETERMINISTIC")?;
    let one_gpu = flag("GROUP_BENCH_ONE_GPU")?;
    let options = RendererOptions { deterministic, target_budget_bytes: 16 << 30, ..Default::default() };
    let (mut scene, side, mover) = box_grid(boxes);

    let mut record = Record::new("group_bench")
        .value("boxes", boxes)
        .value("size_px", [size.x, size.y])
        .value("views", views)
        .value("warm_up_frames", WARM_UP)
        .value("measured_frames", frames)
        .value("readback", readback)
        .value("deterministic", deterministic)
        .value("one_gpu", one_gpu);
    println!(
        "| devices | frame ms | view-frames/s | speed-up | efficiency | delta B | replicate ms | gather ms | views per device |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---|");
    let mut base: Option<(usize, f64)> = None;
    for &d in &devices {
        let mut group = RendererGroup::new_headless_spread(d, options, !one_gpu)?;
        let buses: Vec<String> =
            (0..d).filter_map(|m| group.renderer(m)).map(|r| r.gpu().adapter_info.device_pci_bus_id.clone()).collect();
        if let Some(renderer) = group.renderer(0) {
            record.set_adapter(&renderer.gpu().adapter_info);
        }
        for i in 0..views {
            let camera = ring_camera(i, views, side, size);
            group.register_view(move || ViewDesc::new(camera), standard_render_graph)?;
        }
        let (mut frame_ms, mut gather_ms, mut replicate_ms, mut delta_bytes) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for frame in 0..WARM_UP + frames {
            let angle = frame as f32 * 0.37;
            let at = Vec3::new(angle.cos() * side * 0.25, 0.5, angle.sin() * side * 0.25);
            scene.set_local_transform(mover, Transform::from_translation(at))?;
            let start = Instant::now();
            let report = group.render_frame(&scene)?;
            for member in 0..group.devices() {
                if let Some(renderer) = group.renderer(member) {
                    renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
                }
            }
            let whole = start.elapsed().as_secs_f64() * 1e3;
            let gathered = Instant::now();
            if readback {
                let images = group.gather_colors()?;
                if images.len() != views {
                    return Err(format!("gathered {} of {views} images", images.len()).into());
                }
            }
            let gather = gathered.elapsed().as_secs_f64() * 1e3;
            if frame >= WARM_UP {
                frame_ms.push(whole);
                gather_ms.push(gather);
                replicate_ms.push(report.replicate_seconds * 1e3);
                delta_bytes.push(report.delta_bytes as f64);
            }
        }
        let per_device: Vec<usize> = (0..group.devices())
            .map(|m| (0..views as u32).filter(|v| group.member_of(oxygen::group::GroupViewId(*v)) == Some(m)).count())
            .collect();
        let frame = median(&frame_ms);
        let per_second = views as f64 / (frame / 1e3);
        let (speed_up, efficiency) = match base {
            Some((d0, f0)) => (f0 / frame, f0 / frame / (d as f64 / d0 as f64)),
            None => {
                base = Some((d, frame));
                (1.0, 1.0)
            }
        };
        println!(
            "| {d} | {frame:.3} | {per_second:.0} | {speed_up:.2} | {efficiency:.2} | {:.0} | {:.3} | {:.3} | {per_device:?} | {} |",
            median(&delta_bytes),
            median(&replicate_ms),
            median(&gather_ms),
            buses.join(" "),
        );
        record.push_row(
            Row::new()
                .value("devices", d)
                .value("frame_ms_median", frame)
                .value("frame_ms_samples", frame_ms.clone())
                .value("view_frames_per_second", per_second)
                .value("speed_up", speed_up)
                .value("efficiency", efficiency)
                .value("delta_bytes_median", median(&delta_bytes))
                .value("replicate_ms_median", median(&replicate_ms))
                .value("gather_ms_median", median(&gather_ms))
                .value("views_per_device", per_device)
                .value("adapters", buses.join(" ")),
        );
    }
    record.write()?;
    Ok(())
}
