//! Render nodes over Zenoh on the loopback interface: `oxygen-node`
//! processes joining a coordinator in this test, one joining mid-run, one
//! paused (it falls behind), one killed; every view's images arrive once a
//! frame, equal bit for bit (the deterministic mode) to the same views
//! rendered here by one renderer.
//!
//! Every wait is bounded (the coordinator's stall timeout, the nodes' wait
//! for their coordinator), and the nodes stop by themselves when the
//! coordinator goes; the guard kills whatever is left if a check fails.

use std::collections::BTreeMap;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use oxygen::batch::{BatchDesc, StreamOptions};
use oxygen::gpu::{GpuContext, GpuOptions, Label, LabelSet};
use oxygen::prelude::*;
use oxygen_core::glam::DVec3;
use oxygen_node::wire::ImagePlanes;
use oxygen_node::{Coordinator, NetConfig, NodeOptions, Planes, RigOptions, RigViewId, ViewSpec, run_node};

const NODE: &str = env!("CARGO_BIN_EXE_oxygen-node");

/// The longest this test waits for anything (a node to join, a frame, the
/// nodes to stop): 120 s, enough for lavapipe on two busy cores, or
/// `OXYGEN_NODE_TEST_WAIT_S` seconds. Mutation testing sets it lower: a
/// mutant that makes a frame wait for ever then costs that much, not two
/// minutes.
fn longest_wait() -> Duration {
    let seconds = std::env::var("OXYGEN_NODE_TEST_WAIT_S").ok().and_then(|s| s.parse::<u64>().ok()).unwrap_or(120);
    Duration::from_secs(seconds.max(1))
}

/// Node processes, killed on drop (a failed check leaves none behind).
struct Nodes(BTreeMap<String, Child>);

impl Nodes {
    fn spawn(&mut self, rig: &str, name: &str, endpoint: &str) {
        let child = Command::new(NODE)
            .args([
                "--rig",
                rig,
                "--name",
                name,
                "--connect",
                endpoint,
                "--deterministic",
                "--wait",
                &longest_wait().as_secs().to_string(),
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap_or_else(|e| panic!("starting {NODE}: {e}"));
        self.0.insert(name.to_owned(), child);
    }

    fn signal(&self, name: &str, signal: &str) {
        let pid = self.0[name].id().to_string();
        let status = Command::new("kill").args([signal, &pid]).status().expect("kill");
        assert!(status.success(), "kill {signal} {pid}");
    }

    /// Waits (bounded) for every node left to exit by itself, successfully.
    fn wait_all(&mut self, timeout: Duration) {
        let started = Instant::now();
        for (name, child) in &mut self.0 {
            loop {
                if let Some(status) = child.try_wait().expect("try_wait") {
                    assert!(status.success(), "node {name} exited with {status}");
                    break;
                }
                assert!(started.elapsed() < timeout, "node {name} did not stop within {timeout:?} of its coordinator");
                std::thread::sleep(Duration::from_millis(50));
            }
        }
        self.0.clear();
    }
}

impl Drop for Nodes {
    fn drop(&mut self) {
        for child in self.0.values_mut() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// A port free on the loopback interface now.
fn free_port() -> u16 {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("bind 127.0.0.1:0");
    listener.local_addr().expect("local_addr").port()
}

/// Ten cameras around the grid: eight of 32 × 32, two of 48 × 32 (a
/// second batch on the nodes).
fn specs() -> Vec<ViewSpec> {
    (0..10)
        .map(|i| {
            let angle = i as f64 / 10.0 * std::f64::consts::TAU;
            let size = if i < 8 { UVec2::new(32, 32) } else { UVec2::new(48, 32) };
            ViewSpec::look_at(
                format!("cam{i}"),
                Camera::perspective(1.0, 0.1, None),
                DVec3::new(7.0 * angle.cos(), 4.0, 7.0 * angle.sin()),
                DVec3::ZERO,
                size,
            )
        })
        .collect()
}

const PLANES: Planes = Planes { color: true, depth: true, instances: true };

/// The same views rendered here by one renderer (batches by size,
/// streamed), by name.
struct Reference {
    renderer: Renderer,
    names: BTreeMap<ViewId, String>,
}

impl Reference {
    fn new(specs: &[ViewSpec]) -> Self {
        let mut renderer = Renderer::new_headless_with(RendererOptions { deterministic: true, ..Default::default() })
            .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
        let mut batches = BTreeMap::new();
        let mut names = BTreeMap::new();
        for spec in specs {
            let batch = *batches.entry((spec.size.x, spec.size.y)).or_insert_with(|| {
                // As a deterministic node: a page of its own for each camera.
                let desc = BatchDesc::new("reference", spec.size)
                    .with_label_planes(LabelSet::of(&[Label::Instance]))
                    .with_max_page_side(spec.size.x.max(spec.size.y));
                let batch = renderer.register_batch(desc).expect("batch");
                let stream = StreamOptions { color: true, depth: true, instances: true, ..Default::default() };
                renderer.stream_batch(batch, Some(stream)).expect("stream");
                batch
            });
            let id = renderer.add_camera(batch, spec.desc().expect("desc")).expect("camera");
            names.insert(id, spec.name.clone());
        }
        Reference { renderer, names }
    }

    fn render(&mut self, scene: &Scene) -> BTreeMap<String, ImagePlanes> {
        self.renderer.render_frame(scene).expect("reference frame");
        let mut images = BTreeMap::new();
        for frame in self.renderer.wait_streamed().expect("streamed") {
            for camera in frame.cameras() {
                let planes = ImagePlanes {
                    color: camera.color.map(<[u8]>::to_vec),
                    depth: camera.depth.map(<[f32]>::to_vec),
                    instances: camera.instances.map(<[u32]>::to_vec),
                };
                images.insert(self.names[&camera.view].clone(), planes);
            }
        }
        images
    }
}

#[test]
fn a_rig_renders_every_view_once_a_frame_through_a_join_a_stall_and_a_death() {
    let grid = oxygen_demo::box_grid(9);
    let (mut scene, moving) = (grid.scene, grid.first_box);
    let specs = specs();
    let mut reference = Reference::new(&specs);

    let rig = format!("test-{}", std::process::id());
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let options = RigOptions { planes: PLANES, stall_timeout: longest_wait(), ..Default::default() };
    let mut coordinator = Coordinator::new(&rig, &NetConfig::listen(&endpoint), options).expect("coordinator");
    let views: Vec<RigViewId> = specs.iter().map(|s| coordinator.add_view(s.clone()).expect("view")).collect();

    let mut nodes = Nodes(BTreeMap::new());
    nodes.spawn(&rig, "a", &endpoint);
    nodes.spawn(&rig, "b", &endpoint);
    coordinator.wait_for_nodes(2, longest_wait()).expect("two nodes");
    assert_eq!(coordinator.nodes(), ["a", "b"]);
    assert!(views.iter().all(|v| coordinator.view_cost(*v).is_none()), "no view is measured before it renders");

    let mut joined = Vec::new();
    let mut left = Vec::new();
    let mut stalled = Vec::new();
    let mut taken_over = 0;
    for frame in 1..=12u64 {
        match frame {
            // A third node joins: views move to it at once.
            4 => {
                nodes.spawn(&rig, "c", &endpoint);
                coordinator.wait_for_nodes(3, longest_wait()).expect("three nodes");
            }
            // c pauses (as a node overloaded or swapping would): it falls
            // behind within the stall timeout and its views render
            // elsewhere in that same frame.
            7 => {
                coordinator.set_stall_timeout(Duration::from_secs(3));
                nodes.signal("c", "-STOP");
            }
            // c goes on (and gets views back as the loads say); b dies.
            9 => {
                nodes.signal("c", "-CONT");
                coordinator.set_stall_timeout(longest_wait().min(Duration::from_secs(30)));
                nodes.signal("b", "-KILL");
            }
            _ => {}
        }
        // Frame 6 leaves the scene as it was: no scene bytes travel, and the
        // nodes render it from the replicas they hold.
        let still = frame == 6;
        if !still {
            scene
                .set_local_transform(
                    moving,
                    Transform::from_translation(Vec3::new(-2.0, 0.5 + frame as f32 * 0.1, -2.0)),
                )
                .expect("move");
        }
        let report = coordinator.render_frame(&scene).expect("rig frame");
        let expected = reference.render(&scene);

        assert_eq!(report.frame, frame);
        let got: Vec<RigViewId> = report.outputs.iter().map(|o| o.view).collect();
        assert_eq!(got, views, "frame {frame}: every view once, in view order");
        for output in &report.outputs {
            assert_eq!(output.frame, frame);
            let name = &specs[output.view.0 as usize].name;
            let want = &expected[name];
            assert_eq!(output.planes.color, want.color, "frame {frame}, {name} (from {}): colour", output.node);
            assert_eq!(output.planes.depth, want.depth, "frame {frame}, {name} (from {}): depth", output.node);
            assert_eq!(
                output.planes.instances, want.instances,
                "frame {frame}, {name} (from {}): instances",
                output.node
            );
        }
        let received: usize = report.outputs.iter().map(|o| PLANES.bytes(o.size)).sum();
        assert!(report.image_bytes >= received, "frame {frame}: {} bytes of images for {received}", report.image_bytes);
        if frame == 1 {
            assert!(
                report.delta_bytes > 0 && report.scene_wire_bytes >= 2 * report.delta_bytes,
                "a snapshot to each node"
            );
        } else if still {
            assert_eq!(
                (report.delta_bytes, report.scene_wire_bytes),
                (0, 0),
                "frame {frame}: the scene did not change"
            );
            assert!(report.taken_over.is_empty(), "frame {frame}: every node rendered its replica as it was");
        } else {
            assert!(
                report.delta_bytes > 0 && report.delta_bytes <= 95,
                "frame {frame}: {} bytes for one moved box",
                report.delta_bytes
            );
        }
        if frame == 4 {
            assert!(report.scene_wire_bytes > 3 * report.delta_bytes, "c got a snapshot");
            assert!(report.taken_over.is_empty(), "c rendered its first frame from its snapshot");
            let on_c = views.iter().filter(|v| coordinator.node_of(**v) == Some("c")).count();
            assert!(on_c >= 2, "after c joined: {on_c} views on it");
        }
        joined.extend(report.joined.clone());
        left.extend(report.left.clone());
        stalled.extend(report.stalled.clone());
        taken_over += report.taken_over.len();
        eprintln!(
            "frame {frame}: {:.3} s, delta {} B, scene on the wire {} B, images {} B, joined {:?}, left {:?}, stalled {:?}, taken over {:?}, moved {:?}",
            report.latency_seconds,
            report.delta_bytes,
            report.scene_wire_bytes,
            report.image_bytes,
            report.joined,
            report.left,
            report.stalled,
            report.taken_over,
            report.moved
        );
    }
    // Each view's cost is measured: seconds of a node's frame, a few
    // milliseconds for a 32 × 32 camera on any adapter.
    for view in &views {
        let cost = coordinator.view_cost(*view);
        assert!(cost.is_some_and(|c| c > 0.0 && c < 0.5), "{view}: cost {cost:?}");
    }
    assert_eq!(coordinator.nodes(), ["a", "c"], "b died");
    joined.sort();
    assert_eq!(joined, ["a", "b", "c"]);
    assert_eq!(stalled, ["c"], "c fell behind once");
    assert_eq!(left, ["b"], "b died");
    assert!(taken_over >= 2, "views of the stalled and the dead node rendered elsewhere ({taken_over})");
    assert!(views.iter().all(|v| coordinator.node_of(*v).is_some_and(|n| n != "b")));
    let on_c = views.iter().filter(|v| coordinator.node_of(**v) == Some("c")).count();
    assert!(on_c >= 1, "c caught up and got views back ({on_c})");
    nodes.0.remove("b").map(|mut b| b.wait());

    // The coordinator goes; the nodes stop by themselves.
    drop(coordinator);
    nodes.wait_all(longest_wait().min(Duration::from_secs(60)));
}

/// A node run in this process, as a program embedding one would, through
/// three frames of two views (two batches): what it returns when its
/// coordinator goes accounts for exactly what the coordinator saw (each
/// order rendered, each view's images, the bytes of scene it was sent and
/// of images it sent) and names the adapter that rendered.
#[test]
fn a_nodes_summary_accounts_for_what_its_coordinator_saw() {
    let rig = format!("summary-{}", std::process::id());
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let options = RigOptions { planes: PLANES, stall_timeout: longest_wait(), ..Default::default() };
    let mut coordinator = Coordinator::new(&rig, &NetConfig::listen(&endpoint), options).expect("coordinator");
    let specs = specs();
    for spec in [&specs[0], &specs[8]] {
        coordinator.add_view(spec.clone()).expect("view");
    }
    let mut node_options = NodeOptions::new(&rig, "here", &endpoint);
    node_options.coordinator_wait = longest_wait();
    let node = std::thread::spawn(move || run_node(&node_options));
    coordinator.wait_for_nodes(1, longest_wait()).expect("the node");

    let grid = oxygen_demo::box_grid(4);
    let (mut scene, moving) = (grid.scene, grid.first_box);
    let (mut image_bytes, mut scene_bytes) = (0, 0);
    for frame in 1..=3 {
        let at = Vec3::new(-1.0, 0.5 + frame as f32 * 0.1, -1.0);
        scene.set_local_transform(moving, Transform::from_translation(at)).expect("move");
        let report = coordinator.render_frame(&scene).expect("rig frame");
        assert_eq!(report.outputs.len(), 2, "frame {frame}");
        image_bytes += report.image_bytes;
        scene_bytes += report.scene_wire_bytes;
    }
    drop(coordinator);
    let summary = node.join().expect("the node's thread").expect("the node");
    assert_eq!((summary.frames, summary.view_frames), (3, 6));
    assert_eq!(summary.bytes_sent, image_bytes as u64, "the images sent are the images received");
    assert_eq!(summary.scene_bytes, scene_bytes as u64, "the scene received is the scene sent");
    let adapter = GpuContext::new_headless(&GpuOptions::default()).expect("an adapter").describe();
    assert_eq!(summary.adapter, adapter);
}

#[test]
fn a_node_without_a_coordinator_gives_up_with_a_clear_message() {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let output = Command::new(NODE)
        .args(["--rig", "nobody-here", "--name", "lonely", "--connect", &endpoint, "--wait", "2"])
        .output()
        .expect("run oxygen-node");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "{stderr}");
    assert!(stderr.contains("no coordinator of rig \"nobody-here\" within 2 s"), "{stderr}");

    let bad = Command::new(NODE).args(["--rig", "a/b", "--connect", &endpoint]).output().expect("run oxygen-node");
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success() && stderr.contains("rig \"a/b\" must be"), "{stderr}");

    // A GPU index past the bound: refused before any device is opened.
    let far = Command::new(NODE)
        .args(["--rig", "r", "--connect", &endpoint, "--gpu", "64"])
        .output()
        .expect("run oxygen-node");
    let stderr = String::from_utf8_lossy(&far.stderr);
    assert!(!far.status.success() && stderr.contains("--gpu: 64 (0 to 63)"), "{stderr}");
}

/// A coordinator's own bookkeeping, with no node: it answers to its rig's
/// name, and a view removed is gone (removing it again, or one never
/// added, is an error naming it).
#[test]
fn a_coordinator_knows_its_rig_and_forgets_a_removed_view() {
    let rig = format!("book-{}", std::process::id());
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let mut coordinator =
        Coordinator::new(&rig, &NetConfig::listen(&endpoint), RigOptions::default()).expect("coordinator");
    assert_eq!(coordinator.rig(), rig);
    let spec = specs().remove(0);
    let kept = coordinator.add_view(spec.clone()).expect("view");
    let removed = coordinator.add_view(spec).expect("view");
    coordinator.remove_view(removed).expect("a view just added is removed");
    assert!(
        matches!(coordinator.remove_view(removed), Err(oxygen_node::NodeError::NoSuchView(v)) if v == removed),
        "a removed view is gone"
    );
    assert!(matches!(coordinator.remove_view(RigViewId(99)), Err(oxygen_node::NodeError::NoSuchView(_))));
    coordinator.remove_view(kept).expect("the other view is still there");
}
