//! The frame context of one view's passes: what a pass reads
//! ([`RenderContext`]: the resolved view, the prepared frame, the bindless
//! heap, the targets, the shared pipelines and lighting), what it may read
//! from other views ([`ViewInputs`], awaited through [`FrameProgress`]),
//! where it records ([`CommandRecorder`]) and the [`RenderPass`] trait every
//! pass implements. The passes themselves live in the folders of their
//! subject (`mesh`, `post`, `reference`); this folder is what they share.

mod draw_path;
mod error;
mod inputs;
mod progress;
mod recorder;
mod render_context;
mod render_pass;

pub use draw_path::DrawPath;
pub use error::PassError;
pub use inputs::{LinkedImage, LinkedView, LocalShadowsInput, OutputKind, ProbeCubeInput, ShadowMapInput, ViewInputs};
pub use progress::FrameProgress;
pub use recorder::{CommandRecorder, RecordStats};
pub use render_context::{PrePassEstimate, RenderContext, Shading};
pub use render_pass::RenderPass;
