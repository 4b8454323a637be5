//! Directional-light shadows through cascade views: the demo scene, one main
//! camera, and the sun's cascades registered as ordinary views before it.
//! Writes the main view to a PNG and prints a table of the views.
//!
//! ```text
//! cargo run --release --example shadows [OUTPUT_DIR]   # default: out/
//! ```

use std::path::PathBuf;
use std::sync::Arc;

use oxygen::core::CascadeSettings;
use oxygen::core::demo::{main_camera, multi_view_scene};
use oxygen::prelude::*;
use oxygen::{register_sun_cascades, shadowed_render_graph};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out_dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "out".to_owned()));
    std::fs::create_dir_all(&out_dir)?;
    let demo = multi_view_scene();
    let mut renderer = Renderer::new_headless()?;
    println!("adapter: {}", renderer.gpu().describe());

    let camera = main_camera(UVec2::new(960, 540));
    let settings = CascadeSettings { count: 3, resolution: 1024, max_distance: 40.0, caster_margin: 20.0, lambda: 0.6 };
    let cascades = register_sun_cascades(&mut renderer, &demo.scene, Arc::new(camera), settings);
    let main = renderer.register_view(camera, shadowed_render_graph(cascades));
    let report = renderer.render_frame(&demo.scene)?;

    println!("| view | kind | draws | partitions | draw calls |");
    println!("|---|---|---:|---:|---:|");
    for v in &report.views {
        let kind = if v.view == main { "main" } else { "sun cascade" };
        println!("| {} | {kind} | {} | {} | {} |", v.view, v.draws, v.partitions, v.recorded.draw_calls);
    }
    println!(
        "prep (all views) {:.2} ms, record (all views) {:.2} ms",
        report.prepare_seconds * 1e3,
        report.record_seconds * 1e3
    );
    let path = out_dir.join("shadows_main.png");
    renderer.read_color(main)?.save(&path)?;
    println!("main view -> {}", path.display());
    Ok(())
}
