//! Screen-space ambient occlusion: ground-truth ambient occlusion (GTAO)
//! from a view's depth, denoised in space and optionally in time, which the
//! forward shader multiplies into the indirect light only (the ambient
//! term, the environment and the probes; never the lights). The algorithm
//! is described in `ambient_occlusion.wgsl`.
//!
//! A view asks for it in its forward configuration
//! ([`ForwardLitConfig::ambient_occlusion`](crate::ForwardLitConfig::ambient_occlusion));
//! its graph then records an [`AmbientOcclusionPass`] after the depth
//! pre-pass and before shading (the standard graph does, and turns the
//! pre-pass on for it). A view without it records no pass, allocates
//! nothing, and its shading pipelines leave the code out
//! (`HAS_AMBIENT_OCCLUSION`).
//!
//! Memory: four floats a pixel (linear depth, raw and denoised occlusion,
//! the result), six with the temporal step (last frame's depth and
//! result), kept per view across frames and regrown with its size.

use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

use glam::{DMat4, Mat4};
use oxygen_core::ViewId;
use oxygen_gpu::bindings::{self, LayoutEntries};
use tracing::info_span;

use crate::{CommandRecorder, PassError, RenderContext, RenderPass};

/// How much work the occlusion of a pixel takes: directions across the
/// screen (slices) times samples on each side of each direction (steps).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum AoQuality {
    /// 2 slices × 4 steps: the cheapest, noisiest.
    Low,
    /// 3 slices × 6 steps.
    #[default]
    Medium,
    /// 4 slices × 8 steps.
    High,
    /// 8 slices × 12 steps: near what more samples would give.
    Ultra,
}

impl AoQuality {
    /// Every level, cheapest first.
    pub const ALL: [AoQuality; 4] = [AoQuality::Low, AoQuality::Medium, AoQuality::High, AoQuality::Ultra];

    /// (slices, steps per side).
    pub fn samples(self) -> (u32, u32) {
        match self {
            AoQuality::Low => (2, 4),
            AoQuality::Medium => (3, 6),
            AoQuality::High => (4, 8),
            AoQuality::Ultra => (8, 12),
        }
    }
}

/// A view's screen-space ambient occlusion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AmbientOcclusion {
    /// Samples per pixel.
    pub quality: AoQuality,
    /// How far, in metres, geometry occludes a point: what lies farther
    /// from it fades out of the horizon search (from 60 % of the radius
    /// on). Finite and positive; 1 m by default.
    pub radius: f32,
    /// Blend each frame's occlusion with the last frame's at the same
    /// surface point (reprojected; a point last frame did not see starts
    /// afresh): the sampling pattern turns every frame, so a still view
    /// converges to many frames' samples. Off by default: a single frame
    /// is then the whole answer, as tests and references want.
    pub temporal: bool,
}

impl AmbientOcclusion {
    /// Medium quality, a radius of 1 m, no temporal step.
    pub const DEFAULT: AmbientOcclusion = AmbientOcclusion { quality: AoQuality::Medium, radius: 1.0, temporal: false };

    /// Why these settings cannot be used, if they cannot: a radius that is
    /// not finite and positive.
    pub fn problem(&self) -> Option<String> {
        (!(self.radius.is_finite() && self.radius > 0.0))
            .then(|| format!("ambient occlusion radius {} is not a finite positive number of metres", self.radius))
    }
}

impl Default for AmbientOcclusion {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Share of the radius beyond which samples fade out of the horizon search.
const FALLOFF_START: f32 = 0.6;
/// Relative depth difference at which a neighbour stops counting in the
/// spatial denoise.
const DENOISE_DEPTH_TOLERANCE: f32 = 0.1;
/// Weight of this frame's value in the temporal blend.
const TEMPORAL_WEIGHT: f32 = 0.125;
/// Relative depth difference at which last frame's point is another point.
const REPROJECTION_DEPTH_TOLERANCE: f32 = 0.05;

oxygen_gpu::gpu_struct! {
    /// The occlusion passes' parameters for one view and frame (its WGSL
    /// twin is generated and included by `lighting/ambient_occlusion.wgsl`).
    #[derive(Debug, PartialEq)]
    pub(crate) struct AoParams: 272 bytes {
        /// Clip → view.
        pub(crate) inverse_projection: [[f32; 4]; 4],
        /// This frame's view space → last frame's.
        pub(crate) reproject: [[f32; 4]; 4],
        /// Last frame's projection.
        pub(crate) previous_projection: [[f32; 4]; 4],
        /// Width, height, slices | steps << 16, 1 for a perspective view.
        pub(crate) size: [u32; 4] => "vec4<u32>",
        /// Radius (m), falloff start (share of the radius), pixels a metre
        /// spans at one metre's depth (at any depth, orthographic), the
        /// denoise's depth tolerance.
        pub(crate) shape: [f32; 4] => "vec4<f32>",
        /// View x = (ndc.x · a + b) · depth (without the depth,
        /// orthographic): a and b for x, then for y, as (ax, ay, bx, by).
        pub(crate) unproject: [f32; 4] => "vec4<f32>",
        /// Frame number (turns the sampling pattern), 1 when last frame's
        /// result may be blended in, two zeroes.
        pub(crate) frame: [u32; 4] => "vec4<u32>",
        /// This frame's weight in the temporal blend, the reprojection's
        /// relative depth tolerance, two zeroes.
        pub(crate) frame_weights: [f32; 4] => "vec4<f32>",
    }
}

/// The occlusion's compute pipelines, one per step, over one layout each.
struct AoPipelines {
    linearize: (wgpu::BindGroupLayout, wgpu::ComputePipeline),
    linearize_multisampled: (wgpu::BindGroupLayout, wgpu::ComputePipeline),
    gtao: (wgpu::BindGroupLayout, wgpu::ComputePipeline),
    denoise: (wgpu::BindGroupLayout, wgpu::ComputePipeline),
    temporal: (wgpu::BindGroupLayout, wgpu::ComputePipeline),
}

impl AoPipelines {
    fn new(device: &wgpu::Device) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("ambient occlusion"),
            source: wgpu::ShaderSource::Wgsl(crate::shaders::AMBIENT_OCCLUSION.source().into()),
        });
        let pipeline =
            |entry: &str, entries: LayoutEntries| crate::pipelines::compute_step(device, &module, entry, entries);
        let entries = || LayoutEntries::new(wgpu::ShaderStages::COMPUTE).push(bindings::uniform_of::<AoParams>());
        AoPipelines {
            linearize: pipeline(
                "linearize",
                entries()
                    .at(1)
                    .push(bindings::texture_2d(bindings::UNFILTERABLE_FLOAT))
                    .at(2)
                    .push(bindings::storage_read_write()),
            ),
            linearize_multisampled: pipeline(
                "linearize_multisampled",
                entries()
                    .at(2)
                    .push(bindings::storage_read_write())
                    .at(9)
                    .push(bindings::texture_2d_multisampled(bindings::UNFILTERABLE_FLOAT)),
            ),
            gtao: pipeline(
                "gtao",
                entries().at(3).push(bindings::storage_read_write()).push(bindings::storage_read_only()),
            ),
            denoise: pipeline(
                "denoise",
                entries()
                    .at(4)
                    .push(bindings::storage_read_only())
                    .push(bindings::storage_read_only())
                    .push(bindings::storage_read_write()),
            ),
            temporal: pipeline(
                "temporal",
                entries()
                    .at(4)
                    .push(bindings::storage_read_only())
                    .push(bindings::storage_read_only())
                    .push(bindings::storage_read_write())
                    .push(bindings::storage_read_only())
                    .push(bindings::storage_read_only()),
            ),
        }
    }
}

/// What a view's temporal step remembers of its last frame.
#[derive(Clone, Copy, Debug)]
struct LastFrame {
    frame: u64,
    /// World relative to `origin` → view, as the frame's camera had it.
    world_to_view: DMat4,
    projection: Mat4,
    /// The frame's render origin.
    origin: glam::DVec3,
}

/// A view's occlusion buffers, made the first frame it asks for occlusion.
struct Occlusion {
    raw: wgpu::Buffer,
    denoised: wgpu::Buffer,
    /// The results: this frame's and last frame's (they swap every frame).
    result: [wgpu::Buffer; 2],
}

/// One view's buffers, kept across frames.
struct ViewAo {
    pixels: u64,
    params: wgpu::Buffer,
    /// Linear depth: this frame's and last frame's (they swap every frame).
    depth: [wgpu::Buffer; 2],
    occlusion: Option<Occlusion>,
    /// Which of the pairs is this frame's.
    current: usize,
    /// The frame the depth was last filled for, and its camera.
    last: Option<LastFrame>,
    /// The camera of the frame before `last`, when its occlusion had the
    /// temporal step and `last` is the frame after it.
    previous: Option<LastFrame>,
    /// Whether `last`'s frame computed occlusion, and with the temporal step.
    last_occlusion: Option<bool>,
}

fn pixel_buffer(device: &wgpu::Device, label: &str, pixels: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: (pixels * 4).max(16),
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    })
}

impl ViewAo {
    fn new(device: &wgpu::Device, pixels: u64) -> Self {
        ViewAo {
            pixels,
            params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("ambient occlusion params"),
                size: size_of::<AoParams>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            depth: [pixel_buffer(device, "view depth", pixels), pixel_buffer(device, "view depth", pixels)],
            occlusion: None,
            current: 0,
            last: None,
            previous: None,
            last_occlusion: None,
        }
    }

    /// The buffer the view's shading reads this frame, once its occlusion
    /// was computed.
    fn output(&self) -> Option<&wgpu::Buffer> {
        let occlusion = self.occlusion.as_ref()?;
        match self.last_occlusion? {
            true => Some(&occlusion.result[self.current]),
            false => Some(&occlusion.denoised),
        }
    }
}

/// The screen-space steps' pipelines (made on first use) and every view's
/// buffers: its depth in metres (for ambient occlusion and contact
/// shadows) and its occlusion.
#[derive(Default)]
pub(crate) struct AmbientOcclusionState {
    pipelines: OnceLock<AoPipelines>,
    views: Mutex<HashMap<ViewId, ViewAo>>,
}

impl AmbientOcclusionState {
    /// Records `ctx`'s view's depth in metres for this frame into
    /// `encoder`, and its occlusion when `settings` asks for it (each once
    /// a frame: a second call records only what the first did not).
    pub(crate) fn record(
        &self,
        ctx: &RenderContext<'_>,
        encoder: &mut wgpu::CommandEncoder,
        settings: Option<&AmbientOcclusion>,
    ) -> Result<(), PassError> {
        const PASS: &str = "ambient occlusion";
        if let Some(problem) = settings.and_then(AmbientOcclusion::problem) {
            return Err(PassError::BadInput { pass: PASS, what: problem });
        }
        if ctx.targets.tile.is_some() {
            return Err(PassError::BadInput {
                pass: PASS,
                what: "a camera of a batch has no screen-space depth (its tile shares the batch's depth atlas): \
                       no ambient occlusion or contact shadows"
                    .into(),
            });
        }
        if let Some(msaa) = &ctx.targets.msaa
            && !msaa.depth.usage().contains(wgpu::TextureUsages::TEXTURE_BINDING)
        {
            // GL's multisampled depth stays a renderbuffer, which no shader
            // can read (a readable one made llvmpipe render multisampled
            // views wrongly: `ViewTargets::with_msaa_sampled_depth`); other
            // backends make it readable when the view's graph says it reads
            // it.
            let what = if ctx.gpu.adapter_info.backend == wgpu::Backend::Gl {
                "the screen-space depth of a multisampled view (ambient occlusion, contact shadows) is not \
                 available on GL (use Vulkan, or no MSAA)"
            } else {
                "the view's multisampled depth is not readable: its graph must say that it reads the depth \
                 (RenderGraph::reads_screen_depth; the standard graph does when it has ambient occlusion or \
                 contact shadows)"
            };
            return Err(PassError::BadInput { pass: PASS, what: what.into() });
        }
        let (width, height) = (ctx.targets.width, ctx.targets.height);
        let pixels = u64::from(width) * u64::from(height);
        let quality = settings.map(|s| s.quality.samples());
        let _span =
            info_span!("screen_space_depth", view = %ctx.view.view_id, width, height, occlusion = ?quality).entered();
        let device = &ctx.gpu.device;
        let limit = device.limits().max_storage_buffer_binding_size;
        if pixels * 4 > limit {
            return Err(PassError::BadInput {
                pass: PASS,
                what: format!(
                    "{width} × {height} pixels of screen-space depth exceed the device's storage binding limit of \
                     {limit} bytes"
                ),
            });
        }
        let pipelines = self.pipelines.get_or_init(|| AoPipelines::new(device));
        let mut views = self.views.lock().map_err(|_| PassError::Graph("ambient occlusion state poisoned".into()))?;
        let frame = ctx.prepared.frame_index();
        let state = match views.get_mut(&ctx.view.view_id) {
            Some(state) if state.pixels == pixels => state,
            _ => {
                views.insert(ctx.view.view_id, ViewAo::new(device, pixels));
                views
                    .get_mut(&ctx.view.view_id)
                    .ok_or_else(|| PassError::Graph("ambient occlusion state lost".into()))?
            }
        };
        let same_frame = state.last.is_some_and(|last| last.frame == frame);
        if same_frame && (settings.is_none() || state.last_occlusion.is_some()) {
            return Ok(());
        }
        if !same_frame {
            // Last frame's result is blended in only when it was last
            // frame's and had the temporal step too.
            state.previous = state.last.filter(|last| state.last_occlusion == Some(true) && last.frame + 1 == frame);
            state.current = 1 - state.current;
            state.last = Some(LastFrame {
                frame,
                world_to_view: ctx.view.world_to_view,
                projection: ctx.view.projection,
                origin: ctx.origin,
            });
            state.last_occlusion = None;
        }
        let previous = state.previous.filter(|_| settings.is_some_and(|s| s.temporal));
        let params = params(ctx, settings, previous, frame);
        ctx.gpu.queue.write_buffer(&state.params, 0, bytemuck::bytes_of(&params));
        if let Some(settings) = settings {
            state.last_occlusion = Some(settings.temporal);
            if state.occlusion.is_none() {
                state.occlusion = Some(Occlusion {
                    raw: pixel_buffer(device, "ambient occlusion raw", pixels),
                    denoised: pixel_buffer(device, "ambient occlusion denoised", pixels),
                    result: [
                        pixel_buffer(device, "ambient occlusion", pixels),
                        pixel_buffer(device, "ambient occlusion", pixels),
                    ],
                });
            }
        }

        let (current, last) = (state.current, 1 - state.current);
        let group = |layout: &wgpu::BindGroupLayout, entries: &[(u32, wgpu::BindingResource<'_>)]| {
            let mut all = vec![wgpu::BindGroupEntry { binding: 0, resource: state.params.as_entire_binding() }];
            all.extend(
                entries
                    .iter()
                    .map(|(binding, resource)| wgpu::BindGroupEntry { binding: *binding, resource: resource.clone() }),
            );
            device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(PASS), layout, entries: &all })
        };
        let linearize = (!same_frame).then(|| match &ctx.targets.msaa {
            None => (
                &pipelines.linearize.1,
                group(
                    &pipelines.linearize.0,
                    &[
                        (1, wgpu::BindingResource::TextureView(&ctx.targets.depth_view)),
                        (2, state.depth[current].as_entire_binding()),
                    ],
                ),
            ),
            Some(msaa) => (
                &pipelines.linearize_multisampled.1,
                group(
                    &pipelines.linearize_multisampled.0,
                    &[
                        (2, state.depth[current].as_entire_binding()),
                        (9, wgpu::BindingResource::TextureView(&msaa.depth_view)),
                    ],
                ),
            ),
        });
        let mut steps = Vec::new();
        if let (Some(settings), Some(occlusion)) = (settings, &state.occlusion) {
            steps.push((
                &pipelines.gtao.1,
                group(
                    &pipelines.gtao.0,
                    &[(3, occlusion.raw.as_entire_binding()), (4, state.depth[current].as_entire_binding())],
                ),
            ));
            steps.push((
                &pipelines.denoise.1,
                group(
                    &pipelines.denoise.0,
                    &[
                        (4, state.depth[current].as_entire_binding()),
                        (5, occlusion.raw.as_entire_binding()),
                        (6, occlusion.denoised.as_entire_binding()),
                    ],
                ),
            ));
            if settings.temporal {
                steps.push((
                    &pipelines.temporal.1,
                    group(
                        &pipelines.temporal.0,
                        &[
                            (4, state.depth[current].as_entire_binding()),
                            (5, occlusion.denoised.as_entire_binding()),
                            (6, occlusion.result[current].as_entire_binding()),
                            (7, state.depth[last].as_entire_binding()),
                            (8, occlusion.result[last].as_entire_binding()),
                        ],
                    ),
                ));
            }
        }
        let mut pass =
            encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(PASS), timestamp_writes: None });
        let groups = (width.div_ceil(8), height.div_ceil(8));
        for (pipeline, bind_group) in linearize.iter().chain(&steps) {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind_group, &[]);
            pass.dispatch_workgroups(groups.0, groups.1, 1);
        }
        Ok(())
    }

    /// The occlusion `view`'s shading reads in frame `frame` (one float a
    /// pixel, row by row), when an occlusion pass of the view recorded it
    /// this frame.
    pub(crate) fn output(&self, view: ViewId, frame: u64) -> Option<wgpu::Buffer> {
        let views = self.views.lock().ok()?;
        let state = views.get(&view)?;
        (state.last?.frame == frame).then(|| state.output().cloned()).flatten()
    }

    /// `view`'s depth in metres in frame `frame` (one float a pixel, row by
    /// row; 0 where nothing was drawn), when a pass of the view recorded it
    /// this frame.
    pub(crate) fn depth(&self, view: ViewId, frame: u64) -> Option<wgpu::Buffer> {
        let views = self.views.lock().ok()?;
        let state = views.get(&view)?;
        (state.last?.frame == frame).then(|| state.depth[state.current].clone())
    }

    /// Frees the buffers of the views `keep` says no to.
    pub(crate) fn retain(&self, keep: impl Fn(ViewId) -> bool) {
        if let Ok(mut views) = self.views.lock() {
            views.retain(|view, _| keep(*view));
        }
    }

    /// Views holding screen-space buffers (for tests: a view without
    /// ambient occlusion or contact shadows holds none).
    pub(crate) fn views(&self) -> usize {
        self.views.lock().map_or(0, |views| views.len())
    }

    /// Views holding occlusion buffers.
    pub(crate) fn occlusion_views(&self) -> usize {
        self.views.lock().map_or(0, |views| views.values().filter(|v| v.occlusion.is_some()).count())
    }
}

/// The parameters of `ctx`'s view this frame; `previous` is last frame's
/// camera when its result is blended in.
fn params(
    ctx: &RenderContext<'_>,
    settings: Option<&AmbientOcclusion>,
    previous: Option<LastFrame>,
    frame: u64,
) -> AoParams {
    let temporal = settings.is_some_and(|s| s.temporal);
    let settings = settings.copied().unwrap_or_default();
    let projection = ctx.view.projection;
    // Perspective: clip w = −z_view (the third column's w is −1).
    let perspective = projection.z_axis.w != 0.0;
    let finite = |m: Mat4| if m.is_finite() { m } else { Mat4::IDENTITY };
    let inverse_projection = finite(projection.inverse());
    let (ax, ay) = (1.0 / projection.x_axis.x, 1.0 / projection.y_axis.y);
    let (bx, by) = if perspective {
        (projection.z_axis.x / projection.x_axis.x, projection.z_axis.y / projection.y_axis.y)
    } else {
        (-projection.w_axis.x / projection.x_axis.x, -projection.w_axis.y / projection.y_axis.y)
    };
    let unproject = [ax, ay, bx, by].map(|v| if v.is_finite() { v } else { 0.0 });
    // Pixels a metre spans at a depth of one metre (perspective) or at any
    // depth (orthographic): half the height times the y scale.
    let pixels_per_metre = 0.5 * ctx.targets.height as f32 * projection.y_axis.y.abs();
    let (slices, steps) = settings.quality.samples();
    let (reproject, previous_projection) = match previous {
        Some(last) => {
            let reproject = reprojection((last.world_to_view, last.origin), (ctx.view.world_to_view, ctx.origin));
            (finite(reproject), finite(last.projection))
        }
        None => (Mat4::IDENTITY, projection),
    };
    AoParams {
        inverse_projection: inverse_projection.to_cols_array_2d(),
        reproject: reproject.to_cols_array_2d(),
        previous_projection: previous_projection.to_cols_array_2d(),
        size: [ctx.targets.width, ctx.targets.height, slices | (steps << 16), u32::from(perspective)],
        shape: [
            settings.radius,
            FALLOFF_START,
            if pixels_per_metre.is_finite() { pixels_per_metre } else { 0.0 },
            DENOISE_DEPTH_TOLERANCE,
        ],
        unproject,
        frame: [(frame % 64) as u32 * u32::from(temporal), u32::from(previous.is_some()), 0, 0],
        frame_weights: [TEMPORAL_WEIGHT, REPROJECTION_DEPTH_TOLERANCE, 0.0, 0.0],
    }
}

/// This frame's view space → last frame's, from the two frames'
/// world → view transforms, each for the world relative to its frame's
/// render origin (in f64: the world may be far from its origin, and the
/// product is near the identity for a camera that barely moved).
fn reprojection((last, last_origin): (DMat4, glam::DVec3), (now, origin): (DMat4, glam::DVec3)) -> Mat4 {
    (last * DMat4::from_translation(origin - last_origin) * now.inverse()).as_mat4()
}

/// Records its view's ambient occlusion ([`AmbientOcclusion`]) for the
/// forward pass after it, which reads the result when its configuration
/// asks for the same. Needs the view's depth laid down first (a depth
/// pre-pass).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AmbientOcclusionPass {
    /// What to compute.
    pub settings: AmbientOcclusion,
}

impl AmbientOcclusionPass {
    /// A pass computing `settings`.
    pub fn new(settings: AmbientOcclusion) -> Self {
        AmbientOcclusionPass { settings }
    }
}

impl RenderPass for AmbientOcclusionPass {
    fn name(&self) -> &'static str {
        "ambient occlusion"
    }

    async fn run(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        ctx.lighting.ambient_occlusion().record(ctx, rec.encoder(), Some(&self.settings))
    }
}

/// Records its view's depth in metres (one float a pixel, kept for the
/// frame) for the screen-space effects that read it in shading: contact
/// shadows ([`crate::ContactShadows`]). Records nothing when an
/// [`AmbientOcclusionPass`] of the view did this frame (it computes the
/// same depth first). Needs the view's depth laid down first (a depth
/// pre-pass).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinearDepthPass;

impl RenderPass for LinearDepthPass {
    fn name(&self) -> &'static str {
        "linear depth"
    }

    async fn run(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        ctx.lighting.ambient_occlusion().record(ctx, rec.encoder(), None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point seen by this frame's camera lands where last frame's camera
    /// saw it, far from the world's origin too, and when the render origin
    /// moved between the frames (each frame's transform is relative to its
    /// own origin, as `ResolvedView::relative_to` makes it).
    #[test]
    fn reprojection_takes_this_frames_view_space_to_last_frames() {
        use glam::DVec3;
        let at = DVec3::new(1.0e6, 20.0, -3.0e5);
        let last = DMat4::look_at_rh(at + DVec3::new(0.0, 2.0, 5.0), at, DVec3::Y);
        let now = DMat4::look_at_rh(at + DVec3::new(0.3, 2.1, 4.8), at + DVec3::new(0.1, 0.0, 0.0), DVec3::Y);
        let world = at + DVec3::new(0.5, 0.25, -1.0);
        let seen_now = now.transform_point3(world).as_vec3();
        let seen_last = last.transform_point3(world).as_vec3();
        for (last_origin, origin) in [(DVec3::ZERO, DVec3::ZERO), (at, at), (at, at + DVec3::new(1024.0, 0.0, -1024.0))]
        {
            let relative = |m: DMat4, o: DVec3| m * DMat4::from_translation(o);
            let moved = reprojection((relative(last, last_origin), last_origin), (relative(now, origin), origin))
                .transform_point3(seen_now);
            assert!((moved - seen_last).length() < 1.0e-4, "{moved} against {seen_last} ({last_origin}, {origin})");
        }
        // A camera that did not move: the identity.
        let still = (now * DMat4::from_translation(at), at);
        assert!(reprojection(still, still).abs_diff_eq(Mat4::IDENTITY, 1.0e-6));
    }

    #[test]
    fn quality_levels_grow_in_samples() {
        let samples: Vec<u32> = AoQuality::ALL.iter().map(|q| q.samples().0 * q.samples().1).collect();
        assert!(samples.windows(2).all(|w| w[0] < w[1]), "{samples:?}");
        assert_eq!(AoQuality::default(), AmbientOcclusion::DEFAULT.quality);
    }

    #[test]
    fn a_radius_that_is_not_finite_and_positive_is_a_problem() {
        for radius in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            let settings = AmbientOcclusion { radius, ..AmbientOcclusion::DEFAULT };
            assert!(settings.problem().is_some_and(|p| p.contains("radius")), "{radius}");
        }
        assert_eq!(AmbientOcclusion::DEFAULT.problem(), None);
    }
}
