//! What render nodes buy: a ring of V cameras around a grid of boxes (the
//! view benches' scene, one box moving every frame), rendered by N
//! `oxygen-node` processes joined to a coordinator on the loopback
//! interface, for each N of the list.
//!
//! ```text
//! cargo build --release -p oxygen-node --bins --examples
//! cargo run --release -p oxygen-node --example node_bench BOXES WxH V N[,N..] [frames]
//! cargo run --release -p oxygen-node --example node_bench 1000 128x128 256 1,2,3 20
//! ```
//!
//! The nodes are the `oxygen-node` program next to this example's
//! directory (`target/<profile>/oxygen-node`; `NODE_BENCH_NODE=PATH`
//! names another), started afresh for each N, each on the machine's first
//! GPU, or with `NODE_BENCH_SPREAD=1` node i on GPU i (`--gpu i`, one
//! node per GPU). Each measured frame moves one box, then
//! `Coordinator::render_frame` sends the delta and gathers every camera's
//! images (`NODE_BENCH_PLANES=color,depth,instances`, colour by default;
//! `none` reads nothing back: each view's output is then its tag, sent once
//! the node's GPU is done):
//! its time is the end-to-end latency (scene change to the last image in
//! hand), and V ÷ its median is the view-frames per second.
//! `NODE_BENCH_DETERMINISTIC=1` runs the nodes in the deterministic mode.
//!
//! Each line: N, the median latency, view-frames per second, speed-up over
//! the first N of the list and efficiency (speed-up ÷ N ÷ the first N),
//! the delta's bytes, the scene's bytes on the wire a frame (the delta to
//! each node), the images' megabytes a frame, the slowest node's render
//! time, the rest of the latency (sending, gathering, decoding: what
//! sharding over processes costs), the views per node, and a hash of the
//! last frame's images in view order (BLAKE3, 16 hex digits: with
//! `NODE_BENCH_DETERMINISTIC=1`, equal for every N). With
//! `OXYGEN_RECORD_DIR` set everything is appended to
//! `$OXYGEN_RECORD_DIR/node_bench.jsonl` (`oxygen_demo::record`).

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use glam::{DVec3, UVec2, Vec3};
use oxygen::gpu::{GpuContext, GpuOptions};
use oxygen_core::{Camera, Transform};
use oxygen_demo::record::{Record, Row};
use oxygen_node::{Coordinator, NetConfig, Planes, RigOptions, ViewSpec};

const WARM_UP: usize = 3;

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

fn planes() -> Result<Planes, String> {
    let Ok(list) = std::env::var("NODE_BENCH_PLANES") else { return Ok(Planes::default()) };
    let mut planes = Planes::NONE;
    for plane in list.split(',') {
        match plane {
            "none" => {}
            "color" => planes.color = true,
            "depth" => planes.depth = true,
            "instances" => planes.instances = true,
            other => return Err(format!("NODE_BENCH_PLANES: unknown plane {other:?} (color, depth, instances, none)")),
        }
    }
    Ok(planes)
}

/// The `oxygen-node` program: beside this example's directory.
fn node_program() -> Result<PathBuf, String> {
    if let Ok(path) = std::env::var("NODE_BENCH_NODE") {
        return Ok(PathBuf::from(path));
    }
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let path = exe.parent().and_then(|examples| examples.parent()).map(|dir| dir.join("oxygen-node"));
    match path {
        Some(path) if path.is_file() => Ok(path),
        _ => Err("no oxygen-node program beside this example: build it (cargo build [--release] -p oxygen-node --bins) or set NODE_BENCH_NODE".into()),
    }
}

/// Node processes, killed on drop.
struct Nodes(Vec<Child>);

impl Drop for Nodes {
    fn drop(&mut self) {
        for child in &mut self.0 {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

impl Nodes {
    /// Waits (bounded) for the nodes to stop after their coordinator.
    fn wait(&mut self, timeout: Duration) -> Result<(), String> {
        let started = Instant::now();
        for child in &mut self.0 {
            loop {
                if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
                    if !status.success() {
                        return Err(format!("a node exited with {status}"));
                    }
                    break;
                }
                if started.elapsed() > timeout {
                    return Err(format!("a node did not stop within {timeout:?} of its coordinator"));
                }
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        self.0.clear();
        Ok(())
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "usage: node_bench BOXES WxH V N[,N..] [frames]";
    let mut args = std::env::args().skip(1);
    let boxes: usize = args.next().ok_or(usage)?.parse()?;
    let size = args.next().ok_or(usage)?;
    let (w, h) = size.split_once('x').ok_or(usage)?;
    let size = UVec2::new(w.parse()?, h.parse()?);
    let views: usize = args.next().ok_or(usage)?.parse()?;
    let counts: Vec<usize> = args.next().ok_or(usage)?.split(',').map(str::parse).collect::<Result<_, _>>()?;
    let frames: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(10);
    if boxes == 0 || size.x == 0 || size.y == 0 || views == 0 || frames == 0 || counts.contains(&0) {
        return Err(usage.into());
    }
    let deterministic = flag("NODE_BENCH_DETERMINISTIC")?;
    let spread = flag("NODE_BENCH_SPREAD")?;
    let planes = planes()?;
    let program = node_program()?;
    let grid = oxygen_demo::box_grid(boxes);
    let (mut scene, side, mover) = (grid.scene, grid.side, grid.first_box);

    // The record names the adapter the nodes pick (the same rules, this machine).
    let context = GpuContext::new_headless(&GpuOptions::default())?;
    let mut record = Record::new("node_bench")
        .value("boxes", boxes)
        .value("size_px", [size.x, size.y])
        .value("views", views)
        .value("warm_up_frames", WARM_UP)
        .value("measured_frames", frames)
        .value("planes", format!("{planes:?}"))
        .value("deterministic", deterministic)
        .value("spread", spread);
    record.set_adapter(&context.adapter_info);
    drop(context);

    println!(
        "| nodes | latency ms | view-frames/s | speed-up | efficiency | delta B | scene on the wire B | images MB | slowest node's render ms | rest ms | views per node | last frame's hash |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|");
    let mut base: Option<(usize, f64)> = None;
    for &n in &counts {
        let rig = format!("bench-{}-{n}", std::process::id());
        let port = std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port();
        let endpoint = format!("tcp/127.0.0.1:{port}");
        let options = RigOptions { planes, ..Default::default() };
        let mut coordinator = Coordinator::new(&rig, &NetConfig::listen(&endpoint), options)?;
        let mut nodes = Nodes(Vec::new());
        for i in 0..n {
            let mut command = Command::new(&program);
            command.args(["--rig", &rig, "--name", &format!("n{i}"), "--connect", &endpoint, "--wait", "120"]);
            if spread {
                command.args(["--gpu", &i.to_string()]);
            }
            if deterministic {
                command.arg("--deterministic");
            }
            nodes.0.push(command.stdout(Stdio::null()).stderr(Stdio::inherit()).spawn()?);
        }
        coordinator.wait_for_nodes(n, Duration::from_secs(120))?;
        for i in 0..views {
            let eye = oxygen_demo::ring_eye(i, views, side);
            let camera = Camera::perspective(60f32.to_radians(), 0.1, None);
            let spec = ViewSpec::look_at(format!("cam{i}"), camera, eye.as_dvec3(), DVec3::ZERO, size);
            coordinator.add_view(spec)?;
        }
        let (mut latency_ms, mut render_ms, mut rest_ms) = (Vec::new(), Vec::new(), Vec::new());
        let (mut delta, mut wire, mut images) = (Vec::new(), Vec::new(), Vec::new());
        let mut hash = String::new();
        for frame in 0..WARM_UP + frames {
            let angle = frame as f32 * 0.37;
            let at = Vec3::new(angle.cos() * side * 0.25, 0.5, angle.sin() * side * 0.25);
            scene.set_local_transform(mover, Transform::from_translation(at))?;
            let report = coordinator.render_frame(&scene)?;
            if report.outputs.len() != views {
                return Err(format!("frame {}: {} of {views} views' images", report.frame, report.outputs.len()).into());
            }
            if frame + 1 == WARM_UP + frames {
                // The last frame's images, in view order: equal across
                // node counts in the deterministic mode.
                let mut hasher = blake3::Hasher::new();
                for output in &report.outputs {
                    hasher.update(&output.planes.to_payload());
                }
                hash = hasher.finalize().to_hex()[..16].to_owned();
            }
            if frame >= WARM_UP {
                let slowest = report.nodes.values().map(|n| n.render_seconds).fold(0.0, f64::max);
                latency_ms.push(report.latency_seconds * 1e3);
                render_ms.push(slowest * 1e3);
                rest_ms.push((report.latency_seconds - slowest) * 1e3);
                delta.push(report.delta_bytes as f64);
                wire.push(report.scene_wire_bytes as f64);
                images.push(report.image_bytes as f64 / 1e6);
            }
        }
        let mut per_node: BTreeMap<String, usize> = coordinator.nodes().into_iter().map(|n| (n, 0)).collect();
        for view in 0..views as u32 {
            if let Some(node) = coordinator.node_of(oxygen_node::RigViewId(view)) {
                *per_node.entry(node.to_owned()).or_default() += 1;
            }
        }
        let per_node: Vec<usize> = per_node.into_values().collect();
        drop(coordinator);
        nodes.wait(Duration::from_secs(60))?;

        let latency = median(&latency_ms);
        let per_second = views as f64 / (latency / 1e3);
        let (speed_up, efficiency) = match base {
            Some((n0, l0)) => (l0 / latency, l0 / latency / (n as f64 / n0 as f64)),
            None => {
                base = Some((n, latency));
                (1.0, 1.0)
            }
        };
        println!(
            "| {n} | {latency:.3} | {per_second:.0} | {speed_up:.2} | {efficiency:.2} | {:.0} | {:.0} | {:.2} | {:.3} | {:.3} | {per_node:?} | {hash} |",
            median(&delta),
            median(&wire),
            median(&images),
            median(&render_ms),
            median(&rest_ms),
        );
        record.push_row(
            Row::new()
                .value("nodes", n)
                .value("latency_ms_median", latency)
                .value("latency_ms_samples", latency_ms.clone())
                .value("view_frames_per_second", per_second)
                .value("speed_up", speed_up)
                .value("efficiency", efficiency)
                .value("delta_bytes_median", median(&delta))
                .value("scene_wire_bytes_median", median(&wire))
                .value("image_megabytes_median", median(&images))
                .value("slowest_render_ms_median", median(&render_ms))
                .value("rest_ms_median", median(&rest_ms))
                .value("views_per_node", per_node)
                .value("last_frame_hash", hash.clone()),
        );
    }
    record.write()?;
    Ok(())
}
