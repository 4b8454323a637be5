//! Prefiltered cubes built on the GPU: the environment (from a procedural
//! sky or an equirectangular image) and every reflection probe go through
//! the same steps, so a rough surface reflects both alike.
//!
//! 1. **Level 0** of a scratch cube: the sky evaluated per texel, the image
//!    resampled from its own box-filtered mip chain, or a probe's freshly
//!    rendered faces copied.
//! 2. **Box mips** of the scratch cube, face by face: each level keeps the
//!    energy of the one above, so later steps can read a blurred copy at any
//!    scale.
//! 3. **GGX prefiltering** into the target's levels `1..=roughest`: level `l`
//!    holds the radiance a mirror of roughness `l / roughest` sees (the
//!    split-sum approximation with view = normal), importance-sampled across
//!    face seams with each sample read from the scratch level matching its
//!    solid angle (filtered importance sampling). The roughest level has
//!    4 × 4 faces ([`prefiltered_levels`]); smaller faces would show seams.
//! 4. For environments, **irradiance harmonics**: nine coefficients written
//!    into a 3 × 3 block of the layer after the faces (layer 6; coefficient
//!    `i` at `(i % 3, i / 3)`, divided by [`HARMONICS_SCALE`]), read by the
//!    shader.
//!
//! Each step is a full-screen triangle per face and level, so it runs on
//! every backend the renderer runs on (GL included). The CPU twin, slower
//! but the reference the tests compare against, is
//! `oxygen_core::Environment::prefilter`.

use std::collections::HashMap;
use std::sync::Mutex;

use oxygen_core::{Environment, Sky};

use super::params::CubeFilterParams;
use oxygen_gpu::ViewTargets;
use oxygen_gpu::bindings::{self, LayoutEntries};

/// The cube-building shader (self-contained: the cube layout, the
/// filter's parameter block, then its passes).
pub static CUBE_FILTER_WGSL: std::sync::LazyLock<String> =
    std::sync::LazyLock::new(|| crate::shaders::CUBE_FILTER.source());

/// Faces of a cube, in layer order +X, −X, +Y, −Y, +Z, −Z.
const FACES: u32 = 6;

/// Layer holding an environment's irradiance harmonics (after the faces).
pub const HARMONICS_LAYER: u32 = FACES;

/// The harmonics are stored divided by this: coefficient 0 is about 11 ×
/// the mean radiance, which for a bright environment would overflow a half
/// float (65 504) and turn shading into NaN; sixteen times the range keeps
/// even an environment at the half floats' limit finite. A power of two, so
/// the division costs no precision.
pub const HARMONICS_SCALE: f32 = 16.0;

/// Largest face side an environment is built at.
pub const MAX_ENVIRONMENT_SIZE: u32 = 4096;

/// Most GGX samples per texel (more would keep one draw long enough for a
/// GPU watchdog to reset the device).
pub const MAX_FILTER_SAMPLES: u32 = 4096;

/// Layers of a prefiltered environment texture: the faces and the
/// harmonics layer (seven, a shape every backend samples as an array).
const ENVIRONMENT_LAYERS: u32 = FACES + 1;

/// How finely the GPU prefilters an environment: the speed/accuracy knob of
/// image-based lighting (time in `examples/environment_bench.rs`, error
/// against the CPU reference in `tests/environment.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EnvironmentQuality {
    /// Side of level 0's faces: the sharpness of mirror reflections (a
    /// detailed panorama wants 256 or more). Rounded up to a power of two
    /// (halving exactly is what lets each box level keep the energy of the
    /// one above), from 16 to [`MAX_ENVIRONMENT_SIZE`] or the device's
    /// texture limit.
    pub size: u32,
    /// GGX samples per prefiltered texel, 1 to [`MAX_FILTER_SAMPLES`].
    pub samples: u32,
}

impl Default for EnvironmentQuality {
    fn default() -> Self {
        EnvironmentQuality { size: 128, samples: 64 }
    }
}

/// GGX samples per texel when a probe is prefiltered.
pub const PROBE_FILTER_SAMPLES: u32 = 32;

/// Mip levels of a prefiltered cube whose faces are `size` texels wide:
/// down to 4 × 4 faces (the roughest level), at least one.
pub fn prefiltered_levels(size: u32) -> u32 {
    (u32::BITS - size.max(1).leading_zeros()).saturating_sub(2).max(1)
}

const PARAMS_STRIDE: u64 = 256;
const _: () = assert!(std::mem::size_of::<CubeFilterParams>() as u64 <= PARAMS_STRIDE);

/// The pipelines, samplers and scratch cubes (cached per size: probes
/// re-filter every update).
pub(crate) struct CubeFilter {
    layout: wgpu::BindGroupLayout,
    downsample: wgpu::RenderPipeline,
    sky: wgpu::RenderPipeline,
    equirect: wgpu::RenderPipeline,
    ggx: wgpu::RenderPipeline,
    harmonics: wgpu::RenderPipeline,
    /// Trilinear, clamped to each face's edge.
    cube_sampler: wgpu::Sampler,
    /// Trilinear, wrapping in longitude.
    equirect_sampler: wgpu::Sampler,
    probe_scratch: Mutex<HashMap<u32, wgpu::Texture>>,
}

/// What a step reads: a view of the source and the pass's parameters.
struct Step<'a> {
    pipeline: &'a wgpu::RenderPipeline,
    source: &'a wgpu::TextureView,
    sampler: &'a wgpu::Sampler,
    params: &'a wgpu::Buffer,
    params_index: u32,
}

impl<'a> Step<'a> {
    fn new(
        pipeline: &'a wgpu::RenderPipeline,
        source: &'a wgpu::TextureView,
        sampler: &'a wgpu::Sampler,
        params: &'a wgpu::Buffer,
        params_index: u32,
    ) -> Self {
        Step { pipeline, source, sampler, params, params_index }
    }
}

impl CubeFilter {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        let layout = LayoutEntries::new(wgpu::ShaderStages::FRAGMENT)
            .push(bindings::texture_2d_array(bindings::FILTERABLE_FLOAT))
            .push(bindings::sampler_filtering())
            .push(bindings::dynamic_uniform_of::<CubeFilterParams>())
            .create_layout(device, "cube filter");
        let pipeline = |fragment| {
            crate::pipelines::fullscreen_pipeline(
                device,
                "cube filter",
                &layout,
                &CUBE_FILTER_WGSL,
                ("vs", fragment),
                ViewTargets::HDR_FORMAT,
            )
        };
        let sampler = |label, wrap_u| {
            device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some(label),
                address_mode_u: wrap_u,
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                mipmap_filter: wgpu::MipmapFilterMode::Linear,
                ..Default::default()
            })
        };
        CubeFilter {
            downsample: pipeline("fs_downsample"),
            sky: pipeline("fs_sky"),
            equirect: pipeline("fs_equirect"),
            ggx: pipeline("fs_ggx"),
            harmonics: pipeline("fs_harmonics"),
            layout,
            cube_sampler: sampler("cube filter", wgpu::AddressMode::ClampToEdge),
            equirect_sampler: sampler("equirect", wgpu::AddressMode::Repeat),
            probe_scratch: Mutex::new(HashMap::new()),
        }
    }

    /// Builds `environment`'s prefiltered cube: faces of `quality.size`,
    /// [`prefiltered_levels`] levels, the harmonics in layer 6. The work
    /// is recorded into `encoder`; the texture is ready once it is
    /// submitted.
    pub(crate) fn build_environment(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        environment: &Environment,
        quality: EnvironmentQuality,
    ) -> wgpu::Texture {
        let limit = device.limits().max_texture_dimension_2d.clamp(16, MAX_ENVIRONMENT_SIZE);
        // The largest power of two within the limit, then the request
        // rounded up to a power of two below it.
        let cap = 1u32 << (u32::BITS - 1 - limit.leading_zeros());
        let size = quality.size.clamp(16, cap).next_power_of_two().min(cap);
        let samples = quality.samples.clamp(1, MAX_FILTER_SAMPLES);
        let levels = prefiltered_levels(size);
        let _span = tracing::info_span!("environment_gpu_prefilter", size, levels, samples).entered();
        let scratch = scratch_cube(device, size);
        let scratch_levels = scratch.mip_level_count();

        // Parameters: entry 0 for level 0 (sky / image), entries 1.. for the
        // GGX levels, the last for the harmonics.
        let sky = match environment {
            Environment::Uniform(c) => {
                Sky { sun_direction: glam::Vec3::NEG_Y, zenith: *c, horizon: *c, ground: *c, glow: glam::Vec3::ZERO }
            }
            Environment::Sky(sky) => *sky,
            Environment::Image(_) => Sky::matched_to_sun(glam::Vec3::NEG_Y),
        };
        // Finite, non-negative and within what the half-float cube holds.
        let clean = |v: glam::Vec3| {
            let v =
                if v.is_finite() { v.clamp(glam::Vec3::ZERO, glam::Vec3::splat(65504.0)) } else { glam::Vec3::ZERO };
            v.extend(1.0).to_array()
        };
        let sun = sky.sun_direction.try_normalize().unwrap_or(glam::Vec3::NEG_Y);
        let base = CubeFilterParams {
            zenith: clean(sky.zenith),
            horizon: clean(sky.horizon),
            ground: clean(sky.ground),
            glow: clean(sky.glow),
            sun_direction: sun.extend(0.0).to_array(),
            roughness: 0.0,
            samples,
            target_size: size,
            // The box level whose faces are 32 wide (the size is a power of
            // two of at least 16): 6 × 32² reads per coefficient.
            harmonics_level: scratch_levels.saturating_sub(6),
        };
        let mut params = vec![base; levels as usize + 1];
        for (level, p) in params.iter_mut().enumerate().take(levels as usize).skip(1) {
            p.roughness = level as f32 / (levels - 1) as f32;
            p.target_size = (size >> level).max(1);
        }
        let params = params_buffer(device, &params);

        // 1. Level 0 of the scratch cube.
        let scratch_level = |level| single_level_view(&scratch, level);
        match environment {
            Environment::Image(image) => {
                let equirect = upload_equirect(device, queue, image);
                for level in 1..equirect.mip_level_count() {
                    let source = single_level_view(&equirect, level - 1);
                    let step = Step::new(&self.downsample, &source, &self.cube_sampler, &params, 0);
                    self.draw(device, encoder, &step, &equirect, level, 0..1);
                }
                let source = equirect.create_view(&array_view());
                let step = Step::new(&self.equirect, &source, &self.equirect_sampler, &params, 0);
                self.draw(device, encoder, &step, &scratch, 0, 0..FACES);
            }
            Environment::Uniform(_) | Environment::Sky(_) => {
                // The sky reads no texture; any view of the right kind binds.
                let unused = scratch_level(scratch_levels - 1);
                let step = Step::new(&self.sky, &unused, &self.cube_sampler, &params, 0);
                // Writing level 0 while level `last` is bound is allowed:
                // distinct subresources.
                self.draw(device, encoder, &step, &scratch, 0, 0..FACES);
            }
        }
        // 2. Box mips.
        self.box_mips(device, encoder, &scratch, &params);

        let target = oxygen_gpu::texture_2d(
            device,
            "environment",
            wgpu::Extent3d { width: size, height: size, depth_or_array_layers: ENVIRONMENT_LAYERS },
            levels,
            ViewTargets::HDR_FORMAT,
            wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::COPY_DST,
        );
        // 3. Level 0 is the radiance itself; the rest GGX-filtered.
        let source = scratch_level(0);
        let step = Step::new(&self.downsample, &source, &self.cube_sampler, &params, 0);
        self.draw(device, encoder, &step, &target, 0, 0..FACES);
        let whole = scratch.create_view(&array_view());
        for level in 1..levels {
            let step = Step::new(&self.ggx, &whole, &self.cube_sampler, &params, level);
            self.draw(device, encoder, &step, &target, level, 0..FACES);
        }
        // 4. Harmonics: a 3 × 3 viewport of layer 6, level 0.
        let step = Step::new(&self.harmonics, &whole, &self.cube_sampler, &params, levels);
        let view = layer_view(&target, 0, HARMONICS_LAYER);
        let mut pass = crate::pipelines::fullscreen_pass(encoder, &view, "environment harmonics");
        pass.set_viewport(0.0, 0.0, 3.0, 3.0, 0.0, 1.0);
        pass.set_scissor_rect(0, 0, 3, 3);
        self.bind(device, &mut pass, &step);
        pass.draw(0..3, 0..1);
        drop(pass);
        target
    }

    /// Re-filters a probe whose faces (level 0) were just rendered: levels
    /// `1..=mip_level_count − 3` become the GGX-prefiltered radiance
    /// (roughness `l / (mip_level_count − 3)`, as `probe_lod` in the
    /// shading shader reads them). Does nothing for a texture that is not
    /// an HDR, renderable probe with at least two prefiltered levels. A
    /// side that is not a power of two loses a little energy in the box
    /// levels the samples read (each halving rounds down).
    pub(crate) fn prefilter_probe(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        texture: &wgpu::Texture,
        samples: u32,
    ) {
        let samples = samples.clamp(1, MAX_FILTER_SAMPLES);
        let roughest = texture.mip_level_count().saturating_sub(3);
        if roughest < 1
            || texture.format() != ViewTargets::HDR_FORMAT
            || texture.width() != texture.height()
            || texture.depth_or_array_layers() < FACES
            || !texture.usage().contains(wgpu::TextureUsages::RENDER_ATTACHMENT)
        {
            return;
        }
        let _span = tracing::info_span!("probe_prefilter", size = texture.width(), samples).entered();
        let size = texture.width();
        let scratch = {
            let mut cache = self.probe_scratch.lock().unwrap_or_else(|e| e.into_inner());
            cache.entry(size).or_insert_with(|| scratch_cube(device, size)).clone()
        };
        let mut params =
            vec![CubeFilterParams { samples: samples.max(1), target_size: size, ..CubeFilterParams::default() }];
        params.extend((1..=roughest).map(|level| CubeFilterParams {
            roughness: level as f32 / roughest as f32,
            samples: samples.max(1),
            target_size: (size >> level).max(1),
            ..CubeFilterParams::default()
        }));
        let params = params_buffer(device, &params);
        let source = single_level_view(texture, 0);
        let step = Step::new(&self.downsample, &source, &self.cube_sampler, &params, 0);
        self.draw(device, encoder, &step, &scratch, 0, 0..FACES);
        self.box_mips(device, encoder, &scratch, &params);
        let whole = scratch.create_view(&array_view());
        for level in 1..=roughest {
            let step = Step::new(&self.ggx, &whole, &self.cube_sampler, &params, level);
            self.draw(device, encoder, &step, texture, level, 0..FACES);
        }
    }

    /// Levels 1.. of `cube` halved from the level above, face by face.
    fn box_mips(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        cube: &wgpu::Texture,
        params: &wgpu::Buffer,
    ) {
        for level in 1..cube.mip_level_count() {
            let source = single_level_view(cube, level - 1);
            let step = Step::new(&self.downsample, &source, &self.cube_sampler, params, 0);
            self.draw(device, encoder, &step, cube, level, 0..FACES);
        }
    }

    fn bind(&self, device: &wgpu::Device, pass: &mut wgpu::RenderPass<'_>, step: &Step<'_>) {
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cube filter"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(step.source) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(step.sampler) },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: step.params,
                        offset: 0,
                        size: wgpu::BufferSize::new(std::mem::size_of::<CubeFilterParams>() as u64),
                    }),
                },
            ],
        });
        pass.set_pipeline(step.pipeline);
        pass.set_bind_group(0, &group, &[(u64::from(step.params_index) * PARAMS_STRIDE) as u32]);
    }

    /// One pass per layer in `layers` writing level `level` of `target`.
    fn draw(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        step: &Step<'_>,
        target: &wgpu::Texture,
        level: u32,
        layers: std::ops::Range<u32>,
    ) {
        for layer in layers {
            let view = layer_view(target, level, layer);
            let mut pass = crate::pipelines::fullscreen_pass(encoder, &view, "cube filter");
            self.bind(device, &mut pass, step);
            pass.draw(3 * layer..3 * layer + 3, 0..1);
        }
    }
}

fn array_view() -> wgpu::TextureViewDescriptor<'static> {
    wgpu::TextureViewDescriptor { dimension: Some(wgpu::TextureViewDimension::D2Array), ..Default::default() }
}

/// All layers of one level, as an array: wgpu's GL backend binds a sampled
/// view as its whole texture, so a `D2` view of layer `k > 0` would read
/// layer 0 there; the shader picks the layer instead.
fn single_level_view(texture: &wgpu::Texture, level: u32) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some("cube filter source level"),
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        base_mip_level: level,
        mip_level_count: Some(1),
        ..Default::default()
    })
}

/// One layer of one level, as a render target.
fn layer_view(texture: &wgpu::Texture, level: u32, layer: u32) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some("cube filter target"),
        dimension: Some(wgpu::TextureViewDimension::D2),
        base_mip_level: level,
        mip_level_count: Some(1),
        base_array_layer: layer,
        array_layer_count: Some(1),
        ..Default::default()
    })
}

/// A six-face cube with a full box-filtered mip chain.
fn scratch_cube(device: &wgpu::Device, size: u32) -> wgpu::Texture {
    oxygen_gpu::texture_2d(
        device,
        "cube filter scratch",
        wgpu::Extent3d { width: size, height: size, depth_or_array_layers: crate::array_layer_count(FACES, true) },
        u32::BITS - size.leading_zeros(),
        ViewTargets::HDR_FORMAT,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::RENDER_ATTACHMENT,
    )
}

fn params_buffer(device: &wgpu::Device, params: &[CubeFilterParams]) -> wgpu::Buffer {
    let mut bytes = vec![0u8; params.len() * PARAMS_STRIDE as usize];
    for (chunk, p) in bytes.chunks_mut(PARAMS_STRIDE as usize).zip(params) {
        chunk[..std::mem::size_of::<CubeFilterParams>()].copy_from_slice(bytemuck::bytes_of(p));
    }
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("cube filter params"),
        size: bytes.len() as u64,
        usage: wgpu::BufferUsages::UNIFORM,
        mapped_at_creation: true,
    });
    // Mapped at creation with exactly this size.
    buffer.slice(..).get_mapped_range_mut().expect("mapped at creation").copy_from_slice(&bytes);
    buffer.unmap();
    buffer
}

/// The image as a half-float texture with a full mip chain (level 0
/// uploaded, the rest left for the box filter), halved on the CPU first
/// while a side exceeds the device's limit. Layer 1 is unused (a one-layer
/// array is a plain 2D texture on GL).
fn upload_equirect(device: &wgpu::Device, queue: &wgpu::Queue, image: &oxygen_core::EquirectImage) -> wgpu::Texture {
    let limit = device.limits().max_texture_dimension_2d.max(1);
    let (mut width, mut height) = (image.width, image.height);
    let mut texels = std::borrow::Cow::Borrowed(&image.texels);
    // The fields are public: an image built by hand may not hold what its
    // size says (`EquirectImage::new` would have refused it). Black then.
    if width == 0 || height == 0 || texels.len() as u64 != u64::from(width) * u64::from(height) {
        tracing::warn!(width, height, texels = texels.len(), "an inconsistent equirectangular image: black instead");
        (width, height, texels) = (1, 1, std::borrow::Cow::Owned(vec![glam::Vec3::ZERO]));
    }
    while width > limit || height > limit {
        let (w, h) = (width.div_ceil(2), height.div_ceil(2));
        let mut half = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                let at = |dx: u32, dy: u32| {
                    let (sx, sy) = ((2 * x + dx).min(width - 1), (2 * y + dy).min(height - 1));
                    texels[(sy * width + sx) as usize]
                };
                half.push((at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1)) * 0.25);
            }
        }
        (width, height, texels) = (w, h, std::borrow::Cow::Owned(half));
    }
    let texture = oxygen_gpu::texture_2d(
        device,
        "equirectangular environment",
        wgpu::Extent3d { width, height, depth_or_array_layers: crate::array_layer_count(1, false) },
        u32::BITS - width.max(height).leading_zeros(),
        ViewTargets::HDR_FORMAT,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_DST,
    );
    let bytes: Vec<u8> = texels
        .iter()
        .flat_map(|t| [t.x, t.y, t.z, 1.0])
        .flat_map(|v| crate::lighting::ibl::half::f32_to_f16(v).to_le_bytes())
        .collect();
    queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture: &texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        &bytes,
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(width * 8), rows_per_image: Some(height) },
        wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
    );
    texture
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_roughest_level_has_four_texel_faces() {
        assert_eq!(prefiltered_levels(128), 6);
        assert_eq!(prefiltered_levels(64), 5);
        assert_eq!(prefiltered_levels(16), 3);
        assert_eq!(prefiltered_levels(4), 1);
        assert_eq!(prefiltered_levels(1), 1);
        assert_eq!(prefiltered_levels(0), 1);
        // A renderer probe's full chain leaves two levels below the roughest.
        for size in [8u32, 64, 128, 1024] {
            let full_chain = u32::BITS - size.leading_zeros();
            assert_eq!(full_chain - 3 + 1, prefiltered_levels(size));
        }
    }
}
