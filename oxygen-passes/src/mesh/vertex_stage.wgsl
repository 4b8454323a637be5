// The vertex stage every mesh pass shares: the draw's vertex
// (mesh/mesh_vertex.wgsl `mesh_vertex`) packed into the stage's outputs.
// Apart from the vertex function so that deferred shading's compute
// module, which calls that function per corner, has no vertex stage.

#include "mesh/mesh_vertex.wgsl"

@vertex
fn vs_main(@builtin(vertex_index) vertex_index: u32, @builtin(instance_index) draw_index: u32) -> MeshIo {
    return pack_varying(mesh_vertex(draw_index, vertex_index));
}
