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
        /// How many low bits of a deferred visibility pass's 32-bit surface
        /// id hold the vertex that starts the pixel's triangle; the bits
        /// above hold the draw's index plus one (0: nothing drawn).
        pub surface_vertex_bits: u32,
        /// Zero: explicit padding to 64 bytes. WGSL's uniform layout rounds the
        /// block up to a multiple of 16 (336 bytes) whatever the Rust size, so
        /// the padding is spelled out to keep the two layouts equal, as
        /// `u32`s (a uniform array's stride is 16 bytes).
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
            surface_vertex_bits: 1,
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
    assert!(offset_of!(RendererConstants, surface_vertex_bits) == 52);
};

/// The binding of [`SceneConstants`] (group 3, binding 0), including the
/// WGSL twins of the three structs generated from their Rust declarations
/// (the shader registry names them `bindless/CameraConstants`,
/// `bindless/RendererConstants` and `bindless/SceneConstants`).
pub const SCENE_CONSTANTS_WGSL: &str = include_str!("scene_constants.wgsl");

/// A view's [`SceneConstants`] on the GPU, with the bind group that binds
/// them: a uniform buffer of its own, or one slot of a
/// [`SceneConstantsBlock`] shared by a batch's cameras. The binding has a
/// dynamic offset ([`SceneConstantsBuffer::dynamic_offset`]), 0 for a
/// buffer of its own.
pub struct SceneConstantsBuffer {
    buffer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// Where this view's constants start in `buffer`.
    offset: u32,
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
        SceneConstantsBuffer { buffer, bind_group, offset: 0, current, written: false }
    }

    /// The offset to bind this view's constants with (`set_bind_group(3,
    /// bind_group(), &[dynamic_offset()])`).
    pub fn dynamic_offset(&self) -> u32 {
        self.offset
    }

    /// Writes the view-owned half only, when it changed; returns the bytes
    /// written.
    pub fn set_camera(&mut self, queue: &wgpu::Queue, camera: &CameraConstants) -> u64 {
        if bytemuck::bytes_of(&self.current.camera) == bytemuck::bytes_of(camera) && self.written {
            return 0;
        }
        self.current.camera = *camera;
        let at = u64::from(self.offset) + offset_of!(SceneConstants, camera) as u64;
        queue.write_buffer(&self.buffer, at, bytemuck::bytes_of(camera));
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
        let at = u64::from(self.offset) + offset_of!(SceneConstants, renderer) as u64;
        queue.write_buffer(&self.buffer, at, bytemuck::bytes_of(renderer));
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

    /// The uniform buffer (this view's constants start at
    /// [`SceneConstantsBuffer::dynamic_offset`]).
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }
}

/// The [`SceneConstants`] of many views in one uniform buffer with one bind
/// group, each view's at its own dynamic offset: a batch's cameras are
/// written with one upload a frame, not one or two writes a camera, and
/// bound by changing the offset.
pub struct SceneConstantsBlock {
    buffer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// Bytes from one slot to the next (the constants rounded up to the
    /// device's uniform offset alignment).
    stride: u32,
    capacity: u32,
    /// What the buffer is to hold, written by [`SceneConstantsBlock::stage`].
    staged: Vec<u8>,
    /// The staged bytes that differ from the buffer's.
    dirty: Option<std::ops::Range<usize>>,
}

impl SceneConstantsBlock {
    /// A block of `capacity` slots (at least one) for `layout`.
    pub fn new(device: &wgpu::Device, layout: &wgpu::BindGroupLayout, capacity: u32, label: &str) -> Self {
        let alignment = device.limits().min_uniform_buffer_offset_alignment.max(1);
        let stride = (size_of::<SceneConstants>() as u32).div_ceil(alignment) * alignment;
        let capacity = capacity.max(1);
        let bytes = u64::from(stride) * u64::from(capacity);
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &buffer,
                    offset: 0,
                    size: wgpu::BufferSize::new(size_of::<SceneConstants>() as u64),
                }),
            }],
        });
        SceneConstantsBlock { buffer, bind_group, stride, capacity, staged: vec![0; bytes as usize], dirty: None }
    }

    /// Slots the block holds.
    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    /// The view of slot `slot` (`None` past the capacity), its constants
    /// not written yet.
    pub fn view(&self, slot: u32) -> Option<SceneConstantsBuffer> {
        (slot < self.capacity).then(|| SceneConstantsBuffer {
            buffer: self.buffer.clone(),
            bind_group: self.bind_group.clone(),
            offset: slot * self.stride,
            current: SceneConstants { camera: CameraConstants::zeroed(), renderer: RendererConstants::default() },
            written: false,
        })
    }

    /// Stages `view`'s constants (a view of this block) for the next
    /// [`SceneConstantsBlock::upload`], when they changed; returns the
    /// bytes staged. A view of another buffer is written directly.
    pub fn stage(
        &mut self,
        queue: &wgpu::Queue,
        view: &mut SceneConstantsBuffer,
        camera: &CameraConstants,
        renderer: &RendererConstants,
    ) -> u64 {
        if view.buffer != self.buffer {
            return view.set_camera(queue, camera) + view.set_renderer(queue, renderer);
        }
        let constants = SceneConstants { camera: *camera, renderer: *renderer };
        if view.written && view.current == constants {
            return 0;
        }
        view.current = constants;
        view.written = true;
        let at = view.offset as usize;
        let bytes = bytemuck::bytes_of(&constants);
        self.staged[at..at + bytes.len()].copy_from_slice(bytes);
        let range = at..at + bytes.len();
        self.dirty = Some(match self.dirty.take() {
            Some(d) => d.start.min(range.start)..d.end.max(range.end),
            None => range,
        });
        bytes.len() as u64
    }

    /// Writes what was staged since the last upload, in one write; returns
    /// the bytes written.
    pub fn upload(&mut self, queue: &wgpu::Queue) -> u64 {
        let Some(range) = self.dirty.take() else { return 0 };
        // Whole 4-byte words, as wgpu asks (slots and the constants are).
        let range = range.start / 4 * 4..range.end.div_ceil(4) * 4;
        queue.write_buffer(&self.buffer, range.start as u64, &self.staged[range.clone()]);
        range.len() as u64
    }
}
