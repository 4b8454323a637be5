//! Step 4 of a frame, present: after every view of the frame has been
//! submitted, compose each window from the views shown in it and present
//! it (see `crate::windows` for the model). Its output is
//! [`PresentedFrame`].

use std::collections::HashMap;

use glam::UVec2;
use oxygen_core::ViewId;
use oxygen_gpu::GpuContext;
use oxygen_gpu::bindings::{self, LayoutEntries};
use tracing::{info_span, warn};

use super::record::RecordedFrame;
use super::targets::Targets;
use super::windows::Windows;
use super::{FrameWarning, Renderer};
use crate::views::Views;
use crate::windows::{WindowId, WindowRect};

/// What the present step did.
pub(crate) struct PresentedFrame {
    /// Windows composed and presented (offscreen ones composed).
    pub(crate) windows_presented: usize,
    /// Windows not presented this frame, and why.
    pub(crate) warnings: Vec<FrameWarning>,
}

/// The composition pipelines (one per window format) and what they bind.
pub(crate) struct Compositor {
    layout: wgpu::BindGroupLayout,
    depth_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    /// The composition shader's WGSL (oxygen-passes' registry composes
    /// it), kept for the pipelines of window formats seen later.
    wgsl: String,
    /// By window format and whether the view shown is depth only.
    pipelines: HashMap<(wgpu::TextureFormat, bool), wgpu::RenderPipeline>,
}

impl Compositor {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        let layout = LayoutEntries::new(wgpu::ShaderStages::FRAGMENT)
            .push(bindings::texture_2d(bindings::FILTERABLE_FLOAT))
            .push(bindings::sampler_filtering())
            .create_layout(device, "compose");
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("compose"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let depth_layout = LayoutEntries::new(wgpu::ShaderStages::FRAGMENT)
            .push(bindings::texture_2d(bindings::UNFILTERABLE_FLOAT))
            .create_layout(device, "compose depth");
        Compositor {
            layout,
            depth_layout,
            sampler,
            wgsl: oxygen_passes::compose_window_wgsl(),
            pipelines: HashMap::new(),
        }
    }

    fn pipeline(&mut self, device: &wgpu::Device, format: wgpu::TextureFormat, depth: bool) -> &wgpu::RenderPipeline {
        let (layout, fragment) = if depth { (&self.depth_layout, "fs_depth") } else { (&self.layout, "fs_color") };
        self.pipelines.entry((format, depth)).or_insert_with(|| {
            oxygen_passes::fullscreen_pipeline(device, "compose", layout, &self.wgsl, ("vs", fragment), format)
        })
    }
}

impl Renderer {
    /// Step 4: presents every window from the views `recorded` rendered.
    pub(super) fn present(&mut self, recorded: &RecordedFrame) -> PresentedFrame {
        let _span = info_span!("present", windows = self.windows.windows.len()).entered();
        let rendered: Vec<ViewId> = recorded.rendered.iter().map(|v| v.id).collect();
        self.windows.present(&self.gpu, &self.views, &self.targets, &rendered)
    }
}

impl Windows {
    /// Composes every window with a size from the views shown in it that
    /// rendered this frame (`rendered`; the others keep the window's clear
    /// colour), then presents the ones with a surface.
    pub(super) fn present(
        &mut self,
        gpu: &GpuContext,
        views: &Views,
        targets: &Targets,
        rendered: &[ViewId],
    ) -> PresentedFrame {
        let mut warnings = Vec::new();
        if self.windows.is_empty() {
            return PresentedFrame { windows_presented: 0, warnings };
        }
        let device = gpu.device.clone();
        let mut shown: Vec<(WindowId, WindowRect, ViewId)> = views
            .entries
            .iter()
            .filter_map(|(id, entry)| entry.shown.map(|(window, rect)| (window, rect, *id)))
            .chain(self.shown.iter().map(|(id, (window, rect))| (*window, *rect, *id)))
            .filter(|(_, _, id)| rendered.contains(id))
            .collect();
        shown.sort_by_key(|(window, _, id)| (*window, *id));
        let mut presented = 0;
        let ids: Vec<WindowId> = self.windows.keys().copied().collect();
        for id in ids {
            let Some(window) = self.windows.get(&id) else { continue };
            let size = window.size;
            if size.x == 0 || size.y == 0 {
                continue;
            }
            let format = window.format;
            let stale = window.image.as_ref().is_none_or(|i| i.width() != size.x || i.height() != size.y);
            if stale {
                let image = oxygen_gpu::texture_2d(
                    &device,
                    "window image",
                    wgpu::Extent3d { width: size.x, height: size.y, depth_or_array_layers: 1 },
                    1,
                    format,
                    wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                );
                if let Some(window) = self.windows.get_mut(&id) {
                    window.image = Some(image);
                }
            }
            // A view's display image, or the depth of a depth-only view.
            let views: Vec<(WindowRect, &wgpu::TextureView, bool)> = shown
                .iter()
                .filter(|(window, ..)| *window == id)
                .filter_map(|(_, rect, view)| {
                    let targets = targets.get(*view)?.targets.as_ref()?;
                    match &targets.color {
                        Some(color) => Some((*rect, color.color_view.as_ref()?, false)),
                        None => Some((*rect, &targets.depth_view, true)),
                    }
                })
                .collect();
            let bind_groups: Vec<(WindowRect, wgpu::BindGroup, bool)> = views
                .iter()
                .map(|(rect, view, depth)| {
                    let image = wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(view) };
                    let sampler = wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::Sampler(&self.compositor.sampler),
                    };
                    let group = if *depth {
                        device.create_bind_group(&wgpu::BindGroupDescriptor {
                            label: Some("compose depth"),
                            layout: &self.compositor.depth_layout,
                            entries: &[image],
                        })
                    } else {
                        device.create_bind_group(&wgpu::BindGroupDescriptor {
                            label: Some("compose"),
                            layout: &self.compositor.layout,
                            entries: &[image, sampler],
                        })
                    };
                    (*rect, group, *depth)
                })
                .collect();
            let pipelines = [
                self.compositor.pipeline(&device, format, false).clone(),
                self.compositor.pipeline(&device, format, true).clone(),
            ];
            let Some(window) = self.windows.get_mut(&id) else { continue };
            let Some(image) = window.image.as_ref() else { continue };
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("compose") });
            compose(&mut encoder, &pipelines, &bind_groups, &image.create_view(&Default::default()), size);
            let Some(surface) = &mut window.surface else {
                gpu.queue.submit([encoder.finish()]);
                presented += 1;
                continue;
            };
            match surface.surface.get_current_texture() {
                wgpu::CurrentSurfaceTexture::Success(frame) | wgpu::CurrentSurfaceTexture::Suboptimal(frame) => {
                    if surface.copy && frame.texture.format() == image.format() {
                        encoder.copy_texture_to_texture(
                            image.as_image_copy(),
                            frame.texture.as_image_copy(),
                            wgpu::Extent3d {
                                width: size.x.min(frame.texture.width()),
                                height: size.y.min(frame.texture.height()),
                                depth_or_array_layers: 1,
                            },
                        );
                    } else {
                        let target = frame.texture.create_view(&Default::default());
                        compose(&mut encoder, &pipelines, &bind_groups, &target, size);
                    }
                    gpu.queue.submit([encoder.finish()]);
                    gpu.queue.present(frame);
                    presented += 1;
                }
                other => {
                    // Lost, outdated, timed out or occluded: configure again
                    // and present next frame; the frame's work stands.
                    gpu.queue.submit([encoder.finish()]);
                    surface.surface.configure(&device, &surface.config);
                    let reason = format!("the surface was not ready ({}); reconfigured", surface_state(&other));
                    warn!(window = %id, "{reason}");
                    warnings.push(FrameWarning::WindowSkipped { window: id, reason });
                }
            }
        }
        PresentedFrame { windows_presented: presented, warnings }
    }
}

fn surface_state(state: &wgpu::CurrentSurfaceTexture) -> &'static str {
    match state {
        wgpu::CurrentSurfaceTexture::Success(_) => "ready",
        wgpu::CurrentSurfaceTexture::Suboptimal(_) => "suboptimal",
        wgpu::CurrentSurfaceTexture::Timeout => "timeout",
        wgpu::CurrentSurfaceTexture::Occluded => "occluded",
        wgpu::CurrentSurfaceTexture::Outdated => "outdated",
        wgpu::CurrentSurfaceTexture::Lost => "lost",
        _ => "unavailable",
    }
}

/// Clears `target` to black and draws each view's image into its rectangle
/// (`pipelines`: for colour images, for depth images).
fn compose(
    encoder: &mut wgpu::CommandEncoder,
    pipelines: &[wgpu::RenderPipeline; 2],
    views: &[(WindowRect, wgpu::BindGroup, bool)],
    target: &wgpu::TextureView,
    size: UVec2,
) {
    let mut pass = oxygen_passes::fullscreen_pass(encoder, target, "compose");
    for (rect, group, depth) in views {
        pass.set_pipeline(&pipelines[usize::from(*depth)]);
        let (origin, extent) = rect.pixels(size);
        pass.set_viewport(origin.x as f32, origin.y as f32, extent.x as f32, extent.y as f32, 0.0, 1.0);
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..3, 0..1);
    }
}
