//! `OverlayPass`: the view's overlay ([`oxygen_overlay::Overlay`]: shapes,
//! text, debug lines, a grid) drawn over its final image, after the tone
//! map. The overlay is tessellated on the CPU for the view's camera; the
//! pass uploads the vertices and the atlas rows that changed and draws
//! them all at once: one render pass and one draw a view, whatever the
//! number of shapes. World shapes are depth-tested against the view's
//! depth; a multisampled view's depth does not match the display image
//! (and depth does not resolve), so there, when a shape asks for the test,
//! the view's depth is drawn again single-sampled (an ID render,
//! [`crate::record_id_render`]: the cost of a depth pre-pass) and tested
//! against. A selection outline ([`Outline`]) is found in the view's
//! instance ids by jump flooding (`post/outline.wgsl`: a seeding step and
//! one step a halving stride, in compute) and drawn first: the ids are the
//! view's instance labels when it draws them, otherwise an ID render made
//! for the outline. A view without an overlay, or with an empty one,
//! records nothing.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use glam::{DMat4, UVec2};
use oxygen_core::ViewId;
use oxygen_gpu::bindings::{self, LayoutEntries};
use oxygen_gpu::{Label, LabelTargets, ViewTargets};
use oxygen_overlay::{ATLAS_SIZE, Outline, OverlayVertex, OverlayView};
use tracing::{Instrument, info_span};

use super::params::OutlineParams;
use crate::{CommandRecorder, PassError, RenderContext, RenderPass};

/// Draws the view's overlay ([`RenderContext::overlay`]) over its display
/// image. The standard graph records it last, the batch graph last for
/// each camera (over its tile).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OverlayPass;

/// The pipelines, made on first use.
struct Made {
    layout: wgpu::BindGroupLayout,
    /// World shapes tested against the view's depth.
    with_depth: wgpu::RenderPipeline,
    /// Everything on top (a multisampled view with no tested shape).
    without_depth: wgpu::RenderPipeline,
    sampler: wgpu::Sampler,
}

/// A view's vertex buffer and atlas texture, kept across frames.
struct ViewOverlay {
    vertices: wgpu::Buffer,
    atlas: wgpu::Texture,
    bind_group: wgpu::BindGroup,
    /// The atlas generation the texture holds (`None`: nothing yet).
    generation: Option<u64>,
}

/// The overlay pass's pipelines and every view's buffers.
#[derive(Default)]
pub(crate) struct OverlayState {
    made: OnceLock<Made>,
    outline: OnceLock<OutlineMade>,
    views: Mutex<HashMap<ViewId, ViewOverlay>>,
    outlines: Mutex<HashMap<ViewId, ViewOutline>>,
    /// The ids (and depth) of the views that need them and cannot give
    /// them (an outline without instance labels, depth-tested shapes on a
    /// multisampled view), dropped when no longer needed.
    ids: Mutex<HashMap<ViewId, IdTargets>>,
    /// Each view's vertex list, kept from frame to frame: a large overlay
    /// is tessellated into memory it already has (fresh pages cost more
    /// than the tessellation, 4 times over for 10 000 shapes).
    vertex_lists: Mutex<HashMap<ViewId, Vec<OverlayVertex>>>,
}

/// A view's kept vertex list, lent for one frame and given back however
/// the pass ends.
struct VertexList<'a> {
    state: &'a OverlayState,
    view: ViewId,
    vertices: Vec<OverlayVertex>,
}

impl<'a> VertexList<'a> {
    fn lend(state: &'a OverlayState, view: ViewId) -> Self {
        let vertices = state.vertex_lists.lock().ok().and_then(|mut all| all.remove(&view)).unwrap_or_default();
        VertexList { state, view, vertices }
    }
}

impl Drop for VertexList<'_> {
    fn drop(&mut self) {
        let mut vertices = std::mem::take(&mut self.vertices);
        // Much more room than this frame used: give most of it back.
        if vertices.capacity() > 4 * vertices.len().max(1024) {
            vertices.shrink_to(2 * vertices.len());
        }
        if let Ok(mut all) = self.state.vertex_lists.lock() {
            all.insert(self.view, vertices);
        }
    }
}

/// Where a view's overlay finds the ids (and depth) the view itself does
/// not give.
#[derive(Clone)]
enum IdTargets {
    /// An ID render of its own: depth and, when asked, ids (a multisampled
    /// view, a camera of a batch).
    Own(Arc<ViewTargets>),
    /// An instance plane drawn over the view's own depth (a single-sampled
    /// view of its own targets): half the work.
    OverDepth(Arc<LabelTargets>),
}

/// The selection outline's pipelines: the flood's two steps and the
/// drawing, with and without the view's depth attached (a pass's pipelines
/// must match its attachments; the outline ignores the depth).
struct OutlineMade {
    compute_layout: wgpu::BindGroupLayout,
    draw_layout: wgpu::BindGroupLayout,
    seed: wgpu::ComputePipeline,
    flood: wgpu::ComputePipeline,
    draw_with_depth: wgpu::RenderPipeline,
    draw_without_depth: wgpu::RenderPipeline,
}

/// A view's flood buffers (two, read and written in turn) and the steps'
/// parameters, for its size.
struct ViewOutline {
    size: (u32, u32),
    seeds: [wgpu::Buffer; 2],
    params: wgpu::Buffer,
    stride: u64,
    /// The chosen nodes' bit set, regrown when a larger one comes.
    chosen: wgpu::Buffer,
}

/// Most flood steps: the first stride is the outline's width rounded up to
/// a power of two (the flood need only find chosen pixels that near), at
/// most [`oxygen_overlay::Outline::MAX_WIDTH`] + 1 → 128, so 8 steps.
const MAX_FLOOD_STEPS: u64 = 8;

impl OutlineMade {
    fn new(device: &wgpu::Device) -> OutlineMade {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("outline"),
            source: wgpu::ShaderSource::Wgsl(crate::shaders::OUTLINE.source().into()),
        });
        let uint = wgpu::TextureSampleType::Uint;
        let entries = |stages| {
            LayoutEntries::new(stages)
                .push(bindings::uniform_of::<OutlineParams>())
                .push(bindings::texture_2d(uint))
                .push(bindings::storage_read_only())
                .push(bindings::storage_read_only())
        };
        let compute_layout = entries(wgpu::ShaderStages::COMPUTE)
            .push(bindings::storage_read_write())
            .create_layout(device, "outline flood");
        let draw_layout = entries(wgpu::ShaderStages::FRAGMENT).create_layout(device, "outline");
        let compute = |entry: &str| crate::pipelines::compute_pipeline(device, &module, entry, &compute_layout);
        // Over everything: the depth, attached for the pass's shapes, is
        // not tested.
        let draw = |depth: bool| {
            over_image_pipeline(
                device,
                "outline",
                (&module, &draw_layout),
                ("vs_fullscreen", &[]),
                depth.then_some(wgpu::CompareFunction::Always),
            )
        };
        OutlineMade {
            seed: compute("seed"),
            flood: compute("flood"),
            draw_with_depth: draw(true),
            draw_without_depth: draw(false),
            compute_layout,
            draw_layout,
        }
    }
}

/// A buffer for the chosen nodes' bit set of at least `bytes`.
fn chosen_buffer(device: &wgpu::Device, bytes: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("outlined nodes"),
        size: bytes.max(16).next_multiple_of(4),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Where a view's instance ids are: a texture and the view's corner in it
/// (a batch camera's tile of its page's labels; 0 for an ID render).
struct Instances<'a> {
    view: &'a wgpu::TextureView,
    origin: [u32; 2],
}

/// Records the outline's flood for `ctx`'s view into `encoder`; returns
/// the bind group its drawing reads.
fn flood_outline(
    ctx: &RenderContext<'_>,
    state: &OverlayState,
    outline: &Outline,
    instances: Instances<'_>,
    encoder: &mut wgpu::CommandEncoder,
) -> Result<wgpu::BindGroup, PassError> {
    const PASS: &str = "overlay";
    let device = &ctx.gpu.device;
    let made = state.outline.get_or_init(|| OutlineMade::new(device));
    let (width, height) = (ctx.targets.width, ctx.targets.height);
    let pixels = u64::from(width) * u64::from(height);
    let limit = device.limits().max_storage_buffer_binding_size;
    if pixels * 4 > limit {
        return Err(PassError::BadInput {
            pass: PASS,
            what: format!(
                "an outline over {width} × {height} pixels needs more than the device's storage binding limit of \
                 {limit} bytes"
            ),
        });
    }
    let mut views = state.outlines.lock().map_err(|_| PassError::Graph("outline state poisoned".into()))?;
    if views.get(&ctx.view.view_id).is_none_or(|v| v.size != (width, height)) {
        let seeds = || {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("outline seeds"),
                size: (pixels * 4).max(16),
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            })
        };
        let stride = (size_of::<OutlineParams>() as u64)
            .next_multiple_of(u64::from(device.limits().min_uniform_buffer_offset_alignment));
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("outline steps"),
            size: stride * (MAX_FLOOD_STEPS + 1),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let chosen = chosen_buffer(device, 16);
        let view = ViewOutline { size: (width, height), seeds: [seeds(), seeds()], params, stride, chosen };
        views.insert(ctx.view.view_id, view);
    }
    let view = views.get_mut(&ctx.view.view_id).ok_or_else(|| PassError::Graph("outline state lost".into()))?;
    let bits = outline.node_bits();
    let bytes: &[u8] = bytemuck::cast_slice(&bits);
    if view.chosen.size() < bytes.len() as u64 {
        view.chosen = chosen_buffer(device, bytes.len() as u64);
    }
    ctx.gpu.queue.write_buffer(&view.chosen, 0, bytes);
    let view = &*view;
    // Strides from the width (rounded up to a power of two) down to 1:
    // chosen pixels farther than the outline is wide need not be found.
    // Entry 0 of the parameters is the seeding and the drawing.
    let mut strides = Vec::new();
    let mut stride = (outline.width.ceil() as u32 + 1).next_power_of_two();
    while stride >= 1 && (strides.len() as u64) < MAX_FLOOD_STEPS {
        strides.push(stride);
        stride /= 2;
    }
    // Where the view is drawn (its tile), then where its ids are read.
    let [lx, ly] = instances.origin;
    let origin = ctx.targets.tile.map_or([0, 0, lx, ly], |t| [t.x, t.y, lx, ly]);
    let [r, g, b, a] = outline.color.unorm8().map(|c| f32::from(c) / 255.0);
    for (i, stride) in std::iter::once(0).chain(strides.iter().copied()).enumerate() {
        let params = OutlineParams {
            size: [width, height, stride, 0],
            origin,
            color: [r, g, b, a],
            shape: [outline.width, 0.0, 0.0, 0.0],
        };
        ctx.gpu.queue.write_buffer(&view.params, view.stride * i as u64, bytemuck::bytes_of(&params));
    }
    let step = |i: usize| {
        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: &view.params,
            offset: view.stride * i as u64,
            size: wgpu::BufferSize::new(size_of::<OutlineParams>() as u64),
        })
    };
    let group = |layout: &wgpu::BindGroupLayout, i: usize, read: usize, write: Option<usize>| {
        let mut entries = vec![
            wgpu::BindGroupEntry { binding: 0, resource: step(i) },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(instances.view) },
            wgpu::BindGroupEntry { binding: 2, resource: view.chosen.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 3, resource: view.seeds[read].as_entire_binding() },
        ];
        if let Some(write) = write {
            entries.push(wgpu::BindGroupEntry { binding: 4, resource: view.seeds[write].as_entire_binding() });
        }
        device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("outline"), layout, entries: &entries })
    };
    let _span = info_span!("outline_flood", view = %ctx.view.view_id, steps = strides.len()).entered();
    let groups = (width.div_ceil(8), height.div_ceil(8));
    let mut pass =
        encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("outline"), timestamp_writes: None });
    // Seed into buffer 0 (binding 3 unread), then flood back and forth.
    pass.set_pipeline(&made.seed);
    pass.set_bind_group(0, &group(&made.compute_layout, 0, 1, Some(0)), &[]);
    pass.dispatch_workgroups(groups.0, groups.1, 1);
    let mut current = 0;
    pass.set_pipeline(&made.flood);
    for i in 0..strides.len() {
        pass.set_bind_group(0, &group(&made.compute_layout, i + 1, current, Some(1 - current)), &[]);
        pass.dispatch_workgroups(groups.0, groups.1, 1);
        current = 1 - current;
    }
    drop(pass);
    Ok(group(&made.draw_layout, 0, current, None))
}

const ATTRIBUTES: [wgpu::VertexAttribute; 5] = wgpu::vertex_attr_array![
    0 => Float32x4,
    1 => Float32x2,
    2 => Float32x4,
    3 => Unorm8x4,
    4 => Uint32,
];

const _: () = assert!(size_of::<OverlayVertex>() == 48);

/// A pipeline drawing over a view's display image with premultiplied
/// alpha (the overlay's shapes, the outline): vertex entry point and
/// buffers `vertex`, fragment `fs`, one bind group of `layout`; with
/// `depth`, the view's depth attached read-only and compared so.
fn over_image_pipeline(
    device: &wgpu::Device,
    label: &str,
    (module, layout): (&wgpu::ShaderModule, &wgpu::BindGroupLayout),
    (vertex, buffers): (&str, &[Option<wgpu::VertexBufferLayout<'_>>]),
    depth: Option<wgpu::CompareFunction>,
) -> wgpu::RenderPipeline {
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some(vertex),
            compilation_options: Default::default(),
            buffers,
        },
        primitive: Default::default(),
        depth_stencil: depth.map(|compare| wgpu::DepthStencilState {
            format: ViewTargets::DEPTH_FORMAT,
            depth_write_enabled: Some(false),
            depth_compare: Some(compare),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: ViewTargets::COLOR_FORMAT,
                blend: Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

impl Made {
    fn new(device: &wgpu::Device) -> Made {
        let layout = LayoutEntries::new(wgpu::ShaderStages::FRAGMENT)
            .push(bindings::texture_2d(bindings::FILTERABLE_FLOAT))
            .push(bindings::sampler_filtering())
            .create_layout(device, "overlay");
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("overlay"),
            source: wgpu::ShaderSource::Wgsl(crate::shaders::OVERLAY.source().into()),
        });
        let vertices = [Some(wgpu::VertexBufferLayout {
            array_stride: size_of::<OverlayVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &ATTRIBUTES,
        })];
        // Reverse-Z: a shape at least as near as the surface shows; screen
        // shapes lie on the near plane (1) and always do.
        let pipeline = |depth: bool| {
            let label = if depth { "overlay, depth-tested" } else { "overlay" };
            over_image_pipeline(
                device,
                label,
                (&module, &layout),
                ("vs", &vertices),
                depth.then_some(wgpu::CompareFunction::GreaterEqual),
            )
        };
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("overlay atlas"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        Made { with_depth: pipeline(true), without_depth: pipeline(false), layout, sampler }
    }
}

impl OverlayState {
    /// Frees the buffers of the views `keep` says no to.
    pub(crate) fn retain(&self, keep: impl Fn(ViewId) -> bool) {
        if let Ok(mut views) = self.views.lock() {
            views.retain(|view, _| keep(*view));
        }
        if let Ok(mut outlines) = self.outlines.lock() {
            outlines.retain(|view, _| keep(*view));
        }
        if let Ok(mut ids) = self.ids.lock() {
            ids.retain(|view, _| keep(*view));
        }
        if let Ok(mut lists) = self.vertex_lists.lock() {
            lists.retain(|view, _| keep(*view));
        }
    }

    /// Where `ctx`'s overlay finds its ids and depth: an instance plane
    /// over the view's own depth when that will do (`ids` and nothing
    /// else asked of a single-sampled view of its own targets), else an ID
    /// render of its own, with ids when `ids`; made or remade when what is
    /// kept does not fit.
    fn id_targets(&self, ctx: &RenderContext<'_>, ids: bool) -> Result<IdTargets, PassError> {
        let mut all = self.ids.lock().map_err(|_| PassError::Graph("overlay state poisoned".into()))?;
        let (width, height) = (ctx.targets.width, ctx.targets.height);
        let over_depth = ids && ctx.targets.msaa.is_none() && ctx.targets.tile.is_none();
        let fits = |kept: &IdTargets| match kept {
            IdTargets::OverDepth(planes) => {
                let plane = planes.plane(Label::Instance);
                over_depth && plane.is_some_and(|p| (p.texture.width(), p.texture.height()) == (width, height))
            }
            IdTargets::Own(t) => !over_depth && t.width == width && t.height == height && t.labels.is_some() == ids,
        };
        if let Some(kept) = all.get(&ctx.view.view_id).filter(|kept| fits(kept)) {
            return Ok(kept.clone());
        }
        let label = format!("{} ids", ctx.view.view_id);
        let device = &ctx.gpu.device;
        let made = match over_depth {
            true => IdTargets::OverDepth(Arc::new(LabelTargets::new(device, width, height, crate::ID_LABELS, &label))),
            false => IdTargets::Own(Arc::new(crate::id_targets(device, width, height, ids, &label))),
        };
        all.insert(ctx.view.view_id, made.clone());
        Ok(made)
    }

    /// Drops `view`'s ids and depth, when it holds any.
    fn forget_ids(&self, view: ViewId) {
        if let Ok(mut all) = self.ids.lock() {
            all.remove(&view);
        }
    }

    /// Views holding overlay buffers.
    pub(crate) fn views(&self) -> usize {
        self.views.lock().map_or(0, |views| views.len())
    }

    /// Views holding ids or a depth for their overlay.
    pub(crate) fn id_views(&self) -> usize {
        self.ids.lock().map_or(0, |ids| ids.len())
    }
}

impl RenderPass for OverlayPass {
    fn name(&self) -> &'static str {
        "overlay"
    }

    async fn run(&mut self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        // Most views have no overlay (a batch's cameras, a thousand a
        // frame): not even a span for them.
        if ctx.overlay.is_none() {
            return Ok(());
        }
        let span = info_span!("overlay", view = %ctx.view.view_id);
        self.record(ctx, rec).instrument(span).await
    }
}

impl OverlayPass {
    async fn record(&self, ctx: &RenderContext<'_>, rec: &mut CommandRecorder) -> Result<(), PassError> {
        let Some(overlay) = ctx.overlay else {
            return Ok(());
        };
        let state = ctx.lighting.overlay();
        let lock = || overlay.lock().map_err(|_| PassError::Graph("the view's overlay is poisoned".into()));
        if lock()?.is_empty() {
            state.forget_ids(ctx.view.view_id);
            return Ok(());
        }
        let color = ctx.color_targets(self.name())?;
        let target = color.color_view.as_ref().ok_or(PassError::NoColorTarget { pass: self.name() })?;
        // The view's matrices are relative to the render origin; the
        // overlay's shapes are in the world.
        let world_to_view = ctx.view.world_to_view * DMat4::from_translation(-ctx.origin);
        let camera =
            OverlayView::new(ctx.view.projection, world_to_view, UVec2::new(ctx.targets.width, ctx.targets.height));
        let mut list = VertexList::lend(state, ctx.view.view_id);
        let (outline, tested) = {
            let mut overlay = lock()?;
            overlay.tessellate_into(&camera, &mut list.vertices);
            (overlay.outline().cloned(), overlay.depth_tested())
        };
        let vertices = &list.vertices;
        if let Some(problem) = outline.as_ref().and_then(Outline::problem) {
            return Err(PassError::BadInput { pass: self.name(), what: problem });
        }
        // What the view itself cannot give: instance ids for the outline
        // (no labels drawn: not asked for, or multisampled), a
        // single-sampled depth for tested shapes on a multisampled view
        // (batch cameras are never multisampled).
        let labels = ctx.targets.labels.as_ref().and_then(|l| l.plane(Label::Instance));
        let need_ids = outline.is_some() && labels.is_none();
        let need_depth = ctx.targets.msaa.is_some() && tested && !vertices.is_empty();
        if !(need_ids || need_depth) {
            state.forget_ids(ctx.view.view_id);
        }
        if vertices.is_empty() && outline.is_none() {
            return Ok(());
        }
        let device = &ctx.gpu.device;
        let made_ids = match need_ids || need_depth {
            true => Some(state.id_targets(ctx, need_ids)?),
            false => None,
        };
        // The ID render's targets (kept) or the view's depth with an
        // instance plane (put together for this frame).
        let over_depth;
        let id_targets: Option<&ViewTargets> = match &made_ids {
            Some(IdTargets::Own(targets)) => {
                crate::record_id_render(ctx, targets, ctx.scene_constants, rec).await?;
                Some(targets)
            }
            Some(IdTargets::OverDepth(planes)) => {
                over_depth = crate::ids_over_depth(ctx.targets, planes)
                    .ok_or_else(|| PassError::Graph("ids over the depth of a view that cannot share it".into()))?;
                crate::record_ids_over_depth(ctx, &over_depth, rec).await?;
                Some(&over_depth)
            }
            None => None,
        };
        let outline = match &outline {
            Some(outline) => {
                // The view's own labels (at its tile of a batch's page), or
                // the ids drawn above (at their origin).
                let own = id_targets.as_ref().and_then(|t| t.labels.as_ref()).and_then(|l| l.plane(Label::Instance));
                let instances = match (labels, own) {
                    (Some(plane), _) => {
                        Instances { view: &plane.view, origin: ctx.targets.tile.map_or([0, 0], |t| [t.x, t.y]) }
                    }
                    (None, Some(plane)) => Instances { view: &plane.view, origin: [0, 0] },
                    (None, None) => return Err(PassError::Graph("an outline without instance ids".into())),
                };
                Some(flood_outline(ctx, state, outline, instances, rec.encoder())?)
            }
            None => None,
        };
        let mut overlay = lock()?;
        let made = state.made.get_or_init(|| Made::new(device));
        let mut views = state.views.lock().map_err(|_| PassError::Graph("overlay state poisoned".into()))?;
        let bytes: &[u8] = bytemuck::cast_slice(vertices);
        let most = device.limits().max_buffer_size;
        if bytes.len() as u64 > most {
            return Err(PassError::BadInput {
                pass: self.name(),
                what: format!(
                    "{} overlay vertices need {} bytes, more than the device's largest buffer ({most} bytes): draw \
                     fewer shapes",
                    vertices.len(),
                    bytes.len()
                ),
            });
        }
        let fits = views.get(&ctx.view.view_id).is_some_and(|v| v.vertices.size() >= bytes.len() as u64);
        if !fits {
            let atlas = oxygen_gpu::texture_2d(
                device,
                "overlay atlas",
                wgpu::Extent3d { width: ATLAS_SIZE, height: ATLAS_SIZE, depth_or_array_layers: 1 },
                1,
                wgpu::TextureFormat::Rgba8UnormSrgb,
                wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            );
            let view = atlas.create_view(&Default::default());
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("overlay"),
                layout: &made.layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&made.sampler) },
                ],
            });
            let vertices = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("overlay vertices"),
                size: (bytes.len() as u64).next_power_of_two().clamp(4096, most.max(4096)),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            views.insert(ctx.view.view_id, ViewOverlay { vertices, atlas, bind_group, generation: None });
        }
        let view = views.get_mut(&ctx.view.view_id).ok_or_else(|| PassError::Graph("overlay state lost".into()))?;
        if !bytes.is_empty() {
            ctx.gpu.queue.write_buffer(&view.vertices, 0, bytes);
        }
        // The atlas rows that changed, or all of it when the texture holds
        // another generation (or nothing yet).
        let atlas = overlay.atlas();
        let rows = match view.generation == Some(atlas.generation()) {
            true => atlas.dirty_rows(),
            false => Some(0..ATLAS_SIZE),
        };
        if let Some(rows) = rows.filter(|r| !r.is_empty()) {
            let row_bytes = ATLAS_SIZE as usize * 4;
            ctx.gpu.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &view.atlas,
                    mip_level: 0,
                    origin: wgpu::Origin3d { x: 0, y: rows.start, z: 0 },
                    aspect: wgpu::TextureAspect::All,
                },
                &atlas.pixels()[rows.start as usize * row_bytes..rows.end as usize * row_bytes],
                wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(ATLAS_SIZE * 4), rows_per_image: None },
                wgpu::Extent3d { width: ATLAS_SIZE, height: rows.end - rows.start, depth_or_array_layers: 1 },
            );
        }
        view.generation = Some(atlas.generation());
        overlay.atlas_mut().mark_uploaded();

        // The view's depth, or the ID render's for a multisampled view
        // (none when no shape is tested: everything on top).
        let depth = match (&ctx.targets.msaa, &id_targets) {
            (None, _) => Some(&ctx.targets.depth_view),
            (Some(_), Some(ids)) if need_depth => Some(&ids.depth_view),
            (Some(_), _) => None,
        };
        let mut rec_draws = 0;
        let mut pass = rec.encoder().begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("overlay"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: depth.map(|view| wgpu::RenderPassDepthStencilAttachment {
                view,
                depth_ops: None,
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        // A batch camera's own rectangle of the shared page.
        if let Some(tile) = ctx.targets.tile {
            let (w, h) = (ctx.targets.width, ctx.targets.height);
            pass.set_viewport(tile.x as f32, tile.y as f32, w as f32, h as f32, 0.0, 1.0);
            pass.set_scissor_rect(tile.x, tile.y, w, h);
        }
        // The outline first: shapes are drawn over it.
        if let (Some(group), Some(made)) = (&outline, state.outline.get()) {
            pass.set_pipeline(if depth.is_some() { &made.draw_with_depth } else { &made.draw_without_depth });
            pass.set_bind_group(0, group, &[]);
            pass.draw(0..3, 0..1);
            rec_draws += 1;
        }
        if !vertices.is_empty() {
            pass.set_pipeline(if depth.is_some() { &made.with_depth } else { &made.without_depth });
            pass.set_bind_group(0, &view.bind_group, &[]);
            pass.set_vertex_buffer(0, view.vertices.slice(..bytes.len() as u64));
            pass.draw(0..vertices.len() as u32, 0..1);
            rec_draws += 1;
        }
        drop(pass);
        rec.stats.render_passes += 1;
        rec.stats.draw_calls += rec_draws;
        rec.stats.overlay_vertices += vertices.len() as u64;
        Ok(())
    }
}
