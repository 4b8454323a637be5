//! Reading results back: the `Renderer` methods that read a view's draws,
//! images and prepared frame (window, probe and environment readbacks sit
//! with their subsystems).

use oxygen_bindless::SceneConstantsBuffer;
use oxygen_core::ViewId;
use oxygen_gpu::Label;
use oxygen_passes::{CommandRecorder, FrameProgress, RenderContext, ViewInputs};
use oxygen_sceneprep::{DrawMetadata, PassMask, PreparedSceneFrame};
use tracing::info_span;

use super::{RenderError, Renderer};
#[cfg(doc)]
use crate::RendererOptions;

impl Renderer {
    /// Every draw `id` drew last frame, per partition mask in canonical order
    /// ([`oxygen_sceneprep::canonical_draws`]), whichever path produced
    /// them: on a GPU visibility path the GPU's draws are read back (waits
    /// for the GPU) and joined with the CPU's transparent ones. How tests
    /// compare the GPU paths with the CPU reference.
    pub fn view_draws(&self, id: impl Into<ViewId>) -> Result<Vec<(PassMask, Vec<DrawMetadata>)>, RenderError> {
        let id = id.into();
        let frame = self.prepared_frame(id).ok_or(RenderError::NoSuchView(id))?;
        let mut all = frame.canonical_draws();
        if let Some(visibility) = &self.visibility.gpu {
            all.extend(visibility.read_draws(&self.gpu, &self.heap, frame)?);
        }
        Ok(oxygen_sceneprep::canonical_draws(all))
    }

    /// Every draw `id` drew last frame, in the order the GPU drew them
    /// (partition by partition, each in its draw order): on a GPU path the
    /// GPU's draws are read back (waits for the GPU). In the deterministic
    /// mode ([`RendererOptions::deterministic`]) every path gives the same
    /// sequence; otherwise a GPU path's order within a partition is the
    /// order its threads won their slots in.
    pub fn view_draws_in_draw_order(&self, id: impl Into<ViewId>) -> Result<Vec<DrawMetadata>, RenderError> {
        let id = id.into();
        let frame = self.prepared_frame(id).ok_or(RenderError::NoSuchView(id))?;
        let gpu_written = match &self.visibility.gpu {
            Some(visibility) => visibility.read_draws(&self.gpu, &self.heap, frame)?,
            None => Vec::new(),
        };
        // One read-back entry per GPU-written partition, in partition order.
        let mut gpu_written = gpu_written.into_iter();
        let mut out = Vec::new();
        for partition in frame.partitions() {
            if partition.gpu_count.is_some() {
                out.extend(gpu_written.next().map(|(_, draws)| draws).unwrap_or_default());
            } else {
                out.extend_from_slice(frame.draws_of(partition));
            }
        }
        Ok(out)
    }

    /// The view's colour target as an image (a batch camera's tile of its
    /// batch's atlas; waits for the GPU).
    pub fn read_color(&self, id: impl Into<ViewId>) -> Result<image::RgbaImage, RenderError> {
        let id = id.into();
        let targets = self.view_targets(id)?;
        let color = targets.color.as_ref().ok_or(RenderError::DepthOnly(id))?;
        let display = color.color.as_ref().ok_or(RenderError::NoDisplayTarget(id))?;
        Ok(match targets.tile {
            Some(tile) => self.gpu.read_rgba8_region(display, 0, (tile.x, tile.y), (targets.width, targets.height))?,
            None => self.gpu.read_rgba8(display)?,
        })
    }

    /// The view's label planes ([`crate::ViewDesc::with_labels`]): the
    /// node that drew each pixel, the surface's world normal, the node's
    /// semantic class and the surface's linear depth, each where the view
    /// draws it (waits for the GPU). Fails for a view that did not ask for
    /// labels.
    pub fn read_labels(&self, id: impl Into<ViewId>) -> Result<LabelImage, RenderError> {
        let id = id.into();
        let targets = self.view_targets(id)?;
        let labels = targets.labels.as_ref().ok_or_else(|| {
            RenderError::Unsupported(format!("{id} draws no labels (register it with ViewDesc::with_labels)"))
        })?;
        let (x, y) = targets.tile.map_or((0, 0), |t| (t.x, t.y));
        let (layer, size) = (0, (targets.width, targets.height));
        let words = |label| match labels.plane(label) {
            Some(plane) => self.gpu.read_u32_region(&plane.texture, layer, (x, y), size),
            None => Ok(Vec::new()),
        };
        let normals = match labels.plane(Label::Normal) {
            Some(plane) => {
                let normals = self.gpu.read_rgba16_float_region(&plane.texture, layer, (x, y), size)?;
                normals.pixels.iter().map(|p| [p[0], p[1], p[2]]).collect()
            }
            None => Vec::new(),
        };
        Ok(LabelImage {
            width: size.0,
            height: size.1,
            planes: labels.set(),
            instances: words(Label::Instance)?,
            normals,
            classes: words(Label::Semantic)?,
            linear_depth: words(Label::LinearDepth)?.into_iter().map(f32::from_bits).collect(),
        })
    }

    /// The node `id` showed at pixel (`x`, `y`) of its last frame (its
    /// stable id, [`oxygen_core::scene::node_index`]; `None` where no
    /// opaque or masked surface was drawn): read from the view's instance
    /// labels when it draws them ([`crate::ViewDesc::with_labels`]),
    /// otherwise from a one-pixel ID render of its last frame's draws (the
    /// camera narrowed to that pixel: [`oxygen_passes::region_camera`]),
    /// which works for any view the last frame rendered, multisampled ones
    /// included. Waits for the GPU either way.
    pub fn pick(&self, id: impl Into<ViewId>, x: u32, y: u32) -> Result<Option<u32>, RenderError> {
        let id = id.into();
        let targets = self.view_targets(id)?;
        if x >= targets.width || y >= targets.height {
            return Err(RenderError::Unsupported(format!(
                "pixel ({x}, {y}) lies outside {id}'s {} × {} image",
                targets.width, targets.height
            )));
        }
        let _span = info_span!("pick", view = %id, x, y).entered();
        let Some(plane) = targets.labels.as_ref().and_then(|l| l.plane(Label::Instance)) else {
            return self.pick_by_id_render(id, x, y);
        };
        let (ox, oy) = targets.tile.map_or((0, 0), |t| (t.x, t.y));
        let word = self.gpu.read_u32_region(&plane.texture, 0, (ox + x, oy + y), (1, 1))?;
        Ok(word.first().and_then(|w| w.checked_sub(1)))
    }

    /// [`Renderer::pick`] for a view without instance labels: its last
    /// frame's opaque and masked draws drawn again into one pixel, through
    /// its camera narrowed to that pixel.
    fn pick_by_id_render(&self, id: ViewId, x: u32, y: u32) -> Result<Option<u32>, RenderError> {
        let unavailable = |why: &str| {
            RenderError::Unsupported(format!(
                "{id} draws no instance labels, and picking without them draws its last frame again: {why}"
            ))
        };
        let (origin, shading) = self.frames.drawing.ok_or_else(|| unavailable("the last frame did not finish"))?;
        if let Some(reason) = self.frames.skipped.get(&id) {
            return Err(RenderError::Skipped { view: id, reason: reason.clone() });
        }
        // A view on a schedule keeps its image between renders, but its
        // draws are gone.
        let rendered_last = self.frames.last.iter().any(|(view, _)| *view == id);
        let prepared = self.prepared_frame(id).filter(|_| rendered_last).ok_or_else(|| {
            unavailable("the last frame did not render it (render it again, or give it instance labels to pick from)")
        })?;
        let view = self.targets.last_view(id).ok_or_else(|| self.not_rendered(id))?;
        let own = self.targets.get(id).ok_or_else(|| self.not_rendered(id))?;
        let targets = own.targets.as_ref().ok_or_else(|| self.not_rendered(id))?;
        let camera = oxygen_passes::region_camera(view, [x, y, 1, 1])
            .ok_or_else(|| unavailable("its camera cannot be narrowed to that pixel"))?;
        let device = &self.gpu.device;
        let mut constants = SceneConstantsBuffer::new(device, self.heap.scene_constants_layout(), "pick");
        constants.set_camera(&self.gpu.queue, &camera);
        constants.set_renderer(&self.gpu.queue, &own.constants.constants().renderer);
        let pixel = oxygen_passes::id_targets(device, 1, 1, true, "pick");
        let progress = FrameProgress::new([]);
        let ctx = RenderContext {
            gpu: &self.gpu,
            view,
            prepared,
            scene_constants: &own.constants,
            heap: &self.heap,
            targets,
            pipelines: &self.pipelines,
            lighting: &self.lighting,
            draw_path: self.settings.draw_path,
            inputs: ViewInputs { visibility: self.visibility.gpu.as_ref(), ..Default::default() },
            progress: &progress,
            origin,
            hdr_read_by_others: false,
            shading,
            time_seconds: 0.0,
            overlay: None,
        };
        let mut rec = CommandRecorder::new(device, "pick");
        futures::executor::block_on(oxygen_passes::record_id_render(&ctx, &pixel, &constants, &mut rec))
            .map_err(|source| RenderError::Pass { view: id, name: self.views.name(id).map(str::to_owned), source })?;
        self.gpu.queue.submit([rec.finish().0]);
        let plane =
            pixel.labels.as_ref().and_then(|l| l.plane(Label::Instance)).ok_or_else(|| unavailable("no ids"))?;
        let word = self.gpu.read_u32_region(&plane.texture, 0, (0, 0), (1, 1))?;
        Ok(word.first().and_then(|w| w.checked_sub(1)))
    }

    /// The view's depth as the GPU wrote it (reverse-Z device depth, and
    /// the pose it was rendered with, for [`DepthImage::linear`]); waits
    /// for the GPU. A multisampled view has no single-sampled depth to
    /// read ([`RenderError::Unsupported`]).
    pub fn read_depth(&self, id: impl Into<ViewId>) -> Result<DepthImage, RenderError> {
        let id = id.into();
        let targets = self.view_targets(id)?;
        if targets.msaa.is_some() {
            return Err(RenderError::Unsupported(format!("{id} is multisampled: its depth is never resolved")));
        }
        let view = *self.targets.last_view(id).ok_or_else(|| self.not_rendered(id))?;
        let (x, y) = targets.tile.map_or((0, 0), |t| (t.x, t.y));
        let layer = targets.depth_layer;
        let (width, height) = (targets.width, targets.height);
        let depth = if self.streams.depth_copy_needed {
            // The adapter cannot copy depth into a buffer: through a float texture.
            let full = (targets.depth.width(), targets.depth.height());
            let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
            let float = self.streams.depth_copy.record(&self.gpu.device, &mut encoder, &targets.depth_view, full);
            self.gpu.queue.submit([encoder.finish()]);
            self.gpu.read_u32_region(&float, 0, (x, y), (width, height))?.into_iter().map(f32::from_bits).collect()
        } else {
            self.gpu.read_depth_region(&targets.depth, layer, (x, y), (width, height))?
        };
        Ok(DepthImage { width, height, depth, view })
    }

    /// Reads back a rendered view's linear HDR target (what shading wrote,
    /// before the tone map), NaN and infinities included. Fails with
    /// [`RenderError::HdrNotWritten`] when the view's last frame tone-mapped
    /// in the shading pass (see [`RendererOptions::keep_hdr`]).
    pub fn read_hdr(&self, id: impl Into<ViewId>) -> Result<oxygen_gpu::HdrImage, RenderError> {
        let id = id.into();
        let targets = self.view_targets(id)?;
        let color = targets.color.as_ref().ok_or(RenderError::DepthOnly(id))?;
        if !self.targets.get(id).and_then(|v| v.holds).is_some_and(|h| h.hdr_written) {
            return Err(RenderError::HdrNotWritten(id));
        }
        if let Some(tile) = targets.tile {
            let size = (targets.width, targets.height);
            return Ok(self.gpu.read_rgba16_float_region(&color.hdr, 0, (tile.x, tile.y), size)?);
        }
        if color.hdr_layer != 0 {
            return Err(RenderError::NoDisplayTarget(id));
        }
        Ok(self.gpu.read_hdr_texels(&color.hdr)?)
    }

    /// A view's targets, for reading its images.
    pub(crate) fn view_targets(&self, id: ViewId) -> Result<&oxygen_gpu::ViewTargets, RenderError> {
        let known = self.views.entries.contains_key(&id) || self.shadows.views.all().any(|v| v == id);
        if !known {
            return Err(RenderError::NoSuchView(id));
        }
        self.targets.get(id).and_then(|v| v.targets.as_ref()).ok_or_else(|| self.not_rendered(id))
    }

    /// Why `id` has no image: the reason its last frame skipped it, or
    /// that no frame has rendered it yet.
    pub(crate) fn not_rendered(&self, id: ViewId) -> RenderError {
        match self.frames.skipped.get(&id) {
            Some(reason) => RenderError::Skipped { view: id, reason: reason.clone() },
            None => RenderError::NotRendered(id),
        }
    }

    /// The view's prepared frame from the last `render_frame`.
    pub fn prepared_frame(&self, id: impl Into<ViewId>) -> Option<&PreparedSceneFrame> {
        let id = id.into();
        self.prep.frames().iter().find(|f| f.view_id() == id)
    }
}

/// A view's depth as read back ([`Renderer::read_depth`]): reverse-Z device
/// depth per pixel, row by row (1 at the near plane, falling towards 0 with
/// distance; 0 where nothing was drawn), with the pose it was rendered from.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Device depth, `width × height`, row by row from the top.
    pub depth: Vec<f32>,
    /// The view as it was rendered (its projection turns device depth into
    /// distance).
    pub view: oxygen_core::ResolvedView,
}

impl DepthImage {
    /// Device depth at pixel (`x`, `y`).
    pub fn get(&self, x: u32, y: u32) -> f32 {
        self.depth[(y * self.width + x) as usize]
    }

    /// Linear depth in world units (metres for a scene in metres) at each
    /// pixel: the distance from the camera's plane along its view
    /// direction, found by unprojecting the device depth through the
    /// view's projection (perspective or orthographic, finite or infinite
    /// far plane). Pixels where nothing was drawn (depth 0 under an
    /// infinite far plane) are `f32::INFINITY`.
    pub fn linear(&self) -> Vec<f32> {
        let inverse = self.view.projection.inverse();
        // The projections a camera makes (centred or not) give clip z and
        // w from view z alone, so the pixel's place does not matter: the
        // axis stands for every pixel.
        self.depth
            .iter()
            .map(|d| {
                let p = inverse * glam::Vec4::new(0.0, 0.0, *d, 1.0);
                let z = -p.z / p.w;
                if z.is_finite() && z >= 0.0 { z } else { f32::INFINITY }
            })
            .collect()
    }
}

/// A view's labels as read back ([`Renderer::read_labels`]), row by row
/// from the top. A plane the view does not draw is empty.
#[derive(Clone, Debug, PartialEq)]
pub struct LabelImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The planes the view draws (the others are empty here).
    pub planes: oxygen_gpu::LabelSet,
    /// Per pixel: the stable id ([`oxygen_core::scene::node_index`]) of the node
    /// whose opaque or masked surface is seen there, plus one; 0 where none
    /// is (the background, or only blended surfaces).
    pub instances: Vec<u32>,
    /// Per pixel: the seen surface's world-space unit normal (facing the
    /// camera for the back of a double-sided surface); zero where nothing is.
    pub normals: Vec<[f32; 3]>,
    /// Per pixel: the semantic class of the node seen there
    /// ([`oxygen_core::Scene::set_semantic_class`]) as the GPU wrote it;
    /// 0 where none is.
    pub classes: Vec<u32>,
    /// Per pixel: the seen surface's distance from the camera's plane along
    /// its view direction, in world units, as the GPU wrote it; 0 where
    /// none is (compare [`DepthImage::linear`], computed from device depth).
    pub linear_depth: Vec<f32>,
}

impl LabelImage {
    /// The node seen at pixel (`x`, `y`) of `scene` (the scene rendered),
    /// if any.
    pub fn node(&self, scene: &oxygen_core::Scene, x: u32, y: u32) -> Option<oxygen_core::NodeKey> {
        let label = *self.instances.get((y * self.width + x) as usize)?;
        scene.node_at_index(label.checked_sub(1)?)
    }

    /// The segmentation image computed on the CPU from the instance plane
    /// and `scene`'s classes now: each pixel's node's semantic class
    /// ([`oxygen_core::Scene::set_semantic_class`]), 0 where no node is
    /// seen or the node is gone from `scene`. [`LabelImage::classes`] is
    /// the same image as the GPU wrote it, with the classes of the frame.
    pub fn semantic(&self, scene: &oxygen_core::Scene) -> Vec<u32> {
        let classes: std::collections::HashMap<u32, u32> =
            scene.nodes().map(|(key, node)| (oxygen_core::scene::node_index(key) + 1, node.semantic_class)).collect();
        self.instances.iter().map(|label| classes.get(label).copied().unwrap_or(0)).collect()
    }
}

#[cfg(test)]
mod tests {
    use oxygen_core::glam::{UVec2, Vec3};
    use oxygen_core::{Camera, LookAtResolver, Scene, ViewContext, ViewResolver};

    use super::*;

    fn view(camera: Camera, size: UVec2) -> oxygen_core::ResolvedView {
        let resolver = LookAtResolver { camera, eye: Vec3::ZERO, target: Vec3::NEG_Z, up: Vec3::Y, viewport: size };
        let ctx = ViewContext { view_id: oxygen_demo::view_id(0), frame_index: 1, time_seconds: 0.0 };
        resolver.resolve(&ctx, &Scene::new()).unwrap()
    }

    #[test]
    fn linear_depth_inverts_reverse_z_perspective_and_orthographic_projections() {
        // Reverse Z with an infinite far plane: device depth near / z.
        let near = 0.1;
        let size = UVec2::new(3, 2);
        let perspective = view(Camera::perspective(60f32.to_radians(), near, None), size);
        let depth = vec![1.0, 0.5, 0.01, 0.0, 0.2, 0.1];
        let image = DepthImage { width: 3, height: 2, depth: depth.clone(), view: perspective };
        assert_eq!(image.get(2, 0), 0.01);
        assert_eq!(image.get(0, 1), 0.0);
        assert_eq!(image.get(1, 1), 0.2);
        let linear = image.linear();
        for (i, (d, z)) in depth.iter().zip(&linear).enumerate() {
            let want = if *d == 0.0 { f32::INFINITY } else { near / d };
            // The distance along the view direction, whatever the pixel:
            // the same for each pixel of a row or column.
            assert!((z - want).abs() <= 1e-5 * want.max(1.0) || *z == want, "pixel {i}: {z}, want {want}");
        }
        // A depth no rasterizer writes (negative: behind the camera) is no
        // distance either.
        let behind = DepthImage { depth: vec![-0.5], width: 1, height: 1, ..image };
        assert_eq!(behind.linear(), [f32::INFINITY]);
        // Orthographic, near 1 and far 11: device depth 1 at 1, 0 at 11.
        let ortho = view(Camera::orthographic(4.0, 1.0, 11.0), UVec2::new(2, 1));
        let image = DepthImage { width: 2, height: 1, depth: vec![1.0, 0.25], view: ortho };
        let linear = image.linear();
        assert!((linear[0] - 1.0).abs() < 1e-5 && (linear[1] - 8.5).abs() < 1e-4, "{linear:?}");
    }

    #[test]
    fn labels_name_the_node_and_its_class_and_nothing_where_none_is() {
        let mut scene = Scene::new();
        let a = scene.add_node("a", oxygen_core::Transform::IDENTITY);
        let b = scene.add_node("b", oxygen_core::Transform::IDENTITY);
        scene.set_semantic_class(b, 7).unwrap();
        let label = |key| oxygen_core::scene::node_index(key) + 1;
        let image = LabelImage {
            width: 2,
            height: 2,
            planes: oxygen_gpu::LabelSet::of(&[Label::Instance]),
            instances: vec![0, label(a), label(b), 999],
            normals: Vec::new(),
            classes: Vec::new(),
            linear_depth: Vec::new(),
        };
        assert_eq!(image.node(&scene, 0, 0), None, "background");
        assert_eq!(image.node(&scene, 1, 0), Some(a));
        assert_eq!(image.node(&scene, 0, 1), Some(b));
        assert_eq!(image.node(&scene, 1, 1), None, "a node not in the scene");
        assert_eq!(image.node(&scene, 5, 5), None, "outside the image");
        assert_eq!(image.semantic(&scene), [0, 0, 7, 0]);
    }
}
