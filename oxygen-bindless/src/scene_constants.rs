//! `SceneConstants`: the per-view uniform block, declared once here with
//! `gpu_struct!`: the Rust structs and their WGSL twins (`GpuStruct::wgsl`),
//! which shaders include, with [`SCENE_CONSTANTS_WGSL`]'s binding (the shader
//! registry's layout test compares the two with naga).
//!
//! The block has two owners. [`CameraConstants`] belong to the application's
//! view (matrices, eye); [`RendererConstants`] belong to the renderer (frame
//! number, slots). [`SceneConstantsBuffer`] writes each half with its own
//! call and its own byte range, so neither side can overwrite the other.

use std::mem::{offset_of, size_of};

use bytemuck::Zeroable;
use glam::{Mat4, Vec3};

use crate::INVALID_SLOT;

oxygen_gpu::gpu_struct! {
    /// The view-owned half: matrices and eye position.
    #[derive(Debug, PartialEq)]
    pub struct CameraConstants: 272 bytes {
        /// World → view.
        pub view: [[f32; 4]; 4],
        /// View → clip (reverse-Z).
        pub projection: [[f32; 4]; 4],
        /// World → clip.
        pub view_projection: [[f32; 4]; 4],
        /// Clip → world.
        pub inverse_view_projection: [[f32; 4]; 4],
        /// Eye position; `w` is 1.
        pub camera_position: [f32; 4],
    }
}

impl CameraConstants {
    /// From glam values.
    pub fn new(view: Mat4, projection: Mat4, view_projection: Mat4, inverse_view_projection: Mat4, eye: Vec3) -> Self {
        CameraConstants {
            view: view.to_cols_array_2d(),
            projection: projection.to_cols_array_2d(),
            view_projection: view_projection.to_cols_array_2d(),
            inverse_view_projection: inverse_view_projection.to_cols_array_2d(),
            camera_position: eye.extend(1.0).to_array(),
        }
    }
}

oxygen_gpu::gpu_struct! {
    /// The renderer-owned half: frame counters and every slot a shader needs.
    /// A slot of [`INVALID_SLOT`] means "absent".
    #[derive(Debug, PartialEq, Eq)]
    pub struct RendererConstants: 64 bytes {
        /// Frame sequence number.
        pub frame_sequence: u32,
        /// Application time in seconds, as `f32` bits (kept `u32` so the struct is `Eq`).
        pub time_seconds_bits: u32,
        /// First `DrawMetadata` of this view.
        pub draw_metadata_slot: u32,
        /// Number of draws of this view.
        pub draw_count: u32,
        /// First world matrix of this frame.
        pub world_transforms_slot: u32,
        /// First normal matrix of this frame.
        pub normal_transforms_slot: u32,
        /// Base of the material domain (material handles index from here).
        pub materials_slot: u32,
        /// First directional light of this frame.
        pub directional_lights_slot: u32,
        /// Number of directional lights.
        pub directional_light_count: u32,
        /// First positional (point/spot) light of this frame.
        pub positional_lights_slot: u32,
        /// Number of positional lights.
        pub positional_light_count: u32,
        /// Bit 0: the shader checks `DrawMetadata.generation` against
        /// `draw_metadata_generation` and paints mismatching draws magenta.
        pub debug_flags: u32,
        /// Generation of this view's draw-metadata range (debug mode).
        pub draw_metadata_generation: u32,
        /// Zero: explicit padding to 64 bytes. WGSL's uniform layout rounds the
        /// block up to a multiple of 16 (336 bytes) whatever the Rust size, so
        /// the padding is spelled out to keep the two layouts equal, as three
        /// `u32`s (a uniform array's stride is 16 bytes).
        pub reserved0: u32,
        /// Zero.
        pub reserved1: u32,
        /// Zero.
        pub reserved2: u32,
    }
}

impl RendererConstants {
    /// `debug_flags` bit: check draw-metadata generations in the shader.
    pub const DEBUG_GENERATIONS: u32 = 1;
}

impl Default for RendererConstants {
    fn default() -> Self {
        RendererConstants {
            frame_sequence: 0,
            time_seconds_bits: 0,
            draw_metadata_slot: INVALID_SLOT,
            draw_count: 0,
            world_transforms_slot: INVALID_SLOT,
            normal_transforms_slot: INVALID_SLOT,
            materials_slot: INVALID_SLOT,
            directional_lights_slot: INVALID_SLOT,
            directional_light_count: 0,
            positional_lights_slot: INVALID_SLOT,
            positional_light_count: 0,
            debug_flags: 0,
            draw_metadata_generation: 0,
            reserved0: 0,
            reserved1: 0,
            reserved2: 0,
        }
    }
}

oxygen_gpu::gpu_struct! {
    /// The whole uniform block.
    #[derive(Debug, PartialEq)]
    pub struct SceneConstants: 336 bytes {
        /// View-owned half.
        pub camera: CameraConstants,
        /// Renderer-owned half.
        pub renderer: RendererConstants,
    }
}

const _: () = {
    assert!(offset_of!(SceneConstants, renderer) == 272);
    assert!(offset_of!(CameraConstants, camera_position) == 256);
    assert!(offset_of!(RendererConstants, draw_metadata_slot) == 8);
    assert!(offset_of!(RendererConstants, debug_flags) == 44);
    assert!(offset_of!(RendererConstants, draw_metadata_generation) == 48);
    assert!(offset_of!(RendererConstants, reserved0) == 52);
};

/// The binding of [`SceneConstants`] (group 3, binding 0), including the
/// WGSL twins of the three structs generated from their Rust declarations
/// (the shader registry names them `bindless/CameraConstants`,
/// `bindless/RendererConstants` and `bindless/SceneConstants`).
pub const SCENE_CONSTANTS_WGSL: &str = include_str!("scene_constants.wgsl");

/// A view's uniform buffer holding [`SceneConstants`], with its bind group.
pub struct SceneConstantsBuffer {
    buffer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    current: SceneConstants,
    /// Both halves have been written once (before, `current` is only a guess).
    written: bool,
}

impl SceneConstantsBuffer {
    /// Creates the buffer and its bind group for `layout` (from
    /// [`crate::BindlessHeap::scene_constants_layout`]).
    pub fn new(device: &wgpu::Device, layout: &wgpu::BindGroupLayout, label: &str) -> Self {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size_of::<SceneConstants>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() }],
        });
        let current = SceneConstants { camera: CameraConstants::zeroed(), renderer: RendererConstants::default() };
        // wgpu zero-initialises new buffers, so the GPU copy starts as zeroes
        // until both halves are written.
        SceneConstantsBuffer { buffer, bind_group, current, written: false }
    }

    /// Writes the view-owned half only, when it changed; returns the bytes
    /// written.
    pub fn set_camera(&mut self, queue: &wgpu::Queue, camera: &CameraConstants) -> u64 {
        if bytemuck::bytes_of(&self.current.camera) == bytemuck::bytes_of(camera) && self.written {
            return 0;
        }
        self.current.camera = *camera;
        queue.write_buffer(&self.buffer, offset_of!(SceneConstants, camera) as u64, bytemuck::bytes_of(camera));
        size_of::<CameraConstants>() as u64
    }

    /// Writes the renderer-owned half only, when it changed; returns the
    /// bytes written.
    pub fn set_renderer(&mut self, queue: &wgpu::Queue, renderer: &RendererConstants) -> u64 {
        if self.current.renderer == *renderer && self.written {
            return 0;
        }
        self.written = true;
        self.current.renderer = *renderer;
        queue.write_buffer(&self.buffer, offset_of!(SceneConstants, renderer) as u64, bytemuck::bytes_of(renderer));
        size_of::<RendererConstants>() as u64
    }

    /// What the buffer holds after the last writes.
    pub fn constants(&self) -> &SceneConstants {
        &self.current
    }

    /// The bind group for group 3.
    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.bind_group
    }

    /// The uniform buffer.
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }
}
