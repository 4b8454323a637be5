// The per-view uniform block. Its structs are generated from their Rust
// declarations (oxygen_bindless::SceneConstants and its halves, gpu_struct!).
// INVALID_SLOT and the debug_flags bits come from oxygen_bindless::wgsl_constants().

#include "bindless/CameraConstants"
#include "bindless/RendererConstants"
#include "bindless/SceneConstants"

// Group 3, the last: a batch's cameras each bind their own, and wgpu
// rebinds every group from the one that changed to the last.
@group(3) @binding(0) var<uniform> scene: SceneConstants;
