// GPU records read through bindless slots. Twins of the Rust structs in
// oxygen-sceneprep (DrawMetadata, MaterialRecord, light records) and
// oxygen-core (Vertex); layouts asserted by the naga reflection test.
// The numbers shaders compare these fields with (PASS_*, MATERIAL_*, LIGHT_*)
// are generated: PassMask::wgsl_constants, MaterialRecord::wgsl_constants,
// PositionalLightRecord::wgsl_constants.

struct DrawMetadata {
    vertex_slot: u32,
    index_slot: u32,
    first_index: u32,
    index_count: u32,
    base_vertex: i32,
    instance_count: u32,
    transform_index: u32,
    material_handle: u32,
    pass_mask: u32,
    node_id: u32,
    submesh: u32,
    generation: u32,
    attributes_slot: u32,
    skin_slot: u32,
    joint_base: u32,
    morph_base: u32,
}

struct UvTransformRecord {
    row0: vec3<f32>,
    uv_set: u32,
    row1: vec3<f32>,
    reserved: u32,
}

// Texture coordinate `uv` through a texture's transform (its affine rows):
// what the rasterizer and the path-traced reference both apply.
fn apply_uv_transform(t: UvTransformRecord, uv: vec2<f32>) -> vec2<f32> {
    let p = vec3<f32>(uv, 1.0);
    return vec2<f32>(dot(t.row0, p), dot(t.row1, p));
}

struct MaterialRecord {
    base_color: vec4<f32>,
    emissive: vec3<f32>,
    normal_scale: f32,
    metallic: f32,
    roughness: f32,
    alpha_cutoff: f32,
    flags: u32,
    base_color_texture: u32,
    metallic_roughness_texture: u32,
    normal_texture: u32,
    emissive_texture: u32,
    occlusion_texture: u32,
    occlusion_strength: f32,
    reserved0: u32,
    reserved1: u32,
    uv_transforms: array<UvTransformRecord, 5>,
}

struct DirectionalLightRecord {
    direction: vec3<f32>,
    intensity: f32,
    color: vec3<f32>,
    flags: u32,
    shadow_slot: u32,
    reserved0: u32,
    reserved1: u32,
    reserved2: u32,
}

struct PositionalLightRecord {
    position: vec3<f32>,
    range: f32,
    direction: vec3<f32>,
    intensity: f32,
    color: vec3<f32>,
    kind: u32,
    cos_inner: f32,
    cos_outer: f32,
    flags: u32,
    shadow_slot: u32,
}

// Scalars only: a vec3 member would be 16-byte aligned and break the 32-byte stride.
struct VertexRecord {
    px: f32, py: f32, pz: f32,
    nx: f32, ny: f32, nz: f32,
    u: f32, v: f32,
}

// The path-traced reference's ray scene (oxygen_sceneprep::bvh::BvhNode,
// oxygen_sceneprep::RayInstance): see ray_scene.rs for the layout.
struct BvhNode {
    min: vec3<f32>,
    first: u32,
    max: vec3<f32>,
    count: u32,
}

struct RayInstance {
    // Rows of the inverse world matrix (world → object), affine.
    inverse_row0: vec4<f32>,
    inverse_row1: vec4<f32>,
    inverse_row2: vec4<f32>,
    transform_index: u32,
    blas_root: u32,
    vertex_slot: u32,
    index_slot: u32,
    submesh_first: u32,
    submesh_count: u32,
    attributes_slot: u32,
    // POSED (1) for a skinned or morphed instance posed on the CPU: its
    // vertex_slot was rebased onto its posed vertices on upload.
    flags: u32,
}
