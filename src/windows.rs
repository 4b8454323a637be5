//! Windows: where views are shown. A window is a window surface (or, for
//! tests and screenshots, an offscreen image of a window's size) that views
//! are shown in, each in a rectangle of it: one view full-window,
//! split-screen, a 2 × 2 editor layout, a picture-in-picture.
//!
//! Each frame, after every view has been recorded and submitted, the
//! renderer composes each window: it draws every view shown in it into its
//! rectangle of the window's image, copies that image into the surface
//! texture acquired for the frame and presents it. The image stays readable
//! ([`crate::Renderer::read_window`]): what was presented last.
//!
//! Window life: a view shown in a window follows it — its target and its
//! aspect ratio are the rectangle's size in pixels (the resolver's viewport
//! is replaced, the projection widened or narrowed,
//! [`oxygen_core::ResolvedView::with_viewport`]). A window of zero size
//! (minimised) skips its views and presents nothing. A surface that is lost
//! or outdated is reconfigured and the frame goes on without presenting
//! (said in [`crate::FrameWarning::WindowSkipped`]); nothing panics.

use glam::UVec2;

/// A window the renderer presents to ([`crate::Renderer::add_window`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct WindowId(pub(crate) u32);

impl std::fmt::Display for WindowId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "window#{}", self.0)
    }
}

/// A rectangle of a window, in fractions of its width and height from its
/// top-left corner, so that it follows the window when it is resized.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowRect {
    /// Left edge, 0 to 1.
    pub x: f32,
    /// Top edge, 0 to 1.
    pub y: f32,
    /// Width, 0 to 1.
    pub width: f32,
    /// Height, 0 to 1.
    pub height: f32,
}

impl WindowRect {
    /// The whole window.
    pub const FULL: WindowRect = WindowRect { x: 0.0, y: 0.0, width: 1.0, height: 1.0 };

    /// Cell (`column`, `row`) of a grid of `columns` × `rows` equal cells.
    pub fn grid(columns: u32, rows: u32, column: u32, row: u32) -> WindowRect {
        let (columns, rows) = (columns.max(1) as f32, rows.max(1) as f32);
        WindowRect { x: column as f32 / columns, y: row as f32 / rows, width: 1.0 / columns, height: 1.0 / rows }
    }

    /// Its origin and size in pixels of a window of `size`, clamped to the
    /// window; whole pixels, at least 1 × 1 when the window is not empty.
    /// Non-finite fractions count as 0.
    pub fn pixels(&self, size: UVec2) -> (UVec2, UVec2) {
        let clamp = |v: f32| if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 };
        let (w, h) = (size.x as f32, size.y as f32);
        let x0 = (clamp(self.x) * w).round() as u32;
        let y0 = (clamp(self.y) * h).round() as u32;
        let x1 = (clamp(self.x + self.width) * w).round() as u32;
        let y1 = (clamp(self.y + self.height) * h).round() as u32;
        let origin = UVec2::new(x0.min(size.x.saturating_sub(1)), y0.min(size.y.saturating_sub(1)));
        let extent = UVec2::new(x1.saturating_sub(origin.x).max(1), y1.saturating_sub(origin.y).max(1));
        (origin, extent.min(size - origin))
    }
}

/// How a window's frames reach the screen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum PresentMode {
    /// Wait for the display's vertical blank; no tearing, never drops a
    /// frame. Every adapter has it: the default.
    #[default]
    Fifo,
    /// The newest frame replaces a waiting one at the vertical blank: low
    /// latency without tearing. Falls back to `Fifo` where missing.
    Mailbox,
    /// Present at once; may tear. Falls back to `Fifo` where missing.
    Immediate,
}

impl PresentMode {
    /// wgpu's mode, or `Fifo` when `supported` lacks it.
    pub(crate) fn wgpu(self, supported: &[wgpu::PresentMode]) -> wgpu::PresentMode {
        let wanted = match self {
            PresentMode::Fifo => wgpu::PresentMode::Fifo,
            PresentMode::Mailbox => wgpu::PresentMode::Mailbox,
            PresentMode::Immediate => wgpu::PresentMode::Immediate,
        };
        if supported.contains(&wanted) { wanted } else { wgpu::PresentMode::Fifo }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rects_cover_the_window_without_gaps_or_overlap() {
        let size = UVec2::new(641, 479);
        let mut covered = vec![0u8; (size.x * size.y) as usize];
        for row in 0..2 {
            for column in 0..2 {
                let (origin, extent) = WindowRect::grid(2, 2, column, row).pixels(size);
                for y in origin.y..origin.y + extent.y {
                    for x in origin.x..origin.x + extent.x {
                        covered[(y * size.x + x) as usize] += 1;
                    }
                }
            }
        }
        assert!(covered.iter().all(|&c| c == 1), "a 2×2 grid covers every pixel once");
    }

    #[test]
    fn degenerate_rects_stay_inside_the_window() {
        let size = UVec2::new(100, 50);
        for rect in [
            WindowRect { x: f32::NAN, y: 2.0, width: -1.0, height: f32::INFINITY },
            WindowRect { x: 0.99, y: 0.99, width: 0.5, height: 0.5 },
            WindowRect { x: 1.0, y: 1.0, width: 0.0, height: 0.0 },
        ] {
            let (origin, extent) = rect.pixels(size);
            assert!(extent.x >= 1 && extent.y >= 1, "{rect:?}");
            assert!(origin.x + extent.x <= size.x && origin.y + extent.y <= size.y, "{rect:?}: {origin} {extent}");
        }
    }

    #[test]
    fn window_ids_print_with_their_number() {
        assert_eq!(WindowId(7).to_string(), "window#7");
    }

    #[test]
    fn unsupported_present_modes_fall_back_to_fifo() {
        let only_fifo = [wgpu::PresentMode::Fifo];
        assert_eq!(PresentMode::Mailbox.wgpu(&only_fifo), wgpu::PresentMode::Fifo);
        assert_eq!(PresentMode::Immediate.wgpu(&[wgpu::PresentMode::Immediate]), wgpu::PresentMode::Immediate);
    }
}
