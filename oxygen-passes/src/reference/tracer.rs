//! The path-traced reference view: Oxygen's ground truth for shading.
//!
//! [`ReferenceTracer`] holds the ray-tracing scene on the GPU (uploaded from
//! ScenePrep's [`oxygen_sceneprep::RayScene`] whenever it was rebuilt), the
//! tracing pipeline (`trace.wgsl`, which reads the same bindless
//! domains, camera constants and textures as the raster passes) and, per
//! view, the running sum of the samples taken so far. [`ReferencePass`]
//! adds a frame's samples and writes the mean into the view's HDR target, so
//! the view's tone map is the raster views' tone map.
//!
//! Samples accumulate across frames while the view's camera, viewport and
//! settings and the scene's collection stay the same, and restart from
//! zero when any of them changes; [`ReferenceTracer::samples`] says how many
//! the view's image holds. The traversal is a compute shader (a stack per
//! invocation), which runs on every adapter the project supports; hardware
//! ray queries are not used.

use std::collections::HashMap;
use std::sync::Mutex;

use oxygen_bindless::{Allocation, BindlessError, BindlessHeap, DomainKind, INVALID_SLOT};
use oxygen_core::ViewId;
use oxygen_gpu::bindings::{self, LayoutEntries};
use oxygen_sceneprep::{RayInstance, RayScene, ray::POSED};
use tracing::info_span;

use super::params::{ENVIRONMENT_MAP, RASTER_MODEL, RASTER_REFLECTIONS, TraceParams};

use crate::context::RenderPass;
use crate::context::{CommandRecorder, PassError, RenderContext};

/// How a reference view traces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceSettings {
    /// Paths per pixel added each frame.
    pub samples_per_frame: u32,
    /// Stop accumulating at this many samples per pixel (the frame then
    /// traces nothing and keeps its image).
    pub max_samples: u32,
    /// Bounces after the first hit (0: direct light only).
    pub max_bounces: u32,
    /// Radiance arriving from every direction where a path escapes the
    /// scene (linear RGB, the lights' units) when the renderer has no
    /// environment; with one (`Renderer::set_environment`), escaping paths
    /// read its radiance (level 0 of the cube the shading reads) instead.
    pub environment: [f32; 3],
    /// Model the raster pass's light transport instead of global
    /// illumination: direct light with traced shadows plus the raster's
    /// ambient term (the constant, or the environment's irradiance
    /// harmonics and prefiltered reflection as the shading reads them), no
    /// bounces. For comparing raster views with their reference where both
    /// model the same thing.
    pub raster_model: bool,
    /// With `raster_model`: add what a perfect reflection probe would, the
    /// surroundings' raster-model radiance along the reflection, weighted
    /// by the raster's split-sum BRDF. The reference for probe knobs.
    pub raster_reflections: bool,
    /// The seed of every pixel's random sequence. Two references that
    /// differ only in their seed differ only by their noise, which is how
    /// the accuracy atlas measures a reference's own error (a new seed
    /// restarts accumulation).
    pub seed: u32,
}

impl ReferenceSettings {
    /// Global illumination: 4 samples a frame up to 4096, 8 bounces, the
    /// raster pass's ambient level (0.03) as the environment.
    pub const DEFAULT: ReferenceSettings = ReferenceSettings {
        samples_per_frame: 4,
        max_samples: 4096,
        max_bounces: 8,
        environment: [0.03; 3],
        raster_model: false,
        raster_reflections: false,
        seed: Self::DEFAULT_SEED,
    };

    /// The seed of [`Self::DEFAULT`] and the presets built on it.
    pub const DEFAULT_SEED: u32 = 0x6f78_7967;

    /// The raster pass's light transport, traced: see [`Self::raster_model`].
    /// The environment is the forward pass's default clear colour, what a
    /// raster view shows where nothing is drawn.
    pub const RASTER_MODEL: ReferenceSettings =
        ReferenceSettings { max_bounces: 0, environment: [0.02, 0.03, 0.05], raster_model: true, ..Self::DEFAULT };

    /// The raster model with perfect reflection probes: see
    /// [`Self::raster_reflections`].
    pub const RASTER_MODEL_WITH_REFLECTIONS: ReferenceSettings =
        ReferenceSettings { raster_reflections: true, ..Self::RASTER_MODEL };

    /// What restarts accumulation when it changes (a new cap or a new
    /// number of samples per frame continues the same mean).
    fn key(&self) -> [u32; 7] {
        [
            self.seed,
            self.max_bounces,
            self.environment[0].to_bits(),
            self.environment[1].to_bits(),
            self.environment[2].to_bits(),
            u32::from(self.raster_model),
            u32::from(self.raster_reflections),
        ]
    }

    /// The shader's flags from the settings (`ENVIRONMENT_MAP` is the
    /// renderer's to add).
    fn flags(&self) -> u32 {
        let reflections = self.raster_model && self.raster_reflections;
        (if self.raster_model { RASTER_MODEL } else { 0 }) | if reflections { RASTER_REFLECTIONS } else { 0 }
    }
}

impl Default for ReferenceSettings {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One view's accumulation.
struct ViewSamples {
    sum: wgpu::Buffer,
    output: wgpu::Texture,
    size: (u32, u32),
    samples: u32,
    /// Camera matrices, settings and scene generation of the samples held.
    key: Option<Vec<u32>>,
}

/// The ray scene's ranges in the heap, the pipeline and every reference
/// view's samples.
pub struct ReferenceTracer {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
    /// The ray scene's nodes, words and instances in the heap's domains.
    ranges: Option<[Allocation; 3]>,
    /// The posed vertices of skinned and morphed instances, in the vertex
    /// domain (`None` without any).
    posed: Option<Allocation>,
    tlas_root: u32,
    uploaded_generation: Option<u64>,
    views: Mutex<HashMap<ViewId, ViewSamples>>,
}

/// The tracer's full WGSL: `reference/trace.wgsl` with the heap's
/// declarations, the shared reflectance model, cube layout and environment
/// reads, on the texture path `textures`.
pub fn reference_shader_source(textures: oxygen_bindless::TexturePath) -> String {
    crate::shaders::REFERENCE.textured_source(textures)
}

impl ReferenceTracer {
    /// The pipeline over the heap's layouts, and empty scene buffers.
    pub fn new(device: &wgpu::Device, heap: &BindlessHeap) -> Self {
        let _span = info_span!("reference_tracer_new").entered();
        let layout = LayoutEntries::new(wgpu::ShaderStages::COMPUTE)
            .push(bindings::uniform())
            .at(4)
            .push(bindings::storage_read_only())
            .push(bindings::storage_read_write())
            .push(bindings::storage_texture_2d(wgpu::TextureFormat::Rgba16Float, wgpu::StorageTextureAccess::WriteOnly))
            // The renderer's environment (a placeholder without one), its
            // sampler and the split-sum table: what the shading reads.
            .push(bindings::texture_2d_array(bindings::FILTERABLE_FLOAT))
            .push(bindings::sampler_filtering())
            .push(bindings::uniform_sized(crate::lighting::split_sum::SPLIT_SUM_LUT_BYTES))
            .create_layout(device, "reference tracer");
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("reference tracer"),
            bind_group_layouts: &[
                Some(heap.domain_layout()),
                Some(&layout),
                Some(heap.texture_layout()),
                Some(heap.scene_constants_layout()),
            ],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("reference trace"),
            source: wgpu::ShaderSource::Wgsl(reference_shader_source(heap.texture_path()).into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("reference trace"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("trace_paths"),
            compilation_options: Default::default(),
            cache: None,
        });
        ReferenceTracer {
            layout,
            pipeline,
            ranges: None,
            posed: None,
            tlas_root: INVALID_SLOT,
            uploaded_generation: None,
            views: Mutex::new(HashMap::new()),
        }
    }

    /// Writes `scene` into the heap's ray-scene domains when it was
    /// rebuilt since the last upload (freeing the previous ranges), and
    /// forgets the samples of views not in `views`.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        heap: &mut BindlessHeap,
        scene: &RayScene,
        views: &[ViewId],
    ) -> Result<(), BindlessError> {
        if let Ok(mut samples) = self.views.lock() {
            samples.retain(|id, _| views.contains(id));
        }
        if self.uploaded_generation == Some(scene.generation()) {
            return Ok(());
        }
        let _span =
            info_span!("reference_upload", nodes = scene.nodes().len(), instances = scene.instances().len()).entered();
        if let Some(ranges) = self.ranges.take() {
            for range in ranges {
                heap.slots.free(range)?;
            }
        }
        if let Some(range) = self.posed.take() {
            heap.slots.free(range)?;
        }
        // Past u32 the allocation fails as a full domain, with its numbers.
        let count = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
        let nodes = heap.slots.allocate(DomainKind::BvhNodes, count(scene.nodes().len()))?;
        let words = heap.slots.allocate(DomainKind::RayWords, count(scene.words().len()))?;
        let instances = heap.slots.allocate(DomainKind::RayInstances, count(scene.instances().len()))?;
        self.ranges = Some([nodes, words, instances]);
        heap.ensure_capacity(device, queue);
        heap.write(queue, &nodes, 0, scene.nodes())?;
        heap.write(queue, &words, 0, scene.words())?;
        // Posed instances point into their own vertices: rebased onto
        // where those land in the vertex domain.
        let posed = scene.posed_vertices();
        let posed_range = if posed.is_empty() {
            None
        } else {
            let range = heap.slots.allocate(DomainKind::Vertices, count(posed.len()))?;
            self.posed = Some(range);
            heap.ensure_capacity(device, queue);
            heap.write(queue, &range, 0, posed)?;
            Some(range)
        };
        let rebased: Vec<RayInstance> = scene
            .instances()
            .iter()
            .map(|i| match posed_range {
                Some(range) if i.flags & POSED != 0 => RayInstance { vertex_slot: i.vertex_slot + range.start, ..*i },
                _ => *i,
            })
            .collect();
        heap.write(queue, &instances, 0, &rebased)?;
        self.tlas_root = scene.tlas_root().unwrap_or(INVALID_SLOT);
        self.uploaded_generation = Some(scene.generation());
        Ok(())
    }

    /// Samples per pixel in `view`'s image (0 before its first frame).
    pub fn samples(&self, view: ViewId) -> u32 {
        self.views.lock().ok().and_then(|v| v.get(&view).map(|s| s.samples)).unwrap_or(0)
    }

    /// Adds this frame's samples for the context's view and copies the mean
    /// into its HDR target.
    fn trace(
        &self,
        ctx: &RenderContext<'_>,
        rec: &mut CommandRecorder,
        settings: &ReferenceSettings,
    ) -> Result<(), PassError> {
        const PASS: &str = "ReferencePass";
        let color = ctx.color_targets(PASS)?;
        if color.hdr.format() != wgpu::TextureFormat::Rgba16Float {
            return Err(PassError::BadInput {
                pass: PASS,
                what: format!("needs an Rgba16Float HDR target, the view has {:?}", color.hdr.format()),
            });
        }
        let device = &ctx.gpu.device;
        let (width, height) = (ctx.view.viewport.x.max(1), ctx.view.viewport.y.max(1));
        // The camera as the GPU sees it (relative to the render origin),
        // and where that origin is.
        let mut key: Vec<u32> = ctx.view.view_projection.to_cols_array().iter().map(|x| x.to_bits()).collect();
        key.extend(ctx.origin.to_array().iter().flat_map(|x| {
            let bits = x.to_bits();
            [bits as u32, (bits >> 32) as u32]
        }));
        key.extend_from_slice(&settings.key());
        key.extend_from_slice(&[width, height]);
        let generation = self.uploaded_generation.unwrap_or(0);
        key.extend_from_slice(&[generation as u32, (generation >> 32) as u32]);
        // A new environment restarts the mean too.
        let environment = ctx.lighting.environment_generation();
        key.extend_from_slice(&[environment as u32, (environment >> 32) as u32]);

        let mut views = self.views.lock().map_err(|_| PassError::Graph("reference tracer state poisoned".into()))?;
        let state = views.entry(ctx.view.view_id).or_insert_with(|| ViewSamples::new(device, (width, height)));
        if state.size != (width, height) {
            *state = ViewSamples::new(device, (width, height));
        }
        if state.key.as_ref() != Some(&key) {
            state.samples = 0;
            state.key = Some(key);
        }
        let this_frame = settings.samples_per_frame.min(settings.max_samples.saturating_sub(state.samples));
        if this_frame > 0 {
            let params = TraceParams {
                width,
                height,
                samples_done: state.samples,
                samples_this_frame: this_frame,
                // The raster model stops at the first hit, or after the one
                // reflection of its probe term.
                max_bounces: if settings.raster_model {
                    u32::from(settings.raster_reflections)
                } else {
                    settings.max_bounces
                },
                flags: settings.flags() | if ctx.lighting.has_environment() { ENVIRONMENT_MAP } else { 0 },
                tlas_root: self.tlas_root,
                seed: settings.seed,
                node_base: self.ranges.map_or(0, |r| r[0].start),
                word_base: self.ranges.map_or(0, |r| r[1].start),
                instance_base: self.ranges.map_or(0, |r| r[2].start),
                reserved: 0,
                environment: [
                    finite_or_zero(settings.environment[0]),
                    finite_or_zero(settings.environment[1]),
                    finite_or_zero(settings.environment[2]),
                    0.0,
                ],
            };
            let params_buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("reference params"),
                size: std::mem::size_of::<TraceParams>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            ctx.gpu.queue.write_buffer(&params_buffer, 0, bytemuck::bytes_of(&params));
            let output_view = state.output.create_view(&Default::default());
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("reference tracer"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: params_buffer.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 4, resource: ctx.heap.index_buffer().as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 5, resource: state.sum.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 6, resource: wgpu::BindingResource::TextureView(&output_view) },
                    wgpu::BindGroupEntry {
                        binding: 7,
                        resource: wgpu::BindingResource::TextureView(ctx.lighting.environment_view()),
                    },
                    wgpu::BindGroupEntry {
                        binding: 8,
                        resource: wgpu::BindingResource::Sampler(ctx.lighting.environment_sampler()),
                    },
                    wgpu::BindGroupEntry { binding: 9, resource: ctx.lighting.split_sum_buffer().as_entire_binding() },
                ],
            });
            let mut pass = rec.encoder().begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("reference trace"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, ctx.heap.bind_group(), &[]);
            pass.set_bind_group(1, &bind_group, &[]);
            pass.set_bind_group(2, ctx.heap.texture_bind_group(), &[]);
            pass.set_bind_group(3, ctx.scene_constants.bind_group(), &[ctx.scene_constants.dynamic_offset()]);
            pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
            drop(pass);
            state.samples += this_frame;
        }
        rec.encoder().copy_texture_to_texture(
            state.output.as_image_copy(),
            wgpu::TexelCopyTextureInfo {
                texture: &color.hdr,
                mip_level: 0,
                origin: wgpu::Origin3d { x: 0, y: 0, z: color.hdr_layer },
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        );
        Ok(())
    }
}

fn finite_or_zero(x: f32) -> f32 {
    if x.is_finite() && x > 0.0 { x } else { 0.0 }
}

impl ViewSamples {
    fn new(device: &wgpu::Device, size: (u32, u32)) -> Self {
        ViewSamples {
            sum: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("reference running sum"),
                size: u64::from(size.0) * u64::from(size.1) * 16,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            }),
            output: oxygen_gpu::texture_2d(
                device,
                "reference mean",
                wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
                1,
                wgpu::TextureFormat::Rgba16Float,
                wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
            ),
            size,
            samples: 0,
            key: None,
        }
    }
}

/// Traces a frame's samples for the view ([`ReferenceTracer`]) and writes
/// the mean into its HDR target. Needs the renderer's tracer (a view
/// registered as path traced).
pub struct ReferencePass {
    /// How to trace.
    pub settings: ReferenceSettings,
}

impl RenderPass for ReferencePass {
    fn name(&self) -> &'static str {
        "ReferencePass"
    }

    async fn run(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        let _span = info_span!("reference_trace", view = %ctx.view.view_id).entered();
        let Some(tracer) = ctx.inputs.reference else {
            return Err(PassError::MissingInput {
                pass: self.name(),
                input: "ReferenceTracer (register the view as path traced)",
            });
        };
        tracer.trace(ctx, rec, &self.settings)
    }
}
