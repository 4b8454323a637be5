//! What building an environment costs on the GPU against the CPU reference,
//! how far each [`EnvironmentQuality`] strays from that reference, and what
//! re-filtering a reflection probe costs per update:
//!
//! ```text
//! cargo run --release --example environment_bench [REPEATS] [--smoke]
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
//!
//! `--smoke` runs every step at toy sizes (a 256 × 128 panorama, one 16²
//! × 8 environment against a 64-sample reference, a 32² probe): a check
//! that the bench runs, not a measurement. With `OXYGEN_RECORD_DIR` set,
//! the run's figures are appended to
//! `$OXYGEN_RECORD_DIR/environment_bench.jsonl` (`oxygen_demo::record`).

use std::time::Instant;

use oxygen::core::{Environment, PrefilteredEnvironment};
use oxygen::passes::{EnvironmentQuality, prefiltered_levels};
use oxygen::prelude::*;
use oxygen_demo::record::{Record, Row};

/// `oxygen_demo::structured_panorama` at 1024 × 512 (256 × 128 for a
/// smoke run): smooth enough for the CPU reference, which point-samples
/// the image, to converge; a tiny bright sun would not (512 point samples
/// a texel catch it or miss it), while the GPU's filtered samples keep its
/// energy.
fn panorama(smoke: bool) -> Environment {
    if smoke { oxygen_demo::structured_panorama(256, 128) } else { oxygen_demo::structured_panorama(1024, 512) }
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
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn wait(renderer: &Renderer) -> Result<(), wgpu::PollError> {
    renderer.gpu().device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let smoke = std::env::args().skip(1).any(|a| a == "--smoke");
    let repeats: usize =
        std::env::args().skip(1).find(|a| a != "--smoke").map(|a| a.parse()).transpose()?.unwrap_or(5).max(1);
    let environment = panorama(smoke);
    let mut renderer = Renderer::new_headless()?;
    let mut record = Record::new("environment_bench")
        .adapter(&renderer.gpu().adapter_info)
        .value("smoke", smoke)
        .value("repeats", repeats);
    let (configs, reference_samples, probe_size): (&[(u32, u32)], u32, u32) = if smoke {
        (&[(16, 8)], 64, 32)
    } else {
        (&[(64, 16), (64, 32), (64, 64), (128, 32), (128, 64), (128, 128), (256, 64)], 512, 128)
    };
    record.insert("reference_samples", reference_samples);
    println!("adapter: {}", renderer.gpu().adapter_info.name);
    println!(
        "size × samples | GPU ms | CPU ms (same samples) | CPU/GPU | worst relative RMS per level vs CPU × {reference_samples}"
    );
    for &(size, samples) in configs {
        let quality = EnvironmentQuality { size, samples };
        // Warm-up: pipelines exist, the panorama's first upload is done.
        renderer.set_environment_with_quality(Some(&environment), quality);
        wait(&renderer)?;
        let mut gpu_samples = Vec::with_capacity(repeats);
        for _ in 0..repeats {
            let started = Instant::now();
            renderer.set_environment_with_quality(Some(&environment), quality);
            wait(&renderer)?;
            gpu_samples.push(started.elapsed().as_secs_f64() * 1e3);
        }
        let gpu_ms = median(gpu_samples.clone());
        let gpu = renderer.read_environment()?.ok_or("no environment to read back")?;
        let levels = prefiltered_levels(size);
        let started = Instant::now();
        let _ = environment.prefilter(size, levels, samples);
        let cpu_ms = started.elapsed().as_secs_f64() * 1e3;
        let reference = environment.prefilter(size, levels, reference_samples);
        let worst = worst_per_level(&gpu, &reference);
        let errors: Vec<String> = worst.iter().map(|e| format!("{:.1}%", e * 100.0)).collect();
        println!(
            "{size:>4}² × {samples:>3} | {gpu_ms:7.2} | {cpu_ms:9.1} | {:7.1}× | {}",
            cpu_ms / gpu_ms,
            errors.join(" ")
        );
        record.push_row(
            Row::new()
                .value("face_size_px", size)
                .value("samples", samples)
                .value("gpu_ms_median", gpu_ms)
                .value("gpu_ms_samples", gpu_samples)
                .value("cpu_ms", cpu_ms)
                .value("cpu_over_gpu", cpu_ms / gpu_ms)
                .value("worst_relative_rms_per_level", worst),
        );
    }

    // The probe filter alone, on a probe-shaped texture.
    let size = probe_size;
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
        format: oxygen::gpu::ViewTargets::HDR_FORMAT,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    });
    let time = |samples: Option<u32>| -> Result<f64, wgpu::PollError> {
        let mut times = Vec::new();
        for _ in 0..repeats.max(3) * 4 {
            let mut encoder = device.create_command_encoder(&Default::default());
            if let Some(samples) = samples {
                renderer.internals().lighting.prefilter_probe(device, &mut encoder, &probe, samples);
            }
            let started = Instant::now();
            renderer.gpu().queue.submit([encoder.finish()]);
            wait(&renderer)?;
            times.push(started.elapsed().as_secs_f64() * 1e3);
        }
        Ok(median(times))
    };
    let empty = time(None)?;
    println!("probe {size}² re-filter (levels 1..=5), empty submission {empty:.3} ms subtracted:");
    record.insert("probe_size_px", size);
    record.insert("probe_empty_submission_ms_median", empty);
    for samples in [8, 16, 32, 64] {
        let _ = time(Some(samples))?;
        let ms = time(Some(samples))? - empty;
        println!("  {samples:>2} samples: {ms:.3} ms");
        record.push_row_to(
            "probe_rows",
            Row::new().value("samples", samples).value("refilter_ms_median_minus_empty", ms),
        );
    }
    record.write()?;
    Ok(())
}
