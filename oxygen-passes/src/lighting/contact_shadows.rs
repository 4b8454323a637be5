//! Contact shadows: a short ray march through the view's depth from each
//! shaded point toward each light that casts shadows, for the contact a
//! shadow map misses (thin casters, the foot of an object on the ground,
//! where the map's texels and its biases wash the shadow out). The march
//! runs in the forward shader (`contact_shadow` in `mesh/shading.wgsl`)
//! over the view's depth in metres, which a [`crate::LinearDepthPass`] (or
//! the ambient-occlusion pass) wrote after the depth pre-pass; a point is
//! in contact shadow when the ray passes behind a surface the depth holds
//! by less than `thickness`. The result multiplies the shadow map's
//! visibility of the light, so it only ever darkens.

/// A view's contact shadows
/// ([`ForwardLitConfig::contact_shadows`](crate::ForwardLitConfig::contact_shadows)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactShadows {
    /// How far toward the light the ray goes, in metres (the distance to
    /// a positional light when that is shorter). Finite and positive;
    /// 0.5 m by default.
    pub length: f32,
    /// How thick a surface the depth holds is taken to be, in metres: the
    /// ray is blocked where it passes behind a surface by less than this
    /// (a surface far in front of the ray does not block it, as a screen
    /// cannot see what is behind it). Finite and positive; 5 cm by
    /// default. Thicker than the scene's thin casters, it widens their
    /// shadows behind them: on a pole 4 cm across, 10 cm made the picture
    /// worse than no contact shadows at all, 4 cm took a seventh of the
    /// error away (`tests/contact_shadows.rs`).
    pub thickness: f32,
    /// Samples along the ray, 1 to 64; 16 by default.
    pub steps: u32,
}

impl ContactShadows {
    /// Half a metre, 5 cm thick, 16 steps.
    pub const DEFAULT: ContactShadows = ContactShadows { length: 0.5, thickness: 0.05, steps: 16 };

    /// Most steps a march takes.
    pub const MAX_STEPS: u32 = 64;

    /// Why these settings cannot be used, if they cannot.
    pub fn problem(&self) -> Option<String> {
        let positive = |v: f32| v.is_finite() && v > 0.0;
        if !positive(self.length) {
            return Some(format!("contact shadow length {} is not a finite positive number of metres", self.length));
        }
        if !positive(self.thickness) {
            return Some(format!(
                "contact shadow thickness {} is not a finite positive number of metres",
                self.thickness
            ));
        }
        if !(1..=Self::MAX_STEPS).contains(&self.steps) {
            return Some(format!("contact shadows take 1 to {} steps, not {}", Self::MAX_STEPS, self.steps));
        }
        None
    }

    /// The uniform fields of group 1: length, thickness, steps, a zero.
    pub(crate) fn uniform(&self) -> [f32; 4] {
        [self.length, self.thickness, self.steps as f32, 0.0]
    }
}

impl Default for ContactShadows {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_out_of_range_are_problems_naming_them() {
        assert_eq!(ContactShadows::DEFAULT.problem(), None);
        for (bad, name) in [
            (ContactShadows { length: f32::NAN, ..ContactShadows::DEFAULT }, "length"),
            (ContactShadows { length: 0.0, ..ContactShadows::DEFAULT }, "length"),
            (ContactShadows { thickness: -1.0, ..ContactShadows::DEFAULT }, "thickness"),
            (ContactShadows { thickness: f32::INFINITY, ..ContactShadows::DEFAULT }, "thickness"),
            (ContactShadows { steps: 0, ..ContactShadows::DEFAULT }, "steps"),
            (ContactShadows { steps: 65, ..ContactShadows::DEFAULT }, "steps"),
        ] {
            assert!(bad.problem().is_some_and(|p| p.contains(name)), "{bad:?}");
        }
        assert!(ContactShadows { steps: 64, ..ContactShadows::DEFAULT }.problem().is_none());
    }
}
