//! Step 5 of a frame: compose every window from the views shown in it and
//! present it (see `crate::windows` for the model).

use std::collections::HashMap;

use glam::UVec2;
use oxygen_core::ViewId;
use tracing::{info_span, warn};

use super::{FrameWarning, RenderError, Renderer};
use crate::windows::{COMPOSE_WGSL, PresentMode, WindowId, WindowRect};

/// The format of an offscreen window's image.
const OFFSCREEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// A window surface and how it is configured.
pub(crate) struct WindowSurface {
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    /// The surface texture can be a copy destination (else the views are
    /// composed a second time, straight into it).
    copy: bool,
}

/// A window: its surface (none for an offscreen one), size and image.
pub(crate) struct Window {
    surface: Option<WindowSurface>,
    size: UVec2,
    format: wgpu::TextureFormat,
    /// What was composed last, `size` large; none while the size is zero.
    image: Option<wgpu::Texture>,
}

/// The composition pipelines (one per window format) and what they bind.
pub(crate) struct Compositor {
    layout: wgpu::BindGroupLayout,
    depth_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    /// By window format and whether the view shown is depth only.
    pipelines: HashMap<(wgpu::TextureFormat, bool), wgpu::RenderPipeline>,
}

impl Compositor {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("compose"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("compose"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let depth_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("compose depth"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            }],
        });
        Compositor { layout, depth_layout, sampler, pipelines: HashMap::new() }
    }

    fn pipeline(&mut self, device: &wgpu::Device, format: wgpu::TextureFormat, depth: bool) -> &wgpu::RenderPipeline {
        let (layout, fragment) = if depth { (&self.depth_layout, "fs_depth") } else { (&self.layout, "fs_color") };
        self.pipelines.entry((format, depth)).or_insert_with(|| {
            oxygen_passes::fullscreen_pipeline(device, "compose", layout, COMPOSE_WGSL, ("vs", fragment), format)
        })
    }
}

impl Renderer {
    /// Adds a window surface (created from this renderer's
    /// `gpu().instance`) of `size` pixels, presented with `present_mode`
    /// (or `Fifo` where the surface lacks it). Views are shown in it with
    /// [`crate::ViewDesc::shown_in`]. Fails when the adapter cannot present
    /// to the surface.
    pub fn add_window(
        &mut self,
        surface: wgpu::Surface<'static>,
        size: UVec2,
        present_mode: PresentMode,
    ) -> Result<WindowId, RenderError> {
        let size = self.clamp_window_size(size);
        let caps = surface.get_capabilities(&self.gpu.adapter);
        let format =
            caps.formats.iter().copied().find(|f| f.is_srgb()).or(caps.formats.first().copied()).ok_or_else(|| {
                RenderError::Unsupported(format!("presenting to this surface on {}", self.gpu.describe()))
            })?;
        let copy = caps.usages.contains(wgpu::TextureUsages::COPY_DST);
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | if copy { wgpu::TextureUsages::COPY_DST } else { wgpu::TextureUsages::empty() };
        let config = wgpu::SurfaceConfiguration {
            usage,
            format,
            color_space: wgpu::SurfaceColorSpace::Auto,
            width: size.x.max(1),
            height: size.y.max(1),
            present_mode: present_mode.wgpu(&caps.present_modes),
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes.first().copied().unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: Vec::new(),
        };
        if size.x > 0 && size.y > 0 {
            surface.configure(&self.gpu.device, &config);
        }
        tracing::info!(?format, present_mode = ?config.present_mode, copy, "window surface configured");
        Ok(self.insert_window(Window {
            surface: Some(WindowSurface { surface, config, copy }),
            size,
            format,
            image: None,
        }))
    }

    /// Adds a window with no surface: its views are composed into an image
    /// of `size` that [`Renderer::read_window`] reads (tests, screenshots
    /// on machines without a display).
    pub fn add_offscreen_window(&mut self, size: UVec2) -> WindowId {
        let size = self.clamp_window_size(size);
        self.insert_window(Window { surface: None, size, format: OFFSCREEN_FORMAT, image: None })
    }

    /// A window is never larger than the device's largest texture (a
    /// surface or image beyond it would be a validation error).
    fn clamp_window_size(&self, size: UVec2) -> UVec2 {
        size.min(UVec2::splat(self.gpu.device.limits().max_texture_dimension_2d))
    }

    fn insert_window(&mut self, window: Window) -> WindowId {
        // Never reused, so a view shown in a removed window stays hidden.
        let id = WindowId(self.next_window);
        self.next_window += 1;
        self.windows.insert(id, window);
        id
    }

    /// The window was resized (0 × 0 when minimised: its views are skipped
    /// until it has a size again).
    pub fn resize_window(&mut self, id: WindowId, size: UVec2) -> Result<(), RenderError> {
        let size = self.clamp_window_size(size);
        let window = self.windows.get_mut(&id).ok_or(RenderError::NoSuchWindow(id))?;
        window.size = size;
        if let Some(surface) = &mut window.surface
            && size.x > 0
            && size.y > 0
        {
            surface.config.width = size.x;
            surface.config.height = size.y;
            surface.surface.configure(&self.gpu.device, &surface.config);
        }
        Ok(())
    }

    /// Shows `view`'s image in `rect` of `window` without changing its size:
    /// for views the renderer creates itself, such as a view's sun-shadow
    /// cascades ([`Renderer::sun_cascades`]; a depth-only view is shown as
    /// grey, near white). A registered view is better shown with
    /// [`crate::ViewDesc::shown_in`], which also sizes it to the rectangle.
    pub fn show_in_window(&mut self, view: ViewId, window: WindowId, rect: WindowRect) -> Result<(), RenderError> {
        if !self.windows.contains_key(&window) {
            return Err(RenderError::NoSuchWindow(window));
        }
        self.shown_views.insert(view, (window, rect));
        Ok(())
    }

    /// Stops showing a view given to [`Renderer::show_in_window`].
    pub fn hide_from_window(&mut self, view: ViewId) {
        self.shown_views.remove(&view);
    }

    /// Removes a window; views shown in it are no longer rendered.
    pub fn remove_window(&mut self, id: WindowId) -> Result<(), RenderError> {
        self.shown_views.retain(|_, (window, _)| *window != id);
        self.windows.remove(&id).map(|_| ()).ok_or(RenderError::NoSuchWindow(id))
    }

    /// A window's size in pixels.
    pub fn window_size(&self, id: WindowId) -> Option<UVec2> {
        self.windows.get(&id).map(|w| w.size)
    }

    /// What was composed into the window last (what was presented), as an
    /// image (waits for the GPU).
    pub fn read_window(&self, id: WindowId) -> Result<image::RgbaImage, RenderError> {
        let window = self.windows.get(&id).ok_or(RenderError::NoSuchWindow(id))?;
        let image = window.image.as_ref().ok_or(RenderError::NothingPresented(id))?;
        Ok(self.gpu.read_rgba8(image)?)
    }

    /// The size a view shown in a window has this frame: `None` when it is
    /// not shown in one, `Some(None)` when the window is minimised or gone.
    pub(super) fn shown_size(&self, shown: Option<(WindowId, WindowRect)>) -> Option<Option<UVec2>> {
        let (window, rect) = shown?;
        let size = self.windows.get(&window).map(|w| w.size).filter(|s| s.x > 0 && s.y > 0);
        Some(size.map(|size| rect.pixels(size).1))
    }

    /// Composes every window with a size from the views shown in it that
    /// rendered this frame (the others keep the window's clear colour),
    /// then presents the ones with a surface. Returns how many were
    /// presented (or composed, for offscreen windows).
    pub(super) fn present_windows(&mut self, rendered: &[ViewId], warnings: &mut Vec<FrameWarning>) -> usize {
        if self.windows.is_empty() {
            return 0;
        }
        let _span = info_span!("present", windows = self.windows.len()).entered();
        let device = self.gpu.device.clone();
        let mut shown: Vec<(WindowId, WindowRect, ViewId)> = self
            .views
            .entries
            .iter()
            .filter_map(|(id, entry)| entry.shown.map(|(window, rect)| (window, rect, *id)))
            .chain(self.shown_views.iter().map(|(id, (window, rect))| (*window, *rect, *id)))
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
                let image = device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("window image"),
                    size: wgpu::Extent3d { width: size.x, height: size.y, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                    view_formats: &[],
                });
                if let Some(window) = self.windows.get_mut(&id) {
                    window.image = Some(image);
                }
            }
            // A view's display image, or the depth of a depth-only view.
            let views: Vec<(WindowRect, &wgpu::TextureView, bool)> = shown
                .iter()
                .filter(|(window, ..)| *window == id)
                .filter_map(|(_, rect, view)| {
                    let targets = self.gpu_views.get(view)?.targets.as_ref()?;
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
                self.gpu.queue.submit([encoder.finish()]);
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
                    self.gpu.queue.submit([encoder.finish()]);
                    self.gpu.queue.present(frame);
                    presented += 1;
                }
                other => {
                    // Lost, outdated, timed out or occluded: configure again
                    // and present next frame; the frame's work stands.
                    self.gpu.queue.submit([encoder.finish()]);
                    surface.surface.configure(&device, &surface.config);
                    let reason = format!("the surface was not ready ({}); reconfigured", surface_state(&other));
                    warn!(window = %id, "{reason}");
                    warnings.push(FrameWarning::WindowSkipped { window: id, reason });
                }
            }
        }
        presented
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
