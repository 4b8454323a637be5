//! The tone-map step's effects, each a knob of [`crate::TonemapPass`] that
//! costs nothing when off: a bloom chain ([`Bloom`]: the HDR image halved
//! level by level, blurred back up and mixed into the image) and automatic
//! exposure ([`AutoExposure`]: a histogram of the image's luminance, the
//! exposure that brings its mean to a key, approached over time). The
//! shaders are in `effects.wgsl`. Both change the picture away from the
//! scene's radiance, so the accuracy atlas and the reference comparisons
//! leave them off (their default).
//!
//! Each view with an effect keeps its buffers across frames: the bloom
//! chain (half the view's size, `levels` levels of `Rgba16Float`), the
//! histogram (256 words) and its exposure (four floats).

use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

use oxygen_core::ViewId;
use oxygen_gpu::bindings::{self, LayoutEntries};

use crate::PassError;

/// A bloom chain: light spreading around bright parts of the image, as a
/// lens and the eye scatter it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bloom {
    /// How much of the blurred image is mixed into the picture, 0 to 1;
    /// 0.04 by default. The mix conserves energy: what the bloom adds
    /// around a bright pixel it takes from the pixel.
    pub intensity: f32,
    /// Levels of the chain, 1 to [`Bloom::MAX_LEVELS`] (fewer when the
    /// view is too small to halve that often); 6 by default. Each level
    /// doubles the blur's reach.
    pub levels: u32,
    /// The upsampling tent's radius in texels of the level read, 0.5 to 4;
    /// 1 by default.
    pub radius: f32,
}

impl Bloom {
    /// Intensity 0.04, 6 levels, radius 1.
    pub const DEFAULT: Bloom = Bloom { intensity: 0.04, levels: 6, radius: 1.0 };
    /// Most levels a chain has.
    pub const MAX_LEVELS: u32 = 10;

    /// Why these settings cannot be used, if they cannot.
    pub fn problem(&self) -> Option<String> {
        if !(self.intensity.is_finite() && (0.0..=1.0).contains(&self.intensity)) {
            return Some(format!("bloom intensity {} is not between 0 and 1", self.intensity));
        }
        if !(1..=Self::MAX_LEVELS).contains(&self.levels) {
            return Some(format!("bloom takes 1 to {} levels, not {}", Self::MAX_LEVELS, self.levels));
        }
        if !(self.radius.is_finite() && (0.5..=4.0).contains(&self.radius)) {
            return Some(format!("bloom radius {} is not between 0.5 and 4 texels", self.radius));
        }
        None
    }
}

impl Default for Bloom {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Exposure chosen from the image: the mean log2 luminance of the pixels
/// between two percentiles is brought to `key`, and the view's exposure
/// moves toward that at a speed per second (faster toward a darker
/// picture, as an eye closes faster than it opens). The graph's fixed
/// exposure multiplies the result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutoExposure {
    /// The luminance the mean is brought to; 0.18 (middle grey) by default.
    pub key: f32,
    /// Stops added to the exposure found; 0 by default.
    pub compensation: f32,
    /// The range of log2 luminance the histogram covers (what lies outside
    /// counts at its ends); −10 to 10 by default.
    pub log2_luminance: (f32, f32),
    /// The range of log2 exposure the result stays in; −12 to 12 by default.
    pub log2_exposure: (f32, f32),
    /// The pixels measured: the fraction of the lit ones from the darkest
    /// left out and up to which the brightest are left out; 0.1 and 0.9
    /// by default.
    pub percentiles: (f32, f32),
    /// Rate per second at which the exposure falls toward a target below
    /// it (the picture brightened); 3 by default.
    pub speed_brighter: f32,
    /// Rate per second at which it rises toward a target above it (the
    /// picture darkened); 1 by default. A rate of 0 holds the first frame's
    /// exposure.
    pub speed_darker: f32,
}

impl AutoExposure {
    /// Middle grey, no compensation, the default ranges and speeds.
    pub const DEFAULT: AutoExposure = AutoExposure {
        key: 0.18,
        compensation: 0.0,
        log2_luminance: (-10.0, 10.0),
        log2_exposure: (-12.0, 12.0),
        percentiles: (0.1, 0.9),
        speed_brighter: 3.0,
        speed_darker: 1.0,
    };

    /// Why these settings cannot be used, if they cannot.
    pub fn problem(&self) -> Option<String> {
        let finite = [
            self.key,
            self.compensation,
            self.log2_luminance.0,
            self.log2_luminance.1,
            self.log2_exposure.0,
            self.log2_exposure.1,
            self.percentiles.0,
            self.percentiles.1,
            self.speed_brighter,
            self.speed_darker,
        ];
        if finite.iter().any(|v| !v.is_finite()) {
            return Some(format!("automatic exposure settings must be finite: {self:?}"));
        }
        if self.key <= 0.0 {
            return Some(format!("automatic exposure key {} is not positive", self.key));
        }
        if self.log2_luminance.0 >= self.log2_luminance.1 || self.log2_exposure.0 > self.log2_exposure.1 {
            return Some(format!(
                "automatic exposure ranges must run low to high: luminance {:?}, exposure {:?}",
                self.log2_luminance, self.log2_exposure
            ));
        }
        let (low, high) = self.percentiles;
        if !((0.0..1.0).contains(&low) && low < high && high <= 1.0) {
            return Some(format!(
                "automatic exposure percentiles {:?} must satisfy 0 ≤ low < high ≤ 1",
                self.percentiles
            ));
        }
        if self.speed_brighter < 0.0 || self.speed_darker < 0.0 {
            return Some("automatic exposure speeds must not be negative".into());
        }
        None
    }
}

impl Default for AutoExposure {
    fn default() -> Self {
        Self::DEFAULT
    }
}

oxygen_gpu::gpu_struct! {
    /// One bloom step's parameters (its WGSL twin is generated).
    #[derive(Debug, PartialEq)]
    pub(crate) struct BloomParams: 32 bytes {
        /// 1 / the size of the texture read.
        pub(crate) source_texel: [f32; 2] => "vec2<f32>",
        /// 1 / the size of the level written.
        pub(crate) target_texel: [f32; 2] => "vec2<f32>",
        /// The upsampling tent's radius in source texels.
        pub(crate) radius: f32,
        /// 1 on the first downsampling step (the Karis weights).
        pub(crate) first_level: u32,
        pub(crate) pad0: u32,
        pub(crate) pad1: u32,
    }
}

oxygen_gpu::gpu_struct! {
    /// Automatic exposure's parameters for a view and frame (its WGSL twin
    /// is generated).
    #[derive(Debug, PartialEq)]
    pub(crate) struct ExposureParams: 48 bytes {
        pub(crate) log2_min: f32,
        pub(crate) inverse_log2_range: f32,
        pub(crate) low_fraction: f32,
        pub(crate) high_fraction: f32,
        pub(crate) key: f32,
        pub(crate) compensation: f32,
        pub(crate) min_exposure_log2: f32,
        pub(crate) max_exposure_log2: f32,
        /// Seconds since the view's last frame (0: hold).
        pub(crate) dt: f32,
        pub(crate) speed_brighter: f32,
        pub(crate) speed_darker: f32,
        pub(crate) pad0: f32,
    }
}

oxygen_gpu::gpu_struct! {
    /// The tone map's parameters with effects (its WGSL twin is generated).
    #[derive(Debug, PartialEq)]
    pub(crate) struct EffectsParams: 32 bytes {
        /// 1 / the output's size.
        pub(crate) output_texel: [f32; 2] => "vec2<f32>",
        /// The fixed exposure (times the automatic one when on).
        pub(crate) exposure: f32,
        /// 0 without bloom.
        pub(crate) bloom_intensity: f32,
        /// Levels of the bloom chain (at least 1).
        pub(crate) bloom_levels: u32,
        /// 1 with automatic exposure.
        pub(crate) auto_exposure: u32,
        pub(crate) pad0: u32,
        pub(crate) pad1: u32,
    }
}

/// The effects' pipelines.
struct EffectsPipelines {
    bloom_layout: wgpu::BindGroupLayout,
    bloom_down: wgpu::RenderPipeline,
    bloom_up: wgpu::RenderPipeline,
    histogram_layout: wgpu::BindGroupLayout,
    histogram: wgpu::ComputePipeline,
    adapt_layout: wgpu::BindGroupLayout,
    adapt: wgpu::ComputePipeline,
    tonemap_layout: wgpu::BindGroupLayout,
    /// By output format.
    tonemap: Mutex<HashMap<wgpu::TextureFormat, wgpu::RenderPipeline>>,
    sampler: wgpu::Sampler,
    module: wgpu::ShaderModule,
}

/// The bloom chain's format.
const BLOOM_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

impl EffectsPipelines {
    fn new(device: &wgpu::Device) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("tone-map effects"),
            source: wgpu::ShaderSource::Wgsl(crate::shaders::EFFECTS.source().into()),
        });
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let bloom_layout = LayoutEntries::new(fragment)
            .push(bindings::texture_2d(bindings::FILTERABLE_FLOAT))
            .push(bindings::sampler_filtering())
            .push(bindings::uniform_of::<BloomParams>())
            .create_layout(device, "bloom");
        let render = |label: &str, entry: &str, blend: Option<wgpu::BlendState>| {
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &[Some(&bloom_layout)],
                immediate_size: 0,
            });
            render_pipeline(device, label, &layout, &module, entry, BLOOM_FORMAT, blend)
        };
        let bloom_down = render("bloom down", "fs_bloom_down", None);
        let additive = wgpu::BlendState {
            color: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::One,
                dst_factor: wgpu::BlendFactor::One,
                operation: wgpu::BlendOperation::Add,
            },
            alpha: wgpu::BlendComponent::REPLACE,
        };
        let bloom_up = render("bloom up", "fs_bloom_up", Some(additive));
        let compute = wgpu::ShaderStages::COMPUTE;
        let histogram_layout = LayoutEntries::new(compute)
            .at(3)
            .push(bindings::texture_2d(bindings::UNFILTERABLE_FLOAT))
            .push(bindings::uniform_of::<ExposureParams>())
            .push(bindings::storage_read_write())
            .create_layout(device, "luminance histogram");
        let adapt_layout = LayoutEntries::new(compute)
            .at(4)
            .push(bindings::uniform_of::<ExposureParams>())
            .push(bindings::storage_read_write())
            .push(bindings::storage_read_write())
            .create_layout(device, "adapt exposure");
        let compute_pipeline = |entry: &str, layout: &wgpu::BindGroupLayout| {
            crate::pipelines::compute_pipeline(device, &module, entry, layout)
        };
        let histogram = compute_pipeline("luminance_histogram", &histogram_layout);
        let adapt = compute_pipeline("adapt_exposure", &adapt_layout);
        let tonemap_layout = LayoutEntries::new(fragment)
            .at(1)
            .push(bindings::sampler_filtering())
            .at(7)
            .push(bindings::texture_2d(bindings::UNFILTERABLE_FLOAT))
            .push(bindings::uniform_of::<EffectsParams>())
            .push(bindings::texture_2d(bindings::FILTERABLE_FLOAT))
            .push(bindings::storage_read_only())
            .create_layout(device, "tone map with effects");
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("bloom"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        EffectsPipelines {
            bloom_layout,
            bloom_down,
            bloom_up,
            histogram_layout,
            histogram,
            adapt_layout,
            adapt,
            tonemap_layout,
            tonemap: Mutex::new(HashMap::new()),
            sampler,
            module,
        }
    }

    fn tonemap(&self, device: &wgpu::Device, format: wgpu::TextureFormat) -> wgpu::RenderPipeline {
        let mut pipelines = self.tonemap.lock().unwrap_or_else(|e| e.into_inner());
        pipelines
            .entry(format)
            .or_insert_with(|| {
                let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some("tone map with effects"),
                    bind_group_layouts: &[Some(&self.tonemap_layout)],
                    immediate_size: 0,
                });
                render_pipeline(
                    device,
                    "tone map with effects",
                    &layout,
                    &self.module,
                    "fs_tonemap_effects",
                    format,
                    None,
                )
            })
            .clone()
    }
}

fn render_pipeline(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    fragment: &str,
    format: wgpu::TextureFormat,
    blend: Option<wgpu::BlendState>,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_fullscreen"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(fragment),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState { format, blend, write_mask: wgpu::ColorWrites::ALL })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// One view's effect buffers, kept across frames (the parameter blocks
/// too: each frame writes them, none is made per frame).
struct ViewEffects {
    size: (u32, u32),
    /// The bloom chain and a view of each level.
    bloom: Option<(wgpu::Texture, Vec<wgpu::TextureView>)>,
    /// One parameter block per bloom step (down the chain, then up).
    bloom_params: Vec<wgpu::Buffer>,
    /// The histogram, the exposure and the exposure steps' parameters.
    exposure: Option<(wgpu::Buffer, wgpu::Buffer, wgpu::Buffer)>,
    /// The frame time of the view's last automatic exposure.
    last_time: Option<f32>,
    /// The tone map's parameters.
    tonemap_params: wgpu::Buffer,
}

impl ViewEffects {
    fn new(device: &wgpu::Device, size: (u32, u32)) -> Self {
        ViewEffects {
            size,
            bloom: None,
            bloom_params: Vec::new(),
            exposure: None,
            last_time: None,
            tonemap_params: uniform_buffer::<EffectsParams>(device, "tone map effects params"),
        }
    }
}

/// A uniform block of `T`, written before each use.
fn uniform_buffer<T>(device: &wgpu::Device, label: &str) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size_of::<T>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// The effects' pipelines (made on first use) and every view's buffers.
#[derive(Default)]
pub(crate) struct EffectsState {
    pipelines: OnceLock<EffectsPipelines>,
    views: Mutex<HashMap<ViewId, ViewEffects>>,
    /// A 1 × 1 texture and a zeroed buffer for the effect a view lacks.
    placeholders: OnceLock<(wgpu::TextureView, wgpu::Buffer)>,
}

/// What the tone map of a view with effects reads.
pub(crate) struct EffectsInputs {
    pub(crate) pipeline: wgpu::RenderPipeline,
    pub(crate) bind_group: wgpu::BindGroup,
}

impl EffectsState {
    /// Records `ctx`'s view's bloom chain and exposure steps into
    /// `encoder` and returns the tone map's pipeline and bind group for an
    /// output of `format`.
    #[allow(clippy::too_many_arguments)] // The tone map's settings, each plain.
    pub(crate) fn record(
        &self,
        ctx: &crate::RenderContext<'_>,
        encoder: &mut wgpu::CommandEncoder,
        hdr: &wgpu::Texture,
        hdr_view: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        exposure: f32,
        bloom: Option<&Bloom>,
        auto_exposure: Option<&AutoExposure>,
    ) -> Result<EffectsInputs, PassError> {
        const PASS: &str = "tone map effects";
        if let Some(problem) = bloom.and_then(Bloom::problem).or_else(|| auto_exposure.and_then(AutoExposure::problem))
        {
            return Err(PassError::BadInput { pass: PASS, what: problem });
        }
        let device = &ctx.gpu.device;
        let pipelines = self.pipelines.get_or_init(|| EffectsPipelines::new(device));
        let (placeholder_texture, placeholder_buffer) = self.placeholders.get_or_init(|| {
            let texture = oxygen_gpu::texture_2d(
                device,
                "no bloom",
                wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
                1,
                BLOOM_FORMAT,
                wgpu::TextureUsages::TEXTURE_BINDING,
            );
            let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("no exposure"),
                size: 16,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            });
            (texture.create_view(&Default::default()), buffer)
        });
        let (width, height) = (hdr.width(), hdr.height());
        let mut views = self.views.lock().map_err(|_| PassError::Graph("tone map effects state poisoned".into()))?;
        let state = views.entry(ctx.view.view_id).or_insert_with(|| ViewEffects::new(device, (width, height)));
        if state.size != (width, height) {
            *state = ViewEffects::new(device, (width, height));
        }
        let queue = &ctx.gpu.queue;

        // Bloom: down the chain from the HDR image, then back up.
        let mut levels_used = 1;
        if let Some(bloom) = bloom {
            let half = ((width / 2).max(1), (height / 2).max(1));
            // Halving stops at 2 texels: the filters read two texels out.
            let levels = bloom.levels.min(u32::BITS - half.0.min(half.1).max(2).leading_zeros() - 1).max(1);
            if state.bloom.as_ref().is_none_or(|(t, _)| t.mip_level_count() != levels) {
                let texture = oxygen_gpu::texture_2d(
                    device,
                    "bloom",
                    wgpu::Extent3d { width: half.0, height: half.1, depth_or_array_layers: 1 },
                    levels,
                    BLOOM_FORMAT,
                    wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                );
                let views = (0..levels)
                    .map(|level| {
                        texture.create_view(&wgpu::TextureViewDescriptor {
                            base_mip_level: level,
                            mip_level_count: Some(1),
                            ..Default::default()
                        })
                    })
                    .collect();
                state.bloom = Some((texture, views));
            }
            let steps = 2 * levels as usize - 1;
            while state.bloom_params.len() < steps {
                state.bloom_params.push(uniform_buffer::<BloomParams>(device, "bloom params"));
            }
            let Some((texture, level_views)) = state.bloom.as_ref() else {
                return Err(PassError::Graph("bloom chain lost".into()));
            };
            let mut step_params = state.bloom_params.iter();
            levels_used = texture.mip_level_count();
            let size_of_level = |level: u32| ((half.0 >> level).max(1), (half.1 >> level).max(1));
            let texel = |(w, h): (u32, u32)| [1.0 / w as f32, 1.0 / h as f32];
            let mut step = |encoder: &mut wgpu::CommandEncoder,
                            pipeline: &wgpu::RenderPipeline,
                            source: &wgpu::TextureView,
                            source_size: (u32, u32),
                            target: u32,
                            first: bool,
                            load: wgpu::LoadOp<wgpu::Color>| {
                let params = BloomParams {
                    source_texel: texel(source_size),
                    target_texel: texel(size_of_level(target)),
                    radius: bloom.radius,
                    first_level: u32::from(first),
                    pad0: 0,
                    pad1: 0,
                };
                // One block per step: `steps` were made above.
                let Some(buffer) = step_params.next() else { return };
                queue.write_buffer(buffer, 0, bytemuck::bytes_of(&params));
                let params = buffer;
                let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("bloom"),
                    layout: &pipelines.bloom_layout,
                    entries: &[
                        wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(source) },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: wgpu::BindingResource::Sampler(&pipelines.sampler),
                        },
                        wgpu::BindGroupEntry { binding: 2, resource: params.as_entire_binding() },
                    ],
                });
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("bloom"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &level_views[target as usize],
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &group, &[]);
                pass.draw(0..3, 0..1);
            };
            let clear = wgpu::LoadOp::Clear(wgpu::Color::BLACK);
            step(encoder, &pipelines.bloom_down, hdr_view, (width, height), 0, true, clear);
            for level in 1..levels_used {
                let source = &level_views[level as usize - 1];
                step(encoder, &pipelines.bloom_down, source, size_of_level(level - 1), level, false, clear);
            }
            for level in (0..levels_used.saturating_sub(1)).rev() {
                let source = &level_views[level as usize + 1];
                step(encoder, &pipelines.bloom_up, source, size_of_level(level + 1), level, false, wgpu::LoadOp::Load);
            }
        }

        // Automatic exposure: the histogram, then the adaptation.
        if let Some(auto) = auto_exposure {
            if state.exposure.is_none() {
                let histogram = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("luminance histogram"),
                    size: 256 * 4,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                });
                let exposure = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("view exposure"),
                    size: 16,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                });
                state.exposure =
                    Some((histogram, exposure, uniform_buffer::<ExposureParams>(device, "exposure params")));
                state.last_time = None;
            }
            let dt = state.last_time.map_or(0.0, |last| (ctx.time_seconds - last).max(0.0));
            state.last_time = Some(ctx.time_seconds);
            let params = ExposureParams {
                log2_min: auto.log2_luminance.0,
                inverse_log2_range: 1.0 / (auto.log2_luminance.1 - auto.log2_luminance.0),
                low_fraction: auto.percentiles.0,
                high_fraction: auto.percentiles.1,
                key: auto.key,
                compensation: auto.compensation,
                min_exposure_log2: auto.log2_exposure.0,
                max_exposure_log2: auto.log2_exposure.1,
                dt: if dt.is_finite() { dt } else { 0.0 },
                speed_brighter: auto.speed_brighter,
                speed_darker: auto.speed_darker,
                pad0: 0.0,
            };
            let Some((histogram, exposure, exposure_params)) = state.exposure.as_ref() else {
                return Err(PassError::Graph("exposure buffers lost".into()));
            };
            queue.write_buffer(exposure_params, 0, bytemuck::bytes_of(&params));
            let params = exposure_params;
            let histogram_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("luminance histogram"),
                layout: &pipelines.histogram_layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(hdr_view) },
                    wgpu::BindGroupEntry { binding: 4, resource: params.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 5, resource: histogram.as_entire_binding() },
                ],
            });
            let adapt_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("adapt exposure"),
                layout: &pipelines.adapt_layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 4, resource: params.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 5, resource: histogram.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 6, resource: exposure.as_entire_binding() },
                ],
            });
            let mut pass = encoder
                .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("exposure"), timestamp_writes: None });
            pass.set_pipeline(&pipelines.histogram);
            pass.set_bind_group(0, &histogram_group, &[]);
            pass.dispatch_workgroups(width.div_ceil(16), height.div_ceil(16), 1);
            pass.set_pipeline(&pipelines.adapt);
            pass.set_bind_group(0, &adapt_group, &[]);
            pass.dispatch_workgroups(1, 1, 1);
        }

        let params = EffectsParams {
            output_texel: [1.0 / width as f32, 1.0 / height as f32],
            exposure,
            bloom_intensity: bloom.map_or(0.0, |b| b.intensity),
            bloom_levels: levels_used,
            auto_exposure: u32::from(auto_exposure.is_some()),
            pad0: 0,
            pad1: 0,
        };
        queue.write_buffer(&state.tonemap_params, 0, bytemuck::bytes_of(&params));
        let params = &state.tonemap_params;
        let bloom_view = match (&state.bloom, bloom) {
            (Some((_, views)), Some(_)) => &views[0],
            _ => placeholder_texture,
        };
        let exposure_buffer = match (&state.exposure, auto_exposure) {
            (Some((_, exposure, _)), Some(_)) => exposure,
            _ => placeholder_buffer,
        };
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("tone map with effects"),
            layout: &pipelines.tonemap_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&pipelines.sampler) },
                wgpu::BindGroupEntry { binding: 7, resource: wgpu::BindingResource::TextureView(hdr_view) },
                wgpu::BindGroupEntry { binding: 8, resource: params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 9, resource: wgpu::BindingResource::TextureView(bloom_view) },
                wgpu::BindGroupEntry { binding: 10, resource: exposure_buffer.as_entire_binding() },
            ],
        });
        Ok(EffectsInputs { pipeline: pipelines.tonemap(device, format), bind_group })
    }

    /// Frees the buffers of the views `keep` says no to.
    pub(crate) fn retain(&self, keep: impl Fn(ViewId) -> bool) {
        if let Ok(mut views) = self.views.lock() {
            views.retain(|view, _| keep(*view));
        }
    }

    /// Views holding effect buffers.
    pub(crate) fn views(&self) -> usize {
        self.views.lock().map_or(0, |views| views.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_out_of_range_are_problems_naming_them() {
        assert_eq!(Bloom::DEFAULT.problem(), None);
        assert_eq!(AutoExposure::DEFAULT.problem(), None);
        for (bad, name) in [
            (Bloom { intensity: f32::NAN, ..Bloom::DEFAULT }, "intensity"),
            (Bloom { intensity: 1.5, ..Bloom::DEFAULT }, "intensity"),
            (Bloom { levels: 0, ..Bloom::DEFAULT }, "levels"),
            (Bloom { levels: 11, ..Bloom::DEFAULT }, "levels"),
            (Bloom { radius: 0.1, ..Bloom::DEFAULT }, "radius"),
        ] {
            assert!(bad.problem().is_some_and(|p| p.contains(name)), "{bad:?}");
        }
        for (bad, name) in [
            (AutoExposure { key: 0.0, ..AutoExposure::DEFAULT }, "key"),
            (AutoExposure { key: f32::NAN, ..AutoExposure::DEFAULT }, "finite"),
            (AutoExposure { log2_luminance: (2.0, 1.0), ..AutoExposure::DEFAULT }, "ranges"),
            (AutoExposure { percentiles: (0.5, 0.5), ..AutoExposure::DEFAULT }, "percentiles"),
            (AutoExposure { speed_darker: -1.0, ..AutoExposure::DEFAULT }, "speeds"),
        ] {
            assert!(bad.problem().is_some_and(|p| p.contains(name)), "{bad:?}");
        }
    }
}
