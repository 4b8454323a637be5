//! Deferred shading of a batch's cameras ([`DeferredShading`]): after the
//! visibility pass ([`crate::MeshPass::visibility`]) has written each
//! pixel's surface id (its draw and the vertex that starts its triangle)
//! into the page's visibility target, one compute
//! dispatch per atlas page shades every camera's pixels with the forward
//! pass's own shading code (`mesh/deferred.wgsl`) straight into the page's
//! display colour (stored through a unorm view of it, sRGB-encoded by the
//! shader).
//!
//! Why a compute pass: on GPUs that run fragment shaders on a part of the
//! chip only (the H100 and H200 have two graphics-capable TPCs), the same
//! per-pixel work runs about 30 times faster in a compute shader
//! (`examples/shading_probe.rs`), and a small camera's tiny triangles, which
//! waste most of each 2 × 2 fragment quad, cost it nothing. What it does
//! not do (and where the batch graph shades forward instead, see
//! [`DeferredShading::applies`]): multisampling, an HDR image for later
//! passes (blended surfaces, effects, linked readers), shadow maps, probes,
//! clustered lights and screen-space effects, tiles cleared alone on a page
//! that keeps other cameras' images.

use oxygen_gpu::DeferredTargets;
use tracing::{Instrument, info_span};
use wgpu::util::DeviceExt;

use super::ForwardLitConfig;
use crate::{CommandRecorder, Exposure, MeshPass, PassError, RenderContext, ShaderFeatures};

/// [`DeferredParams::flags`] bit: the environment is drawn behind the scene.
const DEFERRED_SKY: u32 = 1;
/// [`DeferredParams::flags`] bit: exact depth ties went to the later triangle.
const DEFERRED_LAST_TIE_WINS: u32 = 2;

/// The flag bits as WGSL constants (`mesh/deferred_constants`).
pub(crate) fn wgsl_constants() -> String {
    crate::shaders::compose::u32_constants(&[
        ("DEFERRED_SKY", DEFERRED_SKY),
        ("DEFERRED_LAST_TIE_WINS", DEFERRED_LAST_TIE_WINS),
    ])
}

oxygen_gpu::gpu_struct! {
    /// The deferred pass's uniform block (`mesh/deferred.wgsl`).
    #[derive(Debug, PartialEq)]
    pub(crate) struct DeferredParams: 32 bytes {
        /// Pixels of every tile.
        pub(crate) size: [u32; 2] => "vec2<u32>",
        /// Tiles dispatched.
        pub(crate) tiles: u32,
        /// `DEFERRED_SKY`: the environment is drawn behind the scene;
        /// `DEFERRED_LAST_TIE_WINS`: the visibility pass's depth test let
        /// the later of two equally deep triangles win (`GreaterEqual`, the
        /// deterministic mode; else the earlier kept the pixel).
        pub(crate) flags: u32,
        /// Display colour where nothing was drawn (tone-mapped, linear).
        pub(crate) clear: [f32; 4] => "vec4<f32>",
    }
}

oxygen_gpu::gpu_struct! {
    /// One camera's tile on a page and its constants' slot in the pass's
    /// camera array (`mesh/deferred.wgsl`).
    #[derive(Debug, PartialEq)]
    pub(crate) struct DeferredTile: 16 bytes {
        /// The tile's top-left pixel on the page.
        pub(crate) origin: [u32; 2] => "vec2<u32>",
        /// Index into the camera array.
        pub(crate) camera: u32,
        pub(crate) pad: u32,
    }
}

/// Deferred shading of the cameras of a batch: see the module's
/// documentation. Made each frame by the batch graph, like the mesh passes.
#[derive(Clone, Debug)]
pub struct DeferredShading {
    lit: ForwardLitConfig,
    exposure: Exposure,
}

impl DeferredShading {
    /// Whether the adapter of `gpu` can shade deferred at all; `Err` says
    /// why not (what registering a deferred batch answers, and why a frame
    /// is shaded forward). GL cannot: its flat varyings take a triangle's
    /// last vertex, and its compute stage binds 16 sampled textures.
    pub fn adapter_can(gpu: &oxygen_gpu::GpuContext, pipelines: &crate::Pipelines) -> Result<(), String> {
        if gpu.adapter_info.backend == wgpu::Backend::Gl {
            return Err("deferred shading is not offered on GL: its flat varyings take a triangle's last vertex \
                 (WGSL's `first` sampling, which the visibility pass needs, is missing), and its compute stage \
                 would bind 17 sampled textures, past GL's limit of 16; shade the batch forward \
                 (BatchShading::Forward)"
                .into());
        }
        pipelines.deferred_layouts(&gpu.device).map(|_| ())
    }

    /// The shading of `lit` (its clear colour and lighting switches),
    /// tone-mapped with `exposure` into the display colour.
    pub fn new(lit: ForwardLitConfig, exposure: f32) -> Self {
        DeferredShading { lit, exposure: Exposure::new(exposure) }
    }

    /// Whether these cameras can be shaded deferred this frame; `Err` says
    /// why not (the batch graph then shades them forward). They must be
    /// tiles of an atlas made with deferred shading's textures, on an
    /// adapter whose compute stage binds the shading inputs, single-sampled,
    /// their HDR image read by nothing after shading, on pages that keep no
    /// other camera's image, with draws a 32-bit surface id can name
    /// ([`oxygen_sceneprep::PreparedSceneFrame::surface_ids_fit`]), and need
    /// none of the inputs the compute pass does not bind (shadow maps,
    /// probes, clustered lights, screen-space effects).
    pub fn applies(&self, views: &[&RenderContext<'_>]) -> Result<(), String> {
        let Some(first) = views.first() else { return Ok(()) };
        Self::adapter_can(first.gpu, first.pipelines)?;
        let lit = &self.lit;
        if lit.ambient_occlusion.is_some() || lit.contact_shadows.is_some() || lit.screen_space_reflections.is_some() {
            return Err("screen-space effects are shaded forward".into());
        }
        for ctx in views {
            let id = ctx.view.view_id;
            if ctx.targets.deferred.is_none() || ctx.targets.tile.is_none() {
                return Err(format!("{id} has no deferred targets"));
            }
            if ctx.targets.msaa.is_some() {
                return Err(format!("{id} is multisampled"));
            }
            if ctx.targets.page_kept {
                return Err(format!("{id}'s page keeps other cameras' images this frame"));
            }
            ctx.prepared.surface_ids_fit()?;
            if ctx.hdr_read_after_shading() {
                return Err(format!("{id}'s HDR image is read after shading"));
            }
            if super::forward_lighting::reads_inputs(ctx, lit) || super::forward_lighting::clusters_lights(ctx, lit) {
                return Err(format!("{id} reads shadow maps, probes or light clusters"));
            }
        }
        Ok(())
    }

    /// Shades `views` (cameras of one batch, their visibility pass
    /// recorded): one dispatch per page.
    pub async fn run_batch(&self, views: &[&RenderContext<'_>], rec: &mut CommandRecorder) -> Result<(), PassError> {
        let first = views.first().map(|ctx| ctx.view.view_id);
        async { self.record(views, rec) }
            .instrument(info_span!("deferred_shading", views = views.len(), first = ?first))
            .await
    }

    fn record(&self, views: &[&RenderContext<'_>], rec: &mut CommandRecorder) -> Result<(), PassError> {
        let Some(lead) = views.first() else { return Ok(()) };
        self.applies(views).map_err(|what| PassError::BadInput { pass: "deferred shading", what })?;
        let device = &lead.gpu.device;
        // One pipeline for the batch: a feature any camera needs is kept
        // (code for an absent input computes what leaving it out does).
        let forward = MeshPass::forward_lit(self.lit.clone());
        let features =
            views.iter().map(|ctx| forward.shader_features(ctx)).fold(ShaderFeatures::NONE, ShaderFeatures::union);
        let (pipeline, layout) = lead
            .pipelines
            .deferred(device, features, self.exposure)
            .map_err(|what| PassError::BadInput { pass: "deferred shading", what })?;
        let clear = self.clear_color();
        // Cameras by page, in tile order.
        let mut pages: Vec<(u32, Vec<usize>)> = Vec::new();
        for (i, ctx) in views.iter().enumerate() {
            let page = ctx.targets.tile.map_or(0, |t| t.page);
            match pages.iter_mut().find(|(p, _)| *p == page) {
                Some((_, members)) => members.push(i),
                None => pages.push((page, vec![i])),
            }
        }
        // A dispatch's third dimension is the chunk's tiles: at most the
        // device's workgroups a dimension (65 535 on most), which a page of
        // tiny cameras on a large page can exceed.
        let per_dispatch = device.limits().max_compute_workgroups_per_dimension.max(1) as usize;
        let chunks = pages.iter().flat_map(|(_, members)| members.chunks(per_dispatch));
        for members in chunks {
            let lead = views[members[0]];
            let Some(targets) = lead.targets.deferred.as_ref() else { continue };
            let cameras: Vec<oxygen_bindless::SceneConstants> =
                members.iter().map(|i| *views[*i].scene_constants.constants()).collect();
            let tiles: Vec<DeferredTile> = members
                .iter()
                .enumerate()
                .map(|(slot, i)| {
                    let origin = views[*i].targets.tile.map_or([0, 0], |t| [t.x, t.y]);
                    DeferredTile { origin, camera: slot as u32, pad: 0 }
                })
                .collect();
            let (width, height) = (lead.targets.width, lead.targets.height);
            let params = DeferredParams {
                size: [width, height],
                tiles: tiles.len() as u32,
                // The last tie wins as in the pipeline key (mesh pass).
                flags: if lead.lighting.has_environment() { DEFERRED_SKY } else { 0 }
                    | if lead.deterministic() { DEFERRED_LAST_TIE_WINS } else { 0 },
                clear,
            };
            let group = self.page_group(lead, &layout, targets, &params, &cameras, &tiles);
            {
                let mut pass = rec.encoder().begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("deferred shading"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, lead.heap.bind_group(), &[]);
                pass.set_bind_group(1, lead.lighting.no_lighting_inputs(), &[]);
                pass.set_bind_group(2, lead.heap.texture_bind_group(), &[]);
                pass.set_bind_group(3, &group, &[]);
                pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), params.tiles);
            }
        }
        rec.stats.deferred_views += u32::try_from(views.len()).unwrap_or(u32::MAX);
        // The display colour is written and the HDR image is not, as when
        // the forward pass tone-maps in place.
        rec.stats.tone_mapped_in_pass = true;
        Ok(())
    }

    /// The forward pass's clear colour after its tone map, as the
    /// display target receives it (linear; the shader encodes sRGB).
    fn clear_color(&self) -> [f32; 4] {
        match crate::ColorOps::ClearToneMapped(self.lit.clear_color, self.exposure).load() {
            wgpu::LoadOp::Clear(c) => [c.r as f32, c.g as f32, c.b as f32, c.a as f32],
            wgpu::LoadOp::Load | wgpu::LoadOp::DontCare(_) => [0.0, 0.0, 0.0, 1.0],
        }
    }

    /// Group 3 of one page: its parameters, cameras, tiles, the index
    /// buffer, the visibility target and the page's display colour.
    fn page_group(
        &self,
        ctx: &RenderContext<'_>,
        layout: &wgpu::BindGroupLayout,
        targets: &DeferredTargets,
        params: &DeferredParams,
        cameras: &[oxygen_bindless::SceneConstants],
        tiles: &[DeferredTile],
    ) -> wgpu::BindGroup {
        let device = &ctx.gpu.device;
        let buffer = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
        };
        let params = buffer("deferred params", bytemuck::bytes_of(params), wgpu::BufferUsages::UNIFORM);
        let cameras = buffer("deferred cameras", bytemuck::cast_slice(cameras), wgpu::BufferUsages::STORAGE);
        let tiles = buffer("deferred tiles", bytemuck::cast_slice(tiles), wgpu::BufferUsages::STORAGE);
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("deferred shading"),
            layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: cameras.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: tiles.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: ctx.heap.index_buffer().as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(&targets.visibility_view),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::TextureView(&targets.color_storage_view),
                },
            ],
        })
    }
}

/// The layout of group 3 ([`DeferredShading`]'s page group).
pub(crate) fn deferred_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    use oxygen_gpu::bindings;
    oxygen_gpu::LayoutEntries::new(wgpu::ShaderStages::COMPUTE)
        .push(bindings::uniform_of::<DeferredParams>())
        .push(bindings::storage_read_only())
        .push(bindings::storage_read_only())
        .push(bindings::storage_read_only())
        .push(bindings::texture_2d(wgpu::TextureSampleType::Uint))
        .push(bindings::storage_texture_2d(DeferredTargets::SHADED_FORMAT, wgpu::StorageTextureAccess::WriteOnly))
        .create_layout(device, "deferred shading")
}
