//! Why a pass cannot record.

use thiserror::Error;

/// A pass that cannot record.
#[derive(Debug, Error)]
pub enum PassError {
    /// A graph read an output its view is not linked to.
    #[error("reads the {output} of {from}, which the view is not linked to (link it when registering the view)")]
    UndeclaredInput {
        /// The kind of output.
        output: &'static str,
        /// Whose output.
        from: String,
    },
    /// A pass needs what an earlier pass should have produced.
    #[error("{pass}: needs {input}, which no earlier pass of this view produced")]
    MissingInput {
        /// The pass.
        pass: &'static str,
        /// The missing output's type.
        input: &'static str,
    },
    /// A colour pass ran in a depth-only view.
    #[error("{pass}: the view is depth-only and has no colour target")]
    NoColorTarget {
        /// The pass.
        pass: &'static str,
    },
    /// An input the pass cannot use, e.g. local-light shadow maps of
    /// different sizes.
    #[error("{pass}: {what}")]
    BadInput {
        /// The pass.
        pass: &'static str,
        /// What is wrong.
        what: String,
    },
    /// An application-defined failure inside a render graph.
    #[error("render graph: {0}")]
    Graph(String),
}
