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
pub(crate) const SHADOW_ATLAS_FORMAT: wgpu::TextureFormat = oxygen_gpu::ViewTargets::DEPTH_FORMAT;

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
            let layers = atlas_layer_count(layers, true);
            *slot = Some(oxygen_gpu::texture_2d(
                device,
                "local shadow atlas",
                wgpu::Extent3d { width: resolution, height: resolution, depth_or_array_layers: layers },
                1,
                SHADOW_ATLAS_FORMAT,
                wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC,
            ));
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

/// Layers of an array texture sampled as an array and holding `used`
/// layers: at least 2, and never a multiple of 6 when the layers are square.
/// wgpu's GL backend picks a texture's GL target from its descriptor
/// (`TEXTURE_2D` for 1 layer, a cube map (array) for a square one with 6n
/// layers, `TEXTURE_2D_ARRAY` otherwise), and a `D2Array` view of the first
/// two cannot be bound there: such an array reads back as nothing on GL
/// (`tests/gl_layer_experiments.rs`). The extra layer is never used.
pub fn array_layer_count(used: u32, square: bool) -> u32 {
    let layers = used.max(2);
    if square && layers.is_multiple_of(6) { layers + 1 } else { layers }
}

fn atlas_layer_count(tiles: u32, square: bool) -> u32 {
    array_layer_count(tiles, square)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arrays_never_take_a_shape_gl_would_not_sample_as_an_array() {
        for used in 0..40 {
            let layers = array_layer_count(used, true);
            assert!(layers >= used.max(2) && !layers.is_multiple_of(6), "{used} tiles -> {layers} layers");
            assert_eq!(array_layer_count(used, false), used.max(2));
        }
        assert_eq!(array_layer_count(1, true), 2);
        assert_eq!(array_layer_count(6, true), 7);
        assert_eq!(array_layer_count(7, true), 7);
    }
}
