//! Typed outputs of views: what a render graph names to read another view's
//! result. A view's id is its handle: [`ViewId::depth`], [`ViewId::hdr`] and
//! [`ViewId::shadow_map`] name its outputs; a reflection probe's cube is
//! named by its [`ProbeId`]. The renderer orders views by these links.

use crate::ViewId;

/// Identifies a reflection probe registered with a renderer. Opaque, like
/// [`ViewId`]: ids come from a [`ProbeIds`] allocator (the registry of views
/// holds one), never from a number.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ProbeId(u32);

impl std::fmt::Display for ProbeId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "probe#{}", self.0)
    }
}

// As for view ids: the Display form says it all, and keeps lists short.
impl std::fmt::Debug for ProbeId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(self, f)
    }
}

/// Hands out probe ids, each once, in order.
#[derive(Clone, Debug, Default)]
pub struct ProbeIds {
    next: u32,
}

impl ProbeIds {
    /// A fresh id. After 2³² ids the numbers start over.
    pub fn allocate(&mut self) -> ProbeId {
        let id = ProbeId(self.next);
        self.next = self.next.wrapping_add(1);
        id
    }
}

/// Whose output a link names: one view's, or a probe's (its six faces).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum OutputSource {
    /// A view's targets.
    View(ViewId),
    /// A reflection probe's cube, rendered by its face views.
    Probe(ProbeId),
}

impl std::fmt::Display for OutputSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            OutputSource::View(v) => v.fmt(f),
            OutputSource::Probe(p) => p.fmt(f),
        }
    }
}

/// A typed output of a view (or a probe): what a graph names to read it.
/// `K` says what it is: [`Depth`], [`HdrColor`], [`ShadowMap`] or
/// [`ProbeCube`].
pub struct Output<K> {
    /// Who produces it.
    pub source: OutputSource,
    kind: std::marker::PhantomData<fn() -> K>,
}

impl<K> Clone for Output<K> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<K> Copy for Output<K> {}
impl<K> std::fmt::Debug for Output<K> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Output<{}>({})", std::any::type_name::<K>().rsplit("::").next().unwrap_or("?"), self.source)
    }
}
impl<K> PartialEq for Output<K> {
    fn eq(&self, other: &Self) -> bool {
        self.source == other.source
    }
}

impl<K> Output<K> {
    /// The output of `source`.
    pub fn new(source: OutputSource) -> Self {
        Output { source, kind: std::marker::PhantomData }
    }
}

/// The depth target of a view (reverse-Z).
pub enum Depth {}
/// The linear HDR colour target of a view.
pub enum HdrColor {}
/// The shadow map a depth-only view rendered (its depth, where it lives:
/// its own target or its atlas layer), with the light's view.
pub enum ShadowMap {}
/// A reflection probe's six-layer cube with its mip chain.
pub enum ProbeCube {}
/// The displayable (tone-mapped, sRGB) colour of a view: its final image.
pub enum Color {}
/// The instance labels of a view that draws labels: the node seen at each
/// pixel (its stable id plus one, 0 for none).
pub enum InstanceIds {}
/// The normal labels of a view that draws labels: the world-space normal
/// seen at each pixel.
pub enum Normals {}
/// The semantic-class labels of a view that draws them: the class
/// (`Scene::set_semantic_class`) of the node seen at each pixel, 0 for none.
pub enum SemanticClasses {}
/// The linear-depth labels of a view that draws them: each pixel's distance
/// from the camera's plane along its view direction in world units, 0
/// where nothing was drawn, as the bits of an `f32` in an `R32Uint`
/// texture (`bitcast<f32>` in WGSL).
pub enum LinearDepth {}

impl ViewId {
    /// This view's depth target.
    pub fn depth(self) -> Output<Depth> {
        Output::new(OutputSource::View(self))
    }

    /// This view's linear HDR colour target.
    pub fn hdr(self) -> Output<HdrColor> {
        Output::new(OutputSource::View(self))
    }

    /// This view's final, displayable colour (what `read_color` reads):
    /// for insets and picture-in-picture (a composition pass draws it into
    /// a rectangle of another view).
    pub fn color(self) -> Output<Color> {
        Output::new(OutputSource::View(self))
    }

    /// This view's instance labels (a view registered with labels).
    pub fn instance_ids(self) -> Output<InstanceIds> {
        Output::new(OutputSource::View(self))
    }

    /// This view's normal labels (a view registered with labels).
    pub fn normals(self) -> Output<Normals> {
        Output::new(OutputSource::View(self))
    }

    /// This view's semantic-class labels (a view registered with them).
    pub fn semantic_classes(self) -> Output<SemanticClasses> {
        Output::new(OutputSource::View(self))
    }

    /// This view's linear-depth labels (a view registered with them).
    pub fn linear_depth(self) -> Output<LinearDepth> {
        Output::new(OutputSource::View(self))
    }

    /// This (depth-only) view's shadow map.
    pub fn shadow_map(self) -> Output<ShadowMap> {
        Output::new(OutputSource::View(self))
    }
}

impl ProbeId {
    /// The probe's cube.
    pub fn cube(self) -> Output<ProbeCube> {
        Output::new(OutputSource::Probe(self))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::{ViewIdRange, ViewIds};

    /// Ids print as their kind and number, in both forms: lists of ids in
    /// `{:?}` (frame reports, errors) stay short and readable.
    #[test]
    fn probe_ids_print_as_probe_and_number_in_display_and_debug() {
        let mut ids = ProbeIds::default();
        let first = ids.allocate();
        let second = ids.allocate();
        assert_eq!(first.to_string(), "probe#0");
        assert_eq!(format!("{second}"), "probe#1");
        assert_eq!(format!("{:?}", [first, second]), "[probe#0, probe#1]");
    }

    #[test]
    fn an_output_source_prints_as_the_view_or_probe_it_names() {
        let view = ViewIds::new(ViewIdRange::Shadow).allocate();
        let probe = ProbeIds::default().allocate();
        assert_eq!(OutputSource::View(view).to_string(), "shadow-view#0");
        assert_eq!(OutputSource::Probe(probe).to_string(), "probe#0");
    }

    /// The Debug form names the output's kind (the last segment of its type
    /// name) and its source.
    #[test]
    fn an_outputs_debug_text_names_its_kind_and_source() {
        let mut views = ViewIds::default();
        let _ = views.allocate();
        let view = views.allocate();
        assert_eq!(format!("{:?}", view.depth()), "Output<Depth>(view#1)");
        assert_eq!(format!("{:?}", view.shadow_map()), "Output<ShadowMap>(view#1)");
        let probe = ProbeIds::default().allocate();
        assert_eq!(format!("{:?}", probe.cube()), "Output<ProbeCube>(probe#0)");
    }

    /// Two outputs of one kind are equal exactly when they name the same source.
    #[test]
    fn outputs_are_equal_when_their_sources_are() {
        let mut views = ViewIds::default();
        let a = views.allocate();
        let b = views.allocate();
        assert_eq!(a.hdr(), a.hdr());
        assert_ne!(a.hdr(), b.hdr());
        let mut probes = ProbeIds::default();
        let p = probes.allocate();
        let q = probes.allocate();
        assert_eq!(p.cube(), p.cube());
        assert_ne!(p.cube(), q.cube());
        assert_ne!(Output::<HdrColor>::new(OutputSource::Probe(p)), a.hdr());
    }
}
