//! Prints the adapter Oxygen would render on (name, backend, driver) and the
//! features that matter to it. `scripts/test.sh` runs it before the tests so
//! every test log starts with the device the pictures came from.

use oxygen::gpu::{GpuContext, GpuOptions};

fn main() {
    match GpuContext::new_headless(&GpuOptions::default()) {
        Ok(gpu) => {
            println!("adapter: {}", gpu.describe());
            let f = gpu.adapter.features();
            let wanted = [
                ("texture binding arrays", wgpu::Features::TEXTURE_BINDING_ARRAY),
                ("non-uniform indexing", wgpu::Features::SAMPLED_TEXTURE_AND_STORAGE_BUFFER_ARRAY_NON_UNIFORM_INDEXING),
                ("multi-draw-indirect count", wgpu::Features::MULTI_DRAW_INDIRECT_COUNT),
                ("indirect first instance", wgpu::Features::INDIRECT_FIRST_INSTANCE),
                ("timestamp queries", wgpu::Features::TIMESTAMP_QUERY),
                ("multiview", wgpu::Features::MULTIVIEW),
            ];
            for (name, feature) in wanted {
                println!("  {name:<28} {}", if f.contains(feature) { "yes" } else { "no" });
            }
            println!("  max storage buffer binding   {} bytes", gpu.device.limits().max_storage_buffer_binding_size);
            // Why a batch is an atlas and not multiview (docs/performance.md):
            // the views one multiview pass can draw.
            println!("  max multiview views          {}", gpu.adapter.limits().max_multiview_view_count);
        }
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}
