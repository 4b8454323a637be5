//! Reflection probes: a position, a six-layer HDR cube with a mip chain, and
//! six face views that render straight into its layers.
//!
//! Each face view (90° perspective, one per axis direction, as in
//! [`oxygen_passes::PROBE_FACE_AXES`]) runs a depth
//! pre-pass and forward lit shading into its layer of the cube
//! (the probe-face graph); once all six have recorded, the renderer
//! GGX-prefilters the cube's levels across its faces, as the environment's
//! (`Renderer::set_probe_filter_samples`). A view
//! linked to the probe's [`ReflectionProbe::cube`] records after the faces
//! and reflects the probe. Faces are paused between updates
//! ([`ReflectionProbe::before_frame`]), so an every-N-frames probe costs
//! nothing on the other frames and keeps its last image.

use glam::{UVec2, Vec3};
use oxygen_core::{Camera, ResolvedView, Scene, ViewContext, ViewError, ViewId, ViewResolver};
use oxygen_core::{Output, ProbeCube, ProbeId};
use oxygen_gpu::ViewTargets;
use oxygen_passes::{PROBE_FACE_AXES, PROBE_FACES};

use crate::views::{TargetKind, ViewDesc};
use crate::{RenderError, Renderer};

/// When a probe re-renders its faces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbeUpdate {
    /// Every frame.
    EveryFrame,
    /// On frames 1, 1 + n, 1 + 2n, … of the probe's life.
    EveryNthFrame(u32),
    /// Only after [`ReflectionProbe::request_update`].
    OnDemand,
}

/// One face of a probe: a 90° square perspective view from the probe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeFaceResolver {
    /// Probe position.
    pub position: Vec3,
    /// Face index into `PROBE_FACE_AXES`.
    pub face: usize,
    /// Face size in pixels.
    pub resolution: u32,
    /// Near plane.
    pub near: f32,
    /// Far plane.
    pub far: f32,
}

impl ViewResolver for ProbeFaceResolver {
    fn resolve(&self, ctx: &ViewContext, _scene: &Scene) -> Result<ResolvedView, ViewError> {
        let (forward, up) = PROBE_FACE_AXES[self.face.min(PROBE_FACES - 1)];
        let view = glam::DMat4::look_to_rh(
            self.position.as_dvec3(),
            Vec3::from(forward).as_dvec3(),
            Vec3::from(up).as_dvec3(),
        );
        let camera = Camera::perspective(std::f32::consts::FRAC_PI_2, self.near, Some(self.far));
        let projection =
            camera.projection_matrix(1.0).map_err(|source| ViewError::Camera { view: ctx.view_id, source })?;
        ResolvedView::new_f64(ctx.view_id, view, projection, UVec2::splat(self.resolution), self.near, self.far)
    }
}

/// A registered reflection probe.
pub struct ReflectionProbe {
    id: ProbeId,
    faces: [ViewId; PROBE_FACES],
    update: ProbeUpdate,
    frames_seen: u64,
    update_requested: bool,
}

impl ReflectionProbe {
    /// Creates the probe's cube (`resolution`² per face, a full mip chain)
    /// and registers its six face views. Views that reflect it link to
    /// [`ReflectionProbe::cube`], before or after this call.
    pub fn register(
        renderer: &mut Renderer,
        position: Vec3,
        resolution: u32,
        depth_range: (f32, f32),
        update: ProbeUpdate,
    ) -> Result<Self, RenderError> {
        let resolution = resolution.clamp(1, renderer.gpu().device.limits().max_texture_dimension_2d);
        let texture = oxygen_gpu::texture_2d(
            &renderer.gpu().device,
            "reflection probe",
            // One spare layer on GL's account (see `array_layer_count`).
            wgpu::Extent3d {
                width: resolution,
                height: resolution,
                depth_or_array_layers: oxygen_passes::array_layer_count(PROBE_FACES as u32, true),
            },
            // A full chain: rough surfaces reflect blurrier levels.
            u32::BITS - resolution.leading_zeros(),
            ViewTargets::HDR_FORMAT,
            wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        let id = renderer.views.allocate_probe();
        let faces: [ViewId; PROBE_FACES] = std::array::from_fn(|face| {
            let resolver = ProbeFaceResolver { position, face, resolution, near: depth_range.0, far: depth_range.1 };
            let mut desc = ViewDesc::new(resolver);
            desc.target = TargetKind::ProbeFace { probe: id, face: face as u32 };
            renderer.register_probe_face(desc)
        });
        renderer.add_probe(id, faces, texture, position);
        Ok(ReflectionProbe { id, faces, update, frames_seen: 0, update_requested: true })
    }

    /// The probe's cube, for [`ViewDesc::reads`](crate::ViewDesc::reads) or
    /// [`Renderer::link`].
    pub fn cube(&self) -> Output<ProbeCube> {
        self.id.cube()
    }

    /// The probe's id.
    pub fn id(&self) -> ProbeId {
        self.id
    }

    /// The face views.
    pub fn faces(&self) -> [ViewId; PROBE_FACES] {
        self.faces
    }

    /// Gives the probe a parallax box, or takes it away
    /// ([`Renderer::set_probe_parallax`] says what it does and what it
    /// refuses).
    pub fn set_parallax_box(
        &self,
        renderer: &mut Renderer,
        parallax: Option<oxygen_core::Aabb>,
    ) -> Result<(), RenderError> {
        renderer.set_probe_parallax(self.id, parallax)
    }

    /// Asks an on-demand probe to re-render on the next frame.
    pub fn request_update(&mut self) {
        self.update_requested = true;
    }

    /// Call before each `render_frame`: activates the faces on update frames
    /// and pauses them otherwise. Returns whether they render this frame.
    pub fn before_frame(&mut self, renderer: &mut Renderer) -> Result<bool, RenderError> {
        let update = match self.update {
            ProbeUpdate::EveryFrame => true,
            ProbeUpdate::EveryNthFrame(n) => self.frames_seen.is_multiple_of(u64::from(n.max(1))),
            ProbeUpdate::OnDemand => self.update_requested,
        };
        self.frames_seen += 1;
        self.update_requested = false;
        for face in self.faces {
            renderer.set_view_active(face, update)?;
        }
        Ok(update)
    }
}
