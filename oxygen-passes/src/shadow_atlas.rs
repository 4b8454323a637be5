//! The local-light shadow atlas: every spot shadow map and every cube face of
//! a point light's shadow of the frame, gathered as the layers of one depth
//! array, so the shading pass binds one texture however many local lights
//! cast.
//!
//! Local shadow views render depth into their own targets (a view owns its
//! targets); each map is then drawn into its tile's layer (a full-screen
//! triangle writing `frag_depth` from `textureLoad` of the map: an exact
//! f32 copy). A draw rather than `copy_texture_to_texture` because wgpu's GL
//! backend copies through a colour attachment and `glCopyTexSubImage`, which
//! silently does nothing for depth (tests/gl_layer_experiments.rs). The
//! shading pass samples a layer through the comparison sampler, with the
//! same PCF as the cascades, on every backend (`texture_depth_2d_array` with
//! comparison is `sampler2DArrayShadow` on GL). All maps of a frame share one
//! resolution (`register_local_shadows` registers them so). Several views
//! sampling the same maps in one frame copy each map once.
//!
//! The atlas never has 1 layer nor a multiple of 6: wgpu's GL backend fixes
//! a texture's GL target at creation from its layer count (1 layer:
//! `TEXTURE_2D`; square with 6n layers: a cube map) and such a texture
//! cannot be sampled as a 2D array there ([`atlas_layer_count`]).

use std::sync::{Mutex, OnceLock};

use oxygen_core::ViewId;

use crate::MAX_SHADOW_TILES;

/// Format of the atlas layers: the shadow views' depth format.
pub const SHADOW_ATLAS_FORMAT: wgpu::TextureFormat = oxygen_core::ViewTargets::DEPTH_FORMAT;

/// The atlas texture, kept across frames and regrown when the tile count or
/// resolution changes.
#[derive(Default)]
pub(crate) struct ShadowAtlas {
    state: Mutex<Option<AtlasState>>,
    blit: OnceLock<DepthBlit>,
}

struct AtlasState {
    texture: wgpu::Texture,
    /// Per layer: the shadow view and frame its depth was drawn from.
    copied: [Option<(ViewId, u64)>; MAX_SHADOW_TILES],
}

impl ShadowAtlas {
    /// Draws `maps` (shadow view and its depth texture, by tile) of frame
    /// `frame` into the layers of the atlas, skipping layers already drawn
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
        let tiles = maps.iter().rposition(Option::is_some).map_or(1, |last| last as u32 + 1);
        let layers = atlas_layer_count(tiles, width == height);
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
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
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
            let blit = self.blit.get_or_init(|| DepthBlit::new(device));
            blit.draw(device, encoder, map, &layer_view(&state.texture, layer as u32));
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

/// Layers of an atlas holding `tiles` tiles: at least 2, and never a multiple
/// of 6 when the layers are square. wgpu's GL backend picks a texture's GL
/// target from its descriptor (`TEXTURE_2D` for 1 layer, a cube map or cube
/// map array for a square one with 6n layers, `TEXTURE_2D_ARRAY` otherwise)
/// and a `D2Array` view of the first two cannot be bound there: a 1-layer or
/// 6-layer atlas reads back as nothing but its clear value on GL.
pub(crate) fn atlas_layer_count(tiles: u32, square: bool) -> u32 {
    let layers = tiles.max(2);
    if square && layers.is_multiple_of(6) { layers + 1 } else { layers }
}

/// A single-layer view of `layer`, as a render attachment.
fn layer_view(texture: &wgpu::Texture, layer: u32) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some("local shadow atlas layer"),
        dimension: Some(wgpu::TextureViewDimension::D2),
        base_array_layer: layer,
        array_layer_count: Some(1),
        ..Default::default()
    })
}

const DEPTH_BLIT_WGSL: &str = r#"
// The depth map, read as unfilterable floats: GLSL has no textureLoad of a
// depth texture binding, but texelFetch of a float one reads depth fine.
@group(0) @binding(0) var map: texture_2d<f32>;
@vertex
fn vs(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}
@fragment
fn fs(@builtin(position) position: vec4<f32>) -> @builtin(frag_depth) f32 {
    return textureLoad(map, vec2<i32>(position.xy), 0).r;
}
"#;

/// Draws a depth map into an atlas layer of the same size, texel for texel.
struct DepthBlit {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
}

impl DepthBlit {
    fn new(device: &wgpu::Device) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadow atlas blit"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            }],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shadow atlas blit"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("shadow atlas blit"),
            source: wgpu::ShaderSource::Wgsl(DEPTH_BLIT_WGSL.into()),
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("shadow atlas blit"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: SHADOW_ATLAS_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[],
            }),
            multiview_mask: None,
            cache: None,
        });
        DepthBlit { layout, pipeline }
    }

    fn draw(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        map: &wgpu::Texture,
        target: &wgpu::TextureView,
    ) {
        let source = map.create_view(&wgpu::TextureViewDescriptor {
            label: Some("shadow map as floats"),
            aspect: wgpu::TextureAspect::DepthOnly,
            ..Default::default()
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shadow atlas blit"),
            layout: &self.layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&source) }],
        });
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("shadow atlas blit"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: target,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
}

#[cfg(test)]
mod tests {
    use super::atlas_layer_count;

    #[test]
    fn atlas_layers_are_never_one_nor_a_multiple_of_six() {
        assert_eq!(atlas_layer_count(1, true), 2);
        assert_eq!(atlas_layer_count(2, true), 2);
        assert_eq!(atlas_layer_count(6, true), 7);
        assert_eq!(atlas_layer_count(7, true), 7);
        assert_eq!(atlas_layer_count(12, true), 13);
        assert_eq!(atlas_layer_count(6, false), 6);
    }
}
