//! The overlay layer's CPU side: what tools draw over a view, as shapes,
//! turned into one list of vertices per view and frame.
//!
//! An [`Overlay`] belongs to one view. Its [`Canvas`]es take
//! **screen-space** shapes in the view's pixels (rectangles, images, lines
//! with a width, circles, rings and arcs, text) and **world-space** debug
//! shapes (lines, boxes, spheres, arrows, a view's frustum, labels, an
//! editor grid), each depth-tested against the view's surfaces or drawn on
//! top ([`DepthMode`]). The immediate canvas is cleared after each frame
//! its view renders (a view that does not render keeps it, and what is
//! drawn on it again adds up), the retained one keeps its shapes until
//! told.
//!
//! Each frame the overlay pass (`oxygen_passes::OverlayPass`) asks for
//! [`Overlay::tessellate`] with the view's camera ([`OverlayView`]): every
//! shape becomes triangles of [`OverlayVertex`] in clip space, world
//! shapes projected in `f64` on the CPU (so they stay exact a million units
//! from the origin), lines and arcs carrying the distances their fragment
//! shader turns into anti-aliased coverage, text and images carrying their
//! place in one RGBA atlas ([`Overlay::atlas`]). One vertex buffer, one
//! texture, one draw: whatever the number of shapes.
//!
//! A selection outline ([`Outline`]) is drawn around chosen nodes, found in
//! the view's instance ids (its labels, or an ID render where it draws
//! none) by jump flooding on the GPU.
//!
//! Data flows one way: canvas calls → shapes → vertices (and atlas texels)
//! → the GPU. Nothing here touches the GPU.

mod atlas;
mod canvas;
mod tessellate;
mod text;

pub use atlas::{ATLAS_SIZE, Atlas};
pub use canvas::{Canvas, DepthMode, ImageId, Outline, Overlay, OverlayError, Rgba, frustum_corners};
pub use tessellate::{OverlayVertex, OverlayView, VertexKind};
pub use text::Font;
