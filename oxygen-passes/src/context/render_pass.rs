//! The `RenderPass` trait.

use crate::{CommandRecorder, PassError, RenderContext};

/// A pass of a view's render graph.
///
/// A graph creates its passes (plain structs, cheap to build each frame) and
/// awaits them in order: `MeshPass::depth_pre_pass().run(ctx, rec).await?`.
/// `run` is async because a pass awaits what it does not have yet — a
/// pipeline still compiling on another thread, another view's output — and
/// meanwhile its thread records other views.
#[allow(async_fn_in_trait)] // A view's future is created and polled on one thread; no Send bound is wanted.
pub trait RenderPass {
    /// Name for logs and errors.
    fn name(&self) -> &'static str;

    /// Records the pass.
    async fn run(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError>;
}
