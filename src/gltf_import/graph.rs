//! The node graph, checked before it is walked.
//!
//! glTF requires the nodes of a scene to form disjoint trees: no cycles, no
//! node with two parents, every index in range. A file that breaks these
//! rules is refused here with an error naming the node, before any node is
//! added to the [`Scene`](oxygen_core::Scene); the walk that follows is an
//! explicit stack, so a deep (but legal) hierarchy cannot overflow the
//! thread's stack.

use gltf::json;

/// Why a node graph was refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum GraphError {
    /// A child or scene root index names no node.
    #[error("node {node}: child index {child} is out of range ({count} nodes)")]
    ChildOutOfRange {
        /// The parent (or `usize::MAX` for a scene's root list).
        node: usize,
        /// The bad index.
        child: usize,
        /// Nodes in the file.
        count: usize,
    },
    /// A scene lists a root node index that does not exist.
    #[error("scene root index {root} is out of range ({count} nodes)")]
    RootOutOfRange {
        /// The bad index.
        root: usize,
        /// Nodes in the file.
        count: usize,
    },
    /// A node has two parents (or is listed twice by one parent).
    #[error("node {node} has two parents ({first} and {second}); glTF nodes form trees")]
    TwoParents {
        /// The node.
        node: usize,
        /// Its first parent.
        first: usize,
        /// Its second parent.
        second: usize,
    },
    /// A scene root is also some node's child.
    #[error("node {node} is a scene root and also a child of node {parent}")]
    RootWithParent {
        /// The node.
        node: usize,
        /// Its parent.
        parent: usize,
    },
    /// A scene lists one root twice.
    #[error("node {node} is listed twice as a scene root")]
    DuplicateRoot {
        /// The node.
        node: usize,
    },
    /// A cycle: following children from `node` leads back to it.
    #[error("node {node} is its own ancestor (a cycle in the node graph)")]
    Cycle {
        /// A node on the cycle.
        node: usize,
    },
}

/// Checks every node's children and returns each node's parent. A graph that
/// passes is a forest: walks over it terminate and visit each node once.
pub(crate) fn parents(nodes: &[json::Node]) -> Result<Vec<Option<usize>>, GraphError> {
    let count = nodes.len();
    let mut parent: Vec<Option<usize>> = vec![None; count];
    for (index, node) in nodes.iter().enumerate() {
        for child in node.children.iter().flatten() {
            let child = child.value();
            if child >= count {
                return Err(GraphError::ChildOutOfRange { node: index, child, count });
            }
            if child == index {
                return Err(GraphError::Cycle { node: index });
            }
            if let Some(first) = parent[child] {
                return Err(GraphError::TwoParents { node: child, first, second: index });
            }
            parent[child] = Some(index);
        }
    }
    // With one parent each, a cycle is a chain of parents that never reaches
    // a root. Colour each node once: 0 unknown, 1 on the current chain,
    // 2 known to reach a root.
    let mut state = vec![0u8; count];
    let mut chain = Vec::new();
    for start in 0..count {
        let mut at = start;
        while state[at] == 0 {
            state[at] = 1;
            chain.push(at);
            match parent[at] {
                Some(p) => at = p,
                None => break,
            }
        }
        if state[at] == 1 && parent[at].is_some() {
            return Err(GraphError::Cycle { node: at });
        }
        for n in chain.drain(..) {
            state[n] = 2;
        }
    }
    Ok(parent)
}

/// Checks a scene's root list against the parent table.
pub(crate) fn check_roots(roots: &[usize], parent: &[Option<usize>]) -> Result<(), GraphError> {
    let mut seen = std::collections::HashSet::with_capacity(roots.len());
    for &root in roots {
        let Some(p) = parent.get(root) else {
            return Err(GraphError::RootOutOfRange { root, count: parent.len() });
        };
        if let Some(parent) = p {
            return Err(GraphError::RootWithParent { node: root, parent: *parent });
        }
        if !seen.insert(root) {
            return Err(GraphError::DuplicateRoot { node: root });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nodes(children: &[&[u32]]) -> Vec<json::Node> {
        children
            .iter()
            .map(|c| {
                let json = format!(r#"{{"children":{c:?}}}"#);
                serde_json_node(&json)
            })
            .collect()
    }

    fn serde_json_node(text: &str) -> json::Node {
        json::deserialize::from_str(text).unwrap()
    }

    #[test]
    fn a_forest_passes_and_reports_parents() {
        let parents = parents(&nodes(&[&[1, 2], &[3], &[], &[]])).unwrap();
        assert_eq!(parents, vec![None, Some(0), Some(0), Some(1)]);
    }

    #[test]
    fn self_child_two_node_cycle_and_longer_cycle_are_refused() {
        assert_eq!(parents(&nodes(&[&[0]])).unwrap_err(), GraphError::Cycle { node: 0 });
        assert!(matches!(parents(&nodes(&[&[1], &[0]])).unwrap_err(), GraphError::Cycle { .. }));
        assert!(matches!(parents(&nodes(&[&[], &[2], &[3], &[1]])).unwrap_err(), GraphError::Cycle { .. }));
    }

    #[test]
    fn shared_children_and_bad_indices_are_refused() {
        assert_eq!(
            parents(&nodes(&[&[2], &[2], &[]])).unwrap_err(),
            GraphError::TwoParents { node: 2, first: 0, second: 1 }
        );
        assert_eq!(
            parents(&nodes(&[&[1, 1], &[]])).unwrap_err(),
            GraphError::TwoParents { node: 1, first: 0, second: 0 }
        );
        assert!(matches!(parents(&nodes(&[&[5]])).unwrap_err(), GraphError::ChildOutOfRange { child: 5, .. }));
    }

    #[test]
    fn roots_must_be_parentless_unique_and_in_range() {
        let p = parents(&nodes(&[&[1], &[]])).unwrap();
        check_roots(&[0], &p).unwrap();
        assert!(matches!(check_roots(&[1], &p), Err(GraphError::RootWithParent { node: 1, parent: 0 })));
        assert!(matches!(check_roots(&[0, 0], &p), Err(GraphError::DuplicateRoot { node: 0 })));
        assert!(matches!(check_roots(&[9], &p), Err(GraphError::RootOutOfRange { root: 9, .. })));
    }
}
