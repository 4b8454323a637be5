//! Placeholder until the depth pyramid lands (replaced by the real module).
#![allow(missing_docs)]

pub struct HizPyramid {
    view: wgpu::TextureView,
    size: (u32, u32),
}

impl HizPyramid {
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Self {
        let view = device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("hiz placeholder"),
                size: wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::R32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            })
            .create_view(&Default::default());
        HizPyramid { view, size: (width, height) }
    }
    pub fn size(&self) -> (u32, u32) {
        self.size
    }
    pub fn levels(&self) -> u32 {
        1
    }
    pub fn build(&self, _device: &wgpu::Device, _encoder: &mut wgpu::CommandEncoder, _depth: &wgpu::TextureView) {}
    pub fn view(&self) -> &wgpu::TextureView {
        &self.view
    }
}

pub const HIZ_TEST_WGSL: &str = "fn hiz_visible(pyramid: texture_2d<f32>, levels: u32, size: vec2<u32>, view_projection: mat4x4<f32>, box_min: vec3<f32>, box_max: vec3<f32>) -> bool { return true; }\n";
