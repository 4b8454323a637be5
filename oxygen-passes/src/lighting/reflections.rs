//! Screen-space reflections: glossy surfaces reflect what the view itself
//! showed, found by marching the reflected ray through the view's depth,
//! and fall back to the reflection probe or the environment where the ray
//! leaves the screen, passes behind everything or the surface is too rough.
//!
//! The march runs in the forward shader (`screen_reflection` in
//! `mesh/shading.wgsl`) over the depth in metres a [`crate::LinearDepthPass`]
//! wrote after the depth pre-pass. What a hit reflects is the view's HDR
//! colour of the **last frame it rendered** (the surfaces this frame are
//! being shaded as the ray needs them): a [`ReflectionHistoryPass`] keeps
//! it after shading, with a chain of halved levels that rough surfaces read
//! blurred, and the hit point is reprojected through last frame's camera.
//! So a view's first frame reflects the probe or environment everywhere,
//! and a moving object's reflection lags it by a frame.
//!
//! The history lives in a storage buffer of half floats, not a texture: GL
//! allows 16 sampled textures per shader stage and the shading pass already
//! binds 16 there.
//!
//! A view asks for them in its forward configuration
//! ([`ForwardLitConfig::screen_space_reflections`](crate::ForwardLitConfig::screen_space_reflections));
//! the standard graph then records the depth pre-pass, the linear depth and
//! the history pass. Without the knob nothing is recorded or allocated and
//! the shading pipelines leave the code out (`HAS_SCREEN_REFLECTIONS`).
//!
//! Memory: 8 bytes a pixel and a third more for the levels, per view, kept
//! across frames and regrown with its size.

use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

use glam::{DMat4, DVec3, Mat4};
use oxygen_core::ViewId;
use oxygen_gpu::bindings::{self, LayoutEntries};
use tracing::info_span;

use crate::{CommandRecorder, PassError, RenderContext, RenderPass};

/// A view's screen-space reflections
/// ([`ForwardLitConfig::screen_space_reflections`](crate::ForwardLitConfig::screen_space_reflections)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenSpaceReflections {
    /// The roughest surface that reflects the screen, 0 to 1: from 70 % of
    /// it on, the screen's reflection fades into the probe's or the
    /// environment's (whose prefiltered levels serve rough surfaces better
    /// than a blurred screen). 0.5 by default.
    pub max_roughness: f32,
    /// How far the reflected ray goes, in metres. Finite and positive; 20 m
    /// by default. Its last fifth fades out, so a reflection does not end
    /// at a hard edge.
    pub max_distance: f32,
    /// How thick a surface the depth holds is taken to be, in metres: the
    /// ray hits where it passes behind a surface by less than this (plus
    /// the depth one step of the march covers). Finite and positive; 0.3 m
    /// by default. Thinner misses the sides of objects seen edge-on,
    /// thicker reflects the front of an object where its back should be.
    pub thickness: f32,
    /// Samples along the ray's path across the screen, 4 to 256; 48 by
    /// default. A path shorter than this many pixels takes one a pixel.
    /// Four halvings refine the hit between the last two.
    pub steps: u32,
}

impl ScreenSpaceReflections {
    /// Surfaces up to roughness 0.5, rays of 20 m, 0.3 m thick, 48 steps.
    pub const DEFAULT: ScreenSpaceReflections =
        ScreenSpaceReflections { max_roughness: 0.5, max_distance: 20.0, thickness: 0.3, steps: 48 };

    /// Fewest steps a march takes.
    pub const MIN_STEPS: u32 = 4;
    /// Most steps a march takes.
    pub const MAX_STEPS: u32 = 256;

    /// Why these settings cannot be used, if they cannot.
    pub fn problem(&self) -> Option<String> {
        let positive = |v: f32| v.is_finite() && v > 0.0;
        if !(self.max_roughness.is_finite() && (0.0..=1.0).contains(&self.max_roughness)) {
            return Some(format!(
                "screen-space reflections' max roughness {} is not between 0 and 1",
                self.max_roughness
            ));
        }
        if !positive(self.max_distance) {
            return Some(format!(
                "screen-space reflections' max distance {} is not a finite positive number of metres",
                self.max_distance
            ));
        }
        if !positive(self.thickness) {
            return Some(format!(
                "screen-space reflections' thickness {} is not a finite positive number of metres",
                self.thickness
            ));
        }
        if !(Self::MIN_STEPS..=Self::MAX_STEPS).contains(&self.steps) {
            return Some(format!(
                "screen-space reflections take {} to {} steps, not {}",
                Self::MIN_STEPS,
                Self::MAX_STEPS,
                self.steps
            ));
        }
        None
    }

    /// The uniform fields of group 1: max roughness, thickness, max
    /// distance, steps.
    pub(crate) fn uniform(&self) -> [f32; 4] {
        [self.max_roughness, self.thickness, self.max_distance, self.steps as f32]
    }
}

impl Default for ScreenSpaceReflections {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Levels of the history: the image and five halvings (a blur of up to 32
/// pixels, for the roughest surfaces a long ray reflects).
pub(crate) const HISTORY_LEVELS: u32 = 6;

/// Each level's size and where it starts in the history buffer (in pixels):
/// level 0 is `width × height`, each next one half of the last, rounded up
/// (the shader walks the same chain: `history_level` in `mesh/shading.wgsl`).
pub(crate) fn history_levels(width: u32, height: u32) -> Vec<HistoryLevel> {
    let mut levels = Vec::new();
    let (mut w, mut h, mut offset) = (width.max(1), height.max(1), 0u64);
    for _ in 0..HISTORY_LEVELS {
        levels.push(HistoryLevel { width: w, height: h, offset });
        offset += u64::from(w) * u64::from(h);
        if w == 1 && h == 1 {
            break;
        }
        (w, h) = (w.div_ceil(2), h.div_ceil(2));
    }
    levels
}

/// One level of the history.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct HistoryLevel {
    pub(crate) width: u32,
    pub(crate) height: u32,
    /// Pixels before it in the buffer.
    pub(crate) offset: u64,
}

oxygen_gpu::gpu_struct! {
    /// One step of the history pass: the level it reads and the level it
    /// writes (its WGSL twin is generated and included by
    /// `lighting/reflection_history.wgsl`).
    #[derive(Debug, PartialEq)]
    pub(crate) struct HistoryStep: 32 bytes {
        /// Width, height and first pixel of the level read (unused by the
        /// copy from the HDR image), a zero.
        pub(crate) src: [u32; 4] => "vec4<u32>",
        /// Width, height and first pixel of the level written, a zero.
        pub(crate) dst: [u32; 4] => "vec4<u32>",
    }
}

/// The history pass's pipelines: the copy of the HDR image into level 0,
/// and a level halved into the next.
struct HistoryPipelines {
    copy: (wgpu::BindGroupLayout, wgpu::ComputePipeline),
    halve: (wgpu::BindGroupLayout, wgpu::ComputePipeline),
}

impl HistoryPipelines {
    fn new(device: &wgpu::Device) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("reflection history"),
            source: wgpu::ShaderSource::Wgsl(crate::shaders::REFLECTION_HISTORY.source().into()),
        });
        let pipeline =
            |entry: &str, entries: LayoutEntries| crate::pipelines::compute_step(device, &module, entry, entries);
        let entries = || LayoutEntries::new(wgpu::ShaderStages::COMPUTE).push(bindings::uniform_of::<HistoryStep>());
        HistoryPipelines {
            copy: pipeline(
                "copy_hdr",
                entries().push(bindings::storage_read_write()).push(bindings::texture_2d(bindings::UNFILTERABLE_FLOAT)),
            ),
            halve: pipeline("halve", entries().push(bindings::storage_read_write())),
        }
    }
}

/// A view's history, kept across frames.
struct ViewHistory {
    width: u32,
    height: u32,
    levels: Vec<HistoryLevel>,
    /// Every level's pixels, as three half floats in two words each.
    buffer: wgpu::Buffer,
    /// The steps' parameters, one per level at the uniform offset alignment.
    steps: wgpu::Buffer,
    step_stride: u64,
    /// The frame the history holds and its camera (world relative to the
    /// frame's render origin → view, the projection, that origin), once a
    /// frame was kept.
    kept: Option<(u64, DMat4, Mat4, DVec3)>,
}

impl ViewHistory {
    fn new(device: &wgpu::Device, queue: &wgpu::Queue, width: u32, height: u32) -> Self {
        let levels = history_levels(width, height);
        let pixels = levels.last().map_or(1, |l| l.offset + u64::from(l.width) * u64::from(l.height));
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("reflection history"),
            size: pixels * 8,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let step_stride = (size_of::<HistoryStep>() as u64)
            .next_multiple_of(u64::from(device.limits().min_uniform_buffer_offset_alignment));
        let steps = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("reflection history steps"),
            size: step_stride * levels.len() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let word = |l: &HistoryLevel| [l.width, l.height, l.offset as u32, 0];
        for (i, level) in levels.iter().enumerate() {
            let src = if i == 0 { [0; 4] } else { word(&levels[i - 1]) };
            let step = HistoryStep { src, dst: word(level) };
            queue.write_buffer(&steps, step_stride * i as u64, bytemuck::bytes_of(&step));
        }
        ViewHistory { width, height, levels, buffer, steps, step_stride, kept: None }
    }
}

/// What the forward pass reads of a view's history.
pub(crate) struct History {
    /// The levels' pixels.
    pub(crate) buffer: wgpu::Buffer,
    /// Width, height, levels and 1: `LightingInputs::reflection_history`.
    pub(crate) shape: [u32; 4],
    /// This frame's world (relative to its render origin) → the kept
    /// frame's clip space.
    pub(crate) reprojection: Mat4,
}

/// The history pass's pipelines (made on first use) and every view's
/// history.
#[derive(Default)]
pub(crate) struct ReflectionHistoryState {
    pipelines: OnceLock<HistoryPipelines>,
    views: Mutex<HashMap<ViewId, ViewHistory>>,
}

impl ReflectionHistoryState {
    /// The history `ctx`'s view shades with this frame: the last frame it
    /// kept, when one was kept at the view's size.
    pub(crate) fn previous(&self, ctx: &RenderContext<'_>) -> Option<History> {
        let views = self.views.lock().ok()?;
        let history = views.get(&ctx.view.view_id)?;
        let (frame, world_to_view, projection, kept_origin) = history.kept?;
        if frame >= ctx.prepared.frame_index()
            || (history.width, history.height) != (ctx.targets.width, ctx.targets.height)
        {
            return None;
        }
        let reprojection = reprojection(projection, world_to_view, ctx.origin - kept_origin);
        reprojection.is_finite().then(|| History {
            buffer: history.buffer.clone(),
            shape: [history.width, history.height, history.levels.len() as u32, 1],
            reprojection,
        })
    }

    /// Records the copy of `ctx`'s view's HDR image into its history and
    /// the history's levels.
    pub(crate) fn record(&self, ctx: &RenderContext<'_>, encoder: &mut wgpu::CommandEncoder) -> Result<(), PassError> {
        const PASS: &str = "reflection history";
        if ctx.targets.tile.is_some() {
            return Err(PassError::BadInput {
                pass: PASS,
                what: "a camera of a batch has no screen-space depth (its tile shares the batch's atlas): no \
                       screen-space reflections"
                    .into(),
            });
        }
        let Some(color) = &ctx.targets.color else {
            return Err(PassError::BadInput { pass: PASS, what: "the view has no colour to keep".into() });
        };
        let (width, height) = (ctx.targets.width, ctx.targets.height);
        let _span = info_span!("reflection_history", view = %ctx.view.view_id, width, height).entered();
        let device = &ctx.gpu.device;
        let pipelines = self.pipelines.get_or_init(|| HistoryPipelines::new(device));
        let mut views = self.views.lock().map_err(|_| PassError::Graph("reflection history state poisoned".into()))?;
        let stale = views.get(&ctx.view.view_id).is_none_or(|h| (h.width, h.height) != (width, height));
        if stale {
            let bytes = u64::from(width) * u64::from(height) * 8 * 4 / 3;
            let limit = device.limits().max_storage_buffer_binding_size;
            if bytes > limit {
                return Err(PassError::BadInput {
                    pass: PASS,
                    what: format!(
                        "the reflection history of {width} × {height} pixels exceeds the device's storage binding \
                         limit of {limit} bytes"
                    ),
                });
            }
            views.insert(ctx.view.view_id, ViewHistory::new(device, &ctx.gpu.queue, width, height));
        }
        let history =
            views.get_mut(&ctx.view.view_id).ok_or_else(|| PassError::Graph("reflection history lost".into()))?;
        let step = |i: usize| {
            wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: &history.steps,
                offset: history.step_stride * i as u64,
                size: wgpu::BufferSize::new(size_of::<HistoryStep>() as u64),
            })
        };
        let mut groups = vec![(
            &pipelines.copy.1,
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(PASS),
                layout: &pipelines.copy.0,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: step(0) },
                    wgpu::BindGroupEntry { binding: 1, resource: history.buffer.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&color.hdr_view) },
                ],
            }),
            history.levels[0],
        )];
        for (i, level) in history.levels.iter().enumerate().skip(1) {
            groups.push((
                &pipelines.halve.1,
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(PASS),
                    layout: &pipelines.halve.0,
                    entries: &[
                        wgpu::BindGroupEntry { binding: 0, resource: step(i) },
                        wgpu::BindGroupEntry { binding: 1, resource: history.buffer.as_entire_binding() },
                    ],
                }),
                *level,
            ));
        }
        // Each dispatch reads what the one before wrote: wgpu orders
        // dispatches that write the same storage buffer.
        let mut pass =
            encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(PASS), timestamp_writes: None });
        for (pipeline, group, level) in &groups {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(level.width.div_ceil(8), level.height.div_ceil(8), 1);
        }
        history.kept = Some((ctx.prepared.frame_index(), ctx.view.world_to_view, ctx.view.projection, ctx.origin));
        Ok(())
    }

    /// Frees the histories of the views `keep` says no to.
    pub(crate) fn retain(&self, keep: impl Fn(ViewId) -> bool) {
        if let Ok(mut views) = self.views.lock() {
            views.retain(|view, _| keep(*view));
        }
    }

    /// Views holding a history.
    pub(crate) fn views(&self) -> usize {
        self.views.lock().map_or(0, |views| views.len())
    }
}

/// This frame's world, relative to its render origin, → the clip space of
/// the frame kept with `world_to_view` (for the world relative to that
/// frame's origin) and `projection`; `moved` is this frame's origin less
/// the kept frame's (in f64: the world may be far from its origin).
fn reprojection(projection: Mat4, world_to_view: DMat4, moved: DVec3) -> Mat4 {
    (projection.as_dmat4() * world_to_view * DMat4::from_translation(moved)).as_mat4()
}

/// Records its view's HDR image as the history the next frame's
/// screen-space reflections read ([`ScreenSpaceReflections`]): after the
/// view's last colour pass, before the tone map.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReflectionHistoryPass;

impl RenderPass for ReflectionHistoryPass {
    fn name(&self) -> &'static str {
        "reflection history"
    }

    async fn run(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        ctx.lighting.reflection_history().record(ctx, rec.encoder())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_out_of_range_are_problems_naming_them() {
        let d = ScreenSpaceReflections::DEFAULT;
        assert_eq!(d.problem(), None);
        for (bad, name) in [
            (ScreenSpaceReflections { max_roughness: f32::NAN, ..d }, "roughness"),
            (ScreenSpaceReflections { max_roughness: 1.5, ..d }, "roughness"),
            (ScreenSpaceReflections { max_distance: 0.0, ..d }, "distance"),
            (ScreenSpaceReflections { max_distance: f32::INFINITY, ..d }, "distance"),
            (ScreenSpaceReflections { thickness: -0.1, ..d }, "thickness"),
            (ScreenSpaceReflections { steps: 3, ..d }, "steps"),
            (ScreenSpaceReflections { steps: 257, ..d }, "steps"),
        ] {
            assert!(bad.problem().is_some_and(|p| p.contains(name)), "{bad:?}");
        }
        assert_eq!(ScreenSpaceReflections { max_roughness: 0.0, steps: 256, ..d }.problem(), None);
    }

    #[test]
    fn levels_halve_rounding_up_and_follow_each_other_in_the_buffer() {
        let levels = history_levels(37, 10);
        let sizes: Vec<(u32, u32)> = levels.iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, [(37, 10), (19, 5), (10, 3), (5, 2), (3, 1), (2, 1)]);
        for pair in levels.windows(2) {
            assert_eq!(pair[1].offset, pair[0].offset + u64::from(pair[0].width * pair[0].height));
        }
        // A tiny image stops at one pixel.
        assert_eq!(history_levels(2, 1).len(), 2);
        assert_eq!(history_levels(0, 0), [HistoryLevel { width: 1, height: 1, offset: 0 }]);
    }

    /// A point seen by this frame's camera, relative to this frame's
    /// origin, lands where the kept frame's camera saw it, far from the
    /// world's origin too, and when the origin moved between the frames.
    #[test]
    fn reprojection_takes_this_frames_points_to_the_kept_frames_clip_space() {
        let at = DVec3::new(1.0e6, 20.0, -3.0e5);
        let kept = DMat4::look_at_rh(at + DVec3::new(0.0, 2.0, 5.0), at, DVec3::Y);
        let projection = Mat4::perspective_rh(0.9, 1.5, 0.1, 100.0);
        let world = at + DVec3::new(0.5, 0.25, -1.0);
        let expected = projection * kept.transform_point3(world).as_vec3().extend(1.0);
        let kept_origin = at + DVec3::new(0.3, 0.0, 0.1);
        // Each frame's world → view is relative to its own origin
        // (`ResolvedView::relative_to`).
        let kept_relative = kept * DMat4::from_translation(kept_origin);
        for origin in [kept_origin, kept_origin + DVec3::new(1024.0, 0.0, 0.0)] {
            let relative = (world - origin).as_vec3();
            let clip = reprojection(projection, kept_relative, origin - kept_origin) * relative.extend(1.0);
            let (ndc, want) = (clip.truncate() / clip.w, expected.truncate() / expected.w);
            assert!((ndc - want).length() < 1.0e-4, "{ndc} against {want} ({origin})");
        }
    }
}
