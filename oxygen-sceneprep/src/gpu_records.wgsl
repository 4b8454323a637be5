// GPU records read through bindless slots. Their structs are generated from
// the Rust declarations in oxygen-sceneprep (gpu_struct!: NormalMatrix, DrawMetadata,
// UvTransformRecord, MaterialRecord, the light records, the ray scene's
// records, VertexRecord) and included here. The shader registry's layout
// test compares each with its Rust layout, and oxygen-core's vertex,
// attribute and skin records with the VertexRecord members shaders read
// them through (vertex_record_overlays).
// The numbers shaders compare these fields with (PASS_*, MATERIAL_*, LIGHT_*)
// are generated: PassMask::wgsl_constants, MaterialRecord::wgsl_constants,
// PositionalLightRecord::wgsl_constants.

#include "sceneprep/NormalMatrix"
#include "sceneprep/DrawMetadata"
#include "sceneprep/UvTransformRecord"
#include "sceneprep/MaterialRecord"
#include "sceneprep/DirectionalLightRecord"
#include "sceneprep/PositionalLightRecord"
// The path-traced reference's ray scene (ray::BvhNode, RayInstance); the
// domain bindings name BvhNode.
#include "sceneprep/BvhNode"
#include "sceneprep/RayInstance"
// The vertex domain's record (oxygen-core's Vertex, VertexAttributes and
// SkinWeights are read through its members).
#include "sceneprep/VertexRecord"

// A NormalMatrix record's matrix (its first column's padding carries the
// node's semantic class).
fn normal_matrix_of(r: NormalMatrix) -> mat3x3<f32> {
    return mat3x3<f32>(r.x, r.y, r.z);
}

// Texture coordinate `uv` through a texture's transform (its affine rows):
// what the rasterizer and the path-traced reference both apply.
fn apply_uv_transform(t: UvTransformRecord, uv: vec2<f32>) -> vec2<f32> {
    let p = vec3<f32>(uv, 1.0);
    return vec2<f32>(dot(t.row0, p), dot(t.row1, p));
}
