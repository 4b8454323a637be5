//! Pipelines: variants, keys and the lazy cache whose misses are awaited.
//!
//! A pass picks one of four variants per partition, opaque/masked ×
//! back-face/double-sided (blend × back-face/double-sided for transparency).
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

use oxygen_bindless::{BindlessHeap, DomainKind, SCENE_CONSTANTS_WGSL, TexturePath};
use oxygen_sceneprep::{GPU_RECORDS_WGSL, PassMask};
use tracing::debug;

/// Which pass a pipeline belongs to (decides shaders and depth state).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PassKind {
    /// Depth only; writes depth with `Greater`.
    DepthPrePass,
    /// A shadow map: as `DepthPrePass`, plus a slope-scaled depth bias
    /// pushing stored depth away from the light (against shadow acne).
    Shadow,
    /// Shading after a depth pre-pass: `GreaterEqual`, no depth writes.
    ShadingAfterPrePass,
    /// Shading that writes its own depth (no pre-pass): `Greater`, writes.
    Shading,
    /// Blended surfaces: premultiplied alpha over the HDR target,
    /// `GreaterEqual` against the opaque depth, no depth writes.
    Transparent,
}

/// The rasterizer's depth bias of a shadow map: stored depth is pushed away
/// from the light by `constant` depth units plus `slope_scale` times the
/// surface's depth slope, against shadow acne. Reverse-Z: negative values
/// push towards the far plane. A speed/accuracy knob with a measured error:
/// `tests/shadow_quality.rs` shows acne without it and peter-panning grows
/// with it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthBias {
    /// Constant bias in depth-buffer units.
    pub constant: i32,
    /// Bias per unit of depth slope.
    pub slope_scale: f32,
}

impl DepthBias {
    /// No bias (the camera's own depth passes).
    pub const NONE: DepthBias = DepthBias { constant: 0, slope_scale: 0.0 };
    /// The shadow maps' default: 2 units plus 1.5 × slope, towards the far plane.
    pub const SHADOW_DEFAULT: DepthBias = DepthBias { constant: -2, slope_scale: -1.5 };
}

impl Eq for DepthBias {}

impl std::hash::Hash for DepthBias {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.constant.hash(state);
        self.slope_scale.to_bits().hash(state);
    }
}

/// How alpha is treated by a variant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AlphaClass {
    /// Alpha ignored.
    Opaque,
    /// Alpha-tested against the material cutoff.
    Masked,
    /// Alpha-blended.
    Blend,
}

/// One of the pipeline variants a partition selects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PipelineVariant {
    /// Alpha treatment.
    pub alpha: AlphaClass,
    /// No back-face culling.
    pub double_sided: bool,
    /// Clockwise front faces (mirroring transforms).
    pub mirrored: bool,
}

impl PipelineVariant {
    /// The variant a partition mask selects.
    pub fn from_mask(mask: PassMask) -> Self {
        let alpha = if mask.contains(PassMask::TRANSPARENT) {
            AlphaClass::Blend
        } else if mask.contains(PassMask::MASKED) {
            AlphaClass::Masked
        } else {
            AlphaClass::Opaque
        };
        PipelineVariant {
            alpha,
            double_sided: mask.contains(PassMask::DOUBLE_SIDED),
            mirrored: mask.contains(PassMask::MIRRORED),
        }
    }
}

/// Everything that makes two pipelines different.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PipelineKey {
    /// Pass.
    pub pass: PassKind,
    /// Variant.
    pub variant: PipelineVariant,
    /// Colour target format (`None` for depth-only).
    pub color_format: Option<wgpu::TextureFormat>,
    /// Depth target format.
    pub depth_format: wgpu::TextureFormat,
    /// Rasterizer depth bias ([`DepthBias::NONE`] except for shadow maps).
    pub depth_bias: DepthBias,
    /// Optional shading code the pipeline keeps (forward lit and
    /// transparent passes; [`ShaderFeatures::ALL`] for depth-only passes,
    /// whose shader has none).
    pub features: ShaderFeatures,
    /// Tone-map in the fragment shader with this exposure and write the
    /// display colour directly (the forward lit pass of a view whose HDR
    /// nothing reads); `None` writes linear radiance.
    pub tone_map: Option<Exposure>,
    /// Samples per pixel of the targets (1, or 2 and 4 with MSAA).
    pub samples: u32,
}

impl PipelineKey {
    /// The key with the fields its pass ignores set to one value, so that
    /// two requests for the same pipeline share it: depth-only shaders have
    /// no optional code and never tone-map.
    fn canonical(self) -> Self {
        match self.pass {
            PassKind::DepthPrePass | PassKind::Shadow => {
                PipelineKey { features: ShaderFeatures::ALL, tone_map: None, ..self }
            }
            PassKind::ShadingAfterPrePass | PassKind::Shading | PassKind::Transparent => self,
        }
    }

    /// The WGSL override constants the forward shader is specialised with
    /// (empty for depth-only passes).
    pub fn override_constants(&self) -> Vec<(&'static str, f64)> {
        match self.pass {
            PassKind::DepthPrePass | PassKind::Shadow => Vec::new(),
            PassKind::ShadingAfterPrePass | PassKind::Shading | PassKind::Transparent => {
                let mut constants = self.features.override_constants().to_vec();
                constants.push(("TONE_MAP_OUTPUT", f64::from(u8::from(self.tone_map.is_some()))));
                constants.push(("EXPOSURE", f64::from(self.tone_map.map_or(1.0, Exposure::get))));
                constants
            }
        }
    }
}

/// Optional parts of the forward shader. Each is a WGSL pipeline-overridable
/// constant (`override HAS_SUN_SHADOWS: bool = true;` …) set when the
/// pipeline is created, so a scene without, say, positional lights runs a
/// pipeline whose light loop the shader compiler removed. A pass picks the
/// features from what its view has this frame; every combination is a
/// pipeline of its own, created the first time it is needed and cached.
/// Masked materials need no flag: alpha testing lives in its own entry
/// points (`fs_masked`, `fs_alpha_test`), used only by masked partitions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ShaderFeatures {
    /// Sample the view's sun-shadow cascades (`HAS_SUN_SHADOWS`).
    pub sun_shadows: bool,
    /// Loop over the frame's spot and point lights (`HAS_LOCAL_LIGHTS`).
    pub local_lights: bool,
    /// Sample the local-light shadow atlas (`HAS_LOCAL_SHADOWS`).
    pub local_shadows: bool,
    /// Reflect the linked reflection probes (`HAS_PROBES`).
    pub probes: bool,
    /// Sample material textures (`HAS_TEXTURES`); without it every texture
    /// reads as opaque white, which is what an untextured material gets.
    pub textures: bool,
    /// Read a texture's second UV set or its `KHR_texture_transform`
    /// (`HAS_UV_TRANSFORMS`); without it every texture reads set 0 as is
    /// and set 1's derivatives are never taken. Compiled in, the transform
    /// path cost textured shading 0.23 ms at 1280 × 720 on an H100 (1.24 →
    /// 1.47 ms) even for materials that skip it at run time.
    pub uv_transforms: bool,
}

impl ShaderFeatures {
    /// Every optional part: the shader as written, right for any scene.
    pub const ALL: ShaderFeatures = ShaderFeatures {
        sun_shadows: true,
        local_lights: true,
        local_shadows: true,
        probes: true,
        textures: true,
        uv_transforms: true,
    };
    /// No optional part: sun and ambient light on untextured materials.
    pub const NONE: ShaderFeatures = ShaderFeatures {
        sun_shadows: false,
        local_lights: false,
        local_shadows: false,
        probes: false,
        textures: false,
        uv_transforms: false,
    };

    /// The override constants, by their WGSL names (bools as 0 or 1).
    pub fn override_constants(&self) -> [(&'static str, f64); 6] {
        let flag = |on: bool| f64::from(u8::from(on));
        [
            ("HAS_SUN_SHADOWS", flag(self.sun_shadows)),
            ("HAS_LOCAL_LIGHTS", flag(self.local_lights)),
            ("HAS_LOCAL_SHADOWS", flag(self.local_shadows)),
            ("HAS_PROBES", flag(self.probes)),
            ("HAS_TEXTURES", flag(self.textures)),
            ("HAS_UV_TRANSFORMS", flag(self.uv_transforms)),
        ]
    }
}

/// The exposure a tone-mapping pipeline multiplies radiance by: finite and
/// non-negative (anything else becomes 1), compared and hashed by its bits
/// so it can be part of a [`PipelineKey`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exposure(f32);

impl Exposure {
    /// `value`, or 1 when it is not finite or negative (no NaN reaches a shader).
    pub fn new(value: f32) -> Self {
        Exposure(if value.is_finite() && value >= 0.0 { value } else { 1.0 })
    }

    /// The factor.
    pub fn get(self) -> f32 {
        self.0
    }
}

impl Eq for Exposure {}

impl std::hash::Hash for Exposure {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.0.to_bits().hash(state);
    }
}

const MESH_VERTEX_WGSL: &str = include_str!("mesh_vertex.wgsl");
const DEPTH_ONLY_WGSL: &str = include_str!("depth_only.wgsl");
const FORWARD_LIT_WGSL: &str = include_str!("forward_lit.wgsl");
/// The reflectance model and light falloff shared by raster shading and the
/// path-traced reference.
pub const BRDF_WGSL: &str = include_str!("brdf.wgsl");
/// The cube layout every cube shares (probes, the environment, point-light
/// shadow faces): `cube_face`, `cube_face_uv`, `cube_face_point`.
pub const CUBE_FACES_WGSL: &str = include_str!("cube_faces.wgsl");
/// Reading the environment (irradiance harmonics, prefiltered levels) and
/// the split-sum table; shared by shading and the path-traced reference.
pub const ENVIRONMENT_WGSL: &str = include_str!("environment.wgsl");
/// The tone-map operator (`tone_map`, `pbr_neutral`), shared by the tone-map
/// pass and the forward lit pass's in-pass tone map.
pub const TONEMAP_OPERATOR_WGSL: &str = include_str!("tonemap.wgsl");
/// The tone-map shader (self-contained: no bindless declarations): the
/// operator followed by the pass.
pub const TONEMAP_WGSL: &str = concat!(include_str!("tonemap.wgsl"), "\n", include_str!("tonemap_pass.wgsl"));

/// The full WGSL of a pass: shared declarations (scene constants, GPU
/// records, domain bindings, the texture path's bindings), then the shared
/// vertex stage, then the pass's own code.
pub fn shader_source(pass: PassKind, textures: TexturePath) -> String {
    let body = match pass {
        PassKind::DepthPrePass | PassKind::Shadow => DEPTH_ONLY_WGSL.to_owned(),
        PassKind::Shading | PassKind::ShadingAfterPrePass | PassKind::Transparent => {
            format!("{TONEMAP_OPERATOR_WGSL}\n{BRDF_WGSL}\n{CUBE_FACES_WGSL}\n{ENVIRONMENT_WGSL}\n{FORWARD_LIT_WGSL}")
        }
    };
    // Enable directives must come before any declaration.
    let enables = match textures {
        TexturePath::BindingArray => "enable wgpu_binding_array;\n",
        TexturePath::GroupedArrays => "",
    };
    // Numbers defined in Rust, emitted rather than copied into the WGSL.
    let constants = [
        oxygen_bindless::wgsl_constants(),
        PassMask::wgsl_constants(),
        oxygen_sceneprep::MaterialRecord::wgsl_constants(),
        oxygen_sceneprep::PositionalLightRecord::wgsl_constants(),
        crate::lighting_inputs::wgsl_constants(),
    ]
    .concat();
    format!(
        "{enables}{constants}{SCENE_CONSTANTS_WGSL}\n{GPU_RECORDS_WGSL}\n{}\n{}\n{MESH_VERTEX_WGSL}\n{body}",
        DomainKind::wgsl_bindings(),
        textures.wgsl()
    )
}

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
    layout: wgpu::PipelineLayout,
    texture_path: TexturePath,
    modules: Mutex<HashMap<PassKind, wgpu::ShaderModule>>,
    state: Mutex<CompileState>,
    tonemap: Mutex<Option<(wgpu::RenderPipeline, wgpu::BindGroupLayout)>>,
    /// The environment's full-screen draw, per shading key (targets,
    /// samples, tone map).
    sky: Mutex<HashMap<PipelineKey, wgpu::RenderPipeline>>,
    created: AtomicU64,
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
    /// (group 3).
    pub fn new(device: &wgpu::Device, heap: &BindlessHeap, lighting: &crate::LightingResources) -> Self {
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("oxygen bindless pipeline layout"),
            bind_group_layouts: &[
                Some(heap.domain_layout()),
                Some(heap.scene_constants_layout()),
                Some(heap.texture_layout()),
                Some(lighting.layout()),
            ],
            immediate_size: 0,
        });
        Pipelines {
            layout,
            texture_path: heap.texture_path(),
            modules: Mutex::new(HashMap::new()),
            state: Mutex::new(CompileState::default()),
            tonemap: Mutex::new(None),
            sky: Mutex::new(HashMap::new()),
            created: AtomicU64::new(0),
            compilers: AtomicUsize::new(0),
            used: Mutex::new(HashSet::new()),
        }
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
        let module = self.module(device, key.pass);
        let pipeline = self.create(device, &module, key);
        self.created.fetch_add(1, Ordering::Relaxed);
        debug!(?key, "pipeline created");
        let previous = self.lock_state().pipelines.insert(key, Entry::Ready(pipeline.clone()));
        if let Some(Entry::Pending(wakers)) = previous {
            wakers.into_iter().for_each(Waker::wake);
        }
        pipeline
    }

    /// The tone-map pipeline (HDR texture + exposure uniform → `output`),
    /// created on first use.
    pub fn tonemap(
        &self,
        device: &wgpu::Device,
        output: wgpu::TextureFormat,
    ) -> (wgpu::RenderPipeline, wgpu::BindGroupLayout) {
        let mut slot = self.tonemap.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(existing) = slot.as_ref() {
            return existing.clone();
        }
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("tonemap"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let pipeline =
            fullscreen_pipeline(device, "tonemap", &layout, TONEMAP_WGSL, ("vs_fullscreen", "fs_tonemap"), output);
        self.created.fetch_add(1, Ordering::Relaxed);
        *slot = Some((pipeline.clone(), layout.clone()));
        (pipeline, layout)
    }

    /// The pipeline that draws the environment behind the scene for a
    /// shading pass of `key` (its targets, samples and tone map): the
    /// shading module's `vs_sky`/`fs_sky`, depth untouched and always
    /// passing, drawn before the pass's meshes.
    pub fn sky(&self, device: &wgpu::Device, key: PipelineKey) -> wgpu::RenderPipeline {
        let key = PipelineKey { variant: PipelineVariant::from_mask(oxygen_sceneprep::PassMask::OPAQUE), ..key };
        if let Some(p) = self.sky.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
            return p.clone();
        }
        let module = self.module(device, PassKind::Shading);
        let constants = PipelineKey { pass: PassKind::Shading, ..key }.override_constants();
        let options = || wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() };
        let targets = [key.color_format.map(|format| wgpu::ColorTargetState {
            format,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("sky"),
            layout: Some(&self.layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_sky"),
                compilation_options: options(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: key.depth_format,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: wgpu::MultisampleState { count: key.samples.max(1), ..Default::default() },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_sky"),
                compilation_options: options(),
                targets: &targets,
            }),
            multiview_mask: None,
            cache: None,
        });
        self.created.fetch_add(1, Ordering::Relaxed);
        self.sky.lock().unwrap_or_else(|e| e.into_inner()).insert(key, pipeline.clone());
        pipeline
    }

    fn module(&self, device: &wgpu::Device, pass: PassKind) -> wgpu::ShaderModule {
        let mut modules = self.modules.lock().unwrap_or_else(|e| e.into_inner());
        modules
            .entry(pass)
            .or_insert_with(|| {
                device.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(&format!("{pass:?}")),
                    source: wgpu::ShaderSource::Wgsl(shader_source(pass, self.texture_path).into()),
                })
            })
            .clone()
    }

    fn create(&self, device: &wgpu::Device, module: &wgpu::ShaderModule, key: PipelineKey) -> wgpu::RenderPipeline {
        let masked = key.variant.alpha == AlphaClass::Masked;
        let (fragment_entry, depth_write, depth_compare) = match key.pass {
            PassKind::DepthPrePass | PassKind::Shadow => {
                (masked.then_some("fs_alpha_test"), true, wgpu::CompareFunction::Greater)
            }
            PassKind::ShadingAfterPrePass => {
                (Some(if masked { "fs_masked" } else { "fs_opaque" }), false, wgpu::CompareFunction::GreaterEqual)
            }
            PassKind::Shading => {
                (Some(if masked { "fs_masked" } else { "fs_opaque" }), true, wgpu::CompareFunction::Greater)
            }
            PassKind::Transparent => (Some("fs_blend"), false, wgpu::CompareFunction::GreaterEqual),
        };
        // Premultiplied alpha: the shader multiplies colour by alpha.
        let blend = (key.pass == PassKind::Transparent).then_some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING);
        let targets = [key.color_format.map(|format| wgpu::ColorTargetState {
            format,
            blend,
            write_mask: wgpu::ColorWrites::ALL,
        })];
        // The same constants for both stages: wgpu rejects a constant the
        // stage's shader does not declare, and both stages share one module.
        let constants = key.override_constants();
        let compilation_options = || wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() };
        let fragment = fragment_entry.map(|entry| wgpu::FragmentState {
            module,
            entry_point: Some(entry),
            compilation_options: compilation_options(),
            targets: if key.color_format.is_some() { &targets } else { &[] },
        });
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(&format!("{:?} {:?}", key.pass, key.variant)),
            layout: Some(&self.layout),
            vertex: wgpu::VertexState {
                module,
                entry_point: Some("vs_main"),
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

/// A render pass that clears `view` to black and draws into it, with no
/// depth: what every full-screen pass begins (the tone map, the cube
/// filter, the split-sum table, the renderer's window composition).
pub fn fullscreen_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    view: &wgpu::TextureView,
    label: &str,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// A pipeline drawing one full-screen triangle (three vertices, no buffers)
/// into one colour target of `format`, with one bind group of `layout`:
/// the shape of the tone map, the cube filter, the split-sum table and the
/// renderer's window composition.
pub fn fullscreen_pipeline(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    wgsl: &str,
    (vertex, fragment): (&str, &str),
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(wgsl.into()),
    });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some(vertex),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some(fragment),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
        }),
        multiview_mask: None,
        cache: None,
    })
}
