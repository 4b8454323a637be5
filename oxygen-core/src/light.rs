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
}

impl Light {
    /// A white real-time directional light that casts shadows.
    pub fn directional(intensity: f32) -> Self {
        Light {
            kind: LightKind::Directional,
            color: Vec3::ONE,
            intensity,
            casts_shadows: true,
            affects_world: true,
            mobility: Mobility::Realtime,
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
        }
    }
}
