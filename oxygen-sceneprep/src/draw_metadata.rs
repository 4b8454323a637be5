//! `DrawMetadata`: the 64-byte per-draw record shaders read by slot.

use std::mem::{offset_of, size_of};

use oxygen_bindless::DomainKind;

oxygen_gpu::gpu_struct! {
    /// One draw, as stored in the draw-metadata domain and read by the vertex
    /// shader through `draw_metadata_domain[scene.renderer.draw_metadata_slot + instance_index]`.
    ///
    /// Exactly 64 bytes (asserted at compile time); its WGSL twin is
    /// generated from this declaration.
    #[derive(Debug, Default, PartialEq, Eq)]
    pub struct DrawMetadata: 64 bytes {
        /// First vertex of the geometry in the vertex domain.
        pub vertex_slot: u32,
        /// First index of the geometry in the index domain.
        pub index_slot: u32,
        /// First index of the submesh, relative to `index_slot`.
        pub first_index: u32,
        /// Number of indices drawn.
        pub index_count: u32,
        /// Added to every index value, relative to `vertex_slot`.
        pub base_vertex: i32,
        /// Instances drawn (1 until instancing lands).
        pub instance_count: u32,
        /// World/normal matrix, relative to the frame's transform slots.
        pub transform_index: u32,
        /// Material, relative to the material domain base.
        pub material_handle: u32,
        /// [`crate::PassMask`] bits.
        pub pass_mask: u32,
        /// Stable node id (slot index), for debugging and picking.
        pub node_id: u32,
        /// Submesh number within the geometry.
        pub submesh: u32,
        /// The draw-metadata range's generation when the renderer checks
        /// generations (debug mode), else zero.
        pub generation: u32,
        /// First attribute record (colour, second UV set) of the geometry in
        /// the vertex domain, parallel to its vertices; [`oxygen_bindless::INVALID_SLOT`]
        /// when the geometry has none.
        pub attributes_slot: u32,
        /// First skin record (joints, weights) of the geometry in the vertex
        /// domain, parallel to its vertices; `INVALID_SLOT` for a rigid draw.
        pub skin_slot: u32,
        /// A skinned draw's first joint matrix, relative to the frame's
        /// transform slots (joint `i` at `joint_base + i`).
        pub joint_base: u32,
        /// A morphed draw's morph header (weights) relative to the frame's
        /// transform slots; `INVALID_SLOT` without morph targets.
        pub morph_base: u32,
    }
}

const _: () = {
    assert!(size_of::<DrawMetadata>() == 64);
    assert!(size_of::<DrawMetadata>() as u64 == DomainKind::DrawMetadata.record_size());
    assert!(offset_of!(DrawMetadata, vertex_slot) == 0);
    assert!(offset_of!(DrawMetadata, index_slot) == 4);
    assert!(offset_of!(DrawMetadata, first_index) == 8);
    assert!(offset_of!(DrawMetadata, index_count) == 12);
    assert!(offset_of!(DrawMetadata, base_vertex) == 16);
    assert!(offset_of!(DrawMetadata, instance_count) == 20);
    assert!(offset_of!(DrawMetadata, transform_index) == 24);
    assert!(offset_of!(DrawMetadata, material_handle) == 28);
    assert!(offset_of!(DrawMetadata, pass_mask) == 32);
    assert!(offset_of!(DrawMetadata, node_id) == 36);
    assert!(offset_of!(DrawMetadata, submesh) == 40);
    assert!(offset_of!(DrawMetadata, generation) == 44);
    assert!(offset_of!(DrawMetadata, attributes_slot) == 48);
    assert!(offset_of!(DrawMetadata, skin_slot) == 52);
    assert!(offset_of!(DrawMetadata, joint_base) == 56);
    assert!(offset_of!(DrawMetadata, morph_base) == 60);
};

impl DrawMetadata {
    /// The [`crate::PassMask`] of this draw.
    pub fn mask(&self) -> crate::PassMask {
        crate::PassMask::from_bits_truncate(self.pass_mask)
    }

    /// Absolute index range in the shared index buffer.
    pub fn index_range(&self) -> std::ops::Range<u32> {
        let first = self.index_slot + self.first_index;
        first..first + self.index_count
    }

    /// Absolute base vertex for `draw_indexed`.
    pub fn absolute_base_vertex(&self) -> i32 {
        self.vertex_slot as i32 + self.base_vertex
    }
}

oxygen_gpu::gpu_struct! {
    /// The arguments of one indexed draw as `multi_draw_indexed_indirect` reads
    /// them (wgpu's `DrawIndexedIndirectArgs` layout), written by the CPU in
    /// finalization, parallel to the view's [`DrawMetadata`].
    #[derive(Debug, Default, PartialEq, Eq)]
    pub struct DrawIndexedIndirect: 20 bytes {
        /// Indices drawn.
        pub index_count: u32,
        /// Instances drawn.
        pub instance_count: u32,
        /// Absolute first index in the shared index buffer.
        pub first_index: u32,
        /// Absolute base vertex.
        pub base_vertex: i32,
        /// The draw's position in the view's array: how the shader finds its
        /// `DrawMetadata` (needs `INDIRECT_FIRST_INSTANCE`).
        pub first_instance: u32,
    }
}

const _: () = assert!(size_of::<DrawIndexedIndirect>() as u64 == DomainKind::IndirectArgs.record_size());

impl DrawIndexedIndirect {
    /// The arguments for `draw`, which sits at `draw_index` in its view's array.
    pub fn for_draw(draw: &DrawMetadata, draw_index: u32) -> Self {
        DrawIndexedIndirect {
            index_count: draw.index_count,
            instance_count: draw.instance_count,
            first_index: draw.index_slot + draw.first_index,
            base_vertex: draw.absolute_base_vertex(),
            first_instance: draw_index,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A submesh that starts inside its geometry, which starts inside the
    /// shared buffers: every offset non-zero, so a slot added the wrong way
    /// lands somewhere else.
    fn submesh_draw() -> DrawMetadata {
        DrawMetadata {
            vertex_slot: 1000,
            index_slot: 100,
            first_index: 6,
            index_count: 12,
            base_vertex: 24,
            instance_count: 1,
            ..Default::default()
        }
    }

    #[test]
    fn index_range_spans_the_submesh_from_the_geometry_slot() {
        assert_eq!(submesh_draw().index_range(), 106..118);
    }

    #[test]
    fn absolute_base_vertex_offsets_the_geometry_slot() {
        assert_eq!(submesh_draw().absolute_base_vertex(), 1024);
        // `base_vertex` is signed, as `draw_indexed`'s is: a negative one
        // must reach below the slot, not above it.
        let below = DrawMetadata { base_vertex: -8, ..submesh_draw() };
        assert_eq!(below.absolute_base_vertex(), 992);
    }

    #[test]
    fn indirect_arguments_address_the_submesh_in_the_shared_buffers() {
        let draw = submesh_draw();
        assert_eq!(
            DrawIndexedIndirect::for_draw(&draw, 7),
            DrawIndexedIndirect {
                index_count: 12,
                instance_count: 1,
                first_index: 106,
                base_vertex: 1024,
                first_instance: 7,
            }
        );
        // What the CPU path draws directly, the indirect path draws too.
        let args = DrawIndexedIndirect::for_draw(&draw, 7);
        assert_eq!(args.first_index..args.first_index + args.index_count, draw.index_range());
    }
}
