//! Keyframe animation of node transforms: the scene advances to a time the
//! application gives.
//!
//! An [`Animation`] is a set of [`Channel`]s, each driving one property of
//! one node (translation, rotation, scale or morph-target weights) through
//! keyframes with step,
//! linear (spherical for rotations) or cubic-spline interpolation, the
//! three glTF defines. [`Animation::apply`] writes the sampled transforms
//! into the scene; the frame pipeline then sees ordinary transform edits.
//! Sampling is pure (no state between calls), so any time can be rendered
//! in any order, which is what tests and offline renders need.
//!
//! Times before the first keyframe hold the first value, times after the
//! last hold the last (glTF leaves looping to the application:
//! `time % animation.duration()` loops).

use glam::{Quat, Vec3, Vec4};

use crate::scene::{NodeKey, Scene, SceneError};

/// `q` as a unit quaternion (identity where it has no direction).
fn unit(q: Vec4) -> Quat {
    Quat::from_vec4(q.try_normalize().unwrap_or(Vec4::W))
}

/// How values between two keyframes are found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// The earlier keyframe's value until the next keyframe.
    Step,
    /// Straight-line blend; rotations blend along the shorter great arc
    /// (spherical linear interpolation).
    Linear,
    /// Cubic Hermite spline through the keyframes with the tangents the
    /// file gives (glTF `CUBICSPLINE`: each keyframe stores in-tangent,
    /// value, out-tangent).
    CubicSpline,
}

/// The property a channel drives and its keyframe values: one per
/// keyframe, or three (in-tangent, value, out-tangent) with
/// [`Interpolation::CubicSpline`].
#[derive(Clone, Debug, PartialEq)]
pub enum ChannelValues {
    /// Node translation.
    Translation(Vec<Vec3>),
    /// Node rotation (unit quaternions; cubic-spline tangents are not).
    Rotation(Vec<Quat>),
    /// Node scale.
    Scale(Vec<Vec3>),
    /// Morph-target weights: `count` per value (keyframe or tangent), one
    /// run after another.
    Weights {
        /// The weights, `count` at a time.
        values: Vec<f32>,
        /// Weights per value (the geometry's target count).
        count: usize,
    },
}

impl ChannelValues {
    fn len(&self) -> usize {
        match self {
            ChannelValues::Translation(v) | ChannelValues::Scale(v) => v.len(),
            ChannelValues::Rotation(v) => v.len(),
            ChannelValues::Weights { values, count } => values.len() / (*count).max(1),
        }
    }
}

/// One animated property of one node.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    /// The node it moves.
    pub node: NodeKey,
    /// How values between keyframes are found.
    pub interpolation: Interpolation,
    /// Keyframe times in seconds, strictly increasing, finite.
    pub times: Vec<f32>,
    /// The property and its values.
    pub values: ChannelValues,
}

/// What was wrong with a channel handed to [`Channel::new`].
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ChannelError {
    /// No keyframes.
    #[error("a channel needs at least one keyframe")]
    Empty,
    /// Times not finite or not strictly increasing.
    #[error("keyframe time {index} ({time}) is not finite or not after the one before")]
    Times {
        /// The keyframe.
        index: usize,
        /// Its time.
        time: f32,
    },
    /// Values do not match the keyframes (one each, three with cubic splines).
    #[error("{values} values for {times} keyframes with {interpolation:?} interpolation")]
    Count {
        /// Values given.
        values: usize,
        /// Keyframes.
        times: usize,
        /// The interpolation, which decides how many values a keyframe has.
        interpolation: Interpolation,
    },
    /// A value is NaN or infinite.
    #[error("value {index} is not finite")]
    NonFinite {
        /// The value.
        index: usize,
    },
}

impl Channel {
    /// A validated channel: at least one keyframe, finite strictly
    /// increasing times, one value per keyframe (three with cubic splines),
    /// finite values. Rotation keyframe values are normalised.
    pub fn new(
        node: NodeKey,
        interpolation: Interpolation,
        times: Vec<f32>,
        mut values: ChannelValues,
    ) -> Result<Self, ChannelError> {
        if times.is_empty() {
            return Err(ChannelError::Empty);
        }
        for (index, pair) in times.windows(2).enumerate() {
            if !(pair[1] > pair[0]) {
                return Err(ChannelError::Times { index: index + 1, time: pair[1] });
            }
        }
        if let Some(index) = times.iter().position(|t| !t.is_finite()) {
            return Err(ChannelError::Times { index, time: times[index] });
        }
        let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
        if values.len() != times.len() * per_key {
            return Err(ChannelError::Count { values: values.len(), times: times.len(), interpolation });
        }
        if let ChannelValues::Weights { values: w, count } = &values
            && (*count == 0 || w.len() % count != 0)
        {
            return Err(ChannelError::Count { values: w.len(), times: times.len(), interpolation });
        }
        let bad = match &values {
            ChannelValues::Translation(v) | ChannelValues::Scale(v) => v.iter().position(|x| !x.is_finite()),
            ChannelValues::Rotation(v) => v.iter().position(|x| !x.is_finite()),
            ChannelValues::Weights { values, .. } => values.iter().position(|x| !x.is_finite()),
        };
        if let Some(index) = bad {
            return Err(ChannelError::NonFinite { index });
        }
        if let ChannelValues::Rotation(v) = &mut values {
            // Keyframe values are unit quaternions; tangents keep their length.
            for (i, q) in v.iter_mut().enumerate() {
                let is_value = per_key == 1 || i % 3 == 1;
                if is_value {
                    *q = unit(Vec4::from(*q));
                }
            }
        }
        Ok(Channel { node, interpolation, times, values })
    }

    /// The first and last keyframe times.
    pub fn range(&self) -> (f32, f32) {
        (self.times[0], self.times[self.times.len() - 1])
    }

    /// Where `time` falls: the keyframe before it and the blend factor to
    /// the next (0 at or before the first keyframe, and at or after the
    /// last, where the pair is the last keyframe twice).
    fn segment(&self, time: f32) -> (usize, usize, f32, f32) {
        let last = self.times.len() - 1;
        // NaN time: hold the first keyframe.
        if !(time > self.times[0]) {
            return (0, 0, 0.0, 0.0);
        }
        if time >= self.times[last] {
            return (last, last, 0.0, 0.0);
        }
        // The first keyframe after `time`; it exists since time < last.
        let next = self.times.partition_point(|t| *t <= time);
        let previous = next - 1;
        let dt = self.times[next] - self.times[previous];
        (previous, next, (time - self.times[previous]) / dt, dt)
    }

    /// The morph weights at `time` (`None` unless a weights channel).
    pub fn sample_weights(&self, time: f32) -> Option<Vec<f32>> {
        let ChannelValues::Weights { values, count } = &self.values else { return None };
        let (a, b, s, dt) = self.segment(time);
        let at = |i: usize, k: usize| values[i * count + k];
        Some(
            (0..*count)
                .map(|k| match self.interpolation {
                    Interpolation::Step => at(a, k),
                    Interpolation::Linear => at(a, k) + (at(b, k) - at(a, k)) * s,
                    Interpolation::CubicSpline => {
                        let (p0, m0) = (at(3 * a + 1, k), at(3 * a + 2, k) * dt);
                        let (p1, m1) = (at(3 * b + 1, k), at(3 * b, k) * dt);
                        let (s2, s3) = (s * s, s * s * s);
                        p0 * (2.0 * s3 - 3.0 * s2 + 1.0)
                            + m0 * (s3 - 2.0 * s2 + s)
                            + p1 * (-2.0 * s3 + 3.0 * s2)
                            + m1 * (s3 - s2)
                    }
                })
                .collect(),
        )
    }

    /// The value at `time` as a vector of four (xyz for translation and
    /// scale, xyzw for rotations, normalised).
    fn sample4(&self, time: f32) -> Vec4 {
        let (a, b, s, dt) = self.segment(time);
        let at = |i: usize| -> Vec4 {
            match &self.values {
                ChannelValues::Translation(v) | ChannelValues::Scale(v) => v[i].extend(0.0),
                ChannelValues::Rotation(v) => Vec4::from(v[i]),
                ChannelValues::Weights { .. } => Vec4::ZERO,
            }
        };
        let rotation = matches!(self.values, ChannelValues::Rotation(_));
        let value = match self.interpolation {
            Interpolation::Step => at(a),
            Interpolation::Linear if rotation => {
                let (qa, qb) = (Quat::from_vec4(at(a)), Quat::from_vec4(at(b)));
                Vec4::from(qa.slerp(qb, s))
            }
            Interpolation::Linear => at(a).lerp(at(b), s),
            Interpolation::CubicSpline => {
                // Keyframe k stores (in-tangent, value, out-tangent) at 3k..3k+3.
                let (p0, m0) = (at(3 * a + 1), at(3 * a + 2) * dt);
                let (p1, m1) = (at(3 * b + 1), at(3 * b) * dt);
                let (s2, s3) = (s * s, s * s * s);
                p0 * (2.0 * s3 - 3.0 * s2 + 1.0)
                    + m0 * (s3 - 2.0 * s2 + s)
                    + p1 * (-2.0 * s3 + 3.0 * s2)
                    + m1 * (s3 - s2)
            }
        };
        if rotation { Vec4::from(unit(value)) } else { value }
    }

    /// The translation or scale at `time` (`None` for a rotation channel).
    pub fn sample_vec3(&self, time: f32) -> Option<Vec3> {
        match self.values {
            ChannelValues::Translation(_) | ChannelValues::Scale(_) => Some(self.sample4(time).truncate()),
            _ => None,
        }
    }

    /// The rotation at `time` (`None` unless a rotation channel).
    pub fn sample_rotation(&self, time: f32) -> Option<Quat> {
        match self.values {
            ChannelValues::Rotation(_) => Some(Quat::from_vec4(self.sample4(time))),
            _ => None,
        }
    }
}

/// A named set of channels played together.
#[derive(Clone, Debug, PartialEq)]
pub struct Animation {
    /// Name from the file, or "animation N".
    pub name: String,
    /// Its channels.
    pub channels: Vec<Channel>,
}

impl Animation {
    /// The time of its last keyframe (0 for an animation without channels).
    pub fn duration(&self) -> f32 {
        self.channels.iter().map(|c| c.range().1).fold(0.0, f32::max)
    }

    /// Writes every channel's value at `time` (seconds) into its node's
    /// local transform; properties no channel drives keep their value.
    /// A node no longer in the scene is an error naming it; the channels
    /// before it have been applied.
    pub fn apply(&self, scene: &mut Scene, time: f32) -> Result<(), SceneError> {
        let _span = tracing::info_span!("animation_apply", name = %self.name, time).entered();
        for channel in &self.channels {
            let node = scene.node(channel.node).ok_or(SceneError::NoSuchNode(channel.node))?;
            let mut local = node.local;
            match &channel.values {
                ChannelValues::Translation(_) => local.translation = channel.sample4(time).truncate(),
                ChannelValues::Scale(_) => local.scale = channel.sample4(time).truncate(),
                ChannelValues::Rotation(_) => local.rotation = Quat::from_vec4(channel.sample4(time)),
                ChannelValues::Weights { .. } => {
                    let weights = channel.sample_weights(time).unwrap_or_default();
                    scene.set_morph_weights(channel.node, weights)?;
                    continue;
                }
            }
            scene.set_local_transform(channel.node, local)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Transform;

    fn node() -> (Scene, NodeKey) {
        let mut scene = Scene::new();
        let key = scene.add_node("animated", Transform::IDENTITY);
        (scene, key)
    }

    fn translation(interpolation: Interpolation, times: Vec<f32>, values: Vec<Vec3>) -> Channel {
        let (_, key) = node();
        Channel::new(key, interpolation, times, ChannelValues::Translation(values)).unwrap()
    }

    fn weights(interpolation: Interpolation, times: Vec<f32>, values: Vec<f32>, count: usize) -> Channel {
        let (_, key) = node();
        Channel::new(key, interpolation, times, ChannelValues::Weights { values, count }).unwrap()
    }

    /// Morph weights, two targets, keyframes at 1 and 3 (dt 2, off zero so
    /// that times and segments are not confused): step holds, linear
    /// blends each target on its own, the cubic spline is the Hermite
    /// basis of its values and dt-scaled tangents, checked at s = 1/4
    /// against the basis worked out by hand.
    #[test]
    fn morph_weights_follow_each_interpolation_target_by_target() {
        let step = weights(Interpolation::Step, vec![1.0, 3.0], vec![0.2, 0.8, 0.6, 0.0], 2);
        assert_eq!(step.sample_weights(2.9), Some(vec![0.2, 0.8]));
        assert_eq!(step.sample_weights(3.0), Some(vec![0.6, 0.0]));

        let linear = weights(Interpolation::Linear, vec![1.0, 3.0], vec![0.2, 0.8, 0.6, 0.0], 2);
        let at = |t: f32| linear.sample_weights(t).unwrap();
        let close = |got: Vec<f32>, want: [f32; 2]| got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-6);
        // s = (1.5 - 1) / 2 = 1/4.
        assert!(close(at(1.5), [0.2 + 0.4 * 0.25, 0.8 - 0.8 * 0.25]), "{:?}", at(1.5));
        assert!(close(at(0.0), [0.2, 0.8]) && close(at(5.0), [0.6, 0.0]), "the ends hold");

        // Cubic spline: per keyframe (in-tangent, value, out-tangent), each
        // two weights. Keyframe 0: value (0.1, 0.9), out-tangent (0.5, -1);
        // keyframe 1: in-tangent (2, 0.25), value (0.7, 0.3).
        let values = vec![9.0, 9.0, 0.1, 0.9, 0.5, -1.0, 2.0, 0.25, 0.7, 0.3, 9.0, 9.0];
        let cubic = weights(Interpolation::CubicSpline, vec![1.0, 3.0], values, 2);
        let s: f32 = 0.25;
        let (s2, s3) = (s * s, s * s * s);
        let hermite = |p0: f32, m0: f32, p1: f32, m1: f32| {
            p0 * (2.0 * s3 - 3.0 * s2 + 1.0) + m0 * (s3 - 2.0 * s2 + s) + p1 * (-2.0 * s3 + 3.0 * s2) + m1 * (s3 - s2)
        };
        // Tangents are per second: times dt = 2.
        let want = [hermite(0.1, 0.5 * 2.0, 0.7, 2.0 * 2.0), hermite(0.9, -2.0, 0.3, 0.25 * 2.0)];
        // The same numbers written out: basis (0.84375, 0.140625, 0.15625, -0.046875).
        assert!((want[0] - (0.1 * 0.84375 + 1.0 * 0.140625 + 0.7 * 0.15625 + 4.0 * -0.046875)).abs() < 1e-6);
        let got = cubic.sample_weights(1.5).unwrap();
        assert!(close(got.clone(), want), "{got:?} against {want:?}");
        // At the keyframes the spline passes through the values.
        assert!(close(cubic.sample_weights(1.0).unwrap(), [0.1, 0.9]));
        assert!(close(cubic.sample_weights(3.0).unwrap(), [0.7, 0.3]));
        // Three keyframes: the segment after the first is found by time.
        let three = weights(Interpolation::Linear, vec![1.0, 3.0, 4.0], vec![0.0, 1.0, 2.0], 1);
        assert!(close(three.sample_weights(3.5).unwrap().into_iter().chain([0.0]).collect(), [1.5, 0.0]));
        // Not a weights channel: none.
        let moving = translation(Interpolation::Linear, vec![0.0, 1.0], vec![Vec3::ZERO, Vec3::X]);
        assert_eq!(moving.sample_weights(0.5), None);
    }

    /// A cubic-spline translation follows the Hermite basis of its values
    /// and dt-scaled tangents, on each axis (keyframes at 1 and 3, s = 1/4),
    /// and passes through its keyframes.
    #[test]
    fn cubic_spline_translations_follow_the_hermite_basis() {
        let values = vec![
            Vec3::splat(9.0),          // keyframe 0: in-tangent (unused)
            Vec3::new(0.1, 0.9, -2.0), // value
            Vec3::new(0.5, -1.0, 0.0), // out-tangent
            Vec3::new(2.0, 0.25, 1.0), // keyframe 1: in-tangent
            Vec3::new(0.7, 0.3, 4.0),  // value
            Vec3::splat(9.0),          // out-tangent (unused)
        ];
        let cubic = translation(Interpolation::CubicSpline, vec![1.0, 3.0], values);
        // Basis at s = 1/4: (0.84375, 0.140625, 0.15625, -0.046875); dt = 2.
        let hermite = |p0: f32, m0: f32, p1: f32, m1: f32| {
            p0 * 0.84375 + 2.0 * m0 * 0.140625 + p1 * 0.15625 + 2.0 * m1 * -0.046875
        };
        let want = Vec3::new(hermite(0.1, 0.5, 0.7, 2.0), hermite(0.9, -1.0, 0.3, 0.25), hermite(-2.0, 0.0, 4.0, 1.0));
        let got = cubic.sample_vec3(1.5).unwrap();
        assert!((got - want).abs().max_element() < 1e-6, "{got} against {want}");
        assert!((cubic.sample_vec3(1.0).unwrap() - Vec3::new(0.1, 0.9, -2.0)).abs().max_element() < 1e-6);
        assert!((cubic.sample_vec3(3.0).unwrap() - Vec3::new(0.7, 0.3, 4.0)).abs().max_element() < 1e-6);
    }

    #[test]
    fn step_holds_the_earlier_keyframe_and_linear_blends() {
        let values = vec![Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(2.0, 4.0, 0.0)];
        let step = translation(Interpolation::Step, vec![0.0, 1.0, 3.0], values.clone());
        let linear = translation(Interpolation::Linear, vec![0.0, 1.0, 3.0], values);
        assert_eq!(step.sample_vec3(0.99), Some(Vec3::ZERO));
        assert_eq!(step.sample_vec3(1.0), Some(Vec3::new(2.0, 0.0, 0.0)));
        assert_eq!(linear.sample_vec3(0.5), Some(Vec3::new(1.0, 0.0, 0.0)));
        assert_eq!(linear.sample_vec3(2.0), Some(Vec3::new(2.0, 2.0, 0.0)));
        // Outside the keyframes the ends hold; NaN holds the first.
        assert_eq!(linear.sample_vec3(-5.0), Some(Vec3::ZERO));
        assert_eq!(linear.sample_vec3(9.0), Some(Vec3::new(2.0, 4.0, 0.0)));
        assert_eq!(linear.sample_vec3(f32::NAN), Some(Vec3::ZERO));
    }

    #[test]
    fn rotations_slerp_along_the_shorter_arc_and_stay_unit() {
        let (_, key) = node();
        let a = Quat::from_rotation_y(0.0);
        // The same 90° rotation written with the opposite sign: the shorter
        // arc is still 0 → 90°, never the long way round.
        let b = -Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
        let c = Channel::new(key, Interpolation::Linear, vec![0.0, 1.0], ChannelValues::Rotation(vec![a, b])).unwrap();
        let half = c.sample_rotation(0.5).unwrap();
        assert!(half.angle_between(Quat::from_rotation_y(std::f32::consts::FRAC_PI_4)) < 1e-5, "{half:?}");
        for i in 0..=10 {
            assert!((c.sample_rotation(i as f32 / 10.0).unwrap().length() - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn cubic_splines_pass_through_their_keyframes_with_the_given_tangents() {
        // y = t³ on [0, 1]: values 0 and 1, tangents dy/dt = 0 and 3.
        let v = |y: f32| Vec3::new(0.0, y, 0.0);
        let values = vec![v(0.0), v(0.0), v(0.0), v(3.0), v(1.0), v(0.0)];
        let c = translation(Interpolation::CubicSpline, vec![0.0, 1.0], values);
        for t in [0.0f32, 0.25, 0.5, 0.8, 1.0] {
            let y = c.sample_vec3(t).unwrap().y;
            assert!((y - t * t * t).abs() < 1e-5, "t = {t}: {y}");
        }
        // Tangents scale with the segment's length: the same curve over [0, 2].
        let values = vec![v(0.0), v(0.0), v(0.0), v(1.5), v(1.0), v(0.0)];
        let c = translation(Interpolation::CubicSpline, vec![0.0, 2.0], values);
        assert!((c.sample_vec3(1.0).unwrap().y - 0.125).abs() < 1e-5);
    }

    #[test]
    fn bad_channels_are_refused_with_what_is_wrong() {
        let (_, key) = node();
        let t = |times: Vec<f32>, n: usize, i| Channel::new(key, i, times, ChannelValues::Scale(vec![Vec3::ONE; n]));
        assert_eq!(t(vec![], 0, Interpolation::Linear), Err(ChannelError::Empty));
        assert!(matches!(t(vec![0.0, 0.0], 2, Interpolation::Linear), Err(ChannelError::Times { index: 1, .. })));
        assert!(matches!(t(vec![0.0, f32::NAN], 2, Interpolation::Linear), Err(ChannelError::Times { .. })));
        assert!(matches!(t(vec![0.0, 1.0], 2, Interpolation::CubicSpline), Err(ChannelError::Count { .. })));
        let nan = Channel::new(key, Interpolation::Step, vec![0.0], ChannelValues::Scale(vec![Vec3::NAN]));
        assert_eq!(nan, Err(ChannelError::NonFinite { index: 0 }));
    }

    #[test]
    fn applying_writes_only_the_driven_property() {
        let (mut scene, key) = node();
        scene.set_local_transform(key, Transform::IDENTITY.with_scale(Vec3::splat(2.0))).unwrap();
        let channel = Channel::new(
            key,
            Interpolation::Linear,
            vec![0.0, 2.0],
            ChannelValues::Translation(vec![Vec3::ZERO, Vec3::new(0.0, 0.0, 4.0)]),
        )
        .unwrap();
        let animation = Animation { name: "move".into(), channels: vec![channel] };
        assert_eq!(animation.duration(), 2.0);
        let before = scene.revision();
        animation.apply(&mut scene, 1.0).unwrap();
        let local = scene.node(key).unwrap().local;
        assert_eq!(local.translation, Vec3::new(0.0, 0.0, 2.0));
        assert_eq!(local.scale, Vec3::splat(2.0));
        assert!(scene.revision() > before, "the frame pipeline must see the edit");
        scene.remove_node(key).unwrap();
        assert_eq!(animation.apply(&mut scene, 1.0), Err(SceneError::NoSuchNode(key)));
    }
}
