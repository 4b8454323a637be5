//! The interactive viewer: a glTF file in a window.
//!
//! ```text
//! cargo run --release --example viewer -- [FILE] [--size WxH] [--present fifo|mailbox|immediate]
//!                                         [--frames N --screenshot PATH]
//!                                         [--time T] [--animation N|NAME] [--fps F]
//!                                         [--msaa 1|2|4] [--environment sky|none|FILE.hdr] [--costs]
//! ```
//!
//! The scene is lit by an environment (image-based lighting): by default a
//! procedural sky matched to its sun, drawn behind it; `--environment
//! FILE.hdr` takes an equirectangular Radiance image, `none` the constant
//! ambient term.
//!
//! FILE defaults to the shipped `assets/AlphaBlendModeTest/AlphaBlendModeTest.glb`.
//!
//! * Mouse: drag with the left button to orbit (or look around in fly
//!   mode), wheel to zoom. Keys: `W` `A` `S` `D` `Q` `E` move in fly mode,
//!   `F` switches between orbit and fly cameras.
//! * Layouts: `1` one view; `2` a 2 × 2 layout (the file's cameras first,
//!   then orthographic views from the front, the side and above); `3` the
//!   main view with its sun's four shadow cascades shown as small viewports
//!   along the bottom (depth as grey); `4` the main view with a
//!   picture-in-picture from above; `5` an editor's 2 × 2: the main
//!   perspective view and orthographic front, side and top views.
//! * Knobs: `V` cycles the main view's visibility path (CPU, GPU frustum,
//!   GPU occlusion; the GPU paths where the adapter has them), `P` the depth
//!   pre-pass (automatic, on, off), `C` the sun's cascade count (1 to 4),
//!   `R` the shadow maps' resolution (512, 1024, 2048), `K` the shadow
//!   filter's radius (PCF 0, 1, 2), `M` the main view's anti-aliasing
//!   (MSAA 1, 2, 4 samples; `--msaa N` starts with N).
//! * On screen (the overlay): the frame's timings (prepare, record, GPU,
//!   whole frame) in the main view's top-left corner and each other view's
//!   own GPU time in its corner; the title bar shows the knobs. `--hud off`
//!   puts the timings back in the title and draws nothing over the views.
//!   In the editor layout the perspective cell shows the other views'
//!   frusta (and its shadow cascades'), each named.
//! * Click (press and release without dragging) on the main view selects
//!   the node under the cursor and outlines it (`Renderer::pick`,
//!   `Overlay::set_outline`; the main view draws instance labels for it,
//!   and when it is multisampled, where labels are refused, both come from
//!   an ID render); a click on nothing clears the selection.
//!   `--select X,Y` clicks at window pixel (X, Y) after the first frame
//!   (for tests). `--costs` also prints
//!   every view's costs from the frame report (why it rendered, CPU
//!   prepare and record time, GPU time, draws, triangles, bytes uploaded
//!   and streamed back, target memory) as a table, every 60th frame and at
//!   the last frame of a `--frames` run.
//! * `--frames N --screenshot PATH` renders N frames, saves what was
//!   presented last as a PNG and exits: for tests and for people without a
//!   desktop (run it under `xvfb-run`). `--resize WxH` asks for a new
//!   window size after the first frame and counts the N frames from when
//!   the window has it (the test of resizing a real surface).
//! * Animation: a file with animations plays its first (or the one
//!   `--animation` names) from `--time T` (default 0), in real time and
//!   looping; with `--fps F` each frame advances 1/F s instead (no loop),
//!   and with `--screenshot PATH` every frame is saved as a numbered
//!   sequence, `PATH` with `_0000`, `_0001`, ... before its extension.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use oxygen::core::DAabb;
use oxygen::glam::DVec3;
use oxygen::glam::Vec2;
use oxygen::gpu::Msaa;
use oxygen::graph::PrePass;
use oxygen::import::GltfCamera;
use oxygen::lighting::CascadeSettings;
use oxygen::overlay::{Outline, Rgba};
use oxygen::prelude::*;
use oxygen::sceneprep::Visibility;
use oxygen::views::{DLookAtResolver, ResolvedView, ViewContext, ViewError};
use oxygen::windows::{PresentMode, WindowId, WindowRect};
use oxygen_demo::OrbitCamera;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowAttributes};

const USAGE: &str = "\
usage: viewer [FILE] [--size WxH] [--present fifo|mailbox|immediate] [--layout 1|2|3|4|5] [--frames N --screenshot PATH [--resize WxH]] [--time T] [--animation N|NAME] [--fps F] [--msaa 1|2|4] [--environment sky|none|FILE.hdr] [--costs] [--hud on|off] [--select X,Y]";

/// The parsed command line.
struct Args {
    file: PathBuf,
    size: UVec2,
    present: PresentMode,
    frames: Option<u64>,
    screenshot: Option<PathBuf>,
    /// A window size asked for after the first frame.
    resize: Option<UVec2>,
    layout: Layout,
    /// Seconds into the animation of the first frame.
    time: f32,
    /// Which animation (index or name); `None`: the first.
    animation: Option<String>,
    /// Fixed frame rate of the animation clock; `None`: real time.
    fps: Option<f32>,
    /// The main view's anti-aliasing at start.
    msaa: Msaa,
    /// `sky` (default), `none`, or an `.hdr` file.
    environment: String,
    /// Print each view's costs (`--costs`).
    costs: bool,
    /// Timings drawn over the views (`--hud on`, the default) or in the title.
    hud: bool,
    /// A click at this window pixel after the first frame (`--select X,Y`).
    select: Option<(f64, f64)>,
}

/// Every view's costs in `report` as a table (`--costs`): one line a view,
/// then the frame's totals.
fn print_costs(frame: u64, report: &oxygen::FrameReport) {
    let ms = |s: Option<f64>| s.map_or("n/a".to_owned(), |s| format!("{:.3}", s * 1e3));
    println!("costs of frame {frame}:");
    println!(
        "| view | role | why | prepare ms | record ms | GPU ms | draws | triangles | uploaded B | streamed B | targets MiB |"
    );
    println!("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for v in &report.views {
        println!(
            "| {} | {:?} | {} | {:.3} | {:.3} | {} | {} | {} | {} | {} | {:.2} |",
            v.name.as_deref().map_or_else(|| v.view.to_string(), str::to_owned),
            v.role,
            v.why.map_or("follows its owner".to_owned(), |w| format!("{w:?}")),
            v.prep_seconds * 1e3,
            v.record_seconds * 1e3,
            ms(v.gpu_seconds),
            v.draws,
            v.triangles.map_or("n/a".to_owned(), |t| t.to_string()),
            v.uploaded_bytes,
            v.streamed_bytes,
            v.target_bytes as f64 / f64::from(1 << 20),
        );
    }
    println!(
        "| frame | | | {:.3} | {:.3} | {} | | | {} | | |",
        report.prepare_seconds * 1e3,
        report.record_seconds * 1e3,
        ms(report.gpu_seconds),
        report.uploaded_bytes
    );
}

fn parse_size(name: &str, v: &str) -> Result<UVec2, String> {
    let (w, h) = v.split_once('x').ok_or(format!("{name} needs WxH"))?;
    let size = UVec2::new(w.parse().map_err(|_| "bad width")?, h.parse().map_err(|_| "bad height")?);
    if size.x == 0 || size.y == 0 {
        return Err(format!("{name} must be at least 1x1"));
    }
    Ok(size)
}

fn parse_args(mut args: impl Iterator<Item = String>) -> Result<Args, String> {
    let mut parsed = Args {
        file: PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/AlphaBlendModeTest/AlphaBlendModeTest.glb")),
        size: UVec2::new(960, 600),
        present: PresentMode::Fifo,
        frames: None,
        screenshot: None,
        resize: None,
        layout: Layout::Single,
        time: 0.0,
        animation: None,
        fps: None,
        msaa: Msaa::Off,
        environment: "sky".to_owned(),
        costs: false,
        hud: true,
        select: None,
    };
    while let Some(arg) = args.next() {
        let mut value = |name: &str| args.next().ok_or(format!("{name} needs a value"));
        match arg.as_str() {
            "--size" => parsed.size = parse_size("--size", &value("--size")?)?,
            "--resize" => parsed.resize = Some(parse_size("--resize", &value("--resize")?)?),
            "--present" => {
                parsed.present = match value("--present")?.as_str() {
                    "fifo" => PresentMode::Fifo,
                    "mailbox" => PresentMode::Mailbox,
                    "immediate" => PresentMode::Immediate,
                    other => return Err(format!("unknown present mode '{other}'")),
                }
            }
            "--time" => {
                let v = value("--time")?;
                parsed.time = v
                    .parse::<f32>()
                    .ok()
                    .filter(|t| t.is_finite())
                    .ok_or(format!("--time needs a finite number of seconds (got '{v}')"))?;
            }
            "--animation" => parsed.animation = Some(value("--animation")?),
            "--environment" => parsed.environment = value("--environment")?,
            "--msaa" => {
                let v = value("--msaa")?;
                parsed.msaa = v
                    .parse::<u32>()
                    .ok()
                    .and_then(Msaa::from_samples)
                    .ok_or(format!("--msaa needs 1, 2 or 4 (got '{v}')"))?;
            }
            "--fps" => {
                let v = value("--fps")?;
                let fps = v.parse::<f32>().ok().filter(|f| f.is_finite() && *f > 0.0);
                parsed.fps = Some(fps.ok_or(format!("--fps needs a positive number (got '{v}')"))?);
            }
            "--costs" => parsed.costs = true,
            "--hud" => {
                parsed.hud = match value("--hud")?.as_str() {
                    "on" => true,
                    "off" => false,
                    other => return Err(format!("--hud needs on or off (got '{other}')")),
                }
            }
            "--select" => {
                let v = value("--select")?;
                let (x, y) = v.split_once(',').ok_or(format!("--select needs X,Y (got '{v}')"))?;
                let coordinate = |c: &str| c.parse::<f64>().ok().filter(|c| c.is_finite() && *c >= 0.0);
                parsed.select = Some(
                    coordinate(x)
                        .zip(coordinate(y))
                        .ok_or(format!("--select needs two pixel coordinates (got '{v}')"))?,
                );
            }
            "--frames" => parsed.frames = Some(value("--frames")?.parse().map_err(|_| "--frames needs a number")?),
            "--screenshot" => parsed.screenshot = Some(PathBuf::from(value("--screenshot")?)),
            "--layout" => {
                parsed.layout = match value("--layout")?.as_str() {
                    "1" => Layout::Single,
                    "2" => Layout::Grid,
                    "3" => Layout::Cascades,
                    "4" => Layout::PictureInPicture,
                    "5" => Layout::Editor,
                    other => return Err(format!("unknown layout '{other}' (1 to 5)")),
                }
            }
            "-h" | "--help" => return Err(String::new()),
            flag if flag.starts_with('-') => return Err(format!("unknown option '{flag}'")),
            _ => parsed.file = PathBuf::from(arg),
        }
    }
    if parsed.screenshot.is_some() && parsed.frames.is_none() {
        parsed.frames = Some(3);
    }
    Ok(parsed)
}

/// The main camera, moved by the mouse and keyboard, read by its resolver:
/// an orbit camera (oxygen-demo's, which tests render headlessly), or a
/// fly camera at `eye` looking along the orbit's direction.
#[derive(Clone, Copy, Debug)]
struct CameraState {
    orbit: OrbitCamera,
    fly: bool,
    eye: DVec3,
}

impl CameraState {
    fn forward(&self) -> Vec3 {
        self.orbit.forward()
    }
    fn resolver(&self) -> DLookAtResolver {
        // The window's rectangle decides the size.
        let orbit = self.orbit.resolver(UVec2::new(16, 9));
        if self.fly {
            DLookAtResolver { eye: self.eye, target: self.eye + self.forward().as_dvec3(), ..orbit }
        } else {
            orbit
        }
    }
}

/// Resolves the shared camera state each frame.
struct SharedCamera(Arc<Mutex<CameraState>>);

impl ViewResolver for SharedCamera {
    fn resolve(&self, ctx: &ViewContext, scene: &Scene) -> Result<ResolvedView, ViewError> {
        let state = *self.0.lock().unwrap_or_else(|e| e.into_inner());
        state.resolver().resolve(ctx, scene)
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Layout {
    Single,
    Grid,
    Cascades,
    PictureInPicture,
    /// Perspective plus orthographic front, side and top.
    Editor,
}

struct Viewer {
    args: Args,
    scene: Scene,
    cameras: Vec<GltfCamera>,
    /// The scene's bounds in f64: framing does not depend on where the
    /// scene sits.
    bounds: DAabb,
    camera: Arc<Mutex<CameraState>>,
    renderer: Option<Renderer>,
    window: Option<Arc<Window>>,
    window_id: Option<WindowId>,
    views: Vec<ViewId>,
    layout: Layout,
    visibility: Visibility,
    pre_pass: PrePass,
    cascades: CascadeSettings,
    pcf_radius: u32,
    msaa: Msaa,
    frames: u64,
    /// The window's size as the renderer last heard it.
    window_size: UVec2,
    /// Frames rendered while waiting for `--resize` to take effect.
    frames_before_resize: u64,
    dragging: bool,
    /// Whether the mouse moved while pressed (a drag, not a click).
    dragged: bool,
    last_cursor: Option<(f64, f64)>,
    /// A click waiting to be picked after the next frame.
    click: Option<(f64, f64)>,
    /// The selected node (its stable id), outlined.
    selected: Option<u32>,
    /// The last frame's timings, drawn over the next.
    hud_text: Vec<(ViewId, String)>,
    error: Option<String>,
    /// The animation that poses the scene, if the file has one.
    animation: Option<oxygen::core::Animation>,
    /// When the real-time animation clock started (the first frame).
    clock: Option<Instant>,
    /// The pose's time in the last frame, for the title.
    pose_time: Option<f32>,
    /// The environment lighting the scene, given to the renderer once it exists.
    environment: Option<oxygen::core::Environment>,
}

impl Viewer {
    fn rebuild_views(&mut self) -> Result<(), RenderError> {
        let (Some(renderer), Some(window)) = (self.renderer.as_mut(), self.window_id) else { return Ok(()) };
        for view in self.views.drain(..) {
            for cascade in renderer.sun_cascades(view) {
                renderer.hide_from_window(cascade);
            }
            renderer.unregister_view(view)?;
        }
        let mut graph = standard_render_graph.with_pre_pass(self.pre_pass);
        graph.lit.shadow_pcf_radius = self.pcf_radius;
        let cascades = self.cascades;
        let msaa = self.msaa;
        // Instance labels for picking and the outline, where the view can
        // draw them (a multisampled one uses ID renders instead).
        let main = |rect| {
            let desc = ViewDesc::new(SharedCamera(Arc::clone(&self.camera)))
                .shown_in(window, rect)
                .with_sun_shadows(cascades)
                .with_msaa(msaa)
                .named("main");
            if msaa == Msaa::Off {
                desc.with_label_planes(oxygen::gpu::LabelSet::of(&[oxygen::gpu::Label::Instance]))
            } else {
                desc
            }
        };
        let center = self.bounds.center();
        let radius = (self.bounds.half_extents().length() as f32).max(1e-3);
        let orbit = |direction: Vec3, up: Vec3| DLookAtResolver {
            camera: Camera::perspective(45f32.to_radians(), radius * 0.01, None),
            eye: center + (direction.normalize() * radius * 2.2).as_dvec3(),
            target: center,
            up,
            viewport: UVec2::new(16, 9),
        };
        let bounds = self.bounds;
        let axis_view = |from: Vec3, up: Vec3| oxygen_demo::editor_axis_view(&bounds, from, up);
        let axes = oxygen_demo::EDITOR_AXES;
        match self.layout {
            Layout::Single => {
                self.views.push(
                    renderer.register_view(main(WindowRect::FULL).with_visibility(self.visibility), graph.clone())?,
                );
            }
            Layout::Grid => {
                let main_view = main(WindowRect::grid(2, 2, 0, 0)).with_visibility(self.visibility);
                self.views.push(renderer.register_view(main_view, graph.clone())?);
                let mut others: Vec<Box<dyn ViewResolver>> = self
                    .cameras
                    .iter()
                    .take(3)
                    .map(|c| Box::new(c.resolver(UVec2::new(16, 9))) as Box<dyn ViewResolver>)
                    .collect();
                for (direction, up) in axes.iter().skip(others.len()) {
                    others.push(Box::new(axis_view(*direction, *up)));
                }
                for (i, resolver) in others.into_iter().take(3).enumerate() {
                    // Cells after the main view's, row by row.
                    let cell_index = i as u32 + 1;
                    let cell = WindowRect::grid(2, 2, cell_index % 2, cell_index / 2);
                    let desc = ViewDesc::new(BoxedResolver(resolver)).shown_in(window, cell);
                    self.views.push(renderer.register_view(desc, graph.clone())?);
                }
            }
            Layout::Editor => {
                let main_view = main(WindowRect::grid(2, 2, 0, 0)).with_visibility(self.visibility);
                self.views.push(renderer.register_view(main_view, graph.clone())?);
                for (i, (direction, up)) in axes.iter().enumerate() {
                    let cell_index = i as u32 + 1;
                    let cell = WindowRect::grid(2, 2, cell_index % 2, cell_index / 2);
                    let desc = ViewDesc::new(axis_view(*direction, *up)).shown_in(window, cell);
                    self.views.push(renderer.register_view(desc, graph.clone())?);
                }
            }
            Layout::Cascades => {
                let desc = main(WindowRect::FULL).with_visibility(self.visibility);
                self.views.push(renderer.register_view(desc, graph.clone())?);
            }
            Layout::PictureInPicture => {
                self.views.push(
                    renderer.register_view(main(WindowRect::FULL).with_visibility(self.visibility), graph.clone())?,
                );
                let inset = WindowRect { x: 0.72, y: 0.03, width: 0.25, height: 0.25 };
                let desc = ViewDesc::new(orbit(Vec3::new(0.0, 1.0, 0.2), Vec3::NEG_Z)).shown_in(window, inset);
                self.views.push(renderer.register_view(desc, graph)?);
            }
        }
        Ok(())
    }

    /// Poses the scene for the next frame: frame `self.frames` at
    /// T + frames / F with `--fps`, else T + wall time, looping.
    fn pose(&mut self) -> Result<(), Box<dyn std::error::Error>> {
        let Some(animation) = &self.animation else { return Ok(()) };
        let time = match self.args.fps {
            Some(fps) => self.args.time + self.frames as f32 / fps,
            None => {
                let elapsed = self.clock.get_or_insert_with(Instant::now).elapsed().as_secs_f32();
                let duration = animation.duration();
                let t = self.args.time + elapsed;
                if duration > 0.0 { t % duration } else { t }
            }
        };
        animation.apply(&mut self.scene, time)?;
        self.pose_time = Some(time);
        Ok(())
    }

    fn render(&mut self) -> Result<(), Box<dyn std::error::Error>> {
        if self.renderer.is_none() {
            return Ok(());
        }
        self.pose()?;
        self.draw_overlays_before_frame()?;
        let Some(renderer) = self.renderer.as_mut() else { return Ok(()) };
        let started = Instant::now();
        let report = renderer.render_frame(&self.scene)?;
        if let (Some(wanted), Some(window)) = (self.args.resize, &self.window)
            && self.window_size != wanted
        {
            // Frames count from when the renderer has the new size.
            if self.frames_before_resize == 0 {
                let _ = window.request_inner_size(winit::dpi::PhysicalSize::new(wanted.x, wanted.y));
            }
            self.frames_before_resize += 1;
            if self.frames_before_resize > 600 {
                return Err(format!(
                    "the window was not resized to {}x{} (it is {}x{})",
                    wanted.x, wanted.y, self.window_size.x, self.window_size.y
                )
                .into());
            }
            return Ok(());
        }
        self.frames += 1;
        // The main view's cascades (created with the frame that first needs
        // them) in a strip along the bottom, from the next frame on.
        if let (Layout::Cascades, Some(window), Some(&main)) = (self.layout, self.window_id, self.views.first()) {
            for (i, cascade) in renderer.sun_cascades(main).into_iter().enumerate() {
                let rect = WindowRect { x: 0.01 + i as f32 * 0.2, y: 0.74, width: 0.18, height: 0.24 };
                renderer.show_in_window(cascade, window, rect)?;
            }
        }
        for warning in &report.warnings {
            eprintln!("warning: {warning}");
        }
        let frame_ms = started.elapsed().as_secs_f64() * 1e3;
        self.after_frame(&report, frame_ms)?;
        let Some(renderer) = self.renderer.as_mut() else { return Ok(()) };
        if let Some(window) = &self.window {
            let pose = self.pose_time.map_or(String::new(), |t| format!(", t = {t:.2} s"));
            let knobs = format!(
                "{:?}, pre-pass {:?}, {} cascades of {}, PCF {}, MSAA {}{pose}",
                self.visibility,
                self.pre_pass,
                self.cascades.count,
                self.cascades.resolution,
                self.pcf_radius,
                renderer.msaa_samples(self.msaa),
            );
            let title = if self.args.hud {
                format!("Oxygen — {knobs} [1-5 layout, V P C R K M knobs, F fly, click selects]")
            } else {
                // Each registered view's own GPU time (the report's per-view costs).
                let per_view: Vec<String> = report
                    .views
                    .iter()
                    .filter(|v| v.why.is_some())
                    .filter_map(|v| Some(format!("{:.2}", v.gpu_seconds? * 1e3)))
                    .collect();
                let per_view = if per_view.is_empty() { "n/a".to_owned() } else { per_view.join("/") };
                format!(
                    "Oxygen — prepare {:.2} ms, record {:.2} ms, GPU {} (views {per_view} ms), frame {frame_ms:.2} ms — {knobs} [1-5 layout, V P C R K M knobs, F fly]",
                    report.prepare_seconds * 1e3,
                    report.record_seconds * 1e3,
                    report.gpu_seconds.map_or("n/a".to_owned(), |s| format!("{:.2} ms", s * 1e3)),
                )
            };
            window.set_title(&title);
        }
        if self.args.costs && (self.frames % 60 == 1 || self.args.frames == Some(self.frames)) {
            print_costs(self.frames, &report);
        }
        if let (Some(_), Some(id), Some(path)) = (self.args.fps, self.window_id, &self.args.screenshot)
            && self.animation.is_some()
        {
            // A numbered sequence: every frame, PATH_0000.png, PATH_0001.png, ...
            let numbered = numbered_path(path, self.frames - 1);
            renderer.read_window(id)?.save(&numbered)?;
            println!("saved {} (t = {:.3} s)", numbered.display(), self.pose_time.unwrap_or(0.0));
        } else if let (Some(total), Some(id), Some(path)) = (self.args.frames, self.window_id, &self.args.screenshot)
            && self.frames >= total
        {
            renderer.read_window(id)?.save(path)?;
            println!("saved {} after {} frames", path.display(), self.frames);
        }
        Ok(())
    }

    /// The main view's rectangle in the window, as fractions.
    fn main_rect(&self) -> WindowRect {
        match self.layout {
            Layout::Grid | Layout::Editor => WindowRect::grid(2, 2, 0, 0),
            _ => WindowRect::FULL,
        }
    }

    /// What the overlays show this frame: the last frame's timings, the
    /// other views' frusta in the editor layout, the selection's outline.
    fn draw_overlays_before_frame(&mut self) -> Result<(), RenderError> {
        let radius = (self.bounds.half_extents().length()).max(1e-3);
        let Some(renderer) = self.renderer.as_mut() else { return Ok(()) };
        let Some(&main) = self.views.first() else { return Ok(()) };
        if self.args.hud {
            for (view, text) in &self.hud_text {
                let Ok(overlay) = renderer.overlay(*view) else { continue };
                let mut canvas = overlay.immediate();
                let lines = text.lines().count().max(1) as f32;
                canvas.rect(
                    Vec2::new(HUD_AT, HUD_AT),
                    Vec2::new(HUD_AT + HUD_WIDTH, HUD_AT + 6.0 + lines * HUD_LINE),
                    Rgba::new(0.0, 0.0, 0.0, 0.55),
                );
                canvas.text(Vec2::new(HUD_AT + 4.0, HUD_AT + 3.0), HUD_TEXT_SIZE, Rgba::WHITE, text);
            }
        }
        if self.layout == Layout::Editor {
            renderer.draw_view_frusta(main, radius * 3.0, 1.5, Rgba::rgb(1.0, 0.75, 0.2))?;
        }
        let outline =
            self.selected.map(|node| Outline { nodes: vec![node], width: OUTLINE_WIDTH, color: OUTLINE_COLOR });
        renderer.overlay(main)?.set_outline(outline);
        Ok(())
    }

    /// After a frame: the timings for the next one, and the click picked.
    fn after_frame(&mut self, report: &oxygen::FrameReport, frame_ms: f64) -> Result<(), Box<dyn std::error::Error>> {
        let ms = |s: Option<f64>| s.map_or("n/a".to_owned(), |s| format!("{:.2} ms", s * 1e3));
        let Some(&main) = self.views.first() else { return Ok(()) };
        self.hud_text.clear();
        self.hud_text.push((
            main,
            format!(
                "frame {frame_ms:.2} ms, GPU {}\nprepare {:.2} ms, record {:.2} ms\n{}",
                ms(report.gpu_seconds),
                report.prepare_seconds * 1e3,
                report.record_seconds * 1e3,
                self.selected.map_or("click to select".to_owned(), |n| format!("selected node {n}")),
            ),
        ));
        for v in report.views.iter().filter(|v| v.why.is_some() && v.view != main) {
            self.hud_text.push((v.view, format!("GPU {}", ms(v.gpu_seconds))));
        }
        if self.frames == 1 && self.args.select.is_some() {
            self.click = self.args.select;
        }
        if let (Some((x, y)), Some(renderer)) = (self.click.take(), self.renderer.as_ref()) {
            let rect = self.main_rect();
            let (w, h) = (f64::from(self.window_size.x), f64::from(self.window_size.y));
            let (px, py) = (x - f64::from(rect.x) * w, y - f64::from(rect.y) * h);
            if px >= 0.0 && py >= 0.0 && px < f64::from(rect.width) * w && py < f64::from(rect.height) * h {
                match renderer.pick(main, px as u32, py as u32) {
                    Ok(node) => self.selected = node,
                    Err(e) => eprintln!("cannot pick: {e}"),
                }
            }
        }
        Ok(())
    }

    fn done(&self) -> bool {
        self.error.is_some() || self.args.frames.is_some_and(|total| self.frames >= total)
    }
}

/// Where the timings are drawn: this many pixels from the view's corner.
const HUD_AT: f32 = 4.0;
/// The timings' box width in pixels.
const HUD_WIDTH: f32 = 250.0;
/// The timings' text size and line height in pixels.
const HUD_TEXT_SIZE: f32 = 12.0;
const HUD_LINE: f32 = 15.0;
/// The selection outline.
const OUTLINE_WIDTH: f32 = 2.0;
const OUTLINE_COLOR: Rgba = Rgba::rgb(1.0, 0.55, 0.0);

/// `path` with `_NNNN` (frame `i`) before its extension.
fn numbered_path(path: &std::path::Path, i: u64) -> PathBuf {
    let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("frame");
    let name = match path.extension().and_then(|e| e.to_str()) {
        Some(ext) => format!("{stem}_{i:04}.{ext}"),
        None => format!("{stem}_{i:04}"),
    };
    path.with_file_name(name)
}

/// A boxed resolver as a resolver.
struct BoxedResolver(Box<dyn ViewResolver>);

impl ViewResolver for BoxedResolver {
    fn resolve(&self, ctx: &ViewContext, scene: &Scene) -> Result<ResolvedView, ViewError> {
        self.0.resolve(ctx, scene)
    }
}

impl ApplicationHandler for Viewer {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let attributes = WindowAttributes::default()
            .with_title("Oxygen")
            .with_inner_size(winit::dpi::PhysicalSize::new(self.args.size.x, self.args.size.y));
        let result = (|| -> Result<(), Box<dyn std::error::Error>> {
            let window = Arc::new(event_loop.create_window(attributes)?);
            let mut renderer = Renderer::new_headless()?;
            let surface = renderer.gpu().instance.create_surface(Arc::clone(&window))?;
            let size = window.inner_size();
            self.window_size = UVec2::new(size.width, size.height);
            let id = renderer.add_window(surface, self.window_size, self.args.present)?;
            renderer.set_environment(self.environment.as_ref());
            println!("adapter: {}; visibility {:?}", renderer.gpu().describe(), renderer.visibility());
            self.visibility = renderer.visibility();
            self.renderer = Some(renderer);
            self.window = Some(window);
            self.window_id = Some(id);
            self.rebuild_views()?;
            if let Some(window) = &self.window {
                window.request_redraw();
            }
            Ok(())
        })();
        if let Err(e) = result {
            self.error = Some(e.to_string());
            event_loop.exit();
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: winit::window::WindowId, event: WindowEvent) {
        let outcome = (|| -> Result<(), Box<dyn std::error::Error>> {
            match event {
                WindowEvent::CloseRequested => event_loop.exit(),
                WindowEvent::Resized(size) => {
                    if let (Some(renderer), Some(id)) = (self.renderer.as_mut(), self.window_id) {
                        self.window_size = UVec2::new(size.width, size.height);
                        renderer.resize_window(id, self.window_size)?;
                    }
                }
                WindowEvent::RedrawRequested => {
                    self.render()?;
                    if self.done() {
                        event_loop.exit();
                    } else if let Some(window) = &self.window {
                        window.request_redraw();
                    }
                }
                WindowEvent::MouseInput { state, button: MouseButton::Left, .. } => {
                    let pressed = state == ElementState::Pressed;
                    // Released without moving: a click, picked after the next frame.
                    if self.dragging && !pressed && !self.dragged {
                        self.click = self.last_cursor;
                    }
                    self.dragging = pressed;
                    self.dragged = false;
                }
                WindowEvent::CursorMoved { position, .. } => {
                    if let (true, Some((x, y))) = (self.dragging, self.last_cursor) {
                        self.dragged |= (position.x - x).abs() + (position.y - y).abs() > 0.0;
                        let mut camera = self.camera.lock().unwrap_or_else(|e| e.into_inner());
                        camera.orbit.yaw += (position.x - x) as f32 * 0.005;
                        camera.orbit.pitch = (camera.orbit.pitch - (position.y - y) as f32 * 0.005).clamp(-1.5, 1.5);
                    }
                    self.last_cursor = Some((position.x, position.y));
                }
                WindowEvent::MouseWheel { delta, .. } => {
                    let lines = match delta {
                        MouseScrollDelta::LineDelta(_, y) => y,
                        MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                    };
                    let mut camera = self.camera.lock().unwrap_or_else(|e| e.into_inner());
                    camera.orbit.distance = (camera.orbit.distance * 0.9f32.powf(lines)).max(camera.orbit.near * 2.0);
                }
                WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                    let PhysicalKey::Code(code) = event.physical_key else { return Ok(()) };
                    self.key(code)?;
                }
                _ => {}
            }
            Ok(())
        })();
        if let Err(e) = outcome {
            self.error = Some(e.to_string());
            event_loop.exit();
        }
    }
}

impl Viewer {
    fn key(&mut self, code: KeyCode) -> Result<(), RenderError> {
        let step = (self.bounds.half_extents().length() as f32 * 0.05).max(1e-4);
        {
            let mut camera = self.camera.lock().unwrap_or_else(|e| e.into_inner());
            let forward = camera.forward();
            let right = forward.cross(Vec3::Y).normalize_or_zero();
            match code {
                KeyCode::KeyW => camera.eye += (forward * step).as_dvec3(),
                KeyCode::KeyS => camera.eye -= (forward * step).as_dvec3(),
                KeyCode::KeyA => camera.eye -= (right * step).as_dvec3(),
                KeyCode::KeyD => camera.eye += (right * step).as_dvec3(),
                KeyCode::KeyQ => camera.eye -= DVec3::Y * f64::from(step),
                KeyCode::KeyE => camera.eye += DVec3::Y * f64::from(step),
                KeyCode::KeyF => {
                    if !camera.fly {
                        camera.eye = camera.orbit.eye();
                    }
                    camera.fly = !camera.fly;
                }
                _ => {}
            }
        }
        let supported = self.renderer.as_ref().is_some_and(Renderer::gpu_visibility_supported);
        match code {
            KeyCode::Digit1 => self.layout = Layout::Single,
            KeyCode::Digit2 => self.layout = Layout::Grid,
            KeyCode::Digit3 => self.layout = Layout::Cascades,
            KeyCode::Digit4 => self.layout = Layout::PictureInPicture,
            KeyCode::Digit5 => self.layout = Layout::Editor,
            KeyCode::KeyV => {
                self.visibility = match self.visibility {
                    Visibility::Cpu if supported => Visibility::GpuFrustum,
                    Visibility::GpuFrustum => Visibility::GpuOcclusion,
                    _ => Visibility::Cpu,
                }
            }
            KeyCode::KeyC => self.cascades.count = self.cascades.count % 4 + 1,
            KeyCode::KeyR => {
                self.cascades.resolution = match self.cascades.resolution {
                    512 => 1024,
                    1024 => 2048,
                    _ => 512,
                }
            }
            KeyCode::KeyK => self.pcf_radius = (self.pcf_radius + 1) % 3,
            KeyCode::KeyM => {
                self.msaa = match self.msaa {
                    Msaa::Off => Msaa::X2,
                    Msaa::X2 => Msaa::X4,
                    Msaa::X4 => Msaa::Off,
                }
            }
            KeyCode::KeyP => {
                self.pre_pass = match self.pre_pass {
                    PrePass::Auto { .. } => PrePass::On,
                    PrePass::On => PrePass::Off,
                    PrePass::Off => PrePass::DEFAULT,
                }
            }
            _ => return Ok(()),
        }
        self.rebuild_views()
    }
}

fn main() {
    let args = match parse_args(std::env::args().skip(1)) {
        Ok(args) => args,
        Err(e) => {
            if !e.is_empty() {
                eprintln!("error: {e}");
            }
            eprintln!("{USAGE}");
            std::process::exit(2);
        }
    };
    if let Err(e) = run(args) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run(args: Args) -> Result<(), Box<dyn std::error::Error>> {
    let mut scene = Scene::new();
    let import = import_gltf(&mut scene, &args.file, &SceneChoice::Default)?;
    for note in &import.warnings {
        println!("note: {note}");
    }
    let bounds = import.precise_bounds.ok_or("the scene has nothing to draw")?;
    if import.lights == 0 {
        oxygen_demo::add_default_sun(&mut scene);
    }
    // A file without animations is simply not animated, unless one was asked for.
    let animation = match import.animation(args.animation.as_deref()) {
        Ok(a) => Some(a.clone()),
        Err(_) if args.animation.is_none() => None,
        Err(e) => return Err(e.into()),
    };
    if let Some(a) = &animation {
        println!("animation '{}' ({:.2} s) from t = {} s", a.name, a.duration(), args.time);
    }
    let environment = match args.environment.as_str() {
        "none" => None,
        "sky" => Some(oxygen_demo::viewer_environment(&scene)),
        file => Some(oxygen::lighting::load_hdr_environment(file)?),
    };
    let orbit = OrbitCamera::framing(&bounds);
    let camera = CameraState { orbit, fly: false, eye: orbit.eye() };
    let event_loop = EventLoop::new()?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let (layout, msaa) = (args.layout, args.msaa);
    let mut viewer = Viewer {
        args,
        scene,
        cameras: import.cameras,
        bounds,
        camera: Arc::new(Mutex::new(camera)),
        renderer: None,
        window: None,
        window_id: None,
        views: Vec::new(),
        layout,
        visibility: Visibility::Cpu,
        pre_pass: PrePass::DEFAULT,
        cascades: oxygen_demo::viewer_cascades(),
        pcf_radius: ForwardLitConfig::DEFAULT.shadow_pcf_radius,
        msaa,
        frames: 0,
        window_size: UVec2::ZERO,
        frames_before_resize: 0,
        dragging: false,
        dragged: false,
        click: None,
        selected: None,
        hud_text: Vec::new(),
        last_cursor: None,
        error: None,
        animation,
        clock: None,
        pose_time: None,
        environment,
    };
    event_loop.run_app(&mut viewer)?;
    match viewer.error {
        Some(e) => Err(e.into()),
        None => Ok(()),
    }
}
