//! Tests that cannot run their subject on this adapter say so in a way the
//! test command counts.
//!
//! libtest has no "skipped at run time": a test that returns early passes.
//! So a test that cannot run here calls [`skip`] before it returns; that
//! prints the reason and, when `OXYGEN_SKIP_LOG` names a file (as
//! `scripts/test.sh` does, one file per backend), appends a line
//! `binary::test<TAB>reason` to it. The script prints the skipped tests of
//! each backend and, under `CI`, fails when they are not exactly the set
//! that docs/backends.md expects for that backend.

use std::io::Write;

/// Records that the running test cannot run its subject here, and why.
/// The caller returns right after.
pub fn skip(reason: impl std::fmt::Display) {
    record(None, reason);
}

/// Records that the running test leaves out one `part` of its subject here
/// (one of two texture paths, say), and why; the rest of the test runs. It
/// is counted as `binary::test[part]`.
pub fn skip_part(part: &str, reason: impl std::fmt::Display) {
    record(Some(part), reason);
}

fn record(part: Option<&str>, reason: impl std::fmt::Display) {
    let binary = env!("CARGO_CRATE_NAME");
    // libtest runs each test on a thread named after it.
    let thread = std::thread::current();
    let name = thread.name().unwrap_or("unnamed test");
    let test = match part {
        Some(part) => format!("{name}[{part}]"),
        None => name.to_owned(),
    };
    eprintln!("skipped: {binary}::{test}: {reason}");
    let Some(log) = std::env::var_os("OXYGEN_SKIP_LOG") else { return };
    // One short write with O_APPEND: lines from tests running in parallel
    // threads (and binaries run one after another) do not interleave.
    let line = format!("{binary}::{test}\t{}\n", reason.to_string().replace(['\n', '\t'], " "));
    let written = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log)
        .and_then(|mut file| file.write_all(line.as_bytes()));
    if let Err(e) = written {
        // A skip that cannot be recorded must not pass as a run test.
        panic!("cannot record the skip of {binary}::{test} in {}: {e}", std::path::Path::new(&log).display());
    }
}
