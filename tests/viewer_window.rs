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

use oxygen::prelude::*;
use oxygen_demo::OrbitCamera;
use support::golden::compare;
use support::gpu_renderer_with;

/// `target/<profile>/examples/viewer`, next to this test's own binary.
fn viewer_binary() -> PathBuf {
    let exe = std::env::current_exe().expect("the test knows its own path");
    let profile_dir = exe.parent().and_then(|deps| deps.parent()).expect("tests run from target/<profile>/deps");
    profile_dir.join("examples").join(format!("viewer{}", std::env::consts::EXE_SUFFIX))
}

fn have(program: &str) -> bool {
    Command::new("sh").arg("-c").arg(format!("command -v {program}")).output().is_ok_and(|o| o.status.success())
}

#[test]
fn the_viewer_presents_in_a_window_what_the_headless_renderer_renders() {
    if std::env::var("WGPU_BACKEND").is_ok_and(|b| b.eq_ignore_ascii_case("gl")) {
        // The viewer opens its own instance from the environment too; on GL
        // through EGL on Xvfb the surface path is a different test.
        eprintln!("skipped: the window test runs on the Vulkan backend only");
        return;
    }
    if !have("xvfb-run") {
        eprintln!("skipped: no virtual X server (install Debian's `xvfb`; scripts/test.sh does when run as root)");
        return;
    }
    let viewer = viewer_binary();
    assert!(viewer.exists(), "{} is missing: build the examples first (`cargo test` builds them)", viewer.display());
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/AlphaBlendModeTest/AlphaBlendModeTest.glb");
    let screenshot = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("viewer_window.png");
    let _ = std::fs::remove_file(&screenshot);
    let size = UVec2::new(320, 200);
    let output = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1024x768x24"])
        .arg(&viewer)
        .arg(&file)
        .args(["--size", &format!("{}x{}", size.x, size.y), "--frames", "4", "--screenshot"])
        .arg(&screenshot)
        .output()
        .expect("xvfb-run runs");
    let log = format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
    assert!(output.status.success(), "the viewer failed under Xvfb:\n{log}");
    let presented =
        oxygen::image::open(&screenshot).unwrap_or_else(|e| panic!("no screenshot ({e}):\n{log}")).to_rgba8();
    // Xvfb gives the window the size asked for.
    assert_eq!(presented.dimensions(), (size.x, size.y), "{log}");

    // The same view, headless: the viewer's default orbit camera framing
    // the file, its default sun and cascades, the standard graph.
    let mut scene = Scene::new();
    let import = import_gltf(&mut scene, &file, &SceneChoice::Default).unwrap();
    if import.lights == 0 {
        oxygen_demo::add_default_sun(&mut scene);
    }
    let bounds = import.precise_bounds.unwrap();
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
