//! What can go wrong in a rig.

use thiserror::Error;

use crate::spec::RigViewId;

/// An error of a coordinator or a render node.
#[derive(Debug, Error)]
pub enum NodeError {
    /// Zenoh refused something (opening a session, declaring a key,
    /// sending).
    #[error("zenoh: {0}")]
    Zenoh(String),
    /// A name that cannot be part of a key expression.
    #[error("{what} {name:?} must be 1 to 64 characters of A-Z, a-z, 0-9, '-' and '_'")]
    BadName {
        /// What the name was for (a rig, a node).
        what: &'static str,
        /// The name given.
        name: String,
    },
    /// A view that cannot render.
    #[error("view {view:?}: {reason}")]
    InvalidView {
        /// The view's name.
        view: String,
        /// Why.
        reason: String,
    },
    /// No such view in the rig.
    #[error("{0} is not a view of this rig")]
    NoSuchView(RigViewId),
    /// A frame could not be rendered: no node is there to render its views.
    #[error("frame {frame}: no render node to render {views} views on (none joined, or every one left)")]
    NoNodes {
        /// The frame.
        frame: u64,
        /// Views without a node.
        views: usize,
    },
    /// No node joined in time.
    #[error("{wanted} render nodes wanted, {joined} joined within {seconds} s")]
    JoinTimeout {
        /// Nodes waited for.
        wanted: usize,
        /// Nodes that joined.
        joined: usize,
        /// Seconds waited.
        seconds: f64,
    },
    /// A node waited for a coordinator that never showed up.
    #[error("no coordinator of rig {rig:?} within {seconds} s (is it running, and are the endpoints right?)")]
    NoCoordinator {
        /// The rig.
        rig: String,
        /// Seconds waited.
        seconds: f64,
    },
    /// The node's renderer failed.
    #[error("render: {0}")]
    Render(#[from] oxygen::RenderError),
    /// A scene delta could not be applied.
    #[error("scene delta: {0}")]
    Delta(#[from] oxygen_core::scene::delta::DeltaError),
    /// A message that does not decode.
    #[error("malformed message on {key}: {reason}")]
    Malformed {
        /// Where it came from.
        key: String,
        /// What was wrong.
        reason: String,
    },
}

impl NodeError {
    pub(crate) fn zenoh(e: impl std::fmt::Display) -> Self {
        NodeError::Zenoh(e.to_string())
    }
}

/// Checks a rig's or node's name for use in key expressions.
pub(crate) fn check_name(what: &'static str, name: &str) -> Result<(), NodeError> {
    let ok = !name.is_empty()
        && name.len() <= 64
        && name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_');
    if ok { Ok(()) } else { Err(NodeError::BadName { what, name: name.to_owned() }) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_that_would_change_a_key_expression_are_refused() {
        for good in ["rig", "gpu-0", "node_12", "A"] {
            assert!(check_name("node", good).is_ok(), "{good}");
        }
        for bad in ["", "a/b", "*", "a**", "$x", "a b", "é", &"x".repeat(65)] {
            assert!(check_name("node", bad).is_err(), "{bad:?}");
        }
    }
}
