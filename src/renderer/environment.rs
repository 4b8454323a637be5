//! The environment, renderer-wide image-based lighting: the `Renderer`
//! methods that set it and read it back. Its state (the prefiltered cube,
//! its harmonics, the split-sum table) lives in the shared
//! [`LightingResources`](oxygen_passes::LightingResources), which every
//! shading pass binds.

use oxygen_passes::EnvironmentQuality;

use super::{RenderError, Renderer};

impl Renderer {
    /// Lights the scene with an environment (image-based lighting;
    /// `None`: the constant ambient term), converted to a cube and
    /// prefiltered on the GPU at the default [`EnvironmentQuality`] (128²
    /// faces, 64 GGX samples a texel; `set_environment_with_quality` picks
    /// another). Every view's shading then takes its ambient diffuse light
    /// (nine irradiance harmonics) and specular light (the GGX levels,
    /// weighted by the split-sum table) from it — reflection probes, where
    /// a view has them, still give the specular part — and draws it behind
    /// the scene.
    pub fn set_environment(&mut self, environment: Option<&oxygen_core::Environment>) {
        self.set_environment_with_quality(environment, EnvironmentQuality::default());
    }

    /// [`Renderer::set_environment`] at a chosen quality: faces of
    /// `quality.size` (sharper mirror reflections, more memory and time)
    /// and `quality.samples` GGX samples per texel (less noise in the
    /// rough levels, more time); `examples/environment_bench.rs` measures
    /// both.
    pub fn set_environment_with_quality(
        &mut self,
        environment: Option<&oxygen_core::Environment>,
        quality: EnvironmentQuality,
    ) {
        self.lighting.set_environment(&self.gpu.device, &self.gpu.queue, environment, quality);
        self.schedules.environment_changed();
    }

    /// [`Renderer::set_environment`] with an environment prefiltered on
    /// the CPU ([`oxygen_core::Environment::prefilter`], the slow reference
    /// the GPU's is tested against), uploaded as it is.
    pub fn set_prefiltered_environment(&mut self, environment: Option<&oxygen_core::PrefilteredEnvironment>) {
        self.lighting.set_prefiltered_environment(&self.gpu.device, &self.gpu.queue, environment);
        self.schedules.environment_changed();
    }

    /// Reads the environment back as the GPU holds it (the prefiltered
    /// levels and the irradiance harmonics, half floats widened), for tools
    /// and tests; `None` without one. Waits for the GPU.
    pub fn read_environment(&self) -> Result<Option<oxygen_core::PrefilteredEnvironment>, RenderError> {
        let Some(texture) = self.lighting.environment_texture() else { return Ok(None) };
        let rgb = |image: oxygen_gpu::HdrImage| -> Vec<glam::Vec3> {
            image.pixels.iter().map(|p| glam::Vec3::new(p[0], p[1], p[2])).collect()
        };
        let mut levels = Vec::with_capacity(texture.mip_level_count() as usize);
        for level in 0..texture.mip_level_count() {
            let mut faces: [Vec<glam::Vec3>; 6] = Default::default();
            for (face, texels) in faces.iter_mut().enumerate() {
                *texels = rgb(self.gpu.read_rgba16_float_layer(texture, level, face as u32)?);
            }
            levels.push(faces);
        }
        let block = rgb(self.gpu.read_rgba16_float_layer(texture, 0, oxygen_passes::HARMONICS_LAYER)?);
        let side = texture.width() as usize;
        let irradiance_sh = std::array::from_fn(|i| block[(i / 3) * side + i % 3] * oxygen_passes::HARMONICS_SCALE);
        Ok(Some(oxygen_core::PrefilteredEnvironment { size: texture.width(), levels, irradiance_sh }))
    }

    /// Reads back the split-sum table: `(A, B)` for n·v = i / (N − 1)
    /// (column i) and roughness j / (N − 1) (row j), N =
    /// [`oxygen_passes::SPLIT_SUM_LUT_SIZE`], row by row. Waits for the GPU.
    pub fn read_split_sum_lut(&self) -> Result<Vec<glam::Vec2>, RenderError> {
        let image = self.gpu.read_rgba16_float(self.lighting.split_sum_lut())?;
        Ok(image.pixels.iter().map(|p| glam::Vec2::new(p[0], p[1])).collect())
    }
}
