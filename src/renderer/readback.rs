//! Reading results back: the `Renderer` methods that read a view's draws,
//! images and prepared frame (window, probe and environment readbacks sit
//! with their subsystems).

use oxygen_core::ViewId;
use oxygen_sceneprep::{DrawMetadata, PassMask, PreparedSceneFrame};

use super::{RenderError, Renderer};
#[cfg(doc)]
use crate::RendererOptions;

impl Renderer {
    /// Every draw `id` drew last frame, per partition mask in canonical order
    /// ([`oxygen_sceneprep::canonical_draws`]), whichever path produced
    /// them: on a GPU visibility path the GPU's draws are read back (waits
    /// for the GPU) and joined with the CPU's transparent ones. How tests
    /// compare the GPU paths with the CPU reference.
    pub fn view_draws(&self, id: impl Into<ViewId>) -> Result<Vec<(PassMask, Vec<DrawMetadata>)>, RenderError> {
        let id = id.into();
        let frame = self.prepared_frame(id).ok_or(RenderError::NoSuchView(id))?;
        let mut all = frame.canonical_draws();
        if let Some(visibility) = &self.visibility.gpu {
            all.extend(visibility.read_draws(&self.gpu, &self.heap, frame)?);
        }
        Ok(oxygen_sceneprep::canonical_draws(all))
    }

    /// The view's colour target as an image (waits for the GPU).
    pub fn read_color(&self, id: impl Into<ViewId>) -> Result<image::RgbaImage, RenderError> {
        let id = id.into();
        let color = self.color_targets(id)?;
        let display = color.color.as_ref().ok_or(RenderError::NoDisplayTarget(id))?;
        Ok(self.gpu.read_rgba8(display)?)
    }

    /// Reads back a rendered view's linear HDR target (what shading wrote,
    /// before the tone map), NaN and infinities included. Fails with
    /// [`RenderError::HdrNotWritten`] when the view's last frame tone-mapped
    /// in the shading pass (see [`RendererOptions::keep_hdr`]).
    pub fn read_hdr(&self, id: impl Into<ViewId>) -> Result<oxygen_gpu::HdrImage, RenderError> {
        let id = id.into();
        let color = self.color_targets(id)?;
        if color.hdr_layer != 0 {
            return Err(RenderError::NoDisplayTarget(id));
        }
        if !self.targets.get(id).and_then(|v| v.holds).is_some_and(|h| h.hdr_written) {
            return Err(RenderError::HdrNotWritten(id));
        }
        Ok(self.gpu.read_hdr_texels(&color.hdr)?)
    }

    /// The view's prepared frame from the last `render_frame`.
    pub fn prepared_frame(&self, id: impl Into<ViewId>) -> Option<&PreparedSceneFrame> {
        let id = id.into();
        self.prep.frames().iter().find(|f| f.view_id() == id)
    }
}
