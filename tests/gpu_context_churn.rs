//! Contexts made one after another share the process's wgpu instance: the
//! NVIDIA driver (580, H100) listed no adapter at all once a process had
//! created some twenty instances, even after dropping them, which stopped
//! the accuracy atlas and the visibility bench midway. Lavapipe has no such
//! limit, so this checks the sharing itself: 30 contexts, each with its own
//! adapter and device, one instance.

mod support;

use oxygen::core::{GpuContext, GpuOptions};

#[test]
fn contexts_made_one_after_another_share_one_instance() {
    for i in 0..30 {
        let gpu = GpuContext::new_headless(&GpuOptions::default())
            .unwrap_or_else(|e| panic!("context {i}: GPU tests need an adapter: {e}"));
        drop(gpu);
    }
    // This binary makes no other context, so every one of the 30 used the
    // instance the first one created.
    assert_eq!(GpuContext::instances_created(), 1, "30 contexts created their own instances");
}
