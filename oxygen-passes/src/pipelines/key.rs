//! What makes two mesh pipelines different: the pass they belong to, the
//! variant a partition selects (alpha × sidedness × winding), the targets,
//! the depth bias and the optional shader code ([`PipelineKey`]).

use oxygen_gpu::{Label, LabelSet};
use oxygen_sceneprep::PassMask;

use super::{Exposure, ShaderFeatures};

/// Which pass a pipeline belongs to (decides shaders and depth state).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PassKind {
    /// Depth only; writes depth with `Greater`.
    DepthPrePass,
    /// A shadow map: as `DepthPrePass`, plus a slope-scaled depth bias
    /// pushing stored depth away from the light (against shadow acne).
    Shadow,
    /// Shading after a depth pre-pass: `GreaterEqual`, no depth writes.
    ShadingAfterPrePass,
    /// Shading that writes its own depth (no pre-pass): `Greater`, writes.
    Shading,
    /// Blended surfaces: premultiplied alpha over the HDR target,
    /// `GreaterEqual` against the opaque depth, no depth writes.
    Transparent,
    /// Labels after shading: the instance id (`R32Uint`) and world normal
    /// (`Rgba16Float`) of each opaque or masked fragment on the shaded
    /// depth (`GreaterEqual`, no depth writes).
    Labels,
    /// Deferred shading's visibility pass: each opaque or masked
    /// fragment's surface id, its draw and the vertex that starts its
    /// triangle (`R32Uint`, colour target 0), and the
    /// view's label planes after it; writes its own depth as
    /// [`PassKind::Shading`] does. A compute pass shades from it.
    Visibility,
}

/// The rasterizer's depth bias of a shadow map: stored depth is pushed away
/// from the light by `constant` depth units plus `slope_scale` times the
/// surface's depth slope, against shadow acne. Reverse-Z: negative values
/// push towards the far plane. A speed/accuracy knob with a measured error:
/// `tests/shadow_quality.rs` shows acne without it and peter-panning grows
/// with it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthBias {
    /// Constant bias in depth-buffer units.
    pub constant: i32,
    /// Bias per unit of depth slope.
    pub slope_scale: f32,
}

impl DepthBias {
    /// No bias (the camera's own depth passes).
    pub const NONE: DepthBias = DepthBias { constant: 0, slope_scale: 0.0 };
    /// The shadow maps' default: 2 units plus 1.5 × slope, towards the far plane.
    pub const SHADOW_DEFAULT: DepthBias = DepthBias { constant: -2, slope_scale: -1.5 };
}

impl Eq for DepthBias {}

impl std::hash::Hash for DepthBias {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.constant.hash(state);
        self.slope_scale.to_bits().hash(state);
    }
}

/// How alpha is treated by a variant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AlphaClass {
    /// Alpha ignored.
    Opaque,
    /// Alpha-tested against the material cutoff.
    Masked,
    /// Alpha-blended.
    Blend,
}

/// One of the pipeline variants a partition selects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PipelineVariant {
    /// Alpha treatment.
    pub alpha: AlphaClass,
    /// No back-face culling.
    pub double_sided: bool,
    /// Clockwise front faces (mirroring transforms).
    pub mirrored: bool,
}

impl PipelineVariant {
    /// The variant a partition mask selects.
    pub fn from_mask(mask: PassMask) -> Self {
        let alpha = if mask.contains(PassMask::TRANSPARENT) {
            AlphaClass::Blend
        } else if mask.contains(PassMask::MASKED) {
            AlphaClass::Masked
        } else {
            AlphaClass::Opaque
        };
        PipelineVariant {
            alpha,
            double_sided: mask.contains(PassMask::DOUBLE_SIDED),
            mirrored: mask.contains(PassMask::MIRRORED),
        }
    }
}

/// Everything that makes two pipelines different.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PipelineKey {
    /// Pass.
    pub pass: PassKind,
    /// Variant.
    pub variant: PipelineVariant,
    /// Colour target format (`None` for depth-only).
    pub color_format: Option<wgpu::TextureFormat>,
    /// Depth target format.
    pub depth_format: wgpu::TextureFormat,
    /// Rasterizer depth bias ([`DepthBias::NONE`] except for shadow maps).
    pub depth_bias: DepthBias,
    /// Optional shading code the pipeline keeps (forward lit and
    /// transparent passes; for depth-only and labels passes, whose
    /// fragment stage has none, [`ShaderFeatures::vertex_outputs_only`]:
    /// only their vertex outputs vary).
    pub features: ShaderFeatures,
    /// Tone-map in the fragment shader with this exposure and write the
    /// display colour directly (the forward lit pass of a view whose HDR
    /// nothing reads); `None` writes linear radiance.
    pub tone_map: Option<Exposure>,
    /// Samples per pixel of the targets (1, or 2 and 4 with MSAA).
    pub samples: u32,
    /// The label planes a shading pass writes with its colour (colour
    /// targets 1 to 4 in [`oxygen_gpu::Label::ALL`] order, no target where a
    /// label is not in the set): one geometry pass for colour and labels.
    /// The labels pass writes them from target 0; other passes ignore it.
    pub labels: LabelSet,
    /// Of two surfaces at exactly the same depth, the one drawn last shows
    /// (a depth test of "nearer or equal"), as it does after a depth
    /// pre-pass, instead of the one drawn first: the deterministic mode's
    /// shading pass without a pre-pass, so that whether a pre-pass ran
    /// changes no pixel. Only [`PassKind::Shading`] reads it.
    pub last_tie_wins: bool,
}

impl PipelineKey {
    /// The key with the fields its pass ignores set to one value, so that
    /// two requests for the same pipeline share it: depth-only shaders have
    /// no optional code and never tone-map.
    pub(super) fn canonical(self) -> Self {
        match self.pass {
            PassKind::DepthPrePass | PassKind::Shadow => PipelineKey {
                features: self.features.vertex_outputs_only(),
                tone_map: None,
                labels: LabelSet::NONE,
                last_tie_wins: false,
                ..self
            },
            PassKind::Labels => PipelineKey {
                features: self.features.vertex_outputs_only(),
                tone_map: None,
                last_tie_wins: false,
                ..self
            },
            PassKind::Visibility => {
                PipelineKey { features: self.features.vertex_outputs_only(), tone_map: None, ..self }
            }
            PassKind::Transparent => PipelineKey { labels: LabelSet::NONE, last_tie_wins: false, ..self },
            PassKind::ShadingAfterPrePass => PipelineKey { last_tie_wins: false, ..self },
            PassKind::Shading => self,
        }
    }

    /// The WGSL override constants the pipeline's module is specialised
    /// with: the shading passes' features, tone map and label planes, the
    /// labels pass's label planes, none for depth-only passes.
    pub fn override_constants(&self) -> Vec<(&'static str, f64)> {
        // The label planes drawn (mesh/label_values.wgsl, in every module
        // that writes labels: the labels pass and the shading passes).
        let drawn = |label| f64::from(u8::from(self.labels.contains(label)));
        let labels = [
            ("LABEL_INSTANCE", drawn(Label::Instance)),
            ("LABEL_NORMAL", drawn(Label::Normal)),
            ("LABEL_SEMANTIC", drawn(Label::Semantic)),
            ("LABEL_LINEAR_DEPTH", drawn(Label::LinearDepth)),
        ];
        match self.pass {
            PassKind::DepthPrePass | PassKind::Shadow => Vec::new(),
            PassKind::Labels | PassKind::Visibility => labels.to_vec(),
            PassKind::ShadingAfterPrePass | PassKind::Shading | PassKind::Transparent => {
                let mut constants = self.features.override_constants().to_vec();
                constants.push(("TONE_MAP_OUTPUT", f64::from(u8::from(self.tone_map.is_some()))));
                constants.push(("EXPOSURE", f64::from(self.tone_map.map_or(1.0, Exposure::get))));
                constants.extend(labels);
                constants
            }
        }
    }
}
