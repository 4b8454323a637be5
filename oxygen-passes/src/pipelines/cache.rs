//! The lazy pipeline cache whose misses are awaited.
//!
//! Pipelines are created the first time a partition needs one and cached by
//! [`PipelineKey`] for the renderer's lifetime; the bind-group layouts they
//! use never change (heap growth only replaces the bind group), so nothing is
//! ever rebuilt per frame. [`Pipelines::pipelines_created`] proves it.

use std::collections::{HashMap, HashSet, VecDeque};
use std::future::Future;
use std::pin::Pin;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::task::{Context, Poll, Waker};

use oxygen_bindless::{BindlessHeap, TexturePath};
use tracing::debug;

use super::{AlphaClass, PassKind, PipelineKey, mesh_entry_points, pipeline_source};
use oxygen_gpu::DeferredTargets;

/// A tile clear pipeline's key: the shading pass's key and the clear colour
/// (its `f32` bits; `None` leaves the colour as it is).
pub(super) type TileClearKey = (PipelineKey, Option<[u32; 4]>);

/// Lazily created, cached mesh pipelines shared by every view.
///
/// A pass asks for a pipeline with [`Pipelines::get`] and awaits it. A
/// pipeline not yet created is queued, and the future stays pending while a
/// recording thread with nothing else to do compiles it
/// ([`Pipelines::compile_next`]); meanwhile that view's thread goes on with
/// other views. So on a first frame, many views' pipelines compile side by
/// side instead of one after another inside each view's graph. Without any
/// recording thread attached (a pass driven by hand under `block_on`), the
/// future compiles inline, so it can never wait forever.
pub struct Pipelines {
    pub(super) layout: wgpu::PipelineLayout,
    texture_path: TexturePath,
    /// By pass and whether the vertex stage carries vertex attributes.
    modules: Mutex<HashMap<(PassKind, bool), wgpu::ShaderModule>>,
    state: Mutex<CompileState>,
    pub(super) tonemap: Mutex<Option<(wgpu::RenderPipeline, wgpu::BindGroupLayout)>>,
    /// The environment's full-screen draw, per shading key (targets,
    /// samples, tone map).
    pub(super) sky: Mutex<HashMap<PipelineKey, wgpu::RenderPipeline>>,
    /// Tile clears by shading key and clear colour.
    pub(super) tile_clear: Mutex<HashMap<TileClearKey, wgpu::RenderPipeline>>,
    /// Groups 0 to 2 (the heap's domains, the lighting inputs, the heap's
    /// textures), for deferred shading's compute pipeline layout.
    group_layouts: [wgpu::BindGroupLayout; 3],
    /// Deferred shading's page group (3) and its pipeline layout, made the
    /// first time they are asked for; why not, where the device's
    /// per-stage limits cannot bind them to a compute stage.
    deferred_layouts: Mutex<Option<Result<(wgpu::BindGroupLayout, wgpu::PipelineLayout), String>>>,
    /// Deferred shading's compute pipelines, by shading features and exposure.
    deferred: Mutex<HashMap<(crate::ShaderFeatures, crate::Exposure), wgpu::ComputePipeline>>,
    pub(super) created: AtomicU64,
    compilers: AtomicUsize,
    /// Keys requested since [`Pipelines::begin_frame`].
    used: Mutex<HashSet<PipelineKey>>,
}

#[derive(Default)]
struct CompileState {
    pipelines: HashMap<PipelineKey, Entry>,
    queue: VecDeque<PipelineKey>,
}

enum Entry {
    Ready(wgpu::RenderPipeline),
    /// Queued or compiling; woken when ready.
    Pending(Vec<Waker>),
}

impl Pipelines {
    /// Pipelines over the heap's bind-group layouts and the lighting inputs'
    /// (group 1). The view's scene constants are the last group (3): the
    /// one a batch's cameras change from camera to camera, and wgpu rebinds
    /// every group from the one set to the last (the bindless textures of
    /// group 2 each time, were the constants group 1).
    pub fn new(device: &wgpu::Device, heap: &BindlessHeap, lighting: &crate::LightingResources) -> Self {
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("oxygen bindless pipeline layout"),
            bind_group_layouts: &[
                Some(heap.domain_layout()),
                Some(lighting.layout()),
                Some(heap.texture_layout()),
                Some(heap.scene_constants_layout()),
            ],
            immediate_size: 0,
        });
        Pipelines {
            layout,
            group_layouts: [heap.domain_layout().clone(), lighting.layout().clone(), heap.texture_layout().clone()],
            deferred_layouts: Mutex::new(None),
            deferred: Mutex::new(HashMap::new()),
            texture_path: heap.texture_path(),
            modules: Mutex::new(HashMap::new()),
            state: Mutex::new(CompileState::default()),
            tonemap: Mutex::new(None),
            sky: Mutex::new(HashMap::new()),
            tile_clear: Mutex::new(HashMap::new()),
            created: AtomicU64::new(0),
            compilers: AtomicUsize::new(0),
            used: Mutex::new(HashSet::new()),
        }
    }

    /// Deferred shading's page group layout and pipeline layout, made the
    /// first time they are asked for; `Err` says why the device cannot
    /// have them (its per-stage limits: a GL device's 16 sampled textures
    /// a stage, say), which it also answers every later time.
    pub fn deferred_layouts(
        &self,
        device: &wgpu::Device,
    ) -> Result<(wgpu::BindGroupLayout, wgpu::PipelineLayout), String> {
        let mut layouts = self.deferred_layouts.lock().unwrap_or_else(|e| e.into_inner());
        layouts
            .get_or_insert_with(|| {
                validated(device, "the device cannot bind deferred shading's inputs to a compute stage", || {
                    let group = crate::mesh::deferred_layout(device);
                    let [domains, lighting, textures] = &self.group_layouts;
                    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                        label: Some("deferred shading"),
                        bind_group_layouts: &[Some(domains), Some(lighting), Some(textures), Some(&group)],
                        immediate_size: 0,
                    });
                    (group, layout)
                })
            })
            .clone()
    }

    /// Deferred shading's compute pipeline for `features`, tone-mapping
    /// with `exposure` (created the first time it is asked for, on this
    /// thread), with its page group's layout; `Err` as
    /// [`Pipelines::deferred_layouts`].
    pub(crate) fn deferred(
        &self,
        device: &wgpu::Device,
        features: crate::ShaderFeatures,
        exposure: crate::Exposure,
    ) -> Result<(wgpu::ComputePipeline, wgpu::BindGroupLayout), String> {
        let (group, layout) = self.deferred_layouts(device)?;
        let mut pipelines = self.deferred.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(pipeline) = pipelines.get(&(features, exposure)) {
            return Ok((pipeline.clone(), group));
        }
        // Made on this recording thread the first time (a batch's first
        // deferred frame waits for it); a device that rejects it says why
        // instead of raising an uncaptured error.
        let _span = tracing::info_span!("compile_pipeline", pass = "deferred", features = ?features).entered();
        let pipeline = validated(device, "deferred shading's pipeline", || {
            let source = crate::shaders::DEFERRED
                .mesh_source(self.texture_path, crate::shaders::MeshVaryings::of(features.vertex_attributes));
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("deferred shading"),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
            let mut constants = features.override_constants().to_vec();
            constants.push(("TONE_MAP_OUTPUT", 1.0));
            constants.push(("EXPOSURE", f64::from(exposure.get())));
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("deferred shading"),
                layout: Some(&layout),
                module: &module,
                entry_point: Some("cs_deferred"),
                compilation_options: wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() },
                cache: None,
            })
        })?;
        self.created.fetch_add(1, Ordering::Relaxed);
        pipelines.insert((features, exposure), pipeline.clone());
        Ok((pipeline, group))
    }

    /// Pipelines created since this cache was made.
    pub fn pipelines_created(&self) -> u64 {
        self.created.load(Ordering::Relaxed)
    }

    /// The pipeline for `key`: ready at once when it exists, otherwise after
    /// it has been compiled (see the type's docs).
    pub fn get<'a>(&'a self, device: &'a wgpu::Device, key: PipelineKey) -> PipelineFuture<'a> {
        let key = key.canonical();
        self.used.lock().unwrap_or_else(|e| e.into_inner()).insert(key);
        PipelineFuture { pipelines: self, device, key }
    }

    /// Starts counting the pipelines a frame uses ([`Pipelines::used_this_frame`]).
    pub fn begin_frame(&self) {
        self.used.lock().unwrap_or_else(|e| e.into_inner()).clear();
    }

    /// The distinct mesh pipelines requested since [`Pipelines::begin_frame`]
    /// (the tone-map and probe-mip pipelines are not keyed, so not listed).
    pub fn used_this_frame(&self) -> Vec<PipelineKey> {
        self.used.lock().unwrap_or_else(|e| e.into_inner()).iter().copied().collect()
    }

    /// Marks the calling thread as one that runs [`Pipelines::compile_next`]
    /// while its views wait, until the guard is dropped.
    pub fn attach_compiler(&self) -> CompilerGuard<'_> {
        self.compilers.fetch_add(1, Ordering::AcqRel);
        CompilerGuard(self)
    }

    /// Compiles one queued pipeline, if any, and wakes the passes awaiting
    /// it. Returns whether there was one.
    pub fn compile_next(&self, device: &wgpu::Device) -> bool {
        let Some(key) = self.lock_state().queue.pop_front() else { return false };
        self.compile(device, key);
        true
    }

    fn lock_state(&self) -> std::sync::MutexGuard<'_, CompileState> {
        // A poisoned lock means a compile panicked; the map is still consistent.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Compiles `key` (taken off the queue by the caller) and publishes it.
    fn compile(&self, device: &wgpu::Device, key: PipelineKey) -> wgpu::RenderPipeline {
        let _span =
            tracing::info_span!("compile_pipeline", pass = ?key.pass, variant = ?key.variant, features = ?key.features)
                .entered();
        let module = self.module(device, key.pass, &key.features);
        let pipeline = self.create(device, &module, key);
        self.created.fetch_add(1, Ordering::Relaxed);
        debug!(?key, "pipeline created");
        let previous = self.lock_state().pipelines.insert(key, Entry::Ready(pipeline.clone()));
        if let Some(Entry::Pending(wakers)) = previous {
            wakers.into_iter().for_each(Waker::wake);
        }
        pipeline
    }
}

impl Pipelines {
    /// The shader module of `pass` for pipelines of `features` (their
    /// vertex outputs: [`crate::ShaderFeatures::vertex_attributes`]).
    pub(super) fn module(
        &self,
        device: &wgpu::Device,
        pass: PassKind,
        features: &crate::ShaderFeatures,
    ) -> wgpu::ShaderModule {
        let mut modules = self.modules.lock().unwrap_or_else(|e| e.into_inner());
        modules
            .entry((pass, features.vertex_attributes))
            .or_insert_with(|| {
                device.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(&format!("{pass:?}")),
                    source: wgpu::ShaderSource::Wgsl(pipeline_source(pass, self.texture_path, features).into()),
                })
            })
            .clone()
    }

    fn create(&self, device: &wgpu::Device, module: &wgpu::ShaderModule, key: PipelineKey) -> wgpu::RenderPipeline {
        let masked = key.variant.alpha == AlphaClass::Masked;
        let labels = !key.labels.is_empty()
            && matches!(key.pass, PassKind::Shading | PassKind::ShadingAfterPrePass | PassKind::Visibility);
        let (vertex_entry, fragment_entry) = mesh_entry_points(key.pass, masked, labels);
        let (depth_write, depth_compare) = match key.pass {
            PassKind::Shading | PassKind::Visibility if key.last_tie_wins => {
                (true, wgpu::CompareFunction::GreaterEqual)
            }
            PassKind::DepthPrePass | PassKind::Shadow | PassKind::Shading | PassKind::Visibility => {
                (true, wgpu::CompareFunction::Greater)
            }
            PassKind::ShadingAfterPrePass | PassKind::Transparent | PassKind::Labels => {
                (false, wgpu::CompareFunction::GreaterEqual)
            }
        };
        // Premultiplied alpha: the shader multiplies colour by alpha.
        let blend = (key.pass == PassKind::Transparent).then_some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING);
        let target = |format| Some(wgpu::ColorTargetState { format, blend, write_mask: wgpu::ColorWrites::ALL });
        let targets: Vec<Option<wgpu::ColorTargetState>> = match key.pass {
            PassKind::Labels => label_targets(key.labels, wgpu::ColorWrites::ALL),
            // The surface id, then the labels.
            PassKind::Visibility => {
                let mut targets = vec![target(DeferredTargets::VISIBILITY_FORMAT)];
                targets.extend(label_targets(key.labels, wgpu::ColorWrites::ALL));
                targets
            }
            _ if labels => {
                let mut targets = vec![key.color_format.and_then(target)];
                targets.extend(label_targets(key.labels, wgpu::ColorWrites::ALL));
                targets
            }
            _ => vec![key.color_format.and_then(target)],
        };
        // The same constants for both stages: wgpu rejects a constant the
        // stage's shader does not declare, and both stages share one module.
        let constants = key.override_constants();
        let compilation_options = || wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() };
        let fragment = fragment_entry.map(|entry| wgpu::FragmentState {
            module,
            entry_point: Some(entry),
            compilation_options: compilation_options(),
            targets: if key.color_format.is_some()
                || matches!(key.pass, PassKind::Labels | PassKind::Visibility)
                || labels
            {
                &targets
            } else {
                &[]
            },
        });
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(&format!("{:?} {:?}", key.pass, key.variant)),
            layout: Some(&self.layout),
            vertex: wgpu::VertexState {
                module,
                entry_point: Some(vertex_entry),
                compilation_options: compilation_options(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                front_face: if key.variant.mirrored { wgpu::FrontFace::Cw } else { wgpu::FrontFace::Ccw },
                cull_mode: if key.variant.double_sided { None } else { Some(wgpu::Face::Back) },
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: key.depth_format,
                depth_write_enabled: Some(depth_write),
                depth_compare: Some(depth_compare),
                stencil: Default::default(),
                // Reverse-Z: a negative bias moves depth towards the far plane,
                // i.e. away from the light, more so on surfaces seen edge-on.
                bias: wgpu::DepthBiasState {
                    constant: key.depth_bias.constant,
                    slope_scale: key.depth_bias.slope_scale,
                    clamp: 0.0,
                },
            }),
            // Alpha-tested variants discard per pixel, not per sample: their
            // cut-out edges stay aliased (alpha to coverage is not used).
            multisample: wgpu::MultisampleState { count: key.samples.max(1), ..Default::default() },
            fragment,
            multiview_mask: None,
            cache: None,
        })
    }
}

/// What `make` creates, or why the device rejected it (`what`: the
/// error's opening words): its validation errors are caught in an error
/// scope instead of reaching the device's uncaptured-error handler.
fn validated<T>(device: &wgpu::Device, what: &str, make: impl FnOnce() -> T) -> Result<T, String> {
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let made = make();
    match futures::executor::block_on(scope.pop()) {
        None => Ok(made),
        Some(error) => Err(format!("{what}: {error}")),
    }
}

/// Keeps a thread counted as a pipeline compiler ([`Pipelines::attach_compiler`]).
pub struct CompilerGuard<'a>(&'a Pipelines);

impl Drop for CompilerGuard<'_> {
    fn drop(&mut self) {
        self.0.compilers.fetch_sub(1, Ordering::AcqRel);
    }
}

/// A pipeline being looked up or compiled ([`Pipelines::get`]).
pub struct PipelineFuture<'a> {
    pipelines: &'a Pipelines,
    device: &'a wgpu::Device,
    key: PipelineKey,
}

impl Future for PipelineFuture<'_> {
    type Output = wgpu::RenderPipeline;

    fn poll(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<wgpu::RenderPipeline> {
        let this = self.get_mut();
        let key = this.key;
        let mut guard = this.pipelines.lock_state();
        let inline = this.pipelines.compilers.load(Ordering::Acquire) == 0;
        let queued_at = guard.queue.iter().position(|k| *k == key);
        let state = &mut *guard;
        match state.pipelines.get_mut(&key) {
            Some(Entry::Ready(pipeline)) => return Poll::Ready(pipeline.clone()),
            // Still queued and nobody to compile it: take it over.
            Some(Entry::Pending(_)) if inline && queued_at.is_some() => {
                state.queue.retain(|k| *k != key);
            }
            Some(Entry::Pending(wakers)) => {
                if !wakers.iter().any(|w| w.will_wake(cx.waker())) {
                    wakers.push(cx.waker().clone());
                }
                return Poll::Pending;
            }
            None if inline => {
                state.pipelines.insert(key, Entry::Pending(Vec::new()));
            }
            None => {
                state.pipelines.insert(key, Entry::Pending(vec![cx.waker().clone()]));
                state.queue.push_back(key);
                return Poll::Pending;
            }
        }
        // `compile` publishes under the same lock.
        drop(guard);
        Poll::Ready(this.pipelines.compile(this.device, key))
    }
}

/// The colour targets of the label planes of `set`, in [`oxygen_gpu::Label::ALL`]
/// order, none where a label is not in the set (its shader output goes
/// nowhere), trimmed after the last plane.
pub(crate) fn label_targets(
    set: oxygen_gpu::LabelSet,
    write_mask: wgpu::ColorWrites,
) -> Vec<Option<wgpu::ColorTargetState>> {
    let mut targets: Vec<_> = oxygen_gpu::Label::ALL
        .into_iter()
        .map(|label| {
            set.contains(label).then_some(wgpu::ColorTargetState { format: label.format(), blend: None, write_mask })
        })
        .collect();
    while targets.last().is_some_and(Option::is_none) {
        targets.pop();
    }
    targets
}
