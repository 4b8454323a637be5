//! The messages of a rig, as they travel: a `postcard` header in the Zenoh
//! sample's attachment and the bulk (a scene delta, image planes) as its
//! payload, so that megabytes of pixels are neither copied into nor parsed
//! out of a serde structure.
//!
//! Receivers check every header against its payload's length and refuse
//! what does not match; nothing here panics on a malformed message.

use glam::UVec2;
use serde::{Deserialize, Serialize};

use crate::error::NodeError;
use crate::spec::{Planes, RigViewId, ViewSpec};

/// The key expressions of rig `rig` (see the crate docs' table).
#[derive(Clone, Debug)]
pub struct Keys {
    rig: String,
}

impl Keys {
    /// The keys of rig `rig` (a name already checked).
    pub fn new(rig: &str) -> Self {
        Keys { rig: rig.to_owned() }
    }

    /// The coordinator's liveliness token.
    pub fn coordinator(&self) -> String {
        format!("oxygen/{}/coordinator", self.rig)
    }

    /// Node `node`'s liveliness token (`*` for every node's).
    pub fn node(&self, node: &str) -> String {
        format!("oxygen/{}/node/{node}", self.rig)
    }

    /// Orders to node `node`.
    pub fn order(&self, node: &str) -> String {
        format!("oxygen/{}/order/{node}", self.rig)
    }

    /// Node `node`'s outputs (`*` for every node's).
    pub fn output(&self, node: &str) -> String {
        format!("oxygen/{}/output/{node}", self.rig)
    }

    /// Node `node`'s status (`*` for every node's).
    pub fn status(&self, node: &str) -> String {
        format!("oxygen/{}/status/{node}", self.rig)
    }

    /// The last chunk of `key` (the node's name in a node's keys).
    pub fn last_chunk(key: &str) -> &str {
        key.rsplit('/').next().unwrap_or(key)
    }
}

/// What a node's replica does with an order's payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum SceneUpdate {
    /// Nothing changed (the payload is empty).
    Unchanged,
    /// The payload is a delta from the revision the replica holds.
    Delta,
    /// The payload is a snapshot (the node joined, or fell out of step).
    Snapshot,
}

/// A frame for one node to render; the payload is the encoded scene
/// delta or snapshot ([`SceneUpdate`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Order {
    /// The rig's frame (from 1).
    pub frame: u64,
    /// What the payload is.
    pub scene: SceneUpdate,
    /// Views the node renders from this frame on.
    pub add: Vec<(RigViewId, ViewSpec)>,
    /// Views it no longer renders.
    pub remove: Vec<RigViewId>,
    /// The images each view sends back.
    pub planes: Planes,
    /// When set, only these views' images are sent back (a frame rendered
    /// again for views taken over from a node that left: the others were
    /// received already).
    pub only: Option<Vec<RigViewId>>,
}

/// Images of one frame of several views of one size (a node sends a
/// batch's cameras together: one message, not one per view); the payload
/// holds each view's planes in turn (colour, depth, instances, those that
/// [`OutputTag::planes`] names, little-endian), views in the order of
/// [`OutputTag::views`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutputTag {
    /// The rig's frame.
    pub frame: u64,
    /// The views, in the payload's order.
    pub views: Vec<RigViewId>,
    /// Width and height of every view's images.
    pub size: UVec2,
    /// The planes of each view in the payload.
    pub planes: Planes,
}

/// Largest payload of one output message: a node splits a batch's views
/// into messages of at most this many bytes (at least one view each).
/// Small enough that the node's next message is on its way while the
/// coordinator cuts the last (one 64 MiB message made a frame of 1 024
/// colour images 1.3–1.6 times slower than one message a view), large
/// enough that a message's own cost (about 27 µs at the coordinator) is
/// paid once for many small views.
pub const MAX_OUTPUT_BYTES: usize = 1 << 20;

/// How a node's frame went.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Outcome {
    /// Every view rendered and its images sent.
    Rendered {
        /// Views rendered.
        views: u32,
        /// Seconds from the order's arrival to the last image sent.
        seconds: f64,
        /// Of which rendering (the renderer's frame and its GPU work).
        render_seconds: f64,
    },
    /// The frame could not be rendered here.
    Failed {
        /// Why.
        reason: String,
        /// The replica is out of step and needs a snapshot.
        needs_snapshot: bool,
    },
}

/// A node's report of one order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Status {
    /// The rig's frame.
    pub frame: u64,
    /// How it went.
    pub outcome: Outcome,
}

/// Encodes a header.
pub fn encode<T: Serialize>(header: &T) -> Vec<u8> {
    // postcard fails only on types it cannot represent (none of these).
    postcard::to_stdvec(header).unwrap_or_default()
}

/// Decodes a header received on `key`.
pub fn decode<T: for<'de> Deserialize<'de>>(key: &str, bytes: &[u8]) -> Result<T, NodeError> {
    postcard::from_bytes(bytes).map_err(|e| NodeError::Malformed { key: key.to_owned(), reason: e.to_string() })
}

/// One view's planes, as the coordinator hands them to the application.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImagePlanes {
    /// sRGB RGBA, row by row from the top.
    pub color: Option<Vec<u8>>,
    /// Device depth (reverse-Z).
    pub depth: Option<Vec<f32>>,
    /// Instance labels (stable id + 1, 0 for none).
    pub instances: Option<Vec<u32>>,
}

impl ImagePlanes {
    /// Appends the planes to `payload` (colour, depth, instances).
    pub fn append_to(&self, payload: &mut Vec<u8>) {
        append_planes(payload, self.color.as_deref(), self.depth.as_deref(), self.instances.as_deref());
    }

    /// The planes as one payload.
    pub fn to_payload(&self) -> Vec<u8> {
        let mut bytes = Vec::new();
        self.append_to(&mut bytes);
        bytes
    }

    /// Each view's planes that `tag` announces, cut out of `payload`;
    /// refused when its length is not theirs.
    pub fn split_payload(key: &str, tag: &OutputTag, payload: &[u8]) -> Result<Vec<(RigViewId, Self)>, NodeError> {
        let malformed = |reason: String| NodeError::Malformed { key: key.to_owned(), reason };
        if tag.size.x > crate::spec::MAX_SIDE || tag.size.y > crate::spec::MAX_SIDE {
            return Err(malformed(format!("size {}", tag.size)));
        }
        let each = tag.planes.bytes(tag.size);
        let expected = tag.views.len().checked_mul(each);
        if expected != Some(payload.len()) {
            return Err(malformed(format!(
                "{} bytes of images where {} views of {} were announced",
                payload.len(),
                tag.views.len(),
                each
            )));
        }
        let texels = tag.size.x as usize * tag.size.y as usize;
        let words =
            |plane: &[u8]| -> Vec<[u8; 4]> { plane.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect() };
        let mut views = Vec::with_capacity(tag.views.len());
        for (i, view) in tag.views.iter().enumerate() {
            let mut rest = &payload[i * each..(i + 1) * each];
            let mut take = |on: bool| -> Option<&[u8]> {
                if !on {
                    return None;
                }
                let (plane, tail) = rest.split_at(texels * 4);
                rest = tail;
                Some(plane)
            };
            let planes = ImagePlanes {
                color: take(tag.planes.color).map(<[u8]>::to_vec),
                depth: take(tag.planes.depth).map(|p| words(p).into_iter().map(f32::from_le_bytes).collect()),
                instances: take(tag.planes.instances).map(|p| words(p).into_iter().map(u32::from_le_bytes).collect()),
            };
            views.push((*view, planes));
        }
        Ok(views)
    }
}

/// Appends one view's planes to `payload`, as [`ImagePlanes::split_payload`]
/// reads them.
pub fn append_planes(payload: &mut Vec<u8>, color: Option<&[u8]>, depth: Option<&[f32]>, instances: Option<&[u32]>) {
    if let Some(color) = color {
        payload.extend_from_slice(color);
    }
    if let Some(depth) = depth {
        payload.extend(depth.iter().flat_map(|d| d.to_le_bytes()));
    }
    if let Some(instances) = instances {
        payload.extend(instances.iter().flat_map(|i| i.to_le_bytes()));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The keys are the rig's wire contract (the crate docs' table): every
    /// one lies under its own rig's name, so two rigs on one network never
    /// hear each other.
    #[test]
    fn every_key_lies_under_its_rig() {
        let keys = Keys::new("bench");
        assert_eq!(keys.coordinator(), "oxygen/bench/coordinator");
        assert_eq!(keys.node("a"), "oxygen/bench/node/a");
        assert_eq!(keys.order("a"), "oxygen/bench/order/a");
        assert_eq!(keys.output("*"), "oxygen/bench/output/*");
        assert_eq!(keys.status("a"), "oxygen/bench/status/a");
        assert_ne!(Keys::new("other").coordinator(), keys.coordinator());
        assert_eq!(Keys::last_chunk("oxygen/bench/status/a"), "a");
    }

    #[test]
    fn planes_travel_and_a_wrong_length_is_refused() {
        let view = |k: u8| ImagePlanes {
            color: Some((k..k + 32).collect()),
            depth: Some(vec![0.25, 0.5, 1.0, f32::MIN_POSITIVE, 0.0, 2.0, 3.0, f32::from(k)]),
            instances: Some(vec![0, 1, 2, u32::MAX, 5, 6, 7, u32::from(k)]),
        };
        let tag = OutputTag {
            frame: 3,
            views: vec![RigViewId(7), RigViewId(2)],
            size: UVec2::new(4, 2),
            planes: Planes { color: true, depth: true, instances: true },
        };
        let mut payload = Vec::new();
        view(1).append_to(&mut payload);
        view(9).append_to(&mut payload);
        let split = ImagePlanes::split_payload("k", &tag, &payload).unwrap();
        assert_eq!(split, vec![(RigViewId(7), view(1)), (RigViewId(2), view(9))]);
        assert!(ImagePlanes::split_payload("k", &tag, &payload[1..]).is_err());
        let one_view = OutputTag { views: vec![RigViewId(7)], ..tag.clone() };
        assert!(ImagePlanes::split_payload("k", &one_view, &payload).is_err());
        let huge = OutputTag { size: UVec2::new(1 << 20, 1 << 20), ..tag.clone() };
        assert!(ImagePlanes::split_payload("k", &huge, &payload).is_err());
        let header: OutputTag = decode("k", &encode(&tag)).unwrap();
        assert_eq!(header, tag);
        assert!(decode::<OutputTag>("k", &[0xff; 3]).is_err());
    }

    /// One view's payload is its planes in order, as `append_to` writes
    /// them, and splits back into the same planes.
    #[test]
    fn a_views_payload_is_its_planes_in_order() {
        let planes = ImagePlanes { color: Some(vec![1, 2, 3, 4]), depth: Some(vec![0.5]), instances: Some(vec![9]) };
        let mut appended = Vec::new();
        planes.append_to(&mut appended);
        let payload = planes.to_payload();
        assert_eq!(payload, appended);
        assert_eq!(payload.len(), 12);
        let tag = OutputTag {
            frame: 1,
            views: vec![RigViewId(3)],
            size: UVec2::ONE,
            planes: Planes { color: true, depth: true, instances: true },
        };
        assert_eq!(ImagePlanes::split_payload("k", &tag, &payload).unwrap(), vec![(RigViewId(3), planes)]);
    }

    /// A tag may announce views of up to `MAX_SIDE` a side, each side on
    /// its own; past it the tag is refused for its size even when the
    /// payload's length agrees with it.
    #[test]
    fn a_tag_may_announce_the_largest_side_and_not_one_more() {
        let colour = |size: UVec2| {
            let tag = OutputTag { frame: 1, views: vec![RigViewId(0)], size, planes: Planes::default() };
            let payload = vec![7u8; Planes::default().bytes(size)];
            ImagePlanes::split_payload("k", &tag, &payload).map(|views| views.len()).map_err(|e| e.to_string())
        };
        let side = crate::spec::MAX_SIDE;
        assert_eq!(colour(UVec2::new(side, 1)), Ok(1));
        assert_eq!(colour(UVec2::new(1, side)), Ok(1));
        for size in [UVec2::new(side + 1, 1), UVec2::new(1, side + 1)] {
            let refused = colour(size).expect_err("past the largest side");
            assert!(refused.contains("size"), "{size}: {refused}");
        }
    }
}
