//! Import limits: what an untrusted file may make Oxygen allocate.
//!
//! Every size in a glTF file is a claim made by whoever wrote it. The importer
//! checks each claim against [`ImportLimits`] *before* it allocates for it,
//! and keeps a running total of the bytes it has decoded so far in a
//! [`Budget`]. Passing a limit is an error naming the limit, the value asked
//! for and the maximum, never an allocation attempt.
//!
//! The defaults keep the importer's own allocations for any one file under
//! about 1 GiB (see `docs/security.md` for the arithmetic); a caller with
//! larger trusted scenes raises them.

use std::fmt;

/// Upper bounds on what one import may allocate. [`Default`] suits untrusted
/// files on a desktop machine; every field can be raised or lowered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImportLimits {
    /// Size of the `.gltf`/`.glb` file itself, bytes.
    pub max_file_bytes: u64,
    /// Size of the JSON part (the whole `.gltf`, or a `.glb`'s JSON chunk),
    /// bytes. JSON expands when parsed (about 100× for a file of empty
    /// objects), so it has its own, smaller bound.
    pub max_json_bytes: u64,
    /// JSON objects in the document (`{`…`}`), counted before parsing: each
    /// becomes one parsed record of a few hundred bytes.
    pub max_json_objects: u64,
    /// Nodes in the document.
    pub max_nodes: u64,
    /// Depth of the node hierarchy (a root has depth 1).
    pub max_node_depth: u32,
    /// Vertices over all imported meshes.
    pub max_vertices: u64,
    /// Indices over all imported meshes.
    pub max_indices: u64,
    /// Width and height of any one texture, texels.
    pub max_texture_dimension: u32,
    /// Size of any one encoded image (PNG or JPEG) read from a file, a
    /// `data:` URI or a buffer view, bytes.
    pub max_image_file_bytes: u64,
    /// Bytes decoded in all: the file, buffers, decoded pixels, vertices and
    /// indices together.
    pub max_total_bytes: u64,
}

impl Default for ImportLimits {
    fn default() -> Self {
        const MIB: u64 = 1 << 20;
        ImportLimits {
            max_file_bytes: 512 * MIB,
            max_json_bytes: 64 * MIB,
            max_json_objects: 1_000_000,
            max_nodes: 200_000,
            max_node_depth: 512,
            max_vertices: 16 << 20,
            max_indices: 48 << 20,
            max_texture_dimension: 8192,
            max_image_file_bytes: 64 * MIB,
            max_total_bytes: 768 * MIB,
        }
    }
}

impl ImportLimits {
    /// No limits at all, for trusted files whose size is known to be fine.
    /// Structural checks (cycles, ranges, types) still apply.
    pub fn unlimited() -> Self {
        ImportLimits {
            max_file_bytes: u64::MAX,
            max_json_bytes: u64::MAX,
            max_json_objects: u64::MAX,
            max_nodes: u64::MAX,
            max_node_depth: u32::MAX,
            max_vertices: u64::MAX,
            max_indices: u64::MAX,
            max_texture_dimension: u32::MAX,
            max_image_file_bytes: u64::MAX,
            max_total_bytes: u64::MAX,
        }
    }
}

/// A limit that a file tried to pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LimitExceeded {
    /// The [`ImportLimits`] field's name.
    pub limit: &'static str,
    /// What the file asked for (for running totals: the total it would reach).
    pub value: u64,
    /// The limit's value.
    pub max: u64,
}

impl fmt::Display for LimitExceeded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "import limit {} exceeded: {} > {}", self.limit, self.value, self.max)
    }
}

impl std::error::Error for LimitExceeded {}

/// Checks one value against one limit.
pub(crate) fn check(limit: &'static str, value: u64, max: u64) -> Result<(), LimitExceeded> {
    if value > max { Err(LimitExceeded { limit, value, max }) } else { Ok(()) }
}

/// Running totals of one import, checked against its limits as they grow.
#[derive(Debug)]
pub(crate) struct Budget {
    pub(crate) limits: ImportLimits,
    total_bytes: u64,
    vertices: u64,
    indices: u64,
}

impl Budget {
    pub(crate) fn new(limits: ImportLimits) -> Self {
        Budget { limits, total_bytes: 0, vertices: 0, indices: 0 }
    }

    /// Accounts for `bytes` about to be allocated.
    pub(crate) fn spend_bytes(&mut self, bytes: u64) -> Result<(), LimitExceeded> {
        let total = self.total_bytes.saturating_add(bytes);
        check("max_total_bytes", total, self.limits.max_total_bytes)?;
        self.total_bytes = total;
        Ok(())
    }

    /// Checks that `bytes` more could live for a moment (a decoder's scratch
    /// buffer) without keeping them on the account.
    pub(crate) fn afford(&self, bytes: u64) -> Result<(), LimitExceeded> {
        check("max_total_bytes", self.total_bytes.saturating_add(bytes), self.limits.max_total_bytes)
    }

    /// Accounts for a primitive's vertices and indices (and their bytes).
    pub(crate) fn spend_geometry(
        &mut self,
        vertices: u64,
        indices: u64,
        vertex_size: u64,
    ) -> Result<(), LimitExceeded> {
        let v = self.vertices.saturating_add(vertices);
        check("max_vertices", v, self.limits.max_vertices)?;
        let i = self.indices.saturating_add(indices);
        check("max_indices", i, self.limits.max_indices)?;
        self.spend_bytes(vertices.saturating_mul(vertex_size).saturating_add(indices.saturating_mul(4)))?;
        self.vertices = v;
        self.indices = i;
        Ok(())
    }

    /// Bytes accounted for so far.
    pub(crate) fn total_bytes(&self) -> u64 {
        self.total_bytes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unlimited_limits_take_what_the_defaults_refuse() {
        let defaults = ImportLimits::default();
        // A terabyte at once, far past the default total of 768 MiB.
        Budget::new(ImportLimits::unlimited()).spend_bytes(1 << 40).unwrap();
        assert!(Budget::new(defaults).spend_bytes(defaults.max_total_bytes + 1).is_err());
        let unlimited = ImportLimits::unlimited();
        assert_eq!(
            (unlimited.max_file_bytes, unlimited.max_json_bytes, unlimited.max_json_objects, unlimited.max_nodes),
            (u64::MAX, u64::MAX, u64::MAX, u64::MAX)
        );
        assert_eq!((unlimited.max_node_depth, unlimited.max_texture_dimension), (u32::MAX, u32::MAX));
        assert_eq!(
            (unlimited.max_vertices, unlimited.max_indices, unlimited.max_image_file_bytes, unlimited.max_total_bytes),
            (u64::MAX, u64::MAX, u64::MAX, u64::MAX)
        );
    }

    #[test]
    fn a_budget_refuses_the_allocation_that_would_pass_its_limit_and_keeps_its_total() {
        let mut budget = Budget::new(ImportLimits { max_total_bytes: 100, ..ImportLimits::default() });
        budget.spend_bytes(60).unwrap();
        let err = budget.spend_bytes(41).unwrap_err();
        assert_eq!(err, LimitExceeded { limit: "max_total_bytes", value: 101, max: 100 });
        assert_eq!(budget.total_bytes(), 60);
        budget.spend_bytes(40).unwrap();
    }

    #[test]
    fn a_scratch_buffer_must_fit_beside_what_is_kept_but_is_not_kept() {
        let mut budget = Budget::new(ImportLimits { max_total_bytes: 100, ..ImportLimits::default() });
        budget.spend_bytes(60).unwrap();
        budget.afford(40).unwrap();
        assert_eq!(budget.afford(41).unwrap_err(), LimitExceeded { limit: "max_total_bytes", value: 101, max: 100 });
        assert_eq!(budget.total_bytes(), 60);
    }

    #[test]
    fn vertex_and_index_counts_have_their_own_limits() {
        let mut budget = Budget::new(ImportLimits { max_vertices: 10, max_indices: 30, ..ImportLimits::default() });
        budget.spend_geometry(10, 30, 32).unwrap();
        assert_eq!(budget.spend_geometry(1, 0, 32).unwrap_err().limit, "max_vertices");
        assert_eq!(budget.spend_geometry(0, 1, 32).unwrap_err().limit, "max_indices");
    }
}
