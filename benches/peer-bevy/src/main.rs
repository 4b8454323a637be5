//! Bevy's side of the peer benchmark: the scene of Oxygen's
//! `examples/cubes_bench.rs` rendered by Bevy's default 3D renderer, timed
//! the same way, printed in the same line format.
//!
//! ```text
//! cargo run --release -- N V [frames] [--msaa-off]
//! ```
//!
//! The scene (kept identical to the Oxygen side; change both together):
//! N unit cubes on a square grid (spacing 2, XZ plane, centred on the
//! origin, resting on y = 0), four `StandardMaterial`s cycling (metallic 0,
//! perceptual roughness 0.5, the same four linear base colours), one
//! `DirectionalLight` with shadow maps off, and V `Camera3d`s (60° vertical
//! field of view, near 0.1, 960 × 540) evenly spaced on a circle at radius
//! 0.65 and height 0.35 of the grid's side length, each looking at the grid's
//! centre and rendering into its own offscreen `Image`.
//!
//! Each camera keeps Bevy's defaults — MSAA 4×, no depth pre-pass, an
//! Rgba8UnormSrgb (non-HDR) main texture with tone mapping (TonyMcMapface)
//! applied in the PBR shader, deband dithering — unless `--msaa-off` turns
//! MSAA off so that the frame is closer to Oxygen's (which has none).
//!
//! Headless: no window, no winit (not compiled in), `WindowPlugin` without a
//! primary window and never asking to exit; the app is driven by calling
//! `App::update` here instead of a runner.
//!
//! What one frame means, chosen to match Oxygen's "`render_frame` plus a wait
//! for the GPU": the wall time of one `App::update()` — main schedule
//! (transform propagation, CPU frustum culling), extraction, the render
//! schedule (prepare, queue, record, submit) — followed by
//! `RenderDevice::poll(wait_indefinitely)`, which returns when the GPU has
//! finished every submission. `PipelinedRenderingPlugin` is disabled so that
//! the render world runs inside `update()` on this thread's schedule instead
//! of overlapping the next frame's main schedule on another thread; with it,
//! the measured span would not contain the whole frame. Bevy compiles
//! pipelines asynchronously and skips draws whose pipeline is not ready, so
//! the warm-up lasts until no pipeline has been waiting for several frames
//! (and at least WARM_UP frames).
//!
//! The adapter follows `WGPU_BACKEND` and `WGPU_ADAPTER_NAME`, which Bevy's
//! renderer reads from the environment (`scripts/peer-bench.sh` sets them).

use std::any::TypeId;
use std::time::Instant;

use bevy::app::PluginsState;
use bevy::camera::RenderTarget;
use bevy::camera::visibility::VisibleEntities;
use bevy::log::{Level, LogPlugin};
use bevy::prelude::*;
use bevy::render::RenderApp;
use bevy::render::pipelined_rendering::PipelinedRenderingPlugin;
use bevy::render::render_resource::{CachedPipelineState, PipelineCache, PollType, TextureFormat};
use bevy::shader::ShaderCacheError;
use bevy::render::renderer::{RenderAdapterInfo, RenderDevice};
use bevy::window::ExitCondition;

const WARM_UP: usize = 5;
const DEFAULT_MEASURED: usize = 30;
/// Consecutive frames with no pipeline waiting before the warm-up ends.
const SETTLED_FRAMES: usize = 3;
/// Give up if pipelines are still compiling after this many frames.
const MAX_WARM_UP: usize = 2_000;
const VIEWPORT: UVec2 = UVec2::new(960, 540);
const EYE_RADIUS: f32 = 0.65;
const EYE_HEIGHT: f32 = 0.35;
const BASE_COLORS: [[f32; 3]; 4] = [[0.8, 0.2, 0.2], [0.2, 0.7, 0.3], [0.2, 0.3, 0.8], [0.8, 0.7, 0.2]];

struct Config {
    count: usize,
    views: usize,
    measured: usize,
    msaa: Msaa,
}

fn parse_args() -> Result<Config, String> {
    let usage = "usage: peer-bevy N V [frames] [--msaa-off]".to_owned();
    let mut positional = Vec::new();
    let mut msaa = Msaa::default();
    for arg in std::env::args().skip(1) {
        match arg.as_str() {
            "--msaa-off" => msaa = Msaa::Off,
            _ => positional.push(arg.parse::<usize>().map_err(|e| format!("{arg}: {e}; {usage}"))?),
        }
    }
    match positional[..] {
        [count, views] if count > 0 && views > 0 => Ok(Config { count, views, measured: DEFAULT_MEASURED, msaa }),
        [count, views, measured] if count > 0 && views > 0 && measured > 0 => {
            Ok(Config { count, views, measured, msaa })
        }
        _ => Err(usage),
    }
}

/// A headless app: Bevy's default plugins for the enabled features, no
/// primary window, rendering on the main thread's schedule.
fn headless_app() -> App {
    let mut app = App::new();
    app.add_plugins(
        DefaultPlugins
            .set(WindowPlugin {
                primary_window: None,
                primary_cursor_options: None,
                exit_condition: ExitCondition::DontExit,
                close_when_requested: false,
                ..default()
            })
            .set(LogPlugin { level: Level::WARN, ..default() })
            .disable::<PipelinedRenderingPlugin>(),
    );
    // The renderer is created asynchronously; `finish` needs it.
    while app.plugins_state() == PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
    }
    app.finish();
    app.cleanup();
    app
}

/// Spawns the cubes, the light and the cameras; returns the grid's side length.
fn spawn_scene(world: &mut World, config: &Config) -> f32 {
    let per_row = (config.count as f32).sqrt().ceil() as usize;
    let half = (per_row - 1) as f32;
    let side = per_row as f32 * 2.0;
    let cube = world.resource_mut::<Assets<Mesh>>().add(Cuboid::new(1.0, 1.0, 1.0));
    let materials: Vec<Handle<StandardMaterial>> = BASE_COLORS
        .iter()
        .map(|&[r, g, b]| {
            world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial {
                base_color: Color::linear_rgb(r, g, b),
                metallic: 0.0,
                perceptual_roughness: 0.5,
                ..default()
            })
        })
        .collect();
    world.spawn_batch((0..config.count).map(move |i| {
        let (x, z) = ((i % per_row) as f32 * 2.0 - half, (i / per_row) as f32 * 2.0 - half);
        (Mesh3d(cube.clone()), MeshMaterial3d(materials[i % 4].clone()), Transform::from_xyz(x, 0.5, z))
    }));
    let sun_direction = Vec3::new(0.6, -0.5, 0.4).normalize();
    world.spawn((
        DirectionalLight { shadow_maps_enabled: false, ..default() },
        Transform::default().looking_to(sun_direction, Vec3::Y),
    ));
    for v in 0..config.views {
        let target = Image::new_target_texture(VIEWPORT.x, VIEWPORT.y, TextureFormat::Rgba8UnormSrgb, None);
        let target = world.resource_mut::<Assets<Image>>().add(target);
        let angle = v as f32 / config.views as f32 * std::f32::consts::TAU;
        let eye = Vec3::new(angle.cos() * EYE_RADIUS * side, EYE_HEIGHT * side, angle.sin() * EYE_RADIUS * side);
        world.spawn((
            Camera3d::default(),
            Camera { order: v as isize, ..default() },
            RenderTarget::Image(target.into()),
            // Bevy's projection is infinite reverse-Z like Oxygen's; `far` only
            // bounds CPU culling, so it is put well beyond the grid.
            Projection::Perspective(PerspectiveProjection {
                fov: 60f32.to_radians(),
                near: 0.1,
                far: side * 4.0,
                ..default()
            }),
            Transform::from_translation(eye).looking_at(Vec3::ZERO, Vec3::Y),
            config.msaa,
        ));
    }
    side
}

/// Pipelines not ready yet, or the first that failed. A pipeline whose
/// shader asset is still loading is in `Err(ShaderNotLoaded)`, which Bevy
/// retries every frame: that one counts as waiting, not failed.
fn pipelines_pending(app: &App) -> Result<usize, String> {
    let cache = app.sub_app(RenderApp).world().resource::<PipelineCache>();
    let mut waiting = cache.waiting_pipelines().count();
    for pipeline in cache.pipelines() {
        match &pipeline.state {
            CachedPipelineState::Err(ShaderCacheError::ShaderNotLoaded(_)) => waiting += 1,
            CachedPipelineState::Err(error) => return Err(format!("a pipeline failed to compile: {error:?}")),
            _ => {}
        }
    }
    Ok(waiting)
}

/// Mean over the cameras of the fraction of cubes Bevy's CPU culling kept.
fn visible_fraction(world: &mut World, count: usize) -> f64 {
    let mut cameras = world.query_filtered::<&VisibleEntities, With<Camera3d>>();
    let fractions: Vec<f64> =
        cameras.iter(world).map(|v| v.len(TypeId::of::<Mesh3d>()) as f64 / count as f64).collect();
    fractions.iter().sum::<f64>() / fractions.len().max(1) as f64
}

/// One timed frame: `update()` then a wait for the GPU; milliseconds.
fn frame(app: &mut App, device: &RenderDevice) -> Result<f64, String> {
    let start = Instant::now();
    app.update();
    device.poll(PollType::wait_indefinitely()).map_err(|e| format!("waiting for the GPU: {e}"))?;
    Ok(start.elapsed().as_secs_f64() * 1e3)
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn main() -> Result<(), String> {
    let config = parse_args()?;
    let mut app = headless_app();
    spawn_scene(app.world_mut(), &config);
    let device = app.world().resource::<RenderDevice>().clone();

    let mut warm_up = 0;
    let mut settled = 0;
    while warm_up < WARM_UP || settled < SETTLED_FRAMES {
        if warm_up == MAX_WARM_UP {
            return Err(format!("pipelines still compiling after {MAX_WARM_UP} frames"));
        }
        frame(&mut app, &device)?;
        warm_up += 1;
        settled = if pipelines_pending(&app)? == 0 { settled + 1 } else { 0 };
    }

    let mut times = Vec::with_capacity(config.measured);
    for _ in 0..config.measured {
        times.push(frame(&mut app, &device)?);
    }
    pipelines_pending(&app)?;
    times.sort_by(f64::total_cmp);

    let visible = visible_fraction(app.world_mut(), config.count);
    println!(
        "bevy N={} V={} median_ms={:.2} p10_ms={:.2} p90_ms={:.2} frames={} warmup={warm_up} visible={visible:.3} msaa={}",
        config.count,
        config.views,
        percentile(&times, 0.5),
        percentile(&times, 0.1),
        percentile(&times, 0.9),
        config.measured,
        config.msaa.samples(),
    );
    let info = app.world().resource::<RenderAdapterInfo>();
    println!(
        "bevy adapter: {} ({:?}, {:?}, driver {} {})",
        info.name, info.backend, info.device_type, info.driver, info.driver_info
    );
    Ok(())
}
