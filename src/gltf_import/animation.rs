//! Animations: channels on the imported nodes' translation, rotation, scale
//! and morph-target weights, read through validated accessors and charged
//! to the budget.
//!
//! A channel whose node is not part of the imported scene, or that drives
//! the morph-target weights of a node whose mesh has no morph targets, is
//! skipped with a warning; a malformed one (bad accessor, times not
//! increasing, counts that do not match) fails the import naming the
//! animation and channel, like any other malformed part of a file.

use std::borrow::Cow;
use std::collections::HashMap;

use glam::{Quat, Vec3, Vec4};
use gltf::json;
use gltf::json::animation::{Interpolation as JsonInterpolation, Property};
use gltf::json::validation::Checked;
use oxygen_core::{Animation, Channel, ChannelValues, Interpolation, NodeKey};

use super::GltfErrorKind;
use super::accessor::{self, Semantic};
use super::limits::Budget;

/// Every animation of the file, its channels bound to the imported nodes
/// (`nodes`: glTF node index → scene node).
pub(crate) fn import(
    root: &json::Root,
    buffers: &[Cow<'_, [u8]>],
    nodes: &HashMap<usize, NodeKey>,
    budget: &mut Budget,
    warnings: &mut Vec<String>,
) -> Result<Vec<Animation>, GltfErrorKind> {
    let mut out = Vec::with_capacity(root.animations.len());
    for (a, animation) in root.animations.iter().enumerate() {
        let name = animation.name.clone().unwrap_or_else(|| format!("animation {a}"));
        let fail =
            |c: usize, what: String| GltfErrorKind::Invalid(format!("animation {a} ('{name}'), channel {c}: {what}"));
        let mut channels = Vec::with_capacity(animation.channels.len());
        for (c, channel) in animation.channels.iter().enumerate() {
            let sampler = animation
                .samplers
                .get(channel.sampler.value())
                .ok_or_else(|| fail(c, format!("sampler {} does not exist", channel.sampler.value())))?;
            let property = match channel.target.path {
                Checked::Valid(p) => p,
                Checked::Invalid => return Err(fail(c, "unknown target path".into())),
            };
            let Some(&node) = nodes.get(&channel.target.node.value()) else {
                warnings.push(format!(
                    "animation '{name}': channel {c} drives node {}, which is not in the imported scene; skipped",
                    channel.target.node.value()
                ));
                continue;
            };
            let interpolation = match sampler.interpolation {
                Checked::Valid(JsonInterpolation::Step) => Interpolation::Step,
                Checked::Valid(JsonInterpolation::Linear) => Interpolation::Linear,
                Checked::Valid(JsonInterpolation::CubicSpline) => Interpolation::CubicSpline,
                Checked::Invalid => return Err(fail(c, "unknown interpolation".into())),
            };
            let input = accessor::validate(root, buffers, sampler.input.value(), Semantic::AnimationInput)
                .map_err(|e| fail(c, e))?;
            let semantic = match property {
                Property::Rotation => Semantic::AnimationRotation,
                Property::MorphTargetWeights => Semantic::AnimationWeights,
                _ => Semantic::AnimationVector,
            };
            let output = accessor::validate(root, buffers, sampler.output.value(), semantic).map_err(|e| fail(c, e))?;
            // Times and values, 4 bytes a component, charged before they are read.
            let bytes = (input.count as u64).saturating_mul(4).saturating_add((output.count as u64).saturating_mul(16));
            budget
                .spend_bytes(bytes)
                .map_err(|source| GltfErrorKind::Limit { context: format!("animation {a} ('{name}')"), source })?;
            let times: Vec<f32> = input.read_floats::<1>().map_err(|e| fail(c, e))?.into_iter().map(|t| t[0]).collect();
            let values = match property {
                Property::Rotation => ChannelValues::Rotation(
                    output
                        .read_floats::<4>()
                        .map_err(|e| fail(c, e))?
                        .into_iter()
                        .map(|q| Quat::from_vec4(Vec4::from(q)))
                        .collect(),
                ),
                Property::Translation | Property::Scale => {
                    let v: Vec<Vec3> =
                        output.read_floats::<3>().map_err(|e| fail(c, e))?.into_iter().map(Vec3::from).collect();
                    if property == Property::Translation {
                        ChannelValues::Translation(v)
                    } else {
                        ChannelValues::Scale(v)
                    }
                }
                Property::MorphTargetWeights => {
                    // As many weights per keyframe as the node's mesh has targets.
                    let count = root
                        .nodes
                        .get(channel.target.node.value())
                        .and_then(|n| n.mesh)
                        .and_then(|m| root.meshes.get(m.value()))
                        .and_then(|m| m.primitives.first())
                        .map_or(0, |p| p.targets.as_ref().map_or(0, Vec::len));
                    if count == 0 {
                        warnings.push(format!(
                            "animation '{name}': channel {c} animates morph weights of a node without morph targets; skipped"
                        ));
                        continue;
                    }
                    let values: Vec<f32> =
                        output.read_floats::<1>().map_err(|e| fail(c, e))?.into_iter().map(|w| w[0]).collect();
                    ChannelValues::Weights { values, count }
                }
            };
            channels.push(Channel::new(node, interpolation, times, values).map_err(|e| fail(c, e.to_string()))?);
        }
        out.push(Animation { name, channels });
    }
    Ok(out)
}
