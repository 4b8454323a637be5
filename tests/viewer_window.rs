//! The interactive viewer in a real window, under a virtual X server: it
//! renders a few frames into an X11 surface, saves what it presented
//! (`--frames 4 --screenshot`), and the picture must equal the headless
//! render of the same view within tolerance.
//!
//! Needs `xvfb-run` (Debian's `xvfb`; `scripts/test.sh` installs it when
//! run as root): without it the test says so and is skipped, never
//! silently. The viewer binary is the one `cargo test` builds with the
//! examples.

mod support;

use std::path::PathBuf;
use std::process::Command;

use oxygen::core::DAabb;
use oxygen::gpu::Msaa;
use oxygen::prelude::*;
use oxygen::views::DLookAtResolver;
use oxygen::windows::WindowRect;
use oxygen_demo::OrbitCamera;
use support::golden::compare;
use support::gpu_renderer_with;

/// An `extra` argument that is not passed on: it asks [`run_viewer`] to
/// leave the viewer's default environment (the sky) as it is.
const DEFAULT_SKY: &str = "(default environment)";

/// `target/<profile>/examples/viewer`, next to this test's own binary.
fn viewer_binary() -> PathBuf {
    let exe = std::env::current_exe().expect("the test knows its own path");
    let profile_dir = exe.parent().and_then(|deps| deps.parent()).expect("tests run from target/<profile>/deps");
    profile_dir.join("examples").join(format!("viewer{}", std::env::consts::EXE_SUFFIX))
}

fn have(program: &str) -> bool {
    Command::new("sh").arg("-c").arg(format!("command -v {program}")).output().is_ok_and(|o| o.status.success())
}

/// Why the window tests cannot run here, if they cannot.
fn cannot_run() -> Option<&'static str> {
    if std::env::var("WGPU_BACKEND").is_ok_and(|b| b.eq_ignore_ascii_case("gl")) {
        // The viewer opens its own instance from the environment too; on GL
        // through EGL on Xvfb the surface path is a different test.
        return Some("the window test runs on the Vulkan backend only");
    }
    if !have("xvfb-run") {
        return Some("no virtual X server (install Debian's `xvfb`; scripts/test.sh does when run as root)");
    }
    None
}

fn shipped_file() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/AlphaBlendModeTest/AlphaBlendModeTest.glb")
}

/// Runs the viewer under Xvfb with `extra` arguments for four frames and
/// returns the picture it presented last.
fn run_viewer(name: &str, size: UVec2, extra: &[&str]) -> oxygen::image::RgbaImage {
    run_viewer_sized(name, size, size, extra)
}

/// As [`run_viewer`], for a window opened at `size` that presents at
/// `presented_size` (after `--resize`).
fn run_viewer_sized(name: &str, size: UVec2, presented_size: UVec2, extra: &[&str]) -> oxygen::image::RgbaImage {
    let viewer = viewer_binary();
    assert!(viewer.exists(), "{} is missing: build the examples first (`cargo test` builds them)", viewer.display());
    let screenshot = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("{name}.png"));
    let _ = std::fs::remove_file(&screenshot);
    let output = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1024x768x24"])
        .arg(&viewer)
        .arg(shipped_file())
        .args(["--size", &format!("{}x{}", size.x, size.y), "--frames", "4", "--screenshot"])
        .arg(&screenshot)
        // The constant ambient term, as the headless references have, unless
        // a test says otherwise (`--environment` in `extra`, or `DEFAULT_SKY`).
        .args(if extra.contains(&"--environment") || extra.contains(&DEFAULT_SKY) {
            &[][..]
        } else {
            &["--environment", "none"][..]
        })
        // Nothing drawn over the views, unless a test asks for the timings.
        .args(if extra.contains(&"--hud") { &[][..] } else { &["--hud", "off"][..] })
        .args(extra.iter().filter(|a| **a != DEFAULT_SKY))
        .output()
        .expect("xvfb-run runs");
    let log = format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
    assert!(output.status.success(), "the viewer failed under Xvfb:\n{log}");
    let presented =
        oxygen::image::open(&screenshot).unwrap_or_else(|e| panic!("no screenshot ({e}):\n{log}")).to_rgba8();
    // Xvfb gives the window the size asked for.
    assert_eq!(presented.dimensions(), (presented_size.x, presented_size.y), "{log}");
    presented
}

/// The shipped scene as the viewer loads it (with its default sun when the
/// file has no light), and its f64 bounds.
fn viewer_scene() -> (Scene, DAabb) {
    let mut scene = Scene::new();
    let import = import_gltf(&mut scene, shipped_file(), &SceneChoice::Default).unwrap();
    if import.lights == 0 {
        oxygen_demo::add_default_sun(&mut scene);
    }
    (scene, import.precise_bounds.unwrap())
}

#[test]
fn the_viewer_presents_in_a_window_what_the_headless_renderer_renders() {
    if let Some(reason) = cannot_run() {
        support::skip::skip(reason);
        return;
    }
    let size = UVec2::new(320, 200);
    let presented = run_viewer("viewer_window", size, &[]);

    // The same view, headless: the viewer's default orbit camera framing
    // the file, its default sun and cascades, the standard graph.
    let (scene, bounds) = viewer_scene();
    let camera = OrbitCamera::framing(&bounds).resolver(size);
    let mut renderer = gpu_renderer_with(RendererOptions::default());
    let desc = ViewDesc::new(camera).with_sun_shadows(oxygen_demo::viewer_cascades());
    let view = renderer.register_view(desc, standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    let expected = renderer.read_color(view).unwrap();
    let diff = compare(&presented, &expected, 3);
    eprintln!(
        "presented vs headless: {} of {} pixels differ by more than 3 levels (worst {})",
        diff.differing, diff.total, diff.worst
    );
    if diff.differing > 0 {
        let _ = diff.diff.save(PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("viewer_window_diff.png"));
    }
    // Composition samples each view texel at its centre: equal up to
    // rounding, nearly everywhere.
    assert!(
        diff.differing <= diff.total / 1000,
        "{} of {} pixels differ from the headless render (worst {}); see {}",
        diff.differing,
        diff.total,
        diff.worst,
        env!("CARGO_TARGET_TMPDIR")
    );
}

/// The editor layout (`--layout 5`): the orthographic front, side and top
/// cells of the presented window each equal the same orthographic view
/// rendered headlessly at the cell's size.
#[test]
fn the_viewers_editor_layout_shows_three_orthographic_views() {
    if let Some(reason) = cannot_run() {
        support::skip::skip(reason);
        return;
    }
    let size = UVec2::new(320, 200);
    let presented = run_viewer("viewer_editor_layout", size, &["--layout", "5"]);
    let (scene, bounds) = viewer_scene();
    let mut renderer = gpu_renderer_with(RendererOptions::default());
    for (i, (from, up)) in oxygen_demo::EDITOR_AXES.iter().enumerate() {
        let cell = i as u32 + 1;
        let (origin, cell_size) = WindowRect::grid(2, 2, cell % 2, cell / 2).pixels(size);
        let camera = DLookAtResolver { viewport: cell_size, ..oxygen_demo::editor_axis_view(&bounds, *from, *up) };
        let view = renderer.register_view(ViewDesc::new(camera), standard_render_graph).unwrap();
        renderer.render_frame(&scene).unwrap();
        let expected = renderer.read_color(view).unwrap();
        renderer.unregister_view(view).unwrap();
        let shown =
            oxygen::image::imageops::crop_imm(&presented, origin.x, origin.y, cell_size.x, cell_size.y).to_image();
        let diff = compare(&shown, &expected, 3);
        eprintln!(
            "orthographic cell {cell}: {} of {} pixels differ by more than 3 levels (worst {})",
            diff.differing, diff.total, diff.worst
        );
        assert!(
            diff.differing <= diff.total / 1000,
            "cell {cell}: {} of {} pixels differ from the headless orthographic view (worst {})",
            diff.differing,
            diff.total,
            diff.worst
        );
    }
}

/// A real surface resized while the viewer runs (`--resize`): the frames
/// after it are presented at the new size and equal the headless render
/// at that size, so the surface was configured again and the view's
/// target and aspect followed.
#[test]
fn the_viewer_follows_a_resized_window() {
    if let Some(reason) = cannot_run() {
        support::skip::skip(reason);
        return;
    }
    let resized = UVec2::new(240, 180);
    let presented = run_viewer_sized("viewer_resized", UVec2::new(320, 200), resized, &["--resize", "240x180"]);
    let (scene, bounds) = viewer_scene();
    let mut renderer = gpu_renderer_with(RendererOptions::default());
    let desc =
        ViewDesc::new(OrbitCamera::framing(&bounds).resolver(resized)).with_sun_shadows(oxygen_demo::viewer_cascades());
    let view = renderer.register_view(desc, standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    let diff = compare(&presented, &renderer.read_color(view).unwrap(), 3);
    eprintln!(
        "resized: {} of {} pixels differ by more than 3 levels (worst {})",
        diff.differing, diff.total, diff.worst
    );
    assert!(diff.differing <= diff.total / 1000, "{} of {} pixels differ after the resize", diff.differing, diff.total);
}

/// `--time 0.25 --fps 4 --frames 2 --screenshot PATH` on an animated file:
/// two numbered frames, posed at 0.25 s and 0.5 s; the second equals the
/// headless render of the scene posed at 0.5 s.
#[test]
fn the_viewer_writes_a_numbered_sequence_of_an_animation() {
    if let Some(reason) = cannot_run() {
        support::skip::skip(reason);
        return;
    }
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/AnimatedCube/AnimatedCube.gltf");
    let size = UVec2::new(160, 120);
    let screenshot = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("viewer_sequence.png");
    let numbered = |i: u32| PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("viewer_sequence_{i:04}.png"));
    for i in 0..2 {
        let _ = std::fs::remove_file(numbered(i));
    }
    let output = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1024x768x24"])
        .arg(viewer_binary())
        .arg(&file)
        .args([
            "--environment",
            "none",
            "--hud",
            "off",
            "--size",
            "160x120",
            "--time",
            "0.25",
            "--fps",
            "4",
            "--frames",
            "2",
        ])
        .arg("--screenshot")
        .arg(&screenshot)
        .output()
        .expect("xvfb-run runs");
    let log = format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
    assert!(output.status.success(), "the viewer failed under Xvfb:\n{log}");
    assert!(log.contains("t = 0.250 s") && log.contains("t = 0.500 s"), "{log}");
    let frames: Vec<_> = (0..2)
        .map(|i| oxygen::image::open(numbered(i)).unwrap_or_else(|e| panic!("frame {i}: {e}\n{log}")).to_rgba8())
        .collect();

    let mut scene = Scene::new();
    let import = import_gltf(&mut scene, &file, &SceneChoice::Default).unwrap();
    if import.lights == 0 {
        oxygen_demo::add_default_sun(&mut scene);
    }
    import.animations[0].apply(&mut scene, 0.5).unwrap();
    let camera = OrbitCamera::framing(&import.precise_bounds.unwrap()).resolver(size);
    let mut renderer = gpu_renderer_with(RendererOptions::default());
    let desc = ViewDesc::new(camera).with_sun_shadows(oxygen_demo::viewer_cascades());
    let view = renderer.register_view(desc, standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    let expected = renderer.read_color(view).unwrap();
    let second = compare(&frames[1], &expected, 3);
    assert!(
        second.differing <= second.total / 1000,
        "frame 1 vs t = 0.5 s: {} of {} differ",
        second.differing,
        second.total
    );
    let first = compare(&frames[0], &expected, 3);
    assert!(first.differing > first.total / 50, "frame 0 (t = 0.25 s) must differ from t = 0.5 s");
}

/// `--msaa 4`: the window shows the multisampled main view, equal to the
/// headless 4× render and not to the 1× one.
#[test]
fn the_viewer_anti_aliases_its_main_view_when_asked() {
    if let Some(reason) = cannot_run() {
        support::skip::skip(reason);
        return;
    }
    let size = UVec2::new(240, 160);
    let presented = run_viewer("viewer_msaa", size, &["--msaa", "4"]);
    let (scene, bounds) = viewer_scene();
    let render = |msaa| {
        let camera = OrbitCamera::framing(&bounds).resolver(size);
        let mut renderer = gpu_renderer_with(RendererOptions::default());
        let desc = ViewDesc::new(camera).with_sun_shadows(oxygen_demo::viewer_cascades()).with_msaa(msaa);
        let view = renderer.register_view(desc, standard_render_graph).unwrap();
        renderer.render_frame(&scene).unwrap();
        renderer.read_color(view).unwrap()
    };
    let (smooth, aliased) = (render(Msaa::X4), render(Msaa::Off));
    let same = compare(&presented, &smooth, 3);
    let other = compare(&presented, &aliased, 3);
    eprintln!("against 4×: {} differ; against 1×: {} differ (of {})", same.differing, other.differing, same.total);
    assert!(same.differing <= same.total / 1000, "{} of {} differ from the 4× render", same.differing, same.total);
    assert!(other.differing > 4 * same.differing.max(10), "the presented picture must not be the 1× one");
}

/// By default the viewer lights the scene with the procedural sky matched
/// to its sun and draws it behind: the window equals the headless render
/// with that environment, and differs from the one without.
#[test]
fn the_viewer_lights_its_scene_with_the_sky_by_default() {
    if let Some(reason) = cannot_run() {
        support::skip::skip(reason);
        return;
    }
    let size = UVec2::new(240, 160);
    let presented = run_viewer("viewer_sky", size, &[DEFAULT_SKY]);
    let (scene, bounds) = viewer_scene();
    let render = |environment: Option<&oxygen::core::Environment>| {
        let camera = OrbitCamera::framing(&bounds).resolver(size);
        let mut renderer = gpu_renderer_with(RendererOptions::default());
        renderer.set_environment(environment);
        let desc = ViewDesc::new(camera).with_sun_shadows(oxygen_demo::viewer_cascades());
        let view = renderer.register_view(desc, standard_render_graph).unwrap();
        renderer.render_frame(&scene).unwrap();
        renderer.read_color(view).unwrap()
    };
    let sky = oxygen_demo::viewer_environment(&scene);
    let (with_sky, without) = (render(Some(&sky)), render(None));
    let same = compare(&presented, &with_sky, 3);
    let other = compare(&presented, &without, 3);
    eprintln!(
        "against the sky render: {} differ; against none: {} differ (of {})",
        same.differing, other.differing, same.total
    );
    assert!(same.differing <= same.total / 1000, "{} of {} differ from the sky render", same.differing, same.total);
    assert!(other.differing > same.total / 4, "the sky must show behind the scene");
}

/// `--costs` prints every view's costs from the frame report at the last
/// frame: a line a view (the picture-in-picture layout has two registered
/// views, and the sun's cascades follow the main one) with its draws,
/// triangles, bytes uploaded and target memory, then the frame's line.
#[test]
fn the_viewer_prints_each_views_costs() {
    if let Some(reason) = cannot_run() {
        support::skip::skip(reason);
        return;
    }
    let screenshot = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("viewer_costs.png");
    let output = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1024x768x24"])
        .arg(viewer_binary())
        .arg(shipped_file())
        .args(["--size", "200x150", "--layout", "4", "--frames", "3", "--costs", "--screenshot"])
        .arg(&screenshot)
        .output()
        .expect("xvfb-run runs");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let log = format!("{stdout}{}", String::from_utf8_lossy(&output.stderr));
    assert!(output.status.success(), "the viewer failed under Xvfb:\n{log}");
    let table = stdout.rsplit("costs of frame 3:").next().filter(|_| stdout.contains("costs of frame 3:"));
    let table = table.unwrap_or_else(|| panic!("no costs table for the last frame:\n{log}"));
    let rows: Vec<Vec<&str>> = table
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| view |"))
        .map(|l| l.trim_matches('|').split('|').map(str::trim).collect())
        .collect();
    let registered: Vec<&Vec<&str>> = rows.iter().filter(|r| r[1] == "Registered").collect();
    let cascades = rows.iter().filter(|r| r[1].starts_with("SunCascade")).count();
    assert_eq!(registered.len(), 2, "the main view and the picture-in-picture:\n{table}");
    assert!(cascades >= 1, "the main view's cascades:\n{table}");
    for row in &registered {
        let number = |column: usize| row[column].parse::<f64>().unwrap_or_else(|_| panic!("{row:?}: column {column}"));
        // draws, triangles, uploaded bytes, target MiB
        assert!(number(6) >= 1.0 && number(7) >= 12.0, "{row:?}: draws and triangles");
        assert!(number(8) >= 64.0, "{row:?}: at least one draw uploaded");
        assert!(number(10) > 0.0, "{row:?}: its targets");
    }
    assert!(rows.last().is_some_and(|r| r[0] == "frame"), "the frame's line closes the table:\n{table}");
}

/// The viewer's overlay: its timings in the main view's corner, and a
/// click (`--select X,Y`) outlining the node under it. Outside the
/// timings' box the window equals the headless render of the same view
/// with that node picked and outlined as the viewer outlines it; inside
/// the box it does not (the box and its text are there).
#[test]
fn the_viewer_draws_its_timings_and_outlines_the_clicked_node() {
    if let Some(reason) = cannot_run() {
        support::skip::skip(reason);
        return;
    }
    let size = UVec2::new(320, 200);
    let (x, y) = (160, 100);
    let presented = run_viewer("viewer_hud", size, &["--hud", "on", "--select", "160,100"]);

    let (scene, bounds) = viewer_scene();
    let camera = OrbitCamera::framing(&bounds).resolver(size);
    let mut renderer = gpu_renderer_with(RendererOptions::default());
    let instances = oxygen::gpu::LabelSet::of(&[oxygen::gpu::Label::Instance]);
    let desc = ViewDesc::new(camera).with_sun_shadows(oxygen_demo::viewer_cascades()).with_label_planes(instances);
    let view = renderer.register_view(desc, standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    let node = renderer.pick(view, x, y).unwrap().expect("a node at the window's centre");
    let orange = oxygen::overlay::Rgba::rgb(1.0, 0.55, 0.0);
    let outline = oxygen::overlay::Outline { nodes: vec![node], width: 2.0, color: orange };
    renderer.overlay(view).unwrap().set_outline(Some(outline));
    renderer.render_frame(&scene).unwrap();
    let expected = renderer.read_color(view).unwrap();

    // The timings' box: 4 px from the corner, 250 wide, three lines of 15.
    let in_box = |x: u32, y: u32| x <= 255 && y <= 56;
    let differs =
        |a: &oxygen::image::Rgba<u8>, b: &oxygen::image::Rgba<u8>| (0..3).any(|c| a.0[c].abs_diff(b.0[c]) > 3);
    let (mut outside, mut inside, mut total) = (0, 0, 0);
    for (x, y, p) in presented.enumerate_pixels() {
        let q = expected.get_pixel(x, y);
        if in_box(x, y) {
            inside += usize::from(differs(p, q));
        } else {
            total += 1;
            outside += usize::from(differs(p, q));
        }
    }
    let outlined = presented.pixels().filter(|p| p.0[0] > 230 && (120..170).contains(&p.0[1]) && p.0[2] < 40).count();
    eprintln!("outside the box {outside} of {total} pixels differ; inside, {inside}; {outlined} outline pixels");
    assert!(outside <= total / 1000, "{outside} of {total} pixels outside the timings differ from the headless render");
    // Measured under Xvfb on lavapipe: 12 750 pixels of the box differ, 290
    // outline pixels.
    assert!(inside > 10_000, "the timings' box is not drawn ({inside} pixels differ in it)");
    assert!(outlined > 230, "no outline around the clicked node ({outlined} pixels)");
}
