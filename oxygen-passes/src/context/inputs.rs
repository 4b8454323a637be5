//! What a view reads from the other views of the frame: the typed outputs
//! ([`OutputKind`]) a graph awaits through [`crate::RenderContext::input`],
//! and the per-view inputs the renderer hands each view (its cascades, the
//! local shadow atlas, its linked probes and views).

use oxygen_core::{
    Color, Depth, HdrColor, InstanceIds, LinearDepth, Normals, OutputSource, ProbeCube, ProbeId, ResolvedView,
    SemanticClasses, ShadowMap, ViewId,
};
use oxygen_gpu::{Label, ViewTargets};

/// What kinds of output exist and how a view's inputs find them.
pub trait OutputKind: 'static {
    /// What reading it gives.
    type Value<'a>;
    /// Name for errors.
    const NAME: &'static str;
    /// The value and the views that must have recorded first.
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)>;
}

fn linked_view<'i, 'a>(inputs: &'i ViewInputs<'a>, source: OutputSource) -> Option<&'i LinkedView<'a>> {
    let OutputSource::View(id) = source else { return None };
    inputs.views.iter().find(|v| v.id == id)
}

impl OutputKind for Depth {
    type Value<'a> = (&'a ResolvedView, &'a wgpu::TextureView);
    const NAME: &'static str = "depth";
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)> {
        let v = linked_view(inputs, source)?;
        // A multisampled view's single-sample depth is never written (depth
        // does not resolve): there is no depth output to read.
        if v.targets.msaa.is_some() {
            return None;
        }
        Some(((v.view, &v.targets.depth_view), vec![v.id]))
    }
}

impl OutputKind for HdrColor {
    type Value<'a> = (&'a ResolvedView, &'a wgpu::TextureView);
    const NAME: &'static str = "HDR colour";
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)> {
        let v = linked_view(inputs, source)?;
        Some(((v.view, &v.targets.color.as_ref()?.hdr_view), vec![v.id]))
    }
}

/// An image another view rendered, where it lies: a texture (a whole
/// page for a camera of a batch) and the view's rectangle in it.
#[derive(Clone, Debug)]
pub struct LinkedImage<'a> {
    /// The view that rendered it (relative to the render origin).
    pub view: &'a ResolvedView,
    /// The texture view holding it.
    pub image: &'a wgpu::TextureView,
    /// The view's rectangle in it, in pixels: `[x, y, width, height]`.
    pub rect: [u32; 4],
    /// The size of the whole texture, in pixels.
    pub size: [u32; 2],
}

impl<'a> LinkedImage<'a> {
    fn of(v: &LinkedView<'a>, image: &'a wgpu::TextureView, texture: &wgpu::Texture) -> Self {
        let (x, y) = v.targets.tile.map_or((0, 0), |t| (t.x, t.y));
        LinkedImage {
            view: v.view,
            image,
            rect: [x, y, v.targets.width, v.targets.height],
            size: [texture.width(), texture.height()],
        }
    }
}

impl OutputKind for Color {
    type Value<'a> = LinkedImage<'a>;
    const NAME: &'static str = "colour";
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)> {
        let v = linked_view(inputs, source)?;
        let color = v.targets.color.as_ref()?;
        Some((LinkedImage::of(v, color.color_view.as_ref()?, color.color.as_ref()?), vec![v.id]))
    }
}

/// A label plane of a linked view, when it draws that plane.
fn label_plane<'a>(
    inputs: &ViewInputs<'a>,
    source: OutputSource,
    label: Label,
) -> Option<(LinkedImage<'a>, Vec<ViewId>)> {
    let v = linked_view(inputs, source)?;
    let plane = v.targets.labels.as_ref()?.plane(label)?;
    Some((LinkedImage::of(v, &plane.view, &plane.texture), vec![v.id]))
}

impl OutputKind for InstanceIds {
    type Value<'a> = LinkedImage<'a>;
    const NAME: &'static str = "instance labels";
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)> {
        label_plane(inputs, source, Label::Instance)
    }
}

impl OutputKind for Normals {
    type Value<'a> = LinkedImage<'a>;
    const NAME: &'static str = "normal labels";
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)> {
        label_plane(inputs, source, Label::Normal)
    }
}

impl OutputKind for SemanticClasses {
    type Value<'a> = LinkedImage<'a>;
    const NAME: &'static str = "semantic-class labels";
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)> {
        label_plane(inputs, source, Label::Semantic)
    }
}

impl OutputKind for LinearDepth {
    type Value<'a> = LinkedImage<'a>;
    const NAME: &'static str = "linear-depth labels";
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)> {
        label_plane(inputs, source, Label::LinearDepth)
    }
}

impl OutputKind for ShadowMap {
    type Value<'a> = ShadowMapInput<'a>;
    const NAME: &'static str = "shadow map";
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)> {
        let OutputSource::View(id) = source else { return None };
        let own = inputs.cascades.iter().chain(inputs.local_shadows.iter().flat_map(|l| l.tiles.iter().flatten()));
        if let Some(map) = own.into_iter().find(|m| m.producer == id) {
            return Some((map.clone(), vec![id]));
        }
        let v = linked_view(inputs, source)?;
        let map =
            ShadowMapInput { producer: v.id, view: v.view, depth: &v.targets.depth_view, resolution: v.targets.width };
        Some((map, vec![v.id]))
    }
}

impl OutputKind for ProbeCube {
    type Value<'a> = ProbeCubeInput<'a>;
    const NAME: &'static str = "probe cube";
    fn find<'a>(inputs: &ViewInputs<'a>, source: OutputSource) -> Option<(Self::Value<'a>, Vec<ViewId>)> {
        let OutputSource::Probe(id) = source else { return None };
        let probe = inputs.probes.iter().find(|p| p.probe == id)?;
        Some((probe.clone(), probe.faces.to_vec()))
    }
}

/// A shadow map another view rendered.
#[derive(Clone, Debug)]
pub struct ShadowMapInput<'a> {
    /// The shadow view that rendered it.
    pub producer: ViewId,
    /// The light's view (relative to the render origin).
    pub view: &'a ResolvedView,
    /// Its depth (a whole target, or one layer of the local shadow atlas).
    pub depth: &'a wgpu::TextureView,
    /// Texels a side.
    pub resolution: u32,
}

/// The frame's local-light shadow maps: one atlas, one layer per tile.
#[derive(Clone, Debug)]
pub struct LocalShadowsInput<'a> {
    /// The atlas as a 2D array.
    pub atlas: &'a wgpu::TextureView,
    /// Per tile (atlas layer): the shadow view rendering it, if any this frame.
    pub tiles: Vec<Option<ShadowMapInput<'a>>>,
}

/// A reflection probe a view is linked to.
#[derive(Clone, Debug)]
pub struct ProbeCubeInput<'a> {
    /// The probe.
    pub probe: ProbeId,
    /// Its face views (+X, −X, +Y, −Y, +Z, −Z).
    pub faces: [ViewId; crate::PROBE_FACES],
    /// Six-layer HDR texture with its mip chain.
    pub texture: &'a wgpu::Texture,
    /// Its world position.
    pub position: glam::Vec3,
    /// Its parallax box (world space), when it has one: its surroundings
    /// lie on the box's faces, and it serves the points inside first.
    pub parallax: Option<oxygen_core::Aabb>,
}

/// A view this view is linked to, with its targets.
#[derive(Clone, Copy)]
pub struct LinkedView<'a> {
    /// The view.
    pub id: ViewId,
    /// Its resolved view (relative to the render origin).
    pub view: &'a ResolvedView,
    /// Its targets.
    pub targets: &'a ViewTargets,
}

/// What the renderer's features hand one view this frame: what it may read
/// from the other views (its cascades, the local shadow atlas, its linked
/// probes and views), GPU visibility's state for it and the reference
/// tracer. A feature that
/// gives views something adds it here, typed, not to
/// [`crate::RenderContext`].
#[derive(Clone, Default)]
pub struct ViewInputs<'a> {
    /// The view's own sun-shadow cascades, nearest first (empty when it
    /// asked for none or no directional light casts shadows this frame).
    pub cascades: Vec<ShadowMapInput<'a>>,
    /// The frame's local-light shadow maps, when any light casts them.
    pub local_shadows: Option<LocalShadowsInput<'a>>,
    /// The reflection probes the view is linked to, in link order.
    pub probes: Vec<ProbeCubeInput<'a>>,
    /// The views the view is linked to.
    pub views: Vec<LinkedView<'a>>,
    /// GPU visibility, when the renderer has it: the view's count buffers
    /// of GPU-written partitions, and phase 2 of occlusion culling.
    pub visibility: Option<&'a crate::GpuVisibility>,
    /// The path-traced reference's scene and samples, when a view of the
    /// renderer is path traced ([`crate::ReferencePass`]).
    pub reference: Option<&'a crate::ReferenceTracer>,
}
