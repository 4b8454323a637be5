//! What building an environment costs on the GPU against the CPU reference,
//! how far each [`EnvironmentQuality`] strays from that reference, and what
//! re-filtering a reflection probe costs per update:
//!
//! ```text
//! cargo run --release --example environment_bench [REPEATS]
//! ```
//!
//! The environment is `oxygen_demo::structured_panorama` at 1024 × 512 (a
//! sky gradient, a bright blob, stripes). For each (face size, samples):
//! the GPU's wall time for `Renderer::set_environment_with_quality` (upload,
//! conversion, box mips, GGX levels, harmonics, waiting for the GPU; median
//! of REPEATS), the CPU reference's time at the same size and levels with
//! the same samples, and the GPU's error: per level, the worst face's
//! relative RMS difference from the CPU prefilter at 512 samples. Then the
//! probe filter: a 128² probe's levels re-filtered with 8 to 64 samples a
//! texel (median wall time, an empty submission's subtracted).

use std::time::Instant;

use oxygen::core::{Environment, PrefilteredEnvironment};
use oxygen::passes::{EnvironmentQuality, prefiltered_levels};
use oxygen::prelude::*;

/// `oxygen_demo::structured_panorama` at 1024 × 512: smooth enough for
/// the CPU reference, which point-samples the image, to converge; a tiny
/// bright sun would not (512 point samples a texel catch it or miss it),
/// while the GPU's filtered samples keep its energy.
fn panorama() -> Environment {
    oxygen_demo::structured_panorama(1024, 512)
}

fn relative_rms(got: &[Vec3], reference: &[Vec3]) -> f32 {
    let error: f32 = got.iter().zip(reference).map(|(a, b)| (*a - *b).length_squared()).sum();
    let energy: f32 = reference.iter().map(|b| b.length_squared()).sum();
    (error / energy.max(1e-12)).sqrt()
}

fn worst_per_level(gpu: &PrefilteredEnvironment, cpu: &PrefilteredEnvironment) -> Vec<f32> {
    gpu.levels
        .iter()
        .zip(&cpu.levels)
        .map(|(g, c)| (0..6).map(|face| relative_rms(&g[face], &c[face])).fold(0.0, f32::max))
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn wait(renderer: &Renderer) {
    renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely()).expect("the device answers");
}

fn main() {
    let repeats: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(5).max(1);
    let environment = panorama();
    let mut renderer = Renderer::new_headless().expect("a GPU adapter");
    println!("adapter: {}", renderer.gpu().adapter_info.name);
    println!("size × samples | GPU ms | CPU ms (same samples) | CPU/GPU | worst relative RMS per level vs CPU × 512");
    for (size, samples) in [(64, 16), (64, 32), (64, 64), (128, 32), (128, 64), (128, 128), (256, 64)] {
        let quality = EnvironmentQuality { size, samples };
        // Warm-up: pipelines exist, the panorama's first upload is done.
        renderer.set_environment_with_quality(Some(&environment), quality);
        wait(&renderer);
        let gpu_ms = median(
            (0..repeats)
                .map(|_| {
                    let started = Instant::now();
                    renderer.set_environment_with_quality(Some(&environment), quality);
                    wait(&renderer);
                    started.elapsed().as_secs_f64() * 1e3
                })
                .collect(),
        );
        let gpu = renderer.read_environment().expect("readback").expect("an environment");
        let levels = prefiltered_levels(size);
        let started = Instant::now();
        let _ = environment.prefilter(size, levels, samples);
        let cpu_ms = started.elapsed().as_secs_f64() * 1e3;
        let reference = environment.prefilter(size, levels, 512);
        let errors: Vec<String> =
            worst_per_level(&gpu, &reference).iter().map(|e| format!("{:.1}%", e * 100.0)).collect();
        println!(
            "{size:>4}² × {samples:>3} | {gpu_ms:7.2} | {cpu_ms:9.1} | {:7.1}× | {}",
            cpu_ms / gpu_ms,
            errors.join(" ")
        );
    }

    // The probe filter alone, on a probe-shaped texture.
    let size = 128u32;
    let device = &renderer.gpu().device;
    let probe = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("bench probe"),
        size: wgpu::Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: oxygen::passes::array_layer_count(6, true),
        },
        mip_level_count: u32::BITS - size.leading_zeros(),
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: oxygen::core::ViewTargets::HDR_FORMAT,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    });
    let time = |samples: Option<u32>| {
        median(
            (0..repeats.max(3) * 4)
                .map(|_| {
                    let mut encoder = device.create_command_encoder(&Default::default());
                    if let Some(samples) = samples {
                        renderer.lighting().prefilter_probe(device, &mut encoder, &probe, samples);
                    }
                    let started = Instant::now();
                    renderer.gpu().queue.submit([encoder.finish()]);
                    wait(&renderer);
                    started.elapsed().as_secs_f64() * 1e3
                })
                .collect(),
        )
    };
    let empty = time(None);
    println!("probe {size}² re-filter (levels 1..=5), empty submission {empty:.3} ms subtracted:");
    for samples in [8, 16, 32, 64] {
        let _ = time(Some(samples));
        println!("  {samples:>2} samples: {:.3} ms", time(Some(samples)) - empty);
    }
}
