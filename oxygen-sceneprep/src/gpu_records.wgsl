// GPU records read through bindless slots. Their structs are generated from
// the Rust declarations in oxygen-sceneprep (gpu_struct!: NormalMatrix, DrawMetadata,
// UvTransformRecord, MaterialRecord, the light records, the ray scene's
// records) and included here; VertexRecord, oxygen-core's Vertex, is written
// out. The shader registry's layout test compares each with its Rust layout.
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

// Texture coordinate `uv` through a texture's transform (its affine rows):
// what the rasterizer and the path-traced reference both apply.
fn apply_uv_transform(t: UvTransformRecord, uv: vec2<f32>) -> vec2<f32> {
    let p = vec3<f32>(uv, 1.0);
    return vec2<f32>(dot(t.row0, p), dot(t.row1, p));
}

// Scalars only: a vec3 member would be 16-byte aligned and break the 32-byte stride.
struct VertexRecord {
    px: f32, py: f32, pz: f32,
    nx: f32, ny: f32, nz: f32,
    u: f32, v: f32,
}
