//! Reflection probes, a subsystem of the renderer: each probe's cube and
//! position, the ids of the probes' face views (a range of the renderer's
//! own), how finely their levels are prefiltered, and the `Renderer`
//! methods about probes. [`crate::ReflectionProbe`] is the application's
//! handle on one.

use std::collections::BTreeMap;

use oxygen_core::{ViewId, ViewIdRange, ViewIds};
use oxygen_passes::{LightingResources, ProbeCubeInput, ProbeId};

use super::{RenderError, Renderer};
use crate::views::ViewDesc;

/// A probe's cube, position and parallax box.
struct ProbeResources {
    texture: wgpu::Texture,
    position: glam::Vec3,
    parallax: Option<oxygen_core::Aabb>,
}

/// The renderer's reflection probes.
pub(crate) struct Probes {
    /// Ids of the probes' face views.
    face_ids: ViewIds,
    cubes: BTreeMap<ProbeId, ProbeResources>,
    /// GGX samples per texel when a probe's levels are prefiltered.
    filter_samples: u32,
}

impl Probes {
    pub(crate) fn new() -> Self {
        Probes {
            face_ids: ViewIds::new(ViewIdRange::ProbeFace),
            cubes: BTreeMap::new(),
            filter_samples: oxygen_passes::PROBE_FILTER_SAMPLES,
        }
    }

    /// The cube `probe` renders into.
    pub(crate) fn cube(&self, probe: ProbeId) -> Option<&wgpu::Texture> {
        self.cubes.get(&probe).map(|p| &p.texture)
    }

    /// What a view linked to `probe` reads of it (`faces`: its face views).
    pub(crate) fn input(
        &self,
        probe: ProbeId,
        faces: [ViewId; oxygen_passes::PROBE_FACES],
    ) -> Option<ProbeCubeInput<'_>> {
        let resources = self.cubes.get(&probe)?;
        Some(ProbeCubeInput {
            probe,
            faces,
            texture: &resources.texture,
            position: resources.position,
            parallax: resources.parallax,
        })
    }

    /// The commands that GGX-prefilter `probe`'s levels across its faces,
    /// once all six have rendered.
    pub(crate) fn prefilter(
        &self,
        lighting: &LightingResources,
        device: &wgpu::Device,
        probe: ProbeId,
    ) -> Option<wgpu::CommandBuffer> {
        let resources = self.cubes.get(&probe)?;
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("probe prefilter") });
        lighting.prefilter_probe(device, &mut encoder, &resources.texture, self.filter_samples);
        Some(encoder.finish())
    }
}

impl Renderer {
    /// Reads back level `level` of face `face` of a reflection probe's cube
    /// (linear radiance, row by row), or `None` for an unknown probe or a
    /// level or face it does not have. Waits for the GPU.
    pub fn read_probe_face(
        &self,
        probe: ProbeId,
        face: u32,
        level: u32,
    ) -> Result<Option<Vec<glam::Vec3>>, RenderError> {
        let Some(texture) = self.probes.cube(probe) else { return Ok(None) };
        if face >= oxygen_passes::PROBE_FACES as u32 || level >= texture.mip_level_count() {
            return Ok(None);
        }
        let image = self.gpu.read_rgba16_float_layer(texture, level, face)?;
        Ok(Some(image.pixels.iter().map(|p| glam::Vec3::new(p[0], p[1], p[2])).collect()))
    }

    /// GGX samples per texel when a reflection probe's levels are
    /// prefiltered after its faces render (default
    /// [`oxygen_passes::PROBE_FILTER_SAMPLES`]; 1 to
    /// [`oxygen_passes::MAX_FILTER_SAMPLES`]): fewer cost
    /// less GPU time per probe update and leave rough reflections noisier
    /// (`environment_bench` measures both).
    pub fn set_probe_filter_samples(&mut self, samples: u32) {
        self.probes.filter_samples = samples.clamp(1, oxygen_passes::MAX_FILTER_SAMPLES);
    }

    /// Gives reflection probe `probe` a parallax box (`None`: none, the
    /// default): the world-space box its surroundings are taken to lie on,
    /// and the region it serves first. A surface inside the box reflects
    /// this probe ahead of nearer probes whose boxes do not hold it; its
    /// reflection ray is followed to where it leaves the box, and the probe
    /// is read towards that point (box projection). Without a box a probe
    /// takes everything it sees as infinitely far, which puts reflections
    /// of nearby walls in the wrong place (the accuracy atlas's
    /// "probe parallax" rows measure both against the path-traced
    /// reference). The box must be finite and hold the probe's position
    /// strictly inside; anything else is refused with
    /// [`RenderError::InvalidProbeBox`].
    pub fn set_probe_parallax(
        &mut self,
        probe: ProbeId,
        parallax: Option<oxygen_core::Aabb>,
    ) -> Result<(), RenderError> {
        let resources = self.probes.cubes.get_mut(&probe).ok_or(RenderError::NoSuchProbe(probe))?;
        if let Some(bounds) = parallax {
            let invalid = |reason| RenderError::InvalidProbeBox { probe, min: bounds.min, max: bounds.max, reason };
            if !(bounds.min.is_finite() && bounds.max.is_finite()) {
                return Err(invalid("its corners must be finite"));
            }
            if !bounds.min.cmplt(bounds.max).all() {
                return Err(invalid("it is empty: min must be below max on every axis"));
            }
            let p = resources.position;
            if !(bounds.min.cmplt(p).all() && p.cmplt(bounds.max).all()) {
                return Err(invalid("it must hold the probe's position strictly inside"));
            }
        }
        resources.parallax = parallax;
        Ok(())
    }

    /// Registers a probe's face view under an id of the renderer's own
    /// range ([`ViewIdRange::ProbeFace`]), so that it never takes an id the
    /// application's registry will hand out.
    pub(crate) fn register_probe_face(&mut self, desc: ViewDesc) -> ViewId {
        let id = self.probes.face_ids.allocate();
        self.views.register_owned(id, desc, crate::ProbeFaceGraph);
        id
    }

    /// Adds a probe whose face views are registered.
    pub(crate) fn add_probe(
        &mut self,
        id: ProbeId,
        faces: [ViewId; oxygen_passes::PROBE_FACES],
        texture: wgpu::Texture,
        position: glam::Vec3,
    ) {
        self.views.probes.insert(id, faces);
        self.probes.cubes.insert(id, ProbeResources { texture, position, parallax: None });
    }
}
