//! Contexts made one after another share the process's wgpu instance: the
//! NVIDIA driver (580, H100) listed no adapter at all once a process had
//! created some twenty instances, even after dropping them, which stopped
//! the accuracy atlas and the visibility bench midway. Lavapipe has no such
//! limit, so this checks the sharing itself: 30 contexts, each with its own
//! adapter and device, one instance.

mod support;

use oxygen::gpu::{GpuContext, GpuOptions};

#[test]
fn contexts_made_one_after_another_share_one_instance() {
    let probe = GpuContext::new_headless(&GpuOptions::default()).expect("GPU tests need an adapter");
    if probe.adapter_info.backend == wgpu::Backend::Gl {
        // GL contexts keep an instance each: one EGL context cannot be
        // shared by devices on several threads.
        support::skip::skip(format_args!("{}: GL contexts do not share their instance", probe.describe()));
        return;
    }
    drop(probe);
    for i in 0..30 {
        let gpu = GpuContext::new_headless(&GpuOptions::default())
            .unwrap_or_else(|e| panic!("context {i}: GPU tests need an adapter: {e}"));
        drop(gpu);
    }
    // This binary makes no other context, so the probe and the 30 used the
    // instance the probe created.
    assert_eq!(GpuContext::instances_created(), 1, "30 contexts created their own instances");
}
