//! The optional parts of the forward shader a pipeline keeps, and the
//! exposure a pipeline that tone-maps in place is specialised with.

/// Optional parts of the forward shader. Each but one is a WGSL
/// pipeline-overridable constant (`override HAS_SUN_SHADOWS: bool = true;`
/// …) set when the pipeline is created, so a scene without, say, positional lights runs a
/// pipeline whose light loop the shader compiler removed. A pass picks the
/// features from what its view has this frame; every combination is a
/// pipeline of its own, created the first time it is needed and cached.
/// Masked materials need no flag: alpha testing lives in its own entry
/// points (`fs_masked`, `fs_alpha_test`), used only by masked partitions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ShaderFeatures {
    /// Sample the view's sun-shadow cascades (`HAS_SUN_SHADOWS`).
    pub sun_shadows: bool,
    /// Loop over the frame's spot and point lights (`HAS_LOCAL_LIGHTS`).
    pub local_lights: bool,
    /// Sample the local-light shadow atlas (`HAS_LOCAL_SHADOWS`).
    pub local_shadows: bool,
    /// Soften the sun's shadows by its disc (`HAS_SOFT_SHADOWS`,
    /// [`crate::ShadowFilter::Pcss`]): a blocker search, then a filter as
    /// wide as the penumbra; without it PCF of a fixed radius.
    pub soft_shadows: bool,
    /// Visit only the positional lights of the pixel's cluster, from the
    /// view's light clusters (`HAS_CLUSTERED_LIGHTS`,
    /// [`crate::LightCulling::Clustered`]); without it every light.
    pub clustered_lights: bool,
    /// Reflect the linked reflection probes (`HAS_PROBES`).
    pub probes: bool,
    /// Follow reflections to the probes' parallax boxes and prefer the
    /// probe whose box holds the point (`HAS_PROBE_PARALLAX`); without it
    /// every probe is read as infinitely far, the nearest serving. Only a
    /// view linked to a probe that has a box needs it.
    pub probe_parallax: bool,
    /// Sample material textures (`HAS_TEXTURES`); without it every texture
    /// reads as opaque white, which is what an untextured material gets.
    pub textures: bool,
    /// Read a texture's second UV set or its `KHR_texture_transform`
    /// (`HAS_UV_TRANSFORMS`); without it every texture reads set 0 as is
    /// and set 1's derivatives are never taken. Compiled in, the transform
    /// path cost textured shading 0.23 ms at 1280 × 720 on an H100 (1.24 →
    /// 1.47 ms) even for materials that skip it at run time.
    pub uv_transforms: bool,
    /// The vertex stage passes vertex colours and the second UV set on
    /// (glTF `COLOR_0`, `TEXCOORD_1`); without, the colour is white and
    /// set 1 is set 0's place. Not an override constant: a vertex output
    /// cannot be left out by one, so this picks which of two compositions
    /// of the module the pipeline compiles (`mesh/varyings_plain.wgsl`,
    /// three locations, or `mesh/varyings_attributes.wgsl`, five). Every
    /// mesh pass, depth-only ones included, follows it, since the work it
    /// saves is the vertices'.
    pub vertex_attributes: bool,
    /// Dim the indirect light by the view's screen-space ambient occlusion
    /// (`HAS_AMBIENT_OCCLUSION`, [`crate::AmbientOcclusion`]).
    pub ambient_occlusion: bool,
    /// March toward each shadow-casting light through the view's depth
    /// (`HAS_CONTACT_SHADOWS`, [`crate::ContactShadows`]).
    pub contact_shadows: bool,
    /// Reflect the view's last frame where a march through its depth finds
    /// the reflected surface (`HAS_SCREEN_REFLECTIONS`,
    /// [`crate::ScreenSpaceReflections`]).
    pub screen_reflections: bool,
}

impl ShaderFeatures {
    /// Every optional part: the shader as written, right for any scene.
    pub const ALL: ShaderFeatures = ShaderFeatures {
        sun_shadows: true,
        local_lights: true,
        local_shadows: true,
        soft_shadows: true,
        clustered_lights: true,
        probes: true,
        probe_parallax: true,
        textures: true,
        uv_transforms: true,
        vertex_attributes: true,
        ambient_occlusion: true,
        contact_shadows: true,
        screen_reflections: true,
    };
    /// No optional part: sun and ambient light on untextured materials.
    pub const NONE: ShaderFeatures = ShaderFeatures {
        sun_shadows: false,
        local_lights: false,
        local_shadows: false,
        soft_shadows: false,
        clustered_lights: false,
        probes: false,
        probe_parallax: false,
        textures: false,
        uv_transforms: false,
        vertex_attributes: false,
        ambient_occlusion: false,
        contact_shadows: false,
        screen_reflections: false,
    };

    /// Every optional part but the vertex outputs, which stay as they are:
    /// the features of a pass whose fragment stage has no optional code
    /// (depth-only and labels passes), whose vertex stage still follows
    /// the scene's meshes.
    pub fn vertex_outputs_only(self) -> ShaderFeatures {
        ShaderFeatures { vertex_attributes: self.vertex_attributes, ..ShaderFeatures::ALL }
    }

    /// The parts either keeps: one pipeline right for the views of both
    /// (code for an absent input computes what leaving it out does).
    pub fn union(self, other: ShaderFeatures) -> ShaderFeatures {
        ShaderFeatures {
            sun_shadows: self.sun_shadows || other.sun_shadows,
            local_lights: self.local_lights || other.local_lights,
            local_shadows: self.local_shadows || other.local_shadows,
            soft_shadows: self.soft_shadows || other.soft_shadows,
            clustered_lights: self.clustered_lights || other.clustered_lights,
            probes: self.probes || other.probes,
            probe_parallax: self.probe_parallax || other.probe_parallax,
            textures: self.textures || other.textures,
            uv_transforms: self.uv_transforms || other.uv_transforms,
            vertex_attributes: self.vertex_attributes || other.vertex_attributes,
            ambient_occlusion: self.ambient_occlusion || other.ambient_occlusion,
            contact_shadows: self.contact_shadows || other.contact_shadows,
            screen_reflections: self.screen_reflections || other.screen_reflections,
        }
    }

    /// The override constants, by their WGSL names (bools as 0 or 1);
    /// [`ShaderFeatures::vertex_attributes`] is not one.
    pub fn override_constants(&self) -> [(&'static str, f64); 12] {
        let flag = |on: bool| f64::from(u8::from(on));
        [
            ("HAS_SUN_SHADOWS", flag(self.sun_shadows)),
            ("HAS_LOCAL_LIGHTS", flag(self.local_lights)),
            ("HAS_LOCAL_SHADOWS", flag(self.local_shadows)),
            ("HAS_SOFT_SHADOWS", flag(self.soft_shadows)),
            ("HAS_CLUSTERED_LIGHTS", flag(self.clustered_lights)),
            ("HAS_PROBES", flag(self.probes)),
            ("HAS_PROBE_PARALLAX", flag(self.probe_parallax)),
            ("HAS_TEXTURES", flag(self.textures)),
            ("HAS_UV_TRANSFORMS", flag(self.uv_transforms)),
            ("HAS_AMBIENT_OCCLUSION", flag(self.ambient_occlusion)),
            ("HAS_CONTACT_SHADOWS", flag(self.contact_shadows)),
            ("HAS_SCREEN_REFLECTIONS", flag(self.screen_reflections)),
        ]
    }
}

/// The exposure a tone-mapping pipeline multiplies radiance by: finite and
/// non-negative (anything else becomes 1), compared and hashed by its bits
/// so it can be part of a [`PipelineKey`](crate::PipelineKey).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exposure(f32);

impl Exposure {
    /// `value`, or 1 when it is not finite or negative (no NaN reaches a shader).
    pub fn new(value: f32) -> Self {
        Exposure(if value.is_finite() && value >= 0.0 { value } else { 1.0 })
    }

    /// The factor.
    pub fn get(self) -> f32 {
        self.0
    }
}

impl Eq for Exposure {}

impl std::hash::Hash for Exposure {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.0.to_bits().hash(state);
    }
}
