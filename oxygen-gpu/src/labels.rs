//! Per-pixel labels: the images a view may draw beside its colour (which
//! node is seen, its normal, its semantic class, its distance), each a
//! plane of its own so that a view pays only for the planes it asks for.

/// One kind of per-pixel label.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Label {
    /// The stable id of the node seen at the pixel plus one, 0 where no
    /// opaque or masked surface was drawn (`R32Uint`).
    Instance,
    /// The seen surface's world-space unit normal in `xyz`, `w` 1 where a
    /// surface was drawn and 0 elsewhere (`Rgba16Float`).
    Normal,
    /// The seen node's semantic class (`Scene::set_semantic_class`), 0
    /// where nothing was drawn (`R32Uint`).
    Semantic,
    /// The distance from the camera's plane along its view direction, in
    /// world units (metres for a scene in metres), 0 where nothing was
    /// drawn: the bits of an `f32` in an `R32Uint` texture, which every
    /// backend can render into (GL's downlevel rules forbid rendering into
    /// `R32Float`) and which keeps the value exact.
    LinearDepth,
}

impl Label {
    /// Every label, in the order of their colour attachments (after the
    /// colour in the shading pass, from location 0 in the labels pass).
    pub const ALL: [Label; 4] = [Label::Instance, Label::Normal, Label::Semantic, Label::LinearDepth];

    /// The plane's texture format.
    pub const fn format(self) -> wgpu::TextureFormat {
        match self {
            Label::Instance | Label::Semantic | Label::LinearDepth => wgpu::TextureFormat::R32Uint,
            Label::Normal => wgpu::TextureFormat::Rgba16Float,
        }
    }

    /// Bytes a pixel of the plane takes.
    pub const fn bytes_per_pixel(self) -> u64 {
        match self {
            Label::Normal => 8,
            _ => 4,
        }
    }

    /// A short name, for texture labels and messages.
    pub const fn name(self) -> &'static str {
        match self {
            Label::Instance => "instances",
            Label::Normal => "normals",
            Label::Semantic => "semantic classes",
            Label::LinearDepth => "linear depth",
        }
    }

    const fn bit(self) -> u8 {
        1 << self as u8
    }
}

/// Which label planes a view draws: a small set of [`Label`]s.
#[derive(Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct LabelSet(u8);

impl LabelSet {
    /// No labels.
    pub const NONE: LabelSet = LabelSet(0);
    /// Every label.
    pub const ALL: LabelSet =
        LabelSet(Label::Instance.bit() | Label::Normal.bit() | Label::Semantic.bit() | Label::LinearDepth.bit());

    /// The set of `labels`.
    pub fn of(labels: &[Label]) -> Self {
        LabelSet(labels.iter().fold(0, |bits, l| bits | l.bit()))
    }

    /// This set with `label` added.
    pub const fn with(self, label: Label) -> Self {
        LabelSet(self.0 | label.bit())
    }

    /// The labels of either set.
    pub const fn union(self, other: LabelSet) -> Self {
        LabelSet(self.0 | other.0)
    }

    /// Whether `label` is in the set.
    pub const fn contains(self, label: Label) -> bool {
        self.0 & label.bit() != 0
    }

    /// Whether the set is empty.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The labels in the set, in [`Label::ALL`] order.
    pub fn iter(self) -> impl Iterator<Item = Label> {
        Label::ALL.into_iter().filter(move |l| self.contains(*l))
    }

    /// Bytes a pixel of the set's planes takes.
    pub fn bytes_per_pixel(self) -> u64 {
        self.iter().map(Label::bytes_per_pixel).sum()
    }
}

impl std::fmt::Debug for LabelSet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_set().entries(self.iter()).finish()
    }
}

/// One label plane: its texture (for a tile, its atlas page's whole
/// texture) and the view passes render into.
#[derive(Clone)]
pub struct LabelPlane {
    /// The texture ([`Label::format`]).
    pub texture: wgpu::Texture,
    /// The view of `texture` passes render into.
    pub view: wgpu::TextureView,
}

/// The label planes of a view or an atlas page: one texture per label the
/// view asked for.
#[derive(Clone)]
pub struct LabelTargets {
    planes: [Option<LabelPlane>; 4],
}

impl LabelTargets {
    /// Label textures of `width × height` for the labels of `set`.
    pub fn new(device: &wgpu::Device, width: u32, height: u32, set: LabelSet, label: &str) -> Self {
        let size = wgpu::Extent3d { width, height, depth_or_array_layers: 1 };
        // Copy source: streamed and read back; sampled: linked views read them.
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC;
        let planes = Label::ALL.map(|kind| {
            set.contains(kind).then(|| {
                let name = format!("{label} {}", kind.name());
                let texture = crate::target::texture_2d(device, &name, size, 1, kind.format(), usage);
                LabelPlane { view: texture.create_view(&Default::default()), texture }
            })
        });
        LabelTargets { planes }
    }

    /// The plane of `label`, when drawn.
    pub fn plane(&self, label: Label) -> Option<&LabelPlane> {
        self.planes[label as usize].as_ref()
    }

    /// The labels these targets hold.
    pub fn set(&self) -> LabelSet {
        Label::ALL.into_iter().filter(|l| self.plane(*l).is_some()).fold(LabelSet::NONE, LabelSet::with)
    }

    /// Bytes a pixel of these planes takes.
    pub fn bytes_per_pixel(&self) -> u64 {
        self.set().bytes_per_pixel()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_set_holds_what_was_put_in_and_counts_its_bytes() {
        let set = LabelSet::NONE.with(Label::Semantic).with(Label::Normal);
        assert!(set.contains(Label::Semantic) && set.contains(Label::Normal));
        assert!(!set.contains(Label::Instance) && !set.contains(Label::LinearDepth));
        assert_eq!(set.iter().collect::<Vec<_>>(), [Label::Normal, Label::Semantic]);
        assert_eq!(set.bytes_per_pixel(), 12);
        assert_eq!(LabelSet::ALL.bytes_per_pixel(), 20);
        assert_eq!(LabelSet::of(&Label::ALL), LabelSet::ALL);
        assert!(LabelSet::NONE.is_empty() && !set.is_empty());
        assert_eq!(set.union(LabelSet::of(&[Label::Instance])).iter().count(), 3);
        assert_eq!(format!("{set:?}"), "{Normal, Semantic}");
    }

    #[test]
    fn adding_a_label_already_there_keeps_it() {
        let set = LabelSet::of(&[Label::Normal, Label::Normal]);
        assert_eq!(set.iter().collect::<Vec<_>>(), [Label::Normal]);
        assert_eq!(set.with(Label::Normal), set);
        let both = LabelSet::of(&[Label::Instance, Label::Normal]);
        assert_eq!(both.union(set), both);
        assert_eq!(LabelSet::ALL.union(both), LabelSet::ALL);
    }

    #[test]
    fn every_label_has_a_name_of_its_own() {
        let names = Label::ALL.map(Label::name);
        assert_eq!(names, ["instances", "normals", "semantic classes", "linear depth"]);
    }

    #[test]
    fn every_format_matches_its_byte_count() {
        for label in Label::ALL {
            assert_eq!(label.format().block_copy_size(None), Some(label.bytes_per_pixel() as u32), "{label:?}");
        }
    }
}
