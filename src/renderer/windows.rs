//! Windows, a subsystem of the renderer: the windows views are shown in
//! (a surface, or an offscreen image), which view is shown where, and the
//! `Renderer` methods about windows. The present step (`present.rs`)
//! composes and presents them; `crate::windows` describes the model.

use std::collections::BTreeMap;

use glam::UVec2;
use oxygen_core::ViewId;

use super::present::Compositor;
use super::{RenderError, Renderer};
use crate::windows::{PresentMode, WindowId, WindowRect};

/// The format of an offscreen window's image.
const OFFSCREEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// A window surface and how it is configured.
pub(crate) struct WindowSurface {
    pub(super) surface: wgpu::Surface<'static>,
    pub(super) config: wgpu::SurfaceConfiguration,
    /// The surface texture can be a copy destination (else the views are
    /// composed a second time, straight into it).
    pub(super) copy: bool,
}

/// A window: its surface (none for an offscreen one), size and image.
pub(crate) struct Window {
    pub(super) surface: Option<WindowSurface>,
    pub(super) size: UVec2,
    pub(super) format: wgpu::TextureFormat,
    /// What was composed last, `size` large; none while the size is zero.
    pub(super) image: Option<wgpu::Texture>,
}

/// The renderer's windows and the views shown in them.
pub(crate) struct Windows {
    pub(super) windows: BTreeMap<WindowId, Window>,
    /// The next window's id (never reused, so a view shown in a removed
    /// window stays hidden).
    next: u32,
    /// Views shown with `show_in_window` (no resizing).
    pub(super) shown: BTreeMap<ViewId, (WindowId, WindowRect)>,
    pub(super) compositor: Compositor,
}

impl Windows {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        Windows { windows: BTreeMap::new(), next: 0, shown: BTreeMap::new(), compositor: Compositor::new(device) }
    }

    /// The size a view shown in a window has this frame: `None` when it is
    /// not shown in one, `Some(None)` when the window is minimised or gone.
    pub(crate) fn shown_size(&self, shown: Option<(WindowId, WindowRect)>) -> Option<Option<UVec2>> {
        let (window, rect) = shown?;
        let size = self.windows.get(&window).map(|w| w.size).filter(|s| s.x > 0 && s.y > 0);
        Some(size.map(|size| rect.pixels(size).1))
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
        let id = WindowId(self.windows.next);
        self.windows.next += 1;
        self.windows.windows.insert(id, window);
        id
    }

    /// The window was resized (0 × 0 when minimised: its views are skipped
    /// until it has a size again).
    pub fn resize_window(&mut self, id: WindowId, size: UVec2) -> Result<(), RenderError> {
        let size = self.clamp_window_size(size);
        let window = self.windows.windows.get_mut(&id).ok_or(RenderError::NoSuchWindow(id))?;
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
        if !self.windows.windows.contains_key(&window) {
            return Err(RenderError::NoSuchWindow(window));
        }
        self.windows.shown.insert(view, (window, rect));
        Ok(())
    }

    /// Stops showing a view given to [`Renderer::show_in_window`].
    pub fn hide_from_window(&mut self, view: ViewId) {
        self.windows.shown.remove(&view);
    }

    /// Removes a window; views shown in it are no longer rendered.
    pub fn remove_window(&mut self, id: WindowId) -> Result<(), RenderError> {
        self.windows.shown.retain(|_, (window, _)| *window != id);
        self.windows.windows.remove(&id).map(|_| ()).ok_or(RenderError::NoSuchWindow(id))
    }

    /// A window's size in pixels.
    pub fn window_size(&self, id: WindowId) -> Option<UVec2> {
        self.windows.windows.get(&id).map(|w| w.size)
    }

    /// What was composed into the window last (what was presented), as an
    /// image (waits for the GPU).
    pub fn read_window(&self, id: WindowId) -> Result<image::RgbaImage, RenderError> {
        let window = self.windows.windows.get(&id).ok_or(RenderError::NoSuchWindow(id))?;
        let image = window.image.as_ref().ok_or(RenderError::NothingPresented(id))?;
        Ok(self.gpu.read_rgba8(image)?)
    }
}
