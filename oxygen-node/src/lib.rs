//! Oxygen's views sharded over render nodes: processes, each with a GPU of
//! its own (or a share of one), on one machine or many, kept in step over
//! [Zenoh](https://zenoh.io).
//!
//! A **rig** is a set of views (cameras described by [`ViewSpec`]) that a
//! [`Coordinator`] renders every frame of an application's
//! [`Scene`](oxygen_core::Scene) on the render nodes that have joined it.
//! A **render node** ([`run_node`], the `oxygen-node` program) holds a
//! replica of the scene and renders its share of the views as one batch
//! ([`oxygen::batch`]), streaming their images back and publishing each
//! with its tags (view, frame, node).
//!
//! # What travels, and how
//!
//! Nothing here is a network protocol of its own: Zenoh carries every
//! message (its reliable channels, with back-pressure instead of drops),
//! tells who is there (liveliness tokens: a node that exits, crashes or
//! loses its link is seen gone by the coordinator within a lease), and
//! finds peers by the endpoints given. The payloads are the scene's own
//! [`SceneDelta`](oxygen_core::scene::delta::SceneDelta) encoding and small
//! `postcard` headers (the [`wire`] module) over raw image planes.
//!
//! Under a rig's name `R` the key expressions are:
//!
//! | key | from → to | what |
//! |---|---|---|
//! | `oxygen/R/coordinator` | liveliness | the coordinator is up |
//! | `oxygen/R/node/N` | liveliness | node `N` is up |
//! | `oxygen/R/order/N` | coordinator → `N` | a frame to render: scene delta or snapshot, views added and removed |
//! | `oxygen/R/output/N` | `N` → coordinator | the images of one frame of a batch's views (1 MiB a message at most) |
//! | `oxygen/R/status/N` | `N` → coordinator | a frame done (with its time) or failed |
//!
//! # A frame
//!
//! The coordinator works in lock step, as a simulation does (step `F + 1`
//! needs the sensors of step `F`): it sends every node the frame's scene
//! delta (once encoded; a node that joined, or fell out of step, gets a
//! snapshot instead) with its changes of views, then waits until every
//! view's images of that frame are in. A node that leaves or dies during
//! the frame has its views given to the others at once, with that same
//! frame to render (their replicas already hold its scene), so no frame of
//! any view is lost; a node that has not answered within
//! [`RigOptions::stall_timeout`] is treated the same way and gets no views
//! until it answers again. Views are placed by measured cost as in
//! [`oxygen::group::RendererGroup`]: a joining node takes views from the
//! loaded ones at once, and after each frame the view whose move best
//! evens the nodes' loads moves (from the next frame).
//!
//! See `docs/multi-gpu.md` for the commands that start a rig.

#![warn(missing_docs)]

mod coordinator;
mod error;
mod net;
mod node;
mod spec;
pub mod wire;

pub use coordinator::{Coordinator, NodeReport, RigFrame, RigOptions, ViewOutput};
pub use error::NodeError;
pub use net::NetConfig;
pub use node::{MAX_GPU, NodeOptions, NodeSummary, run_node};
pub use spec::{MAX_SIDE, Planes, RigViewId, ViewSpec};
