//! The local-light shadow atlas: every spot shadow map and every cube face of
//! a point light's shadow of the frame, gathered as the layers of one depth
//! array, so the shading pass binds one texture however many local lights
//! cast.
//!
//! Local shadow views render depth into their own targets (a view owns its
//! targets). A depth texture may be copied only as a whole subresource, and
//! one layer of an array is one: each map is copied into its tile's layer,
//! with no draw and no format conversion. The shading pass samples a layer
//! through the comparison sampler, with the same PCF as the cascades, on
//! every backend (GL included: `texture_depth_2d_array` with comparison is
//! `sampler2DArrayShadow` there). All maps of a frame share one resolution
//! (`register_local_shadows` registers them so). Several views sampling the
//! same maps in one frame copy each map once.

use std::sync::Mutex;

use oxygen_core::ViewId;

use crate::MAX_SHADOW_TILES;

/// Format of the atlas layers: the shadow views' depth format.
pub const SHADOW_ATLAS_FORMAT: wgpu::TextureFormat = oxygen_core::ViewTargets::DEPTH_FORMAT;

/// The atlas texture, kept across frames and regrown when the tile count or
/// resolution changes.
#[derive(Default)]
pub(crate) struct ShadowAtlas {
    state: Mutex<Option<AtlasState>>,
}

struct AtlasState {
    texture: wgpu::Texture,
    /// Per layer: the shadow view and frame its depth was copied from.
    copied: [Option<(ViewId, u64)>; MAX_SHADOW_TILES],
}

impl ShadowAtlas {
    /// Copies `maps` (shadow view and its depth texture, by tile) of frame
    /// `frame` into the layers of the atlas, skipping layers already copied
    /// from the same view this frame, and returns its array view. Fails,
    /// naming the sizes, when the maps differ in size.
    pub(crate) fn fill(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        maps: &[Option<(ViewId, &wgpu::Texture)>; MAX_SHADOW_TILES],
        frame: u64,
    ) -> Result<wgpu::TextureView, String> {
        let mut sizes = maps.iter().flatten().map(|(_, t)| (t.width(), t.height()));
        let (width, height) = sizes.next().unwrap_or((1, 1));
        if let Some(other) = sizes.find(|s| *s != (width, height)) {
            return Err(format!(
                "local-light shadow maps must share one size to share the atlas ({width}x{height} and {}x{})",
                other.0, other.1
            ));
        }
        let layers = maps.iter().rposition(Option::is_some).map_or(1, |last| last as u32 + 1);
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        let fits = state.as_ref().is_some_and(|s| {
            let t = &s.texture;
            t.width() == width && t.height() == height && t.depth_or_array_layers() >= layers
        });
        if !fits {
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("local shadow atlas"),
                size: wgpu::Extent3d { width, height, depth_or_array_layers: layers },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: SHADOW_ATLAS_FORMAT,
                usage: wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            });
            *state = Some(AtlasState { texture, copied: [None; MAX_SHADOW_TILES] });
        }
        // Just created or reused: either way an atlas of this size exists now.
        let state = state.as_mut().expect("atlas exists");
        for (layer, map) in maps.iter().enumerate() {
            let Some((view, map)) = map else { continue };
            if state.copied[layer] == Some((*view, frame)) {
                continue;
            }
            state.copied[layer] = Some((*view, frame));
            encoder.copy_texture_to_texture(
                map.as_image_copy(),
                wgpu::TexelCopyTextureInfo {
                    texture: &state.texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d { x: 0, y: 0, z: layer as u32 },
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            );
        }
        Ok(atlas_view(&state.texture))
    }
}

/// The array view of an atlas texture.
pub(crate) fn atlas_view(texture: &wgpu::Texture) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    })
}
