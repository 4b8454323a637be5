//! The `RenderPass` lifecycle.

use crate::{CommandRecorder, PassError, RenderContext};

/// A pass of a view's render graph.
///
/// A render-graph factory creates its passes (plain structs, cheap to build
/// each frame) and awaits them in order:
/// `pass.prepare_resources(ctx, rec).await?; pass.execute(ctx, rec).await?;`.
/// `prepare_resources` fetches or lazily creates pipelines and anything else
/// the pass needs; `execute` records commands. Both are async so that a pass
/// may wait on resources (e.g. pipeline compilation) without blocking the
/// other views' futures.
#[allow(async_fn_in_trait)] // Futures are driven on the renderer's thread; no Send bound is wanted.
pub trait RenderPass {
    /// Name for logs and errors.
    fn name(&self) -> &'static str;

    /// Gets what `execute` will need.
    async fn prepare_resources(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError>;

    /// Records the pass.
    async fn execute(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError>;

    /// `prepare_resources`, then `execute`: what a render graph does with each pass.
    async fn run(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        self.prepare_resources(ctx, rec).await?;
        self.execute(ctx, rec).await
    }
}
