//! The cached pipelines that are not mesh variants: the tone map and the
//! environment drawn behind the scene.

use std::sync::atomic::Ordering;

use oxygen_gpu::bindings::{self, LayoutEntries};

use super::{PassKind, PipelineKey, PipelineVariant, Pipelines, fullscreen_pipeline};
use crate::post::TONEMAP_WGSL;

impl Pipelines {
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
        let layout = LayoutEntries::new(wgpu::ShaderStages::FRAGMENT)
            .push(bindings::texture_2d(bindings::UNFILTERABLE_FLOAT))
            .push(bindings::uniform())
            .create_layout(device, "tonemap");
        let pipeline =
            fullscreen_pipeline(device, "tonemap", &layout, &TONEMAP_WGSL, ("vs_fullscreen", "fs_tonemap"), output);
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
        let module = self.module(device, PassKind::Shading, &key.features);
        let constants = PipelineKey { pass: PassKind::Shading, ..key }.override_constants();
        // A pass that writes labels has their targets too; the sky leaves
        // them as cleared (no node: 0).
        let targets = pass_targets(key, wgpu::ColorWrites::ALL, wgpu::ColorWrites::empty());
        let entry_points = ("vs_sky", "fs_sky");
        let pipeline =
            self.full_screen_pipeline(device, "sky", &module, entry_points, &constants, &targets, key, false);
        self.created.fetch_add(1, Ordering::Relaxed);
        self.sky.lock().unwrap_or_else(|e| e.into_inner()).insert(key, pipeline.clone());
        pipeline
    }

    /// The pipeline that clears one batch camera's tile in a pass that
    /// loads its atlas page (other tiles keep their images this frame): the
    /// targets of the shading pass of `key`, `color` written where given
    /// (left as it is otherwise), zero labels, depth 0 (reverse-Z far) with
    /// an always-passing test. The shading module's `vs_tile_clear` and
    /// `fs_tile_clear`, drawn scissored to the tile before its meshes.
    pub fn tile_clear(&self, device: &wgpu::Device, key: PipelineKey, color: Option<[f32; 4]>) -> wgpu::RenderPipeline {
        let key = PipelineKey { variant: PipelineVariant::from_mask(oxygen_sceneprep::PassMask::OPAQUE), ..key };
        let cache_key = (key, color.map(|c| c.map(f32::to_bits)));
        if let Some(p) = self.tile_clear.lock().unwrap_or_else(|e| e.into_inner()).get(&cache_key) {
            return p.clone();
        }
        let module = self.module(device, PassKind::Shading, &key.features);
        let mut constants = PipelineKey { pass: PassKind::Shading, ..key }.override_constants();
        let [r, g, b, a] = color.unwrap_or_default();
        constants.extend(
            [("TILE_CLEAR_R", r), ("TILE_CLEAR_G", g), ("TILE_CLEAR_B", b), ("TILE_CLEAR_A", a)]
                .map(|(n, v)| (n, f64::from(v))),
        );
        let color_writes = if color.is_some() { wgpu::ColorWrites::ALL } else { wgpu::ColorWrites::empty() };
        let targets = pass_targets(key, color_writes, wgpu::ColorWrites::ALL);
        let entry_points = ("vs_tile_clear", "fs_tile_clear");
        let pipeline =
            self.full_screen_pipeline(device, "tile clear", &module, entry_points, &constants, &targets, key, true);
        self.created.fetch_add(1, Ordering::Relaxed);
        self.tile_clear.lock().unwrap_or_else(|e| e.into_inner()).insert(cache_key, pipeline.clone());
        pipeline
    }

    /// A full-screen triangle of the shading module in a mesh pass of
    /// `key` (its depth format and samples): depth tested always, written
    /// when `depth_write`; the sky's and the tile clear's.
    #[allow(clippy::too_many_arguments)]
    fn full_screen_pipeline(
        &self,
        device: &wgpu::Device,
        label: &str,
        module: &wgpu::ShaderModule,
        (vertex, fragment): (&str, &str),
        constants: &[(&str, f64)],
        targets: &[Option<wgpu::ColorTargetState>],
        key: PipelineKey,
        depth_write: bool,
    ) -> wgpu::RenderPipeline {
        let options = || wgpu::PipelineCompilationOptions { constants, ..Default::default() };
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(&self.layout),
            vertex: wgpu::VertexState {
                module,
                entry_point: Some(vertex),
                compilation_options: options(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: key.depth_format,
                depth_write_enabled: Some(depth_write),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: wgpu::MultisampleState { count: key.samples.max(1), ..Default::default() },
            fragment: Some(wgpu::FragmentState {
                module,
                entry_point: Some(fragment),
                compilation_options: options(),
                targets,
            }),
            multiview_mask: None,
            cache: None,
        })
    }
}

/// The colour targets of a mesh pass of `key`, for a full-screen pipeline
/// drawn inside it: its colour (none at all for a depth-only pass) written
/// with `color_writes`, then the label planes a shading pass writes, with
/// `label_writes`.
fn pass_targets(
    key: PipelineKey,
    color_writes: wgpu::ColorWrites,
    label_writes: wgpu::ColorWrites,
) -> Vec<Option<wgpu::ColorTargetState>> {
    let color = key.color_format.map(|format| wgpu::ColorTargetState { format, blend: None, write_mask: color_writes });
    let mut targets: Vec<_> = color.into_iter().map(Some).collect();
    if matches!(key.pass, PassKind::Shading | PassKind::ShadingAfterPrePass) && !key.labels.is_empty() {
        if targets.is_empty() {
            targets.push(None);
        }
        targets.extend(super::cache::label_targets(key.labels, label_writes));
    }
    targets
}
