//! Renders the procedural demo scene (ground, a grid of cubes, a masked
//! double-sided quad, a sun) through two registered views and writes one
//! PNG per view.
//!
//! ```text
//! cargo run --release --example multi_view [OUTPUT_DIR]   # default: out/
//! ```
//! Set `RUST_LOG=info` (or `debug`) for the pipeline's tracing output.

use std::path::PathBuf;

use oxygen::prelude::*;
use oxygen_demo::{main_camera, multi_view_scene, side_camera};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "warn".into()))
        .with_writer(std::io::stderr)
        .init();
    let out_dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "out".to_owned()));
    std::fs::create_dir_all(&out_dir)?;

    let mut renderer = Renderer::new_headless()?;
    println!("adapter: {}", renderer.gpu().describe());

    let demo = multi_view_scene();
    let views = [
        ("main", renderer.register_view(main_camera(UVec2::new(960, 540)), standard_render_graph)?),
        ("side", renderer.register_view(side_camera(UVec2::new(640, 480)), standard_render_graph)?),
    ];
    let report = renderer.render_frame(&demo.scene)?;
    println!(
        "frame {}: prepare {:.2} ms, record {:.2} ms, {} pipelines created",
        report.frame_index,
        report.prepare_seconds * 1e3,
        report.record_seconds * 1e3,
        renderer.internals().pipelines.pipelines_created()
    );
    for (name, id) in views {
        let path = out_dir.join(format!("multi_view_{name}.png"));
        renderer.read_color(id)?.save(&path)?;
        let frame = renderer.prepared_frame(id).ok_or("view was not prepared")?;
        let partitions: Vec<String> =
            frame.partitions().iter().map(|p| format!("{}×{}", p.mask.names(), p.len())).collect();
        println!("{id} '{name}': {} draws in [{}] -> {}", frame.draws().len(), partitions.join(", "), path.display());
    }
    Ok(())
}
