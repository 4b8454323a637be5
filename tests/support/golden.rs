//! Golden images: a rendered picture against a PNG kept in `tests/golden/`.
//!
//! Two pixels match when every channel differs by at most `channel_tolerance`
//! levels; a picture matches when at most `max_differing` fraction of its
//! pixels do not. On a mismatch the actual image and a difference image
//! (differing pixels red, matching ones dimmed) are written next to the
//! golden for a person to look at.
//!
//! Outside CI a missing golden is written (and the test passes, saying so)
//! and `OXYGEN_UPDATE_GOLDEN=1` rewrites every golden. Under `CI` goldens are
//! never written: a missing golden fails, and so does an update request, with
//! a message saying how to make the golden on a developer's machine.

use std::path::PathBuf;

use image::{Rgba, RgbaImage};

/// Tolerances of a golden comparison.
#[derive(Clone, Copy, Debug)]
pub struct Tolerance {
    /// Largest per-channel difference that still counts as equal.
    pub channel_tolerance: u8,
    /// Largest fraction of pixels allowed to differ.
    pub max_differing: f64,
}

impl Default for Tolerance {
    fn default() -> Self {
        Tolerance { channel_tolerance: 10, max_differing: 0.005 }
    }
}

fn golden_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests").join("golden")
}

/// Compares `actual` with `tests/golden/{name}.png`.
pub fn assert_golden(name: &str, actual: &RgbaImage, tolerance: Tolerance) {
    let dir = golden_dir();
    let golden_path = dir.join(format!("{name}.png"));
    let update = std::env::var("OXYGEN_UPDATE_GOLDEN").is_ok_and(|v| v == "1");
    if under_ci() {
        assert!(
            !update,
            "OXYGEN_UPDATE_GOLDEN=1 under CI: goldens are never written by CI; \
             update {} on a developer's machine and commit it",
            golden_path.display()
        );
        assert!(
            golden_path.exists(),
            "golden image {} is missing: run the test without CI to create it, look at it, then commit it",
            golden_path.display()
        );
    } else if update || !golden_path.exists() {
        std::fs::create_dir_all(&dir).expect("create tests/golden");
        actual.save(&golden_path).expect("write golden");
        eprintln!("wrote golden image {}", golden_path.display());
        return;
    }
    let golden = image::open(&golden_path).unwrap_or_else(|e| panic!("{}: {e}", golden_path.display())).to_rgba8();
    let Comparison { differing, total, worst, diff } = compare(actual, &golden, tolerance.channel_tolerance);
    let allowed = (total as f64 * tolerance.max_differing).floor() as usize;
    if differing > allowed {
        let actual_path = dir.join(format!("{name}.actual.png"));
        let diff_path = dir.join(format!("{name}.diff.png"));
        let _ = actual.save(&actual_path);
        let _ = diff.save(&diff_path);
        panic!(
            "{name}: {differing} of {total} pixels differ by more than {} levels (allowed {allowed}; worst {worst}).\n\
             actual: {}\n  diff: {}\ngolden: {}",
            tolerance.channel_tolerance,
            actual_path.display(),
            diff_path.display(),
            golden_path.display()
        );
    }
}

/// Whether this run is CI's: `CI` set to anything but empty, `0` or
/// `false` in any case (as CI services and `.ci/run` set it; the same rule
/// as scripts/test.sh and scripts/check.sh).
pub fn under_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "0" && !v.eq_ignore_ascii_case("false"))
}

/// How two pictures of one size differ.
pub struct Comparison {
    /// Pixels whose largest channel difference exceeds the tolerance.
    pub differing: usize,
    /// Pixels compared.
    pub total: usize,
    /// The largest channel difference seen.
    pub worst: u8,
    /// Differing pixels red, matching ones dimmed.
    pub diff: RgbaImage,
}

/// Compares two pictures pixel by pixel (panics when their sizes differ).
pub fn compare(actual: &RgbaImage, expected: &RgbaImage, channel_tolerance: u8) -> Comparison {
    assert_eq!(expected.dimensions(), actual.dimensions(), "the pictures' sizes differ");
    let mut diff = RgbaImage::new(actual.width(), actual.height());
    let mut differing = 0usize;
    let mut worst = 0u8;
    for ((a, g), d) in actual.pixels().zip(expected.pixels()).zip(diff.pixels_mut()) {
        let error = a.0.iter().zip(g.0.iter()).map(|(x, y)| x.abs_diff(*y)).max().unwrap_or(0);
        worst = worst.max(error);
        if error > channel_tolerance {
            differing += 1;
            *d = Rgba([255, 0, 0, 255]);
        } else {
            *d = Rgba([g.0[0] / 3, g.0[1] / 3, g.0[2] / 3, 255]);
        }
    }
    Comparison { differing, total: (actual.width() * actual.height()) as usize, worst, diff }
}
