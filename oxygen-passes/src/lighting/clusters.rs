//! Clustered light culling: a view's frustum cut into a grid of clusters
//! (screen tiles × depth slices), and for each cluster the positional
//! lights whose range reaches it, as one bit per light. A compute pass
//! writes the bits before the view shades; the forward shader
//! (`HAS_CLUSTERED_LIGHTS`) then visits only the lights of its pixel's
//! cluster instead of every light of the frame.
//!
//! The bits keep the frame's light order, and a light is left out only where
//! its range window makes its contribution exactly zero, so a clustered view
//! shades the same sum as the every-light loop. A light without a range
//! reaches every cluster. Spheres are tested against each cluster's
//! view-space bounding box, widened by a relative 10⁻³ so that rounding
//! never drops a light that reaches a pixel.
//!
//! Memory: one bit per light per cluster (`tiles × slices × ⌈lights / 32⌉`
//! words), counted against the device's storage binding limit before it is
//! allocated.

use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

use glam::{Mat4, UVec2};
use oxygen_bindless::BindlessHeap;
use oxygen_core::ViewId;
use oxygen_gpu::bindings::{self, LayoutEntries};
use tracing::info_span;

use crate::PassError;

/// How a view's forward shading finds the positional lights of a pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum LightCulling {
    /// Every pixel loops over every positional light of the frame: no
    /// extra pass, the cheapest with a few lights.
    #[default]
    EveryLight,
    /// A compute pass sorts the lights into the view's clusters first, and
    /// a pixel shades only its cluster's: for scenes with many lights of
    /// limited range. The image is the same (see the module docs).
    Clustered(ClusterGrid),
}

/// The shape of a view's cluster grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterGrid {
    /// Side of a screen tile in pixels (at least 1; 32 by default).
    pub tile_pixels: u32,
    /// Depth slices (1 to [`ClusterGrid::MAX_SLICES`]; 24 by default):
    /// the first from the near plane to twice the near distance, then
    /// slices growing geometrically up to `depth_range`, the last reaching
    /// to infinity.
    pub depth_slices: u32,
    /// Metres in front of the eye that the geometric slices cover (the
    /// camera's far distance when that is nearer; 200 by default). A
    /// non-finite or non-positive value takes the default.
    pub depth_range: f32,
}

impl ClusterGrid {
    /// Most depth slices a grid may have.
    pub const MAX_SLICES: u32 = 64;

    /// 32-pixel tiles, 24 slices over 200 m.
    pub const DEFAULT: ClusterGrid = ClusterGrid { tile_pixels: 32, depth_slices: 24, depth_range: 200.0 };
}

impl Default for ClusterGrid {
    fn default() -> Self {
        Self::DEFAULT
    }
}

oxygen_gpu::gpu_struct! {
    /// The cluster pass's parameters for one view (its WGSL twin is
    /// generated and included by `lighting/clusters.wgsl`).
    #[derive(Debug, PartialEq)]
    pub(crate) struct ClusterParams: 176 bytes {
        /// World (relative to the render origin) → view.
        pub(crate) view: [[f32; 4]; 4],
        /// Clip → view.
        pub(crate) inverse_projection: [[f32; 4]; 4],
        /// Tiles across, tiles down, depth slices, words per cluster.
        pub(crate) grid: [u32; 4] => "vec4<u32>",
        /// Far depth of slice 0, 1 / ln(slice ratio), the near plane's
        /// depth, the depth the last slice is cut at.
        pub(crate) depth: [f32; 4] => "vec4<f32>",
        /// First positional light in its domain, their count, two zeroes.
        pub(crate) lights: [u32; 4] => "vec4<u32>",
    }
}

/// A view's grid this frame, as both shaders read it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct GridShape {
    /// Tiles across and down.
    pub(crate) tiles: UVec2,
    /// Depth slices.
    pub(crate) slices: u32,
    /// 32-bit words of light bits per cluster.
    pub(crate) words: u32,
    /// Far depth of slice 0.
    pub(crate) first_depth: f32,
    /// 1 / ln(ratio of consecutive slices' far depths); 0 with fewer than
    /// three slices (none grows geometrically).
    pub(crate) inverse_log_ratio: f32,
}

/// Depth at which the last slice's box is cut: beyond any light's reach,
/// small enough that squares of it stay finite.
const LAST_SLICE_DEPTH: f32 = 1.0e18;

impl GridShape {
    /// The grid of `grid` over a `viewport` whose near and far planes are at
    /// `near` and `far` metres (`far` may be infinite), for `lights` lights.
    /// Out-of-range settings are brought into range (see [`ClusterGrid`]).
    pub(crate) fn new(grid: &ClusterGrid, viewport: UVec2, near: f32, far: f32, lights: u32) -> Self {
        let tile = grid.tile_pixels.max(1);
        let tiles = UVec2::new(viewport.x.max(1).div_ceil(tile), viewport.y.max(1).div_ceil(tile));
        let slices = grid.depth_slices.clamp(1, ClusterGrid::MAX_SLICES);
        let range = if grid.depth_range.is_finite() && grid.depth_range > 0.0 {
            grid.depth_range
        } else {
            ClusterGrid::DEFAULT.depth_range
        };
        let range = if far.is_finite() && far > 0.0 { range.min(far) } else { range };
        // Slice 0 ends at twice the near distance (an orthographic view's
        // near plane may be at or behind the eye: a millimetre then).
        let near = if near.is_finite() { near.max(1e-3) } else { 1e-3 };
        let first_depth = (2.0 * near).min(range * 0.5).max(1e-4);
        // Slices 1 to S − 2 grow geometrically from there to the range; the
        // last reaches to infinity.
        let geometric = slices.saturating_sub(2);
        let inverse_log_ratio = if geometric > 0 {
            let log_ratio = (range / first_depth).max(1.0 + 1e-3).ln() / geometric as f32;
            1.0 / log_ratio
        } else {
            0.0
        };
        GridShape { tiles, slices, words: lights.div_ceil(32).max(1), first_depth, inverse_log_ratio }
    }

    /// Clusters in the grid.
    pub(crate) fn clusters(&self) -> u64 {
        u64::from(self.tiles.x) * u64::from(self.tiles.y) * u64::from(self.slices)
    }

    /// Bytes of the light bits.
    pub(crate) fn bytes(&self) -> u64 {
        self.clusters() * u64::from(self.words) * 4
    }

    /// The slice a point `depth` metres in front of the eye falls in (the
    /// forward shader's `cluster_slice`, on the CPU for the tests).
    #[cfg(test)]
    pub(crate) fn slice(&self, depth: f32) -> u32 {
        if depth < self.first_depth || self.slices == 1 {
            return 0;
        }
        let k = 1.0 + ((depth / self.first_depth).ln() * self.inverse_log_ratio).floor();
        (k.max(0.0) as u32).min(self.slices - 1)
    }

    /// Depths in front of the eye that slice `k` spans (the cluster
    /// shader's `slice_depths`, on the CPU for the tests).
    #[cfg(test)]
    pub(crate) fn slice_depths(&self, k: u32, near: f32) -> (f32, f32) {
        let at = |i: u32| {
            if i == 0 { self.first_depth } else { self.first_depth * ((i as f32) / self.inverse_log_ratio).exp() }
        };
        let start = if k == 0 { near.min(self.first_depth) } else { at(k - 1) };
        let end = if k + 1 >= self.slices { LAST_SLICE_DEPTH } else { at(k) };
        (start, end)
    }

    /// The uniform fields of group 1 that describe the grid.
    pub(crate) fn uniform_fields(&self) -> ([u32; 4], [f32; 4]) {
        ([self.tiles.x, self.tiles.y, self.slices, self.words], [self.first_depth, self.inverse_log_ratio, 0.0, 0.0])
    }
}

/// A view's light bits on the GPU, kept across frames and regrown when the
/// grid outgrows them.
struct ViewClusters {
    params: wgpu::Buffer,
    bits: wgpu::Buffer,
    group: wgpu::BindGroup,
    /// The frame and parameters its bits were last prepared for: a second
    /// lit pass of the same view in the same frame reads those bits instead
    /// of sorting the lights again.
    prepared: Option<(u64, ClusterParams)>,
}

/// One view's cluster pass this frame, recorded by the shading pass before
/// it begins its render pass ([`LightClusters::record`]).
pub(crate) struct ClusterJob {
    group: wgpu::BindGroup,
    invocations: u32,
}

/// The cluster pass's pipeline (made on first use) and every clustered
/// view's buffers.
#[derive(Default)]
pub(crate) struct LightClusters {
    pipeline: OnceLock<(wgpu::BindGroupLayout, wgpu::ComputePipeline)>,
    views: Mutex<HashMap<ViewId, ViewClusters>>,
}

impl LightClusters {
    fn pipeline(&self, device: &wgpu::Device, heap: &BindlessHeap) -> &(wgpu::BindGroupLayout, wgpu::ComputePipeline) {
        self.pipeline.get_or_init(|| {
            let layout = LayoutEntries::new(wgpu::ShaderStages::COMPUTE)
                .push(bindings::uniform_of::<ClusterParams>())
                .push(bindings::storage_read_write())
                .create_layout(device, "light clusters");
            let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("light clusters"),
                bind_group_layouts: &[Some(heap.domain_layout()), Some(&layout)],
                immediate_size: 0,
            });
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("light clusters"),
                source: wgpu::ShaderSource::Wgsl(crate::shaders::LIGHT_CLUSTERS.source().into()),
            });
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("light clusters"),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some("assign_lights"),
                compilation_options: Default::default(),
                cache: None,
            });
            (layout, pipeline)
        })
    }

    /// Prepares `view`'s cluster pass over `shape`: writes its parameters
    /// and returns its light-bit buffer (for group 1) and the job to record,
    /// none when a pass of the view prepared the same bits earlier in this
    /// frame (the job recorded then fills them before this pass reads
    /// them). Fails when the bits would not fit in one storage binding.
    pub(crate) fn prepare(
        &self,
        ctx: &crate::RenderContext<'_>,
        shape: &GridShape,
    ) -> Result<(wgpu::Buffer, Option<ClusterJob>), PassError> {
        let _span =
            info_span!("light_clusters", view = %ctx.view.view_id, clusters = shape.clusters(), words = shape.words)
                .entered();
        let device = &ctx.gpu.device;
        let bytes = shape.bytes();
        let limit = device.limits().max_storage_buffer_binding_size;
        if bytes > limit {
            return Err(PassError::BadInput {
                pass: "forward lit (light clusters)",
                what: format!(
                    "{} clusters × {} lights need {bytes} bytes of light bits, over the device's storage binding \
                     limit of {limit}: use larger tiles or fewer depth slices",
                    shape.clusters(),
                    shape.words * 32,
                ),
            });
        }
        let lights = ctx.prepared.slots().positional_lights;
        let params = ClusterParams {
            view: ctx.view.view.to_cols_array_2d(),
            inverse_projection: finite_inverse(ctx.view.projection).to_cols_array_2d(),
            grid: shape.uniform_fields().0,
            depth: [
                shape.first_depth,
                shape.inverse_log_ratio,
                if ctx.view.near.is_finite() { ctx.view.near.min(shape.first_depth) } else { 0.0 },
                LAST_SLICE_DEPTH,
            ],
            lights: [if lights.count > 0 { lights.start } else { 0 }, lights.count, 0, 0],
        };
        let (layout, _) = self.pipeline(device, ctx.heap);
        let mut views = self.views.lock().map_err(|_| PassError::Graph("light cluster state poisoned".into()))?;
        let frame = ctx.prepared.frame_index();
        let state = match views.get_mut(&ctx.view.view_id) {
            Some(state) if state.bits.size() >= bytes => {
                if state.prepared == Some((frame, params)) {
                    return Ok((state.bits.clone(), None));
                }
                state
            }
            _ => {
                let params = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("light cluster params"),
                    size: size_of::<ClusterParams>() as u64,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                let bits = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("light cluster bits"),
                    size: bytes.max(16),
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                });
                let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("light clusters"),
                    layout,
                    entries: &[
                        wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 1, resource: bits.as_entire_binding() },
                    ],
                });
                views.insert(ctx.view.view_id, ViewClusters { params, bits, group, prepared: None });
                views.get_mut(&ctx.view.view_id).ok_or_else(|| PassError::Graph("light cluster state lost".into()))?
            }
        };
        ctx.gpu.queue.write_buffer(&state.params, 0, bytemuck::bytes_of(&params));
        state.prepared = Some((frame, params));
        // One invocation per word of every cluster; `bytes` fits a storage
        // binding, which is far below u32 words.
        let invocations = u32::try_from(shape.clusters() * u64::from(shape.words)).unwrap_or(u32::MAX);
        Ok((state.bits.clone(), Some(ClusterJob { group: state.group.clone(), invocations })))
    }

    /// Records `jobs` (one compute pass for all of them).
    pub(crate) fn record(&self, encoder: &mut wgpu::CommandEncoder, heap: &BindlessHeap, jobs: &[ClusterJob]) {
        let Some((_, pipeline)) = self.pipeline.get() else { return };
        if jobs.is_empty() {
            return;
        }
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("light clusters"), timestamp_writes: None });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, heap.bind_group(), &[]);
        for job in jobs {
            pass.set_bind_group(1, &job.group, &[]);
            // Workgroups of 64, past 65 535 of them in y too (the shader
            // linearises the two, as the cull shader does).
            crate::visibility::dispatch_threads(&mut pass, job.invocations);
        }
    }

    /// Forgets the buffers of the views `keep` says no to.
    pub(crate) fn retain(&self, keep: impl Fn(ViewId) -> bool) {
        if let Ok(mut state) = self.views.lock() {
            state.retain(|id, _| keep(*id));
        }
    }
}

/// `m`'s inverse, or the identity when `m` has none (a degenerate
/// projection never reaches a shader as NaN).
fn finite_inverse(m: Mat4) -> Mat4 {
    let inverse = m.inverse();
    let finite = inverse.to_cols_array().iter().all(|x| x.is_finite());
    if finite && m.determinant() != 0.0 { inverse } else { Mat4::IDENTITY }
}

/// A point of view space `depth` metres in front of the eye on the ray
/// through `ndc` (the cluster shader's `point_at_depth`, on the CPU for the
/// tests): two points of the pixel's ray from the inverse projection, then
/// the one at that depth. Works for perspective and orthographic views.
#[cfg(test)]
fn point_at_depth(inverse_projection: Mat4, ndc: glam::Vec2, depth: f32) -> glam::Vec3 {
    let unproject = |z: f32| {
        let p = inverse_projection * glam::Vec4::new(ndc.x, ndc.y, z, 1.0);
        p.truncate() / p.w
    };
    let (a, b) = (unproject(1.0), unproject(0.5));
    let t = (depth + a.z) / (a.z - b.z);
    a + (b - a) * t
}

#[cfg(test)]
mod tests {
    use glam::{Vec2, Vec3};

    use super::*;

    fn grid(slices: u32, range: f32) -> ClusterGrid {
        ClusterGrid { tile_pixels: 32, depth_slices: slices, depth_range: range }
    }

    /// Tiles cover the viewport (a partial tile at the edge counts), words
    /// cover the lights, and settings out of range are brought into it.
    #[test]
    fn a_grid_covers_its_viewport_and_its_lights() {
        let shape = GridShape::new(&grid(24, 200.0), UVec2::new(640, 360), 0.1, f32::INFINITY, 1000);
        assert_eq!((shape.tiles, shape.slices, shape.words), (UVec2::new(20, 12), 24, 32));
        assert_eq!(shape.bytes(), 20 * 12 * 24 * 32 * 4);
        let odd = GridShape::new(&grid(24, 200.0), UVec2::new(641, 1), 0.1, f32::INFINITY, 33);
        assert_eq!((odd.tiles, odd.words), (UVec2::new(21, 1), 2));
        let clamped = GridShape::new(
            &ClusterGrid { tile_pixels: 0, depth_slices: 1000, depth_range: f32::NAN },
            UVec2::new(4, 4),
            0.1,
            f32::INFINITY,
            0,
        );
        assert_eq!((clamped.tiles, clamped.slices, clamped.words), (UVec2::new(4, 4), ClusterGrid::MAX_SLICES, 1));
        assert!(clamped.inverse_log_ratio.is_finite() && clamped.first_depth > 0.0);
    }

    /// Slice 0 ends at twice the near distance, the geometric slices end at
    /// the depth range, and every depth falls in the slice whose span holds
    /// it (the two shaders agree on where the boundaries are).
    #[test]
    fn every_depth_falls_in_the_slice_that_spans_it() {
        let near = 0.1;
        let shape = GridShape::new(&grid(24, 200.0), UVec2::new(640, 360), near, f32::INFINITY, 8);
        assert!((shape.first_depth - 0.2).abs() < 1e-6);
        let (_, end) = shape.slice_depths(shape.slices - 2, near);
        assert!((end / 200.0 - 1.0).abs() < 1e-4, "the geometric slices end at the range ({end})");
        assert_eq!(shape.slice_depths(shape.slices - 1, near).1, LAST_SLICE_DEPTH);
        let mut depth = near;
        while depth < 5000.0 {
            let k = shape.slice(depth);
            let (start, end) = shape.slice_depths(k, near);
            // Within the boundaries' rounding (the cluster shader widens
            // each span by a relative 1e-4).
            assert!(
                depth >= start * (1.0 - 1e-5) && depth <= end * (1.0 + 1e-5),
                "{depth} in slice {k}: {start}..{end}"
            );
            depth *= 1.013;
        }
        // A finite far plane nearer than the range ends the geometric slices there.
        let near_far = GridShape::new(&grid(8, 200.0), UVec2::new(64, 64), near, 50.0, 8);
        assert!((near_far.slice_depths(6, near).1 / 50.0 - 1.0).abs() < 1e-4);
        assert!(near_far.slice_depths(6, near).0 < 50.0);
        // Two slices: before and after twice the near distance.
        let two = GridShape::new(&grid(2, 200.0), UVec2::new(64, 64), near, f32::INFINITY, 8);
        assert_eq!((two.slice(0.15), two.slice(0.25), two.slice(1e6)), (0, 1, 1));
        assert_eq!(two.slice_depths(1, near), (two.first_depth, LAST_SLICE_DEPTH));
        // One slice holds everything.
        let one = GridShape::new(&grid(1, 200.0), UVec2::new(64, 64), near, f32::INFINITY, 8);
        assert_eq!((one.slice(0.05), one.slice(1e6)), (0, 0));
    }

    /// The point of a pixel's ray at a depth, for a perspective and an
    /// orthographic projection (reverse-Z, as the cameras build them).
    #[test]
    fn a_pixel_ray_reaches_the_depth_asked_for() {
        let perspective = Mat4::perspective_infinite_reverse_rh(1.0, 16.0 / 9.0, 0.1);
        let p = point_at_depth(perspective.inverse(), Vec2::new(0.5, -0.25), 10.0);
        assert!((p.z + 10.0).abs() < 1e-3, "{p}");
        let back = perspective * p.extend(1.0);
        assert!((back.truncate().truncate() / back.w - Vec2::new(0.5, -0.25)).length() < 1e-4);
        let orthographic = Mat4::orthographic_rh(-4.0, 4.0, -2.0, 2.0, 50.0, 0.5);
        let q = point_at_depth(orthographic.inverse(), Vec2::new(1.0, 1.0), 20.0);
        assert!((q - Vec3::new(4.0, 2.0, -20.0)).length() < 1e-3, "{q}");
    }
}
