//! Shadow views and reflection probes are ordinary registered views: a sun
//! with cascaded shadows, a spot light with its own shadow view, a point
//! light with six (one per cube face), and a mirror
//! sphere reflecting a coloured box through a probe's six face views. One
//! main camera; writes its PNG and prints a table of every view.
//!
//! ```text
//! cargo run --release --example shadows_and_probes [OUTPUT_DIR]   # default: out/
//! ```

use oxygen::ViewRole;
use oxygen::core::CascadeSettings;
use oxygen::glam::{Quat, Vec4};
use oxygen::lighting::{LocalShadowSettings, ProbeUpdate, ReflectionProbe};
use oxygen::prelude::*;
use std::path::PathBuf;

fn scene() -> Result<Scene, Box<dyn std::error::Error>> {
    let mut scene = Scene::new();
    let grey = scene.add_material(Material::opaque("ground", Vec4::splat(0.6)));
    let plane = scene.add_geometry(Geometry::plane(30.0));
    let ground = scene.add_node("ground", Transform::IDENTITY);
    scene.set_renderable(ground, Renderable { geometry: plane, materials: vec![grey] })?;

    let cube = scene.add_geometry(Geometry::cube(1.0));
    let red = scene.add_material(Material::opaque("red", Vec4::new(0.85, 0.1, 0.08, 1.0)));
    let blue = scene.add_material(Material::opaque("blue", Vec4::new(0.1, 0.2, 0.85, 1.0)));
    for (name, at, material) in
        [("red box", Vec3::new(2.2, 0.5, 0.0), red), ("blue box", Vec3::new(-3.0, 0.5, -1.5), blue)]
    {
        let node = scene.add_node(name, Transform::from_translation(at));
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![material] })?;
    }
    let mirror =
        scene.add_material(Material { metallic: 1.0, roughness: 0.03, ..Material::opaque("mirror", Vec4::ONE) });
    let sphere = scene.add_geometry(Geometry::uv_sphere(1.0, 48, 24));
    let ball = scene.add_node("mirror ball", Transform::from_translation(Vec3::new(0.0, 1.0, 0.0)));
    scene.set_renderable(ball, Renderable { geometry: sphere, materials: vec![mirror] })?;

    let sun_direction = Vec3::new(-0.5, -1.0, -0.35).normalize();
    let sun =
        scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, sun_direction)));
    scene.set_light(sun, Some(Light::directional(2.0)))?;
    let spot_position = Vec3::new(-5.0, 4.0, 3.0);
    let aim = (Vec3::new(-3.0, 0.0, -1.5) - spot_position).normalize();
    let spot = scene.add_node(
        "spot",
        Transform::from_translation(spot_position).with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, aim)),
    );
    scene.set_light(spot, Some(Light::spot(300.0, Some(25.0), 0.3, 0.45)))?;
    // A warm lantern beside the red box: its shadow falls away from it on
    // every side, through the point light's six cube-face views.
    let lantern = scene.add_node("lantern", Transform::from_translation(Vec3::new(3.6, 1.4, 1.2)));
    scene.set_light(lantern, Some(Light { color: Vec3::new(1.0, 0.7, 0.4), ..Light::point(25.0, Some(12.0)) }))?;
    Ok(scene)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out_dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "out".to_owned()));
    std::fs::create_dir_all(&out_dir)?;
    let scene = scene()?;
    let mut renderer = Renderer::new_headless()?;
    println!("adapter: {}", renderer.gpu().describe());

    let camera = LookAtResolver::new(
        Camera::perspective(50f32.to_radians(), 0.1, Some(80.0)),
        Vec3::new(0.5, 4.0, 8.0),
        Vec3::new(-0.3, 0.6, 0.0),
        UVec2::new(960, 540),
    )
    .unwrap();
    // The main view comes first: the renderer records it after what it reads
    // (its own sun cascades, the spot and point shadow views, the probe's
    // faces), whatever the registration order.
    renderer.set_local_shadows(Some(LocalShadowSettings { resolution: 1024, ..Default::default() }));
    let settings = CascadeSettings { count: 3, resolution: 1024, max_distance: 40.0, caster_margin: 20.0, lambda: 0.6 };
    let main = renderer.register_view(ViewDesc::new(camera).with_sun_shadows(settings), standard_render_graph)?;
    let mut probe = ReflectionProbe::register(
        &mut renderer,
        Vec3::new(0.0, 1.0, 0.0),
        128,
        (0.05, 60.0),
        ProbeUpdate::EveryNthFrame(10),
    )?;
    renderer.link(main, probe.cube())?;

    probe.before_frame(&mut renderer)?;
    let started = std::time::Instant::now();
    let report = renderer.render_frame(&scene)?;
    renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely())?;
    let first_frame_ms = started.elapsed().as_secs_f64() * 1e3;
    let kind = |role: ViewRole| match role {
        ViewRole::Registered => "main",
        ViewRole::SunCascade { .. } => "sun cascade",
        ViewRole::LocalShadow { .. } => "local-light shadow",
        ViewRole::ProbeFace { .. } => "probe face",
        ViewRole::BatchCamera { .. } => "batch camera",
    };
    println!("| view | kind | draws | partitions | prep ms | record ms |");
    println!("|---|---|---:|---:|---:|---:|");
    for v in &report.views {
        println!(
            "| {} | {} | {} | {} | {:.3} | {:.3} |",
            v.view,
            kind(v.role),
            v.draws,
            v.partitions,
            v.prep_seconds * 1e3,
            v.record_seconds * 1e3
        );
    }
    println!(
        "first frame: {first_frame_ms:.1} ms, GPU waited; prepare {:.2} ms (frame phase + all views), record {:.2} ms \
         on {} threads, compiling {} pipelines",
        report.prepare_seconds * 1e3,
        report.record_seconds * 1e3,
        report.record_threads,
        renderer.internals().pipelines.pipelines_created()
    );
    let path = out_dir.join("shadows_and_probes.png");
    renderer.read_color(main)?.save(&path)?;
    println!("main view -> {}", path.display());
    Ok(())
}
