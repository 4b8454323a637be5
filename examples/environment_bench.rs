//! What prefiltering an environment costs on the CPU, and how far a coarser
//! prefilter strays from a fine one (the knob behind
//! `Renderer::set_environment`'s defaults: 64² faces, 7 levels, 64 samples):
//!
//! ```text
//! cargo run --release --example environment_bench
//! ```
//!
//! The procedural sky for a sun 50° high. For each (face size, samples) the
//! prefilter's wall time and, against 128² faces with 512 samples, the
//! largest relative difference of level 3's texels (roughness 0.5 at 7
//! levels) from the reference's nearest texel in the same direction.

use std::time::Instant;

use oxygen::core::environment::cube_texel_direction;
use oxygen::core::{Environment, PrefilteredEnvironment};
use oxygen::prelude::*;

/// Level `level` of `p` looked up along `dir` (nearest texel).
fn lookup(p: &PrefilteredEnvironment, level: usize, dir: Vec3) -> Vec3 {
    let side = (p.size >> level).max(1);
    let mut best = (f32::MIN, Vec3::ZERO);
    for face in 0..6 {
        for y in 0..side {
            for x in 0..side {
                let d = cube_texel_direction(face, x, y, side);
                let c = d.dot(dir);
                if c > best.0 {
                    best = (c, p.levels[level][face][(y * side + x) as usize]);
                }
            }
        }
    }
    best.1
}

fn main() {
    let sky = Environment::sky_for_sun(Vec3::new(0.3, -0.77, -0.56).normalize());
    let started = Instant::now();
    let reference = sky.prefilter(128, 7, 512);
    println!("reference 128² × 512 samples: {:.1} ms", started.elapsed().as_secs_f64() * 1e3);
    for (size, samples) in [(32, 32), (32, 64), (64, 32), (64, 64), (64, 128), (128, 64)] {
        let levels = 7;
        let started = Instant::now();
        let p = sky.prefilter(size, levels, samples);
        let ms = started.elapsed().as_secs_f64() * 1e3;
        // Level 3 of 7 (roughness 0.5 in both), at the centres of its own
        // texels: the reference (twice as fine or more) looked up there.
        let side = (size >> 3).max(1);
        let mut worst = 0.0f32;
        for face in 0..6 {
            for y in 0..side {
                for x in 0..side {
                    let d = cube_texel_direction(face, x, y, side);
                    let (a, b) = (p.levels[3][face][(y * side + x) as usize], lookup(&reference, 3, d));
                    worst = worst.max(((a - b).abs() / b.max(Vec3::splat(1e-3))).max_element());
                }
            }
        }
        println!(
            "{size:>3}² × {samples:>3} samples: {ms:8.1} ms, level 3 texels within {:.1} % of the reference",
            worst * 100.0
        );
    }
}
