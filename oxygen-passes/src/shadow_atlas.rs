//! The local-light shadow atlas: every spot shadow map and every cube face of
//! a point light's shadow of the frame, as the layers of one depth array, so
//! the forward pass binds one texture however many local lights cast.
//!
//! Each local shadow view renders its depth straight into its layer (a
//! single-layer view of the array as its depth attachment): nothing is copied
//! and no convention ties views to tiles, because the renderer gives the view
//! of tile `t` layer `t`. The forward pass samples a layer through the
//! comparison sampler, with the same PCF as the cascades. All tiles share one
//! resolution.

use std::sync::Mutex;

/// Format of the atlas layers: the shadow views' depth format.
pub const SHADOW_ATLAS_FORMAT: wgpu::TextureFormat = oxygen_core::ViewTargets::DEPTH_FORMAT;

/// The atlas texture, kept across frames and regrown when the tile count or
/// resolution grows.
#[derive(Default)]
pub(crate) struct ShadowAtlas {
    texture: Mutex<Option<wgpu::Texture>>,
}

impl ShadowAtlas {
    /// An atlas of at least `layers` layers of `resolution`² texels (the
    /// same texture as last frame when it still fits).
    pub(crate) fn ensure(&self, device: &wgpu::Device, resolution: u32, layers: u32) -> wgpu::Texture {
        let mut slot = self.texture.lock().unwrap_or_else(|e| e.into_inner());
        let fits = slot.as_ref().is_some_and(|t| t.width() == resolution && t.depth_or_array_layers() >= layers);
        if !fits {
            *slot = Some(device.create_texture(&wgpu::TextureDescriptor {
                label: Some("local shadow atlas"),
                size: wgpu::Extent3d { width: resolution, height: resolution, depth_or_array_layers: layers.max(1) },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: SHADOW_ATLAS_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            }));
        }
        // Either it fitted or it was just replaced.
        slot.clone().expect("atlas exists")
    }
}

/// The array view of an atlas texture.
pub(crate) fn atlas_view(texture: &wgpu::Texture) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    })
}
