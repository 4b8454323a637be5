// SceneConstants: twin of oxygen_bindless::SceneConstants (same layout;
// asserted by the naga reflection test in oxygen-bindless). INVALID_SLOT
// and the debug_flags bits come from oxygen_bindless::wgsl_constants().

struct CameraConstants {
    view: mat4x4<f32>,
    projection: mat4x4<f32>,
    view_projection: mat4x4<f32>,
    inverse_view_projection: mat4x4<f32>,
    camera_position: vec4<f32>,
}

struct RendererConstants {
    frame_sequence: u32,
    time_seconds_bits: u32,
    draw_metadata_slot: u32,
    draw_count: u32,
    world_transforms_slot: u32,
    normal_transforms_slot: u32,
    materials_slot: u32,
    directional_lights_slot: u32,
    directional_light_count: u32,
    positional_lights_slot: u32,
    positional_light_count: u32,
    debug_flags: u32,
    draw_metadata_generation: u32,
    // Explicit padding to 64 bytes (the Rust `reserved: [u32; 3]`): uniform
    // layout rounds SceneConstants up to a multiple of 16 (336 bytes) anyway,
    // and spelling it out keeps the Rust twin the same size.
    reserved0: u32,
    reserved1: u32,
    reserved2: u32,
}

struct SceneConstants {
    camera: CameraConstants,
    renderer: RendererConstants,
}

@group(1) @binding(0) var<uniform> scene: SceneConstants;
