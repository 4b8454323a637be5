//! Loads a glTF/GLB file, registers one view per glTF camera plus three
//! orbit cameras framing the whole scene, renders one frame and writes a PNG
//! per view, printing what it did.
//!
//! ```text
//! cargo run --release --example gltf_viewer -- [FILE] [OUTPUT_DIR] [--scene N|NAME] [--size WxH]
//!     [--time T] [--animation N|NAME] [--frames N --fps F] [--environment sky|none|FILE.hdr]
//! ```
//! With `--time`, `--animation` or `--frames` the scene is posed by one of
//! the file's animations (the first unless `--animation` names one) at `T`
//! seconds; `--frames N --fps F` renders N frames, T + i/F seconds, as a
//! numbered sequence (`NAME_VIEW_0000.png`, ...).
//! FILE defaults to the shipped `assets/AlphaBlendModeTest/AlphaBlendModeTest.glb`,
//! OUTPUT_DIR to `out/`. A scene without lights gets a default sun (said so).
//! The scene is lit by an environment too (image-based lighting, drawn
//! behind it): by default the procedural sky matched to its sun;
//! `--environment FILE.hdr` takes a panorama, `--environment none` the
//! constant ambient term.
//! The file is imported with Oxygen's default import limits and its external
//! files confined to its folder (`docs/security.md`); a view that cannot be
//! rendered (a glTF camera with an unusable projection, say) is reported and
//! skipped while the others are written.

use std::path::PathBuf;
use std::time::Instant;

use oxygen::glam::{DVec3, Quat};
use oxygen::prelude::*;
use oxygen::views::DLookAtResolver;

const USAGE: &str = "\
usage: gltf_viewer [FILE] [OUTPUT_DIR] [--scene N|NAME] [--size WxH]
                   [--time T] [--animation N|NAME] [--frames N --fps F]
                   [--environment sky|none|FILE.hdr]

  FILE            a .gltf or .glb file (default: the shipped AlphaBlendModeTest.glb)
  OUTPUT_DIR      where the PNGs go, created if missing (default: out)
  --scene N       import scene N (an index) or NAME instead of the default scene
  --size WxH      size of each view in pixels (default: 800x600)
  --time T        pose the scene with its animation at T seconds (default 0)
  --animation N   which animation (an index or a name; default the first)
  --frames N      render N frames as a numbered sequence (needs --fps)
  --fps F         frames per second of the sequence
  --environment E the light from everywhere: sky (default, matched to the
                  sun), none (a constant ambient term) or an
                  equirectangular .hdr file
  -h, --help      print this help";

/// The parsed command line.
#[derive(Debug)]
struct Args {
    file: PathBuf,
    out_dir: PathBuf,
    choice: SceneChoice,
    size: UVec2,
    /// Posing by an animation, when any animation option was given.
    animation: Option<AnimationArgs>,
    /// `sky`, `none` or a panorama's path.
    environment: String,
}

/// Which animation, from when, and how many frames.
#[derive(Debug)]
struct AnimationArgs {
    /// Index or name; `None`: the first.
    which: Option<String>,
    /// Seconds of the first frame.
    time: f32,
    /// Frames of the sequence and their rate; `None`: one frame.
    sequence: Option<(u32, f32)>,
}

fn main() {
    let args = match parse_args(std::env::args().skip(1)) {
        Ok(Some(args)) => args,
        Ok(None) => {
            println!("{USAGE}");
            return;
        }
        Err(e) => {
            eprintln!("error: {e}\n\n{USAGE}");
            std::process::exit(2);
        }
    };
    if let Err(e) = run(args) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

/// `Ok(None)` asks for the usage text.
fn parse_args(args: impl Iterator<Item = String>) -> Result<Option<Args>, String> {
    let mut positional = Vec::new();
    let mut choice = SceneChoice::Default;
    let mut size = UVec2::new(800, 600);
    let (mut time, mut which, mut frames, mut fps) = (None, None, None, None);
    let mut environment = "sky".to_owned();
    let mut args = args;
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "-h" | "--help" => return Ok(None),
            "--scene" => {
                let v = args.next().ok_or("--scene needs an index or a name")?;
                choice = v.parse().map_or(SceneChoice::Name(v), SceneChoice::Index);
            }
            "--size" => {
                let v = args.next().ok_or("--size needs WxH")?;
                let parsed =
                    v.split_once('x').and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)));
                let (w, h) = parsed.ok_or_else(|| format!("--size needs WxH, e.g. 800x600 (got '{v}')"))?;
                if w == 0 || h == 0 {
                    return Err("--size must be at least 1x1".into());
                }
                size = UVec2::new(w, h);
            }
            "--time" => {
                let v = args.next().ok_or("--time needs seconds")?;
                let t = v.parse::<f32>().ok().filter(|t| t.is_finite());
                time = Some(t.ok_or_else(|| format!("--time needs a finite number of seconds (got '{v}')"))?);
            }
            "--animation" => which = Some(args.next().ok_or("--animation needs an index or a name")?),
            "--environment" => {
                environment = args.next().ok_or("--environment needs sky, none or a .hdr file")?;
                if environment.is_empty() {
                    return Err("--environment needs sky, none or a .hdr file (got '')".into());
                }
            }
            "--frames" => {
                let v = args.next().ok_or("--frames needs a count")?;
                let n = v.parse::<u32>().ok().filter(|n| (1..=100_000).contains(n));
                frames = Some(n.ok_or_else(|| format!("--frames needs a count from 1 to 100000 (got '{v}')"))?);
            }
            "--fps" => {
                let v = args.next().ok_or("--fps needs frames per second")?;
                let f = v.parse::<f32>().ok().filter(|f| f.is_finite() && *f > 0.0);
                fps = Some(f.ok_or_else(|| format!("--fps needs a positive number (got '{v}')"))?);
            }
            flag if flag.starts_with('-') && flag.len() > 1 => return Err(format!("unknown option '{flag}'")),
            _ => positional.push(arg),
        }
    }
    if positional.len() > 2 {
        return Err(format!("unexpected argument '{}' (at most FILE and OUTPUT_DIR)", positional[2]));
    }
    let mut positional = positional.into_iter();
    let file = positional.next().map_or_else(
        || PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/AlphaBlendModeTest/AlphaBlendModeTest.glb")),
        PathBuf::from,
    );
    if file.as_os_str().is_empty() {
        return Err("FILE is empty".into());
    }
    let out_dir = PathBuf::from(positional.next().unwrap_or_else(|| "out".to_owned()));
    if out_dir.as_os_str().is_empty() {
        return Err("OUTPUT_DIR is empty (give a folder, e.g. out)".into());
    }
    let sequence = match (frames, fps) {
        (Some(n), Some(f)) => Some((n, f)),
        (None, None) => None,
        (Some(_), None) => return Err("--frames needs --fps (the sequence's frame rate)".into()),
        (None, Some(_)) => return Err("--fps needs --frames (how many frames)".into()),
    };
    let animation = (time.is_some() || which.is_some() || sequence.is_some()).then(|| AnimationArgs {
        which,
        time: time.unwrap_or(0.0),
        sequence,
    });
    Ok(Some(Args { file, out_dir, choice, size, animation, environment }))
}

fn run(args: Args) -> Result<(), Box<dyn std::error::Error>> {
    tracing_subscriber::fmt()
        // Import notes and frame warnings are printed below; tracing repeats them only when asked.
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
                "warn,oxygen::gltf_import=error,oxygen::renderer=error,oxygen_sceneprep=error".into()
            }),
        )
        .with_writer(std::io::stderr)
        .init();
    let Args { file, out_dir, choice, size, animation, environment } = args;
    std::fs::create_dir_all(&out_dir)
        .map_err(|e| format!("cannot create output directory {}: {e}", out_dir.display()))?;

    let started = Instant::now();
    let mut scene = Scene::new();
    let import = import_gltf(&mut scene, &file, &choice)?;
    println!(
        "loaded {} in {:.1} ms: {} renderables, {} lights, {} cameras",
        file.display(),
        started.elapsed().as_secs_f64() * 1e3,
        import.renderables,
        import.lights,
        import.cameras.len()
    );
    for w in &import.warnings {
        println!("  note: {w}");
    }
    // f64 bounds: a model far from the origin is framed as it is at the
    // origin (the f32 corners are whole units off thirty million units out).
    let bounds = import.precise_bounds.ok_or("the scene has nothing to draw")?;
    let posing = match &animation {
        Some(a) => Some((import.animation(a.which.as_deref())?, a)),
        None => None,
    };
    if import.lights == 0 {
        let sun = scene.add_node(
            "default sun",
            Transform::IDENTITY
                .with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::new(-0.3, -0.8, -0.5).normalize())),
        );
        scene.set_light(sun, Some(Light::directional(2.5)))?;
        println!("  no lights in the file: added a default directional light");
    }

    let environment = match environment.as_str() {
        "none" => None,
        "sky" => Some(oxygen_demo::viewer_environment(&scene)),
        file => Some(oxygen::lighting::load_hdr_environment(file)?),
    };
    let mut renderer = Renderer::new_headless()?;
    if let Some(e) = &environment {
        let what = match e {
            oxygen::core::Environment::Sky(_) => "the sky matched to the sun".to_owned(),
            oxygen::core::Environment::Uniform(_) => "a uniform colour".to_owned(),
            oxygen::core::Environment::Image(i) => format!("a {} × {} panorama", i.width, i.height),
        };
        println!("environment: {what} (image-based lighting; --environment none turns it off)");
    }
    renderer.set_environment(environment.as_ref());
    // Three orbit views of `size`: refuse a size whose targets would not fit
    // before anything is allocated.
    renderer.check_target_budget(&[(size, false); 3]).map_err(|e| format!("--size {}x{}: {e}", size.x, size.y))?;
    println!(
        "adapter: {}; draw path {:?}, texture path {:?}",
        renderer.gpu().describe(),
        renderer.draw_path(),
        renderer.texture_path()
    );
    let stem = file.file_stem().and_then(|s| s.to_str()).unwrap_or("scene").to_owned();
    let mut views = Vec::new();
    for (i, camera) in import.cameras.iter().enumerate() {
        let viewport = match camera.aspect_ratio {
            Some(aspect) if aspect > 0.0 && aspect.is_finite() => {
                UVec2::new(size.x, ((size.x as f32 / aspect).round() as u32).max(1))
            }
            _ => size,
        };
        let id = renderer.register_view(camera.resolver(viewport), standard_render_graph)?;
        views.push((format!("camera{i}"), camera.name.clone(), id));
    }
    // Three orbit views around the scene's bounds: front, three-quarter, and
    // from above, built in f64 (`DLookAtResolver`) so that the eye and the
    // target keep their millimetres far from the origin.
    let center = bounds.center();
    let radius = bounds.half_extents().length().max(1e-3);
    for (tag, direction, up) in [
        ("orbit_front", DVec3::new(0.0, 0.15, 1.0), Vec3::Y),
        ("orbit_three_quarter", DVec3::new(0.8, 0.45, 0.8), Vec3::Y),
        ("orbit_top", DVec3::new(0.0, 1.0, 0.25), Vec3::NEG_Z),
    ] {
        let orbit = DLookAtResolver {
            camera: Camera::perspective(45f32.to_radians(), (radius * 0.01) as f32, None),
            eye: center + direction.normalize() * radius * 2.0,
            target: center,
            up,
            viewport: size,
        };
        views.push((tag.to_owned(), tag.to_owned(), renderer.register_view(orbit, standard_render_graph)?));
    }

    // One frame, or the sequence: frame i at T + i / F.
    let (count, fps) = posing.as_ref().and_then(|(_, a)| a.sequence).unwrap_or((1, 1.0));
    let mut written = 0;
    for i in 0..count {
        let numbered = posing.as_ref().is_some_and(|(_, a)| a.sequence.is_some());
        if let Some((animation, args)) = &posing {
            let time = args.time + i as f32 / fps;
            animation.apply(&mut scene, time)?;
            println!("animation '{}' at {time:.3} s (of {:.3} s)", animation.name, animation.duration());
        }
        let report = renderer.render_frame(&scene)?;
        for warning in &report.warnings {
            println!("  warning: {warning}");
        }
        println!(
            "frame {}: prepare {:.2} ms, record {:.2} ms, {} pipelines created",
            report.frame_index,
            report.prepare_seconds * 1e3,
            report.record_seconds * 1e3,
            renderer.internals().pipelines.pipelines_created()
        );
        for (tag, name, id) in &views {
            let Some(view_report) = report.views.iter().find(|r| r.view == *id) else {
                println!("{id} '{name}': skipped (see the warning above)");
                continue;
            };
            let file_name = if numbered { format!("{stem}_{tag}_{i:04}.png") } else { format!("{stem}_{tag}.png") };
            let path = out_dir.join(file_name);
            renderer.read_color(*id)?.save(&path).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
            written += 1;
            let frame = renderer.prepared_frame(*id).ok_or("view was not prepared")?;
            let partitions: Vec<String> =
                frame.partitions().iter().map(|p| format!("{}×{}", p.mask.names(), p.len())).collect();
            println!(
                "{id} '{name}': {} draws, {} draw calls in [{}] -> {}",
                view_report.draws,
                view_report.recorded.draw_calls,
                partitions.join(", "),
                path.display()
            );
        }
    }
    if written == 0 {
        return Err("no view could be rendered".into());
    }
    Ok(())
}
