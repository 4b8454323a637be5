//! A rig's views as data: what a coordinator sends a node so that it can
//! register the view itself.

use glam::{DVec3, UVec2, Vec3};
use oxygen::views::ViewDesc;
use oxygen_core::{Camera, DLookAtResolver};
use serde::{Deserialize, Serialize};

use crate::error::NodeError;

/// A view of a rig (the coordinator numbers them; nodes number their own).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct RigViewId(pub u32);

impl std::fmt::Display for RigViewId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "rig-view#{}", self.0)
    }
}

/// Largest side of a rig view, in pixels.
pub const MAX_SIDE: u32 = 8192;

/// A camera of a rig: a look-at camera in `f64` world positions (so that a
/// rig far from the origin sees what it sees at the origin), rendered at
/// `size` pixels by the standard batch graph.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewSpec {
    /// A name for logs and files.
    pub name: String,
    /// Projection.
    pub camera: Camera,
    /// Eye position (world).
    pub eye: DVec3,
    /// Point looked at (world).
    pub target: DVec3,
    /// Up direction; must not be parallel to `target - eye`.
    pub up: Vec3,
    /// Width and height in pixels (1 to [`MAX_SIDE`]).
    pub size: UVec2,
}

impl ViewSpec {
    /// A camera at `eye` looking at `target`, +Y up, `size` pixels.
    pub fn look_at(name: impl Into<String>, camera: Camera, eye: DVec3, target: DVec3, size: UVec2) -> Self {
        ViewSpec { name: name.into(), camera, eye, target, up: Vec3::Y, size }
    }

    /// Why this view cannot render, if it cannot: an invalid camera, a size
    /// of 0 or above [`MAX_SIDE`], a position that is not finite, an eye on
    /// its target or an up along the line of sight.
    pub fn check(&self) -> Result<(), NodeError> {
        let invalid = |reason: String| NodeError::InvalidView { view: self.name.clone(), reason };
        self.camera.validate().map_err(|e| invalid(e.to_string()))?;
        if self.size.x == 0 || self.size.y == 0 || self.size.x > MAX_SIDE || self.size.y > MAX_SIDE {
            return Err(invalid(format!("size {}x{} (1 to {MAX_SIDE} a side)", self.size.x, self.size.y)));
        }
        let forward = self.target - self.eye;
        if !self.eye.is_finite() || !self.target.is_finite() || !self.up.is_finite() {
            return Err(invalid("eye, target and up must be finite".into()));
        }
        if forward.length_squared() == 0.0 || forward.normalize().cross(self.up.as_dvec3()).length_squared() <= 1e-12 {
            return Err(invalid("the eye is on the target, or up is along the line of sight".into()));
        }
        Ok(())
    }

    /// The view's description for a renderer (checked first).
    pub fn desc(&self) -> Result<ViewDesc, NodeError> {
        self.check()?;
        let resolver = DLookAtResolver {
            camera: self.camera,
            eye: self.eye,
            target: self.target,
            up: self.up,
            viewport: self.size,
        };
        Ok(ViewDesc::new(resolver).named(self.name.clone()))
    }
}

/// The images each view of a rig sends back every frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Planes {
    /// Display colour (sRGB RGBA, 4 bytes a pixel).
    pub color: bool,
    /// Device depth (reverse-Z `f32`).
    pub depth: bool,
    /// Instance labels (the node's stable id + 1, 0 for none; `u32`): the
    /// segmentation.
    pub instances: bool,
}

impl Default for Planes {
    /// Colour only.
    fn default() -> Self {
        Planes { color: true, depth: false, instances: false }
    }
}

impl Planes {
    /// No images: each view's output only says it rendered (what a rig
    /// that keeps its images on the nodes' GPUs, or a benchmark of
    /// rendering alone, asks for).
    pub const NONE: Planes = Planes { color: false, depth: false, instances: false };

    /// Whether any plane is sent.
    pub fn any(&self) -> bool {
        self.color || self.depth || self.instances
    }

    /// Bytes of one view's images of `size`.
    pub fn bytes(&self, size: UVec2) -> usize {
        let texels = size.x as usize * size.y as usize;
        texels * 4 * (usize::from(self.color) + usize::from(self.depth) + usize::from(self.instances))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> ViewSpec {
        ViewSpec::look_at(
            "cam",
            Camera::perspective(1.0, 0.1, None),
            DVec3::new(0.0, 1.0, 5.0),
            DVec3::ZERO,
            UVec2::new(32, 24),
        )
    }

    #[test]
    fn a_view_that_cannot_render_is_refused_with_its_reason() {
        assert!(spec().desc().is_ok());
        let cases: [(&str, ViewSpec); 5] = [
            ("size", ViewSpec { size: UVec2::new(0, 24), ..spec() }),
            ("size", ViewSpec { size: UVec2::new(MAX_SIDE + 1, 24), ..spec() }),
            ("finite", ViewSpec { eye: DVec3::new(f64::NAN, 0.0, 0.0), ..spec() }),
            ("target", ViewSpec { target: DVec3::new(0.0, 1.0, 5.0), ..spec() }),
            ("line of sight", ViewSpec { up: Vec3::new(0.0, -1.0, -5.0), ..spec() }),
        ];
        for (reason, bad) in cases {
            let message = bad.check().expect_err(reason).to_string();
            assert!(message.contains(reason), "{message} should name {reason}");
        }
        let bad_camera = ViewSpec { camera: Camera { ..Camera::perspective(-1.0, 0.1, None) }, ..spec() };
        assert!(bad_camera.check().is_err());
    }

    /// Each of eye, target and up is checked for being finite (a NaN target
    /// would otherwise slip through: its line of sight is NaN, and every
    /// comparison with NaN is false), and both sides may reach
    /// [`MAX_SIDE`], not pass it.
    #[test]
    fn every_position_must_be_finite_and_each_side_may_reach_the_largest() {
        for bad in [
            ViewSpec { target: DVec3::new(0.0, f64::INFINITY, 0.0), ..spec() },
            ViewSpec { up: Vec3::new(f32::NAN, 1.0, 0.0), ..spec() },
        ] {
            let message = bad.check().expect_err("a position that is not finite").to_string();
            assert!(message.contains("finite"), "{message}");
        }
        for size in [UVec2::new(MAX_SIDE, 24), UVec2::new(24, MAX_SIDE), UVec2::splat(MAX_SIDE)] {
            assert!(ViewSpec { size, ..spec() }.check().is_ok(), "{size}");
        }
        let message =
            ViewSpec { size: UVec2::new(24, MAX_SIDE + 1), ..spec() }.check().expect_err("too tall").to_string();
        assert!(message.contains("size"), "{message}");
    }

    /// Views are named by their number in logs and errors.
    #[test]
    fn a_rig_view_displays_its_number() {
        assert_eq!(RigViewId(7).to_string(), "rig-view#7");
    }

    /// A rig that asks for no plane sends none; any one plane is a plane.
    #[test]
    fn planes_say_whether_any_is_sent() {
        assert!(!Planes::NONE.any());
        for planes in [
            Planes { color: true, ..Planes::NONE },
            Planes { depth: true, ..Planes::NONE },
            Planes { instances: true, ..Planes::NONE },
        ] {
            assert!(planes.any(), "{planes:?}");
        }
    }

    #[test]
    fn planes_count_their_bytes() {
        let all = Planes { color: true, depth: true, instances: true };
        assert_eq!(all.bytes(UVec2::new(4, 2)), 8 * 12);
        assert_eq!(Planes::default().bytes(UVec2::new(4, 2)), 8 * 4);
    }
}
