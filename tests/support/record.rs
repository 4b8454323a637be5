//! Records of what GPU tests measure (issue 27): where the docs quote a
//! figure a test measures (docs/performance.md's shadow-resolution table,
//! docs/accuracy.md's tests of the tracer), the test writes it as the
//! benches write theirs, through `oxygen_demo::record`
//! (docs/records/README.md).
//!
//! One record file per test binary: `<binary>_tests.jsonl`, whose records
//! name that file in `bench` (`reference_view_tests` for
//! tests/reference_view.rs). Each run of a recording test appends one
//! record; its `values.test` is the test's name and the rest is what the
//! test measured, at full precision, beside the constants it checks them
//! against (tolerances and the scene's parameters, named as such), so a
//! table quoting both reads them from one record.
//!
//! ```ignore
//! support::record::write(|r| r.value("shadowed_pixels", shadowed).row(Row::new().value("resolution", 128)));
//! ```
//!
//! (`Row` is `oxygen_demo::record::Row`.)
//!
//! Nothing is written unless `OXYGEN_RECORD_DIR` is set
//! (scripts/test-records.sh sets it to docs/records); a record that cannot
//! be written, or a misused one (a NaN, a repeated key), fails the test,
//! with or without the variable. Tests write after their assertions, so a
//! failing test records nothing.

use std::cell::RefCell;
use std::path::PathBuf;

use oxygen::prelude::Renderer;
use oxygen_demo::record::Record;

thread_local! {
    /// The adapter of the last renderer `support` made on this thread
    /// (each test runs on a thread of its own).
    static ADAPTER: RefCell<Option<wgpu::AdapterInfo>> = const { RefCell::new(None) };
}

/// Notes `renderer`'s adapter as the one this test runs on;
/// `support::gpu_renderer` and `gpu_renderer_with` call it.
pub fn note_renderer(renderer: &Renderer) {
    let info = renderer.gpu().adapter_info.clone();
    ADAPTER.with(|adapter| *adapter.borrow_mut() = Some(info));
}

/// The adapter of the last renderer `support` made for this test, if any.
pub fn test_adapter() -> Option<wgpu::AdapterInfo> {
    ADAPTER.with(|adapter| adapter.borrow().clone())
}

/// The record file's name (without `.jsonl`) and the records' `bench`:
/// `<binary>_tests`.
pub fn bench() -> String {
    format!("{}_tests", env!("CARGO_CRATE_NAME"))
}

/// The running test's name: libtest runs each test on a thread named after it.
pub fn test_name() -> String {
    let thread = std::thread::current();
    match thread.name() {
        Some(name) if name != "main" => name.to_owned(),
        _ => panic!("support::record: not on a test's own thread, so the test has no name to record"),
    }
}

/// Writes this test's record, measured on the adapter of the last renderer
/// `support` made for it (`support::gpu_renderer`, `gpu_renderer_with`):
/// `build` adds the values to a record that already holds the bench, the
/// adapter and `test`. Returns the file written, `None` when
/// `OXYGEN_RECORD_DIR` is not set. Panics when the test made no renderer
/// through `support` (use [`write_on`]) or the record is refused.
pub fn write(build: impl FnOnce(Record) -> Record) -> Option<PathBuf> {
    let Some(adapter) = test_adapter() else {
        panic!("support::record::write: this test made no renderer through support; name its adapter with write_on")
    };
    write_on(&adapter, build)
}

/// [`write`] with the adapter given.
pub fn write_on(adapter: &wgpu::AdapterInfo, build: impl FnOnce(Record) -> Record) -> Option<PathBuf> {
    let bench = bench();
    let record = build(Record::new(&bench).adapter(adapter).value("test", test_name()));
    record.write().unwrap_or_else(|e| panic!("the record of this test ({bench}.jsonl) was not written: {e}"))
}

/// [`write`] for a test that measures the CPU alone (the record's adapter
/// is null).
pub fn write_cpu(build: impl FnOnce(Record) -> Record) -> Option<PathBuf> {
    let bench = bench();
    let record = build(Record::new(&bench).value("test", test_name()));
    record.write().unwrap_or_else(|e| panic!("the record of this test ({bench}.jsonl) was not written: {e}"))
}
