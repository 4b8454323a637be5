//! The hierarchical depth pyramid (HiZ) that occlusion culling tests boxes
//! against: level 0 is a copy of a view's depth, every further level the
//! minimum — in reverse Z the farthest depth — of the texels below it, at
//! mip sizes (halved, rounded down): the 2×2 texels below, and for the last
//! texel of a row or column also the odd one left over. A texel of level k
//! therefore covers the depth pixels `[x·2^k, (x+1)·2^k)` on each axis, the
//! last one up to the edge, and `hiz_test.wgsl`'s `hiz_visible` reads at
//! most 3×3 texels of a level at which a box's screen rectangle spans no
//! more, so the test is conservative: a box is hidden only when every pixel
//! it could cover is nearer than it.
//!
//! The levels live one after the other in an `f32` storage buffer, not in
//! a mipmapped texture: on llvmpipe (lavapipe) a `textureLoad` whose mip
//! level differs between neighbouring invocations of a dispatch reads the
//! wrong level (tests/hiz_pyramid.rs shows it), and an occlusion test picks
//! its level per box.

use oxygen_gpu::bindings::{self, LayoutEntries};
use tracing::info_span;

use super::params::LevelParams;

/// A test shader for `hiz_test.wgsl`'s `fn hiz_visible(levels, size,
/// view_projection, box_min, box_max) -> bool` (which the visibility cull
/// shader includes): its compute entry point `visible_boxes` writes, per
/// box of binding 1 (`array<{ lo: vec4<f32>, hi: vec4<f32> }>`), 1 to
/// binding 2 where the box may be visible against the pyramid of binding
/// 3, with the view-projection, level-0 size, level count and box count of
/// the uniform at binding 0; composed by the shader registry.
#[cfg(any(test, feature = "testing"))]
pub fn hiz_visible_boxes_wgsl() -> String {
    crate::shaders::HIZ_VISIBLE_BOXES.source()
}

/// The pyramid's shader as compiled: `hiz.wgsl`'s copy and reduction
/// entry points with their parameter block.
pub fn hiz_shader_source() -> String {
    crate::shaders::HIZ.source()
}

/// The two compute pipelines every pyramid shares.
pub struct HizPipelines {
    copy_layout: wgpu::BindGroupLayout,
    reduce_layout: wgpu::BindGroupLayout,
    copy: wgpu::ComputePipeline,
    reduce: wgpu::ComputePipeline,
}

impl HizPipelines {
    /// Compiles the copy and reduction pipelines.
    pub fn new(device: &wgpu::Device) -> Self {
        let _span = info_span!("hiz_pipelines").entered();
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("depth pyramid"),
            source: wgpu::ShaderSource::Wgsl(hiz_shader_source().into()),
        });
        // The depth texture (the copy's alone), the pyramid, the level's
        // `LevelParams`.
        let copy_layout = LayoutEntries::new(wgpu::ShaderStages::COMPUTE)
            .push(bindings::depth_2d())
            .push(bindings::storage_read_write())
            .push(bindings::uniform())
            .create_layout(device, "depth pyramid copy");
        let reduce_layout = LayoutEntries::new(wgpu::ShaderStages::COMPUTE)
            .skip(1)
            .push(bindings::storage_read_write())
            .push(bindings::uniform())
            .create_layout(device, "depth pyramid reduce");
        let pipeline = |entry: &'static str, group: &wgpu::BindGroupLayout| {
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(entry),
                bind_group_layouts: &[Some(group)],
                immediate_size: 0,
            });
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let copy = pipeline("copy_depth", &copy_layout);
        let reduce = pipeline("reduce", &reduce_layout);
        HizPipelines { copy_layout, reduce_layout, copy, reduce }
    }
}

/// A min-reduced depth pyramid for one view's depth target.
pub struct HizPyramid {
    buffer: wgpu::Buffer,
    /// Per level: its parameter block (level 0's names the copy).
    level_params: Vec<wgpu::Buffer>,
    /// Level k (k ≥ 1) from level k − 1.
    reduce_groups: Vec<wgpu::BindGroup>,
    /// Per level: (offset in texels, width, height).
    levels: Vec<(u32, u32, u32)>,
    size: (u32, u32),
}

impl HizPyramid {
    /// A pyramid for a depth target of `width` × `height` (each at least 1).
    pub fn new(device: &wgpu::Device, pipelines: &HizPipelines, width: u32, height: u32) -> Self {
        use wgpu::util::DeviceExt;
        let (width, height) = (width.max(1), height.max(1));
        let count = 32 - width.max(height).leading_zeros();
        let mut levels = Vec::with_capacity(count as usize);
        let mut offset = 0;
        for k in 0..count {
            let (w, h) = ((width >> k).max(1), (height >> k).max(1));
            levels.push((offset, w, h));
            offset += w * h;
        }
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("depth pyramid"),
            size: u64::from(offset) * 4,
            // COPY_SRC: tests read the levels back.
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let level_params: Vec<wgpu::Buffer> = (0..count as usize)
            .map(|k| {
                let (dst_offset, dst_width, dst_height) = levels[k];
                let (src_offset, src_width, src_height) = if k == 0 { (0, width, height) } else { levels[k - 1] };
                let params = LevelParams {
                    src_offset,
                    src_width,
                    src_height,
                    dst_offset,
                    dst_width,
                    dst_height,
                    reserved: [0; 2],
                };
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("depth pyramid level"),
                    contents: bytemuck::bytes_of(&params),
                    usage: wgpu::BufferUsages::UNIFORM,
                })
            })
            .collect();
        let reduce_groups = level_params[1..]
            .iter()
            .map(|params| {
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("depth pyramid level"),
                    layout: &pipelines.reduce_layout,
                    entries: &[
                        wgpu::BindGroupEntry { binding: 1, resource: buffer.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 2, resource: params.as_entire_binding() },
                    ],
                })
            })
            .collect();
        HizPyramid { buffer, level_params, reduce_groups, levels, size: (width, height) }
    }

    /// Size of level 0 (the depth target's size).
    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// Levels, down to 1 × 1.
    pub fn levels(&self) -> u32 {
        self.levels.len() as u32
    }

    /// Where level `k` starts in [`HizPyramid::buffer`] (in texels) and its
    /// size (for tests).
    #[cfg(any(test, feature = "testing"))]
    pub fn level(&self, k: u32) -> Option<(u32, u32, u32)> {
        self.levels.get(k as usize).copied()
    }

    /// The levels, one after the other, row by row (`array<f32>`).
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }

    /// Records the dispatches that fill every level from `depth`: a view of
    /// one layer and mip of a `Depth32Float` texture of [`HizPyramid::size`].
    pub fn build(
        &self,
        device: &wgpu::Device,
        pipelines: &HizPipelines,
        encoder: &mut wgpu::CommandEncoder,
        depth: &wgpu::TextureView,
    ) {
        let _span = info_span!("hiz_build", width = self.size.0, height = self.size.1).entered();
        let copy_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("depth pyramid copy"),
            layout: &pipelines.copy_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(depth) },
                wgpu::BindGroupEntry { binding: 1, resource: self.buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: self.level_params[0].as_entire_binding() },
            ],
        });
        // One compute pass per level: each level reads the one written just
        // before it, and a pass boundary makes that write visible.
        let mut dispatch = |pipeline: &wgpu::ComputePipeline, group: &wgpu::BindGroup, (_, w, h): (u32, u32, u32)| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("depth pyramid"),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
        };
        dispatch(&pipelines.copy, &copy_group, self.levels[0]);
        for (group, level) in self.reduce_groups.iter().zip(&self.levels[1..]) {
            dispatch(&pipelines.reduce, group, *level);
        }
    }
}
