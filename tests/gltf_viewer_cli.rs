//! The viewer's command line, run as a user would: usage on `--help`, a clear
//! refusal of unknown options, extra arguments and an empty output folder,
//! and the path named in every file error.

mod support;

use std::path::PathBuf;
use std::process::{Command, Output};

use support::far::{assert_framed_alike, wrapped_glb};

/// The viewer binary `cargo test` built beside this test.
fn viewer() -> Command {
    let mut path = std::env::current_exe().unwrap();
    path.pop(); // deps/
    if path.ends_with("deps") {
        path.pop();
    }
    let exe = path.join("examples").join(format!("gltf_viewer{}", std::env::consts::EXE_SUFFIX));
    assert!(exe.exists(), "{} not built (cargo test builds examples)", exe.display());
    let mut command = Command::new(exe);
    command.env("OXYGEN_SKIP_GPU_SETUP", "1");
    command
}

fn run(args: &[&str]) -> (Output, String) {
    let output = viewer().args(args).output().unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
    (output, text)
}

fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("viewer_cli").join(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn help_prints_usage_and_succeeds() {
    let (output, text) = run(&["--help"]);
    assert!(output.status.success(), "{text}");
    assert!(text.contains("usage: gltf_viewer"), "{text}");
}

#[test]
fn unknown_options_and_extra_arguments_are_refused_with_usage() {
    for (args, expected) in [
        (&["--frobnicate"][..], "unknown option '--frobnicate'"),
        (&["a.glb", "out", "extra"][..], "unexpected argument 'extra'"),
        (&["a.glb", ""][..], "OUTPUT_DIR is empty"),
        (&["--size", "0x5"][..], "at least 1x1"),
        (&["--size", "big"][..], "'big'"),
    ] {
        let (output, text) = run(args);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {text}");
        assert!(text.contains(expected) && text.contains("usage:"), "{args:?}: {text}");
    }
}

#[test]
fn a_missing_file_and_an_unwritable_output_folder_are_named() {
    let (output, text) = run(&["/nonexistent/scene.glb", tmp("missing").to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(1));
    assert!(text.contains("/nonexistent/scene.glb"), "{text}");

    let blocker = tmp("blocked").join("a_file");
    std::fs::write(&blocker, b"not a folder").unwrap();
    let out = blocker.join("sub");
    let (output, text) = run(&["/nonexistent/scene.glb", out.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(1));
    assert!(text.contains(out.to_str().unwrap()), "{text}");
}

#[test]
fn a_file_reaching_outside_its_folder_is_refused_by_name() {
    let dir = tmp("escape");
    let json = r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[]}],"buffers":[{"byteLength":4,"uri":"../../../../../../etc/hostname"}]}"#;
    let file = dir.join("escape.gltf");
    std::fs::write(&file, json).unwrap();
    let (output, text) = run(&[file.to_str().unwrap(), dir.join("out").to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(1), "{text}");
    assert!(text.contains("escape.gltf") && text.contains("etc/hostname") && text.contains("refused"), "{text}");
}

fn asset(relative: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets").join(relative).display().to_string()
}

#[test]
fn animation_options_are_checked_before_anything_renders() {
    for (args, expected) in [
        (&["--frames", "3"][..], "--frames needs --fps"),
        (&["--fps", "24"][..], "--fps needs --frames"),
        (&["--time", "soon"][..], "'soon'"),
        (&["--time", "inf"][..], "finite"),
        (&["--fps", "0", "--frames", "2"][..], "positive"),
        (&["--frames", "0", "--fps", "2"][..], "from 1"),
    ] {
        let (output, text) = run(args);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {text}");
        assert!(text.contains(expected) && text.contains("usage:"), "{args:?}: {text}");
    }
    // An animation the file does not have: the ones it has are listed.
    let out = tmp("no_such_animation");
    let (output, text) =
        run(&[&asset("AnimatedCube/AnimatedCube.gltf"), out.to_str().unwrap(), "--animation", "7", "--size", "32x24"]);
    assert_eq!(output.status.code(), Some(1), "{text}");
    assert!(text.contains("0 ('animation_AnimatedCube')"), "{text}");
}

/// `--frames 3 --fps 2 --time 0.25`: three numbered frames per view, at
/// 0.25, 0.75 and 1.25 s; the cube turns between them.
#[test]
fn a_numbered_sequence_is_written_at_the_given_rate() {
    let out = tmp("sequence");
    let args = [&asset("AnimatedCube/AnimatedCube.gltf"), out.to_str().unwrap()];
    let (output, text) = run(&[args[0], args[1], "--frames", "3", "--fps", "2", "--time", "0.25", "--size", "64x48"]);
    assert!(output.status.success(), "{text}");
    for time in ["0.250", "0.750", "1.250"] {
        assert!(text.contains(&format!("at {time} s")), "{text}");
    }
    let frame = |i: u32| {
        let path = out.join(format!("AnimatedCube_orbit_three_quarter_{i:04}.png"));
        image::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgba8()
    };
    let (first, last) = (frame(0), frame(2));
    let differing = first.pixels().zip(last.pixels()).filter(|(a, b)| a != b).count();
    assert!(differing > 100, "the cube must turn between frames 0 and 2 ({differing} pixels differ)");
    assert!(out.join("AnimatedCube_orbit_front_0001.png").exists());
}

/// The main job lights the scene with the sky by default (said so, and
/// drawn behind the scene: a corner of the picture is sky, not the clear
/// colour); `--environment none` turns it off; a missing panorama is named.
#[test]
fn the_sky_lights_the_scene_unless_told_otherwise() {
    let corner = |dir: &PathBuf| {
        let path = dir.join("BoxTextured_orbit_front.png");
        image::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgba8().get_pixel(1, 1).0
    };
    let file = asset("BoxTextured/BoxTextured.glb");
    let lit = tmp("environment_sky");
    let (output, text) = run(&[&file, lit.to_str().unwrap(), "--size", "64x48"]);
    assert!(output.status.success(), "{text}");
    assert!(text.contains("environment: the sky matched to the sun"), "{text}");
    let plain = tmp("environment_none");
    let (output, text) = run(&[&file, plain.to_str().unwrap(), "--size", "64x48", "--environment", "none"]);
    assert!(output.status.success(), "{text}");
    assert!(!text.contains("environment:"), "{text}");
    let (sky, clear) = (corner(&lit), corner(&plain));
    assert!(sky[2] > clear[2] + 40, "the sky behind the scene: {sky:?} against the clear colour {clear:?}");
    let (output, text) = run(&[&file, plain.to_str().unwrap(), "--environment", "/nonexistent/sky.hdr"]);
    assert!(!output.status.success());
    assert!(text.contains("/nonexistent/sky.hdr"), "{text}");
}

/// The main job frames a model thirty million units out as it frames it at
/// the origin: the orbit views are built on the import's f64 bounds with an
/// f64 camera. (The main job built before that, framing on the f32 bounds
/// with an f32 camera, moved 2 927 of the front view's 9 216 pixels here.)
#[test]
fn the_main_job_frames_a_far_model_as_it_frames_it_at_the_origin() {
    let original = asset("OrientationTest/OrientationTest.glb");
    let far_file = tmp("far_model").join("OrientationTestFar.glb");
    std::fs::write(&far_file, wrapped_glb(&original, [3.0e7, 1.0e3, 3.0e7])).unwrap();
    let render = |file: &str, name: &str| {
        let out = tmp(name);
        let (output, text) = run(&[file, out.to_str().unwrap(), "--size", "96x96", "--environment", "none"]);
        assert!(output.status.success(), "{text}");
        out
    };
    let (near, far) = (render(&original, "far_model_origin"), render(far_file.to_str().unwrap(), "far_model_far"));
    for view in ["orbit_front", "orbit_three_quarter", "orbit_top"] {
        let read = |dir: &PathBuf, stem: &str| {
            let path = dir.join(format!("{stem}_{view}.png"));
            image::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgba8()
        };
        assert_framed_alike(&read(&far, "OrientationTestFar"), &read(&near, "OrientationTest"), view);
    }
}
