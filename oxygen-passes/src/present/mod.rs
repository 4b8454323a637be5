//! Presenting: the shader the renderer's window compositor draws each view
//! into its window rectangle with. The compositor itself (its bind group
//! layouts, a pipeline per window format, the surfaces) belongs to the
//! windows in the root crate; its shader is here, with every other, so that
//! the shader registry composes and validates it.

/// The window composition shader, composed from `present/compose_window.wgsl`:
/// the vertex entry point `vs` (a full-screen triangle drawn into a view's
/// rectangle through the viewport) and the fragment entry points
/// `fs_color` (group 0: a filterable `texture_2d<f32>` at binding 0, a
/// filtering sampler at binding 1) and `fs_depth` (group 0: an unfilterable
/// `texture_2d<f32>` at binding 0 holding reverse-Z depth, shown as grey).
pub fn compose_window_wgsl() -> String {
    crate::shaders::COMPOSE_WINDOW.source()
}
