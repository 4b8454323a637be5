//! Punctual lights attached to scene nodes.
//!
//! A light takes its position and direction from its node's world transform:
//! it shines down the node's local −Z axis (the glTF convention).

use glam::Vec3;

/// The shape of a light.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum LightKind {
    /// Parallel rays along the node's −Z; intensity in lux.
    Directional,
    /// Omnidirectional from the node's position; intensity in candela.
    Point {
        /// Distance at which the light is cut off (`None`: unbounded).
        range: Option<f32>,
    },
    /// A cone along the node's −Z; intensity in candela.
    Spot {
        /// Cut-off distance (`None`: unbounded).
        range: Option<f32>,
        /// Angle (radians) from the axis where falloff starts.
        inner_cone: f32,
        /// Angle (radians) from the axis where the light ends.
        outer_cone: f32,
    },
}

/// Whether a light may change at run time; baked lights are already in
/// lightmaps and are not collected for real-time shading.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Mobility {
    /// Fully dynamic.
    Realtime,
    /// Static and baked: excluded from real-time light lists.
    Baked,
}

/// A light source.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Light {
    /// Shape and shape parameters.
    pub kind: LightKind,
    /// Linear RGB colour.
    pub color: Vec3,
    /// Intensity (lux for directional, candela otherwise).
    pub intensity: f32,
    /// The light wants shadows (its node must also cast shadows).
    pub casts_shadows: bool,
    /// The light contributes to the lit world at all.
    pub affects_world: bool,
    /// Real-time or baked.
    pub mobility: Mobility,
    /// How large the light looks, for soft shadows: a directional light's
    /// angular radius in radians (the sun's is about 0.0047, 0.27°). 0, the
    /// default, is a point source with hard-edged shadows. The path-traced
    /// reference samples directions over the light's disc, and a view's
    /// PCSS shadows (`ShadowFilter::Pcss`) widen their penumbrae by it.
    /// Negative or non-finite values count as 0, values past
    /// [`Light::MAX_ANGULAR_RADIUS`] as that. For a point or spot light it
    /// is the radius of its sphere in metres ([`Light::radius`]): the
    /// reference traces its shadows to points of its disc, and PCSS widens
    /// their penumbrae by it.
    #[serde(default)]
    pub source_radius: f32,
}

impl Light {
    /// The largest angular radius a directional light's disc may have
    /// (0.3 rad, about 17°): past it a shadow's penumbra is most of the
    /// shadow.
    pub const MAX_ANGULAR_RADIUS: f32 = 0.3;

    /// The angular radius shaders use: [`Light::source_radius`] of a
    /// directional light, finite and within 0 to
    /// [`Light::MAX_ANGULAR_RADIUS`]; 0 for other lights.
    pub fn angular_radius(&self) -> f32 {
        match self.kind {
            LightKind::Directional if self.source_radius.is_finite() => {
                self.source_radius.clamp(0.0, Self::MAX_ANGULAR_RADIUS)
            }
            _ => 0.0,
        }
    }

    /// The largest radius a point or spot light's sphere may have (1 m).
    pub const MAX_RADIUS: f32 = 1.0;

    /// The radius in metres shaders use: [`Light::source_radius`] of a
    /// point or spot light, finite and within 0 to [`Light::MAX_RADIUS`];
    /// 0 for a directional light.
    pub fn radius(&self) -> f32 {
        match self.kind {
            LightKind::Point { .. } | LightKind::Spot { .. } if self.source_radius.is_finite() => {
                self.source_radius.clamp(0.0, Self::MAX_RADIUS)
            }
            _ => 0.0,
        }
    }

    /// A white real-time directional light that casts shadows.
    pub fn directional(intensity: f32) -> Self {
        Light {
            kind: LightKind::Directional,
            color: Vec3::ONE,
            intensity,
            casts_shadows: true,
            affects_world: true,
            mobility: Mobility::Realtime,
            source_radius: 0.0,
        }
    }

    /// A white real-time point light.
    pub fn point(intensity: f32, range: Option<f32>) -> Self {
        Light { kind: LightKind::Point { range }, ..Light::directional(intensity) }
    }

    /// A white real-time spot light.
    pub fn spot(intensity: f32, range: Option<f32>, inner_cone: f32, outer_cone: f32) -> Self {
        Light { kind: LightKind::Spot { range, inner_cone, outer_cone }, ..Light::directional(intensity) }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    /// The point and spot constructors give the shape asked for, with the
    /// directional light's defaults for everything else.
    #[test]
    fn point_and_spot_lights_have_their_own_shape_and_the_shared_defaults() {
        let point = Light::point(40.0, Some(12.0));
        assert_eq!(point.kind, LightKind::Point { range: Some(12.0) });
        let spot = Light::spot(80.0, None, 0.25, 0.5);
        assert_eq!(spot.kind, LightKind::Spot { range: None, inner_cone: 0.25, outer_cone: 0.5 });
        for (light, intensity) in [(point, 40.0), (spot, 80.0)] {
            assert_eq!(light.intensity, intensity);
            assert_eq!(light.color, Vec3::ONE);
            assert!(light.casts_shadows && light.affects_world);
            assert_eq!(light.mobility, Mobility::Realtime);
            assert_eq!(light.source_radius, 0.0);
        }
    }

    /// A directional light's disc is kept finite and within its bounds; other
    /// lights are points.
    #[test]
    fn only_a_directional_light_has_an_angular_radius_within_bounds() {
        let sun = |r: f32| Light { source_radius: r, ..Light::directional(1.0) };
        assert_eq!(sun(0.01).angular_radius(), 0.01);
        assert_eq!(sun(-0.01).angular_radius(), 0.0);
        assert_eq!(sun(f32::NAN).angular_radius(), 0.0);
        assert_eq!(sun(f32::INFINITY).angular_radius(), 0.0);
        assert_eq!(sun(2.0).angular_radius(), Light::MAX_ANGULAR_RADIUS);
        assert_eq!(Light { source_radius: 0.1, ..Light::point(1.0, None) }.angular_radius(), 0.0);
    }
}
