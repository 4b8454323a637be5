//! The accuracy atlas: every speed/accuracy knob of the raster path, timed
//! and measured against the path-traced reference of the same scene.
//!
//! ```text
//! cargo run --release --example accuracy_atlas [OUT_DIR] [SIZE] [SAMPLES]   # defaults: docs/accuracy 160 512
//! ```
//!
//! For each knob setting it renders the raster view (warm-up, then the
//! median of 10 frames' GPU time, from timestamps where the adapter has
//! them, else of the wall time of each frame waited for) and compares
//! its HDR image with the reference: the same scene traced with the raster
//! path's light transport ([`ReferenceSettings::RASTER_MODEL`]: direct light,
//! exact shadows, the raster's ambient term, SAMPLES paths per pixel), so
//! that what is left is the knob's approximation, not a lighting model the
//! raster path does not have. Errors: RMSE of linear radiance, and SSIM of
//! the tone-mapped sRGB luma (1 = identical; 8 × 8 windows, stride 4).
//!
//! `accuracy_atlas --chart atlas.csv atlas.png` redraws the chart from a
//! run's CSV.
//!
//! Writes `OUT_DIR/atlas.csv` (one row per setting), `OUT_DIR/atlas.png`
//! (time against RMSE, one curve per knob), and per setting an error map
//! `OUT_DIR/error_<knob>_<setting>.png` (|raster − reference| luminance,
//! ×8, white = 1/8 or more). docs/accuracy.md explains how to read them.
//!
//! Knobs: sun-shadow resolution, cascade count, PCF radius, texture path,
//! render origin (the scene 30 000 units from the world origin), and
//! visibility (CPU, GPU frustum, GPU occlusion: each must cost no accuracy).

use std::path::{Path, PathBuf};
use std::time::Instant;

use oxygen::prelude::*;
use plotters::prelude::*;

const WARM_UP: usize = 3;
const MEASURED: usize = 10;

/// One scene with its camera.
struct Stage {
    name: &'static str,
    scene: Scene,
    camera: LookAtResolver,
    /// Sun cascades of its raster view by default.
    cascades: CascadeSettings,
}

/// One raster configuration.
struct Setting {
    knob: &'static str,
    value: String,
    stage: usize,
    options: RendererOptions,
    cascades: Option<CascadeSettings>,
    pcf_radius: u32,
    visibility: Option<Visibility>,
}

struct Row {
    knob: &'static str,
    value: String,
    stage: &'static str,
    ms: f64,
    rmse: f64,
    ssim: f64,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1).peekable();
    // `--chart atlas.csv out.png`: redraw a chart from a run's CSV (for
    // runs on machines without the font).
    if args.peek().map(String::as_str) == Some("--chart") {
        let (csv, png) = (args.nth(1).ok_or("--chart CSV PNG")?, args.next().ok_or("--chart CSV PNG")?);
        return chart(&read_csv(&std::fs::read_to_string(csv)?)?, Path::new(&png));
    }
    let out = PathBuf::from(args.next().unwrap_or_else(|| "docs/accuracy".into()));
    let size: u32 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(160);
    let samples: u32 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(512);
    std::fs::create_dir_all(&out)?;
    let viewport = UVec2::new(size, size * 9 / 16);
    let stages = stages(viewport)?;
    let settings = settings();

    // The references, one per stage, traced once.
    let mut references = Vec::new();
    for stage in &stages {
        let started = Instant::now();
        let (hdr, srgb, adapter) = reference(stage, samples)?;
        eprintln!(
            "[atlas] reference of {}: {samples} samples per pixel in {:.1} s on {adapter}",
            stage.name,
            started.elapsed().as_secs_f64()
        );
        references.push((hdr, srgb));
    }

    let mut rows = Vec::new();
    for (i, setting) in settings.iter().enumerate() {
        let stage = &stages[setting.stage];
        let (hdr, srgb, ms) = raster(stage, setting)?;
        let (reference_hdr, reference_srgb) = &references[setting.stage];
        let rmse = rmse(&hdr, reference_hdr);
        let ssim = ssim(&srgb, reference_srgb);
        error_map(&hdr, reference_hdr, srgb.dimensions()).save(out.join(format!(
            "error_{}_{}.png",
            setting.knob.replace(' ', "_"),
            setting.value.replace([' ', '/', '×'], "_")
        )))?;
        eprintln!(
            "[atlas] {}/{} {} = {}: {ms:.2} ms, RMSE {rmse:.5}, SSIM {ssim:.4}",
            i + 1,
            settings.len(),
            setting.knob,
            setting.value
        );
        rows.push(Row { knob: setting.knob, value: setting.value.clone(), stage: stage.name, ms, rmse, ssim });
    }

    let mut csv = String::from("knob,setting,scene,frame_ms,rmse_linear,ssim\n");
    for r in &rows {
        csv.push_str(&format!("{},{},{},{:.4},{:.6},{:.5}\n", r.knob, r.value, r.stage, r.ms, r.rmse, r.ssim));
    }
    std::fs::write(out.join("atlas.csv"), csv)?;
    chart(&rows, &out.join("atlas.png"))?;
    eprintln!("[atlas] wrote {}", out.display());
    Ok(())
}

/// Rows back from `atlas.csv`.
fn read_csv(text: &str) -> Result<Vec<Row>, Box<dyn std::error::Error>> {
    let mut rows = Vec::new();
    for line in text.lines().skip(1).filter(|l| !l.trim().is_empty()) {
        let cells: Vec<&str> = line.split(',').collect();
        let [knob, value, stage, ms, rmse, ssim] = cells[..] else {
            return Err(format!("not a row of the atlas: {line}").into());
        };
        // Knob and scene names live as long as the program.
        let leak = |s: &str| -> &'static str { Box::leak(s.to_owned().into_boxed_str()) };
        rows.push(Row {
            knob: leak(knob),
            value: value.to_owned(),
            stage: leak(stage),
            ms: ms.parse()?,
            rmse: rmse.parse()?,
            ssim: ssim.parse()?,
        });
    }
    Ok(rows)
}

fn stages(viewport: UVec2) -> Result<Vec<Stage>, Box<dyn std::error::Error>> {
    // A box on a floor under a low sun: long shadows, the shadow knobs'
    // scene.
    let shadows = Stage {
        name: "box on a floor",
        scene: oxygen_demo::floor_with_box(0.6),
        camera: LookAtResolver {
            camera: Camera::perspective(60f32.to_radians(), 0.1, None),
            eye: Vec3::new(0.0, 3.0, 5.0),
            target: Vec3::new(0.0, 0.0, -1.0),
            up: Vec3::Y,
            viewport,
        },
        cascades: CascadeSettings { count: 1, resolution: 1024, ..Default::default() },
    };
    // The shipped textured box, at the origin and 30 000 units out.
    let textured = |offset: Vec3, name| -> Result<Stage, Box<dyn std::error::Error>> {
        let mut scene = Scene::new();
        let root = scene.add_node("offset", Transform::from_translation(offset));
        // The repository's copy; relative to the working directory when
        // the binary runs elsewhere than it was built.
        let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/BoxTextured/BoxTextured.glb");
        let path = if shipped.exists() { shipped } else { PathBuf::from("assets/BoxTextured/BoxTextured.glb") };
        let import = import_gltf(&mut scene, &path, &SceneChoice::Default)?;
        for node in import.roots {
            scene.set_parent(node, Some(root))?;
        }
        oxygen_demo::add_default_sun(&mut scene);
        let floor = scene.add_geometry(Geometry::plane(6.0));
        let grey = scene.add_material(Material::opaque("floor", Vec4::splat(0.5)));
        let node = scene.add_node("floor", Transform::from_translation(offset + Vec3::new(0.0, -0.5, 0.0)));
        scene.set_renderable(node, Renderable { geometry: floor, materials: vec![grey] })?;
        Ok(Stage {
            name,
            scene,
            camera: LookAtResolver {
                camera: Camera::perspective(50f32.to_radians(), 0.05, None),
                eye: offset + Vec3::new(1.6, 1.2, 2.0),
                target: offset,
                up: Vec3::Y,
                viewport,
            },
            cascades: CascadeSettings { count: 1, resolution: 2048, ..Default::default() },
        })
    };
    Ok(vec![
        shadows,
        textured(Vec3::ZERO, "textured box")?,
        textured(Vec3::new(30_000.0, 0.0, 0.0), "textured box 3e4 out")?,
    ])
}

fn settings() -> Vec<Setting> {
    let base = |knob, value: String, stage| Setting {
        knob,
        value,
        stage,
        options: RendererOptions { keep_hdr: true, ..Default::default() },
        cascades: None,
        pcf_radius: 1,
        visibility: Some(Visibility::Cpu),
    };
    let mut all = Vec::new();
    for resolution in [256, 512, 1024, 2048, 4096] {
        let mut s = base("shadow resolution", resolution.to_string(), 0);
        s.cascades = Some(CascadeSettings { count: 1, resolution, ..Default::default() });
        all.push(s);
    }
    for count in 1..=4 {
        let mut s = base("cascade count", count.to_string(), 0);
        s.cascades = Some(CascadeSettings { count, resolution: 1024, ..Default::default() });
        all.push(s);
    }
    for radius in 0..=3 {
        let mut s = base("PCF radius", radius.to_string(), 0);
        s.pcf_radius = radius;
        all.push(s);
    }
    for (name, path) in [("binding array", TexturePath::BindingArray), ("grouped arrays", TexturePath::GroupedArrays)] {
        let mut s = base("texture path", name.to_string(), 1);
        s.options.texture_path = Some(path);
        all.push(s);
    }
    for (name, origin) in
        [("absolute", RenderOrigin::Absolute), ("follow the camera", RenderOrigin::FollowFirstView { grid: 64.0 })]
    {
        let mut s = base("render origin", name.to_string(), 2);
        s.options.origin = origin;
        all.push(s);
    }
    for (name, visibility) in
        [("CPU", Visibility::Cpu), ("GPU frustum", Visibility::GpuFrustum), ("GPU occlusion", Visibility::GpuOcclusion)]
    {
        let mut s = base("visibility", name.to_string(), 1);
        s.visibility = Some(visibility);
        all.push(s);
    }
    all
}

/// The stage's reference: HDR and tone-mapped images, and the adapter.
fn reference(stage: &Stage, samples: u32) -> Result<(HdrPixels, image::RgbaImage, String), Box<dyn std::error::Error>> {
    let mut renderer = Renderer::new_headless_with(RendererOptions {
        keep_hdr: true,
        // Camera-relative: the reference must not inherit the precision
        // loss the render-origin knob measures.
        origin: RenderOrigin::FollowFirstView { grid: 1.0 },
        ..Default::default()
    })?;
    let settings = ReferenceSettings { samples_per_frame: 16, max_samples: samples, ..ReferenceSettings::RASTER_MODEL };
    let view = renderer
        .register_view(ViewDesc::new(stage.camera).path_traced(), ReferenceGraph { settings, exposure: 1.0 })?;
    while renderer.reference_samples(view) < samples {
        renderer.render_frame(&stage.scene)?;
        renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
    }
    let hdr = renderer.read_hdr(view)?;
    let adapter = renderer.gpu().adapter.get_info().name;
    Ok((hdr.pixels, renderer.read_color(view)?, adapter))
}

type HdrPixels = Vec<[f32; 4]>;

/// The raster view of `setting`: HDR and tone-mapped images, median ms.
fn raster(stage: &Stage, setting: &Setting) -> Result<(HdrPixels, image::RgbaImage, f64), Box<dyn std::error::Error>> {
    let mut renderer = Renderer::new_headless_with(setting.options)?;
    let mut desc = ViewDesc::new(stage.camera).with_sun_shadows(setting.cascades.unwrap_or(stage.cascades));
    if let Some(visibility) = setting.visibility {
        desc = desc.with_visibility(visibility);
    }
    let config = ForwardLitConfig { shadow_pcf_radius: setting.pcf_radius, ..ForwardLitConfig::default() };
    let view = renderer.register_view(desc, lit_render_graph(config))?;
    // GPU time between the frame's timestamps where the adapter writes
    // them (a report carries an earlier frame's), else the wall clock of
    // the frame waited for.
    let (mut gpu_times, mut wall_times) = (Vec::new(), Vec::new());
    for frame in 0..WARM_UP + MEASURED + 2 {
        let started = Instant::now();
        let report = renderer.render_frame(&stage.scene)?;
        renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
        if frame >= WARM_UP + 2 {
            wall_times.push(started.elapsed().as_secs_f64() * 1e3);
            gpu_times.extend(report.gpu_seconds.map(|s| s * 1e3));
        }
    }
    let mut times = if gpu_times.len() == wall_times.len() { gpu_times } else { wall_times };
    times.sort_by(f64::total_cmp);
    let hdr = renderer.read_hdr(view)?;
    Ok((hdr.pixels, renderer.read_color(view)?, times[times.len() / 2]))
}

fn rmse(a: &[[f32; 4]], b: &[[f32; 4]]) -> f64 {
    let sum: f64 =
        a.iter().zip(b).map(|(p, q)| (0..3).map(|c| (f64::from(p[c]) - f64::from(q[c])).powi(2)).sum::<f64>()).sum();
    (sum / (a.len().max(1) * 3) as f64).sqrt()
}

fn luma(p: &image::Rgba<u8>) -> f64 {
    (0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])) / 255.0
}

/// Mean SSIM of the luma over 8 × 8 windows at a stride of 4.
fn ssim(a: &image::RgbaImage, b: &image::RgbaImage) -> f64 {
    const C1: f64 = 0.01 * 0.01;
    const C2: f64 = 0.03 * 0.03;
    let (w, h) = a.dimensions();
    let (mut total, mut windows) = (0.0, 0usize);
    for y in (0..h.saturating_sub(7)).step_by(4) {
        for x in (0..w.saturating_sub(7)).step_by(4) {
            let (mut sa, mut sb, mut saa, mut sbb, mut sab) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for dy in 0..8 {
                for dx in 0..8 {
                    let (p, q) = (luma(a.get_pixel(x + dx, y + dy)), luma(b.get_pixel(x + dx, y + dy)));
                    sa += p;
                    sb += q;
                    saa += p * p;
                    sbb += q * q;
                    sab += p * q;
                }
            }
            let n = 64.0;
            let (ma, mb) = (sa / n, sb / n);
            let (va, vb, cov) = (saa / n - ma * ma, sbb / n - mb * mb, sab / n - ma * mb);
            total += ((2.0 * ma * mb + C1) * (2.0 * cov + C2)) / ((ma * ma + mb * mb + C1) * (va + vb + C2));
            windows += 1;
        }
    }
    if windows == 0 { 1.0 } else { total / windows as f64 }
}

/// |raster − reference| in luminance, ×8, as a grey image (white: 1/8 or more).
fn error_map(a: &[[f32; 4]], b: &[[f32; 4]], (width, height): (u32, u32)) -> image::GrayImage {
    image::GrayImage::from_fn(width, height, |x, y| {
        let i = (y * width + x) as usize;
        let l = |p: &[f32; 4]| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
        let d = a.get(i).zip(b.get(i)).map_or(0.0, |(p, q)| (l(p) - l(q)).abs());
        image::Luma([(d * 8.0 * 255.0).clamp(0.0, 255.0) as u8])
    })
}

/// Time against RMSE, one curve per knob, labelled by setting.
fn chart(rows: &[Row], path: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let font = ["/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", "/usr/share/fonts/TTF/DejaVuSans.ttf"]
        .iter()
        .find_map(|p| std::fs::read(p).ok());
    let Some(font) = font else {
        eprintln!("[atlas] no DejaVuSans.ttf found (apt-get install fonts-dejavu-core): the chart is skipped");
        return Ok(());
    };
    // plotters keeps registered fonts for the process.
    let font: &'static [u8] = Box::leak(font.into_boxed_slice());
    plotters::style::register_font("sans-serif", FontStyle::Normal, font).map_err(|_| "the font does not load")?;
    let (width, height) = (1200u32, 800u32);
    let mut pixels = vec![255u8; (width * height * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (width, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let max_ms = rows.iter().map(|r| r.ms).fold(0.0, f64::max) * 1.1;
        let max_rmse = rows.iter().map(|r| r.rmse).fold(0.0, f64::max) * 1.1;
        let mut chart = ChartBuilder::on(&root)
            .caption("Accuracy atlas: frame time against RMSE to the path-traced reference", ("sans-serif", 24))
            .margin(20)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(0.0..max_ms.max(1e-3), 0.0..max_rmse.max(1e-6))?;
        chart.configure_mesh().x_desc("frame ms (GPU)").y_desc("RMSE, linear radiance").draw()?;
        let mut knobs: Vec<&str> = rows.iter().map(|r| r.knob).collect();
        knobs.dedup();
        for (k, knob) in knobs.iter().enumerate() {
            let color = Palette99::pick(k).to_rgba();
            let points: Vec<(f64, f64, String)> =
                rows.iter().filter(|r| r.knob == *knob).map(|r| (r.ms, r.rmse, r.value.clone())).collect();
            chart
                .draw_series(LineSeries::new(points.iter().map(|p| (p.0, p.1)), color.stroke_width(2)))?
                .label(*knob)
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2)));
            chart.draw_series(points.iter().map(|p| {
                EmptyElement::at((p.0, p.1))
                    + Circle::new((0, 0), 4, color.filled())
                    + Text::new(p.2.clone(), (6, -14), ("sans-serif", 13))
            }))?;
        }
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
        root.present()?;
    }
    image::RgbImage::from_raw(width, height, pixels).ok_or("chart buffer")?.save(path)?;
    Ok(())
}
