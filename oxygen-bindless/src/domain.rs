//! The typed domains of the heap and how shaders see them.

/// A typed GPU buffer of fixed-size records that shaders index by slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum DomainKind {
    /// `DrawMetadata` records (64 B), one range per view per frame.
    DrawMetadata,
    /// World matrices (`mat4x4<f32>`, 64 B), one range per frame shared by views.
    WorldTransforms,
    /// `NormalMatrix` records (a `mat3x3<f32>`, 48 B), parallel to the world matrices.
    NormalTransforms,
    /// `MaterialRecord`s (240 B), persistent per material.
    Materials,
    /// `DirectionalLightRecord`s (48 B), one range per frame.
    DirectionalLights,
    /// `PositionalLightRecord`s (64 B), one range per frame.
    PositionalLights,
    /// `VertexRecord`s (32 B), persistent per geometry: its vertices, then
    /// its `VertexAttributes` (colour, second UV set) when it has them.
    Vertices,
    /// `u32` indices, persistent per geometry; bound as the index buffer.
    Indices,
    /// `DrawIndexedIndirect` arguments (20 B), one range per view per frame,
    /// parallel to the view's draw metadata; read by `multi_draw_indexed_indirect`.
    IndirectArgs,
    /// Texture location records (`u32`), one per texture slot, persistent:
    /// where the texture lives on the chosen [`crate::TexturePath`].
    TextureLocations,
    /// `BvhNode`s (32 B) of the path-traced reference's two-level bounding
    /// volume hierarchy, one range per ray-scene rebuild (compute only).
    BvhNodes,
    /// `u32` words of the ray scene: leaf orders and submesh tables.
    RayWords,
    /// `RayInstance`s (80 B): one per instance the reference traces.
    RayInstances,
}

impl DomainKind {
    /// Every domain, in binding order.
    pub const ALL: [DomainKind; 13] = [
        DomainKind::DrawMetadata,
        DomainKind::WorldTransforms,
        DomainKind::NormalTransforms,
        DomainKind::Materials,
        DomainKind::DirectionalLights,
        DomainKind::PositionalLights,
        DomainKind::Vertices,
        DomainKind::Indices,
        DomainKind::IndirectArgs,
        DomainKind::TextureLocations,
        DomainKind::BvhNodes,
        DomainKind::RayWords,
        DomainKind::RayInstances,
    ];

    /// Number of domains.
    pub const COUNT: usize = Self::ALL.len();

    /// Position in [`Self::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Size of one record in bytes. The record types (defined where they are
    /// produced, e.g. `DrawMetadata` in ScenePrep) assert their size against
    /// this at compile time.
    pub const fn record_size(self) -> u64 {
        match self {
            DomainKind::DrawMetadata => 64,
            DomainKind::WorldTransforms => 64,
            DomainKind::NormalTransforms => 48,
            DomainKind::Materials => 240,
            DomainKind::DirectionalLights => 48,
            DomainKind::PositionalLights => 80,
            DomainKind::Vertices => 32,
            DomainKind::Indices => 4,
            DomainKind::IndirectArgs => 20,
            DomainKind::TextureLocations => 4,
            DomainKind::BvhNodes => 32,
            DomainKind::RayWords => 4,
            DomainKind::RayInstances => 80,
        }
    }

    /// The storage binding in bind group 0, or `None` when the domain is not
    /// read by shaders through a binding (indices feed the index buffer).
    pub const fn binding(self) -> Option<u32> {
        match self {
            DomainKind::Indices | DomainKind::IndirectArgs => None,
            other => Some(other as u32),
        }
    }

    /// Variable name and element type in WGSL.
    pub const fn wgsl(self) -> (&'static str, &'static str) {
        match self {
            DomainKind::DrawMetadata => ("draw_metadata_domain", "DrawMetadata"),
            DomainKind::WorldTransforms => ("world_transform_domain", "mat4x4<f32>"),
            DomainKind::NormalTransforms => ("normal_transform_domain", "NormalMatrix"),
            DomainKind::Materials => ("material_domain", "MaterialRecord"),
            DomainKind::DirectionalLights => ("directional_light_domain", "DirectionalLightRecord"),
            DomainKind::PositionalLights => ("positional_light_domain", "PositionalLightRecord"),
            DomainKind::Vertices => ("vertex_domain", "VertexRecord"),
            DomainKind::Indices => ("index_domain", "u32"),
            DomainKind::IndirectArgs => ("indirect_args_domain", "u32"),
            DomainKind::TextureLocations => ("texture_location_domain", "u32"),
            DomainKind::BvhNodes => ("bvh_node_domain", "BvhNode"),
            DomainKind::RayWords => ("ray_word_domain", "u32"),
            DomainKind::RayInstances => ("ray_instance_domain", "RayInstance"),
        }
    }

    /// The shader stages that read the domain. Kept tight so each stage stays
    /// within `max_storage_buffers_per_shader_stage` (4 vertex, 6 fragment).
    /// The fragment stage reads a draw's record (its material and node) and
    /// its normal record (the node's semantic class) through the draw's index,
    /// the one flat varying the vertex stage passes on.
    pub const fn visibility(self) -> wgpu::ShaderStages {
        match self {
            DomainKind::DrawMetadata | DomainKind::NormalTransforms => {
                wgpu::ShaderStages::VERTEX.union(wgpu::ShaderStages::FRAGMENT).union(wgpu::ShaderStages::COMPUTE)
            }
            DomainKind::WorldTransforms | DomainKind::Vertices => {
                wgpu::ShaderStages::VERTEX.union(wgpu::ShaderStages::COMPUTE)
            }
            // Only the reference tracer (a compute shader) reads the ray scene.
            DomainKind::BvhNodes | DomainKind::RayWords | DomainKind::RayInstances => wgpu::ShaderStages::COMPUTE,
            _ => wgpu::ShaderStages::FRAGMENT.union(wgpu::ShaderStages::COMPUTE),
        }
    }

    /// Buffer usages beyond copy source/destination.
    pub(crate) fn usages(self) -> wgpu::BufferUsages {
        match self {
            // Storage too: the path-traced reference reads triangles from
            // it (bound by that pass, not in group 0).
            DomainKind::Indices => wgpu::BufferUsages::INDEX | wgpu::BufferUsages::STORAGE,
            // Storage too: GPU visibility writes commands with compute.
            DomainKind::IndirectArgs => wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::STORAGE,
            _ => wgpu::BufferUsages::STORAGE,
        }
    }

    /// Lower-case name for errors and logs.
    pub const fn name(self) -> &'static str {
        match self {
            DomainKind::DrawMetadata => "draw-metadata",
            DomainKind::WorldTransforms => "world-transforms",
            DomainKind::NormalTransforms => "normal-transforms",
            DomainKind::Materials => "materials",
            DomainKind::DirectionalLights => "directional-lights",
            DomainKind::PositionalLights => "positional-lights",
            DomainKind::Vertices => "vertices",
            DomainKind::Indices => "indices",
            DomainKind::IndirectArgs => "indirect-args",
            DomainKind::TextureLocations => "texture-locations",
            DomainKind::BvhNodes => "bvh-nodes",
            DomainKind::RayWords => "ray-words",
            DomainKind::RayInstances => "ray-instances",
        }
    }

    /// WGSL declarations of every bound domain in bind group 0; the record
    /// structs they name must be declared by the including shader.
    pub fn wgsl_bindings() -> String {
        let mut out = String::new();
        for kind in Self::ALL {
            if let Some(binding) = kind.binding() {
                let (name, ty) = kind.wgsl();
                out.push_str(&format!("@group(0) @binding({binding}) var<storage, read> {name}: array<{ty}>;\n"));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_and_indirect_domains_get_their_buffer_usages_and_the_rest_are_storage() {
        assert_eq!(DomainKind::Indices.usages(), wgpu::BufferUsages::INDEX | wgpu::BufferUsages::STORAGE);
        // Storage too: GPU visibility writes commands from a compute shader.
        assert_eq!(DomainKind::IndirectArgs.usages(), wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::STORAGE);
        for kind in DomainKind::ALL.iter().filter(|k| k.binding().is_some()) {
            assert_eq!(kind.usages(), wgpu::BufferUsages::STORAGE, "{kind:?}");
        }
    }

    /// The vertex shader reads draws, transforms and vertices; only the
    /// tracer's compute shader reads the ray scene; and no stage sees more
    /// storage buffers than the limits `visibility` is kept tight for.
    #[test]
    fn each_stage_sees_the_domains_it_reads_within_the_storage_limits() {
        use wgpu::ShaderStages;
        for kind in
            [DomainKind::DrawMetadata, DomainKind::WorldTransforms, DomainKind::NormalTransforms, DomainKind::Vertices]
        {
            assert!(kind.visibility().contains(ShaderStages::VERTEX | ShaderStages::COMPUTE), "{kind:?}");
        }
        for kind in [DomainKind::BvhNodes, DomainKind::RayWords, DomainKind::RayInstances] {
            assert_eq!(kind.visibility(), ShaderStages::COMPUTE, "{kind:?}");
        }
        let bound = || DomainKind::ALL.into_iter().filter(|k| k.binding().is_some());
        let seen_by = |stage: ShaderStages| bound().filter(|k| k.visibility().contains(stage)).count();
        assert!(seen_by(ShaderStages::VERTEX) <= 4, "{} vertex", seen_by(ShaderStages::VERTEX));
        assert!(seen_by(ShaderStages::FRAGMENT) <= 6, "{} fragment", seen_by(ShaderStages::FRAGMENT));
    }
}
