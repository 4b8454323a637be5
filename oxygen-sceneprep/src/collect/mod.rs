//! Collection: what the scene contributes to this frame.
//!
//! * [`frame_phase`] runs once per frame and is shared by every view: world
//!   and normal matrices, world bounds of each renderable, and the gated
//!   light lists, and the frame's shadow casters. Views never traverse the
//!   scene graph again.
//! * [`render_origin`] decides, once per frame, the world position the
//!   frame phase rebases what goes to the GPU on.
//! * [`view_phase`] runs per view: pre-filter, visibility cull, and the
//!   [`RenderItem`]s finalization turns into draws.

pub mod frame_phase;
pub mod render_origin;
pub mod view_phase;

pub use frame_phase::{
    FrameCollection, LocalShadowCaster, LocalShadowKind, RenderableEntry, SkippedNode, SubmeshEntry,
};
pub use render_origin::RenderOrigin;
pub(crate) use view_phase::RenderItem;
pub use view_phase::{CullBound, Instancing, ViewFilter, ViewPrepOptions};
