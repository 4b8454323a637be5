//! Collection: what the scene contributes to this frame.
//!
//! * [`frame_phase`] runs once per frame and is shared by every view: world
//!   and normal matrices, world bounds of each renderable, and the gated
//!   light lists. Views never traverse the scene graph again.
//! * [`view_phase`] runs per view: pre-filter, visibility cull, and the
//!   [`RenderItem`]s finalization turns into draws.

pub mod frame_phase;
pub mod view_phase;

pub use frame_phase::{FrameCollection, RenderableEntry, SkippedNode, SubmeshEntry};
pub use view_phase::{CullBound, RenderItem, ViewFilter, ViewPrepOptions};
