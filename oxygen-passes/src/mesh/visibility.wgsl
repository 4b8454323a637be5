// The visibility pass of deferred shading: for each pixel, a 32-bit surface
// id in an R32Uint target, and the label planes the view asks for beside
// it; no colour. A compute pass (mesh/deferred.wgsl) then shades every
// pixel once from the id. Masked variants cut out what their alpha cuts
// out, as shading does, so the target holds only surfaces shading keeps.
//
// The id is the draw's index in the view's draws plus one (0: nothing
// drawn) above the low `scene.renderer.surface_vertex_bits` bits, which
// hold the index value of the vertex that starts the pixel's triangle: a
// flat varying takes the triangle's first vertex's value (its provoking
// vertex), so each vertex writes its own and the rasterizer picks. The
// compute pass finds the triangle among the few that start at that vertex
// (finalize/triangle_table.rs in oxygen-sceneprep). The primitive index
// would name it directly, but reading it, and the second word it needs,
// cost an H200 8.8 ms of a 256-view field's 65 (docs/performance.md).

#include "mesh/mesh_vertex.wgsl"
#include "mesh/label_values.wgsl"

// The surface id of draw `draw_index`'s vertex `vertex_index` (base
// vertex included): its index value in the low `surface_vertex_bits`, the
// draw's index plus one above them.
fn surface_id(draw_index: u32, vertex_index: u32) -> u32 {
    let draw = draw_metadata_domain[scene.renderer.draw_metadata_slot + draw_index];
    let corner = u32(i32(vertex_index) - i32(draw.vertex_slot) - draw.base_vertex);
    return ((draw_index + 1u) << scene.renderer.surface_vertex_bits) | corner;
}

// The draw of a surface id.
fn draw_of_surface(surface: u32) -> u32 {
    return (surface >> scene.renderer.surface_vertex_bits) - 1u;
}

// Opaque surfaces of a view without label planes: the position and the
// surface id are all the vertex stage writes, the fewest outputs a vertex
// can have (this pass is vertex-bound on small triangles).
struct SurfaceIo {
    // Invariant so that a depth pre-pass's depth is reproduced bit for bit.
    @builtin(position) @invariant clip_position: vec4<f32>,
    @location(0) @interpolate(flat, first) surface: u32,
}

@vertex
fn vs_visibility(@builtin(vertex_index) vertex_index: u32, @builtin(instance_index) draw_index: u32) -> SurfaceIo {
    let m = mesh_vertex(draw_index, vertex_index);
    return SurfaceIo(m.clip_position, surface_id(draw_index, vertex_index));
}

@fragment
fn fs_visibility(io: SurfaceIo) -> @location(0) u32 {
    return io.surface;
}

// Masked surfaces and views with label planes need the surface point: the
// shared vertex outputs, with the surface id in the draw's flat slot (whose
// sampling, WGSL's default for flat, is also the first vertex's).
@vertex
fn vs_visibility_labelled(
    @builtin(vertex_index) vertex_index: u32,
    @builtin(instance_index) draw_index: u32,
) -> MeshIo {
    var m = mesh_vertex(draw_index, vertex_index);
    m.draw = surface_id(draw_index, vertex_index);
    return pack_varying(m);
}

struct Visible {
    @location(0) surface: u32,
    @location(1) instance: u32,
    @location(2) normal: vec4<f32>,
    @location(3) semantic_class: u32,
    @location(4) linear_depth: u32,
}

// The surface point of the labelled stage's outputs (its draw decoded) and
// the surface id.
struct SurfacePoint {
    mesh: MeshVarying,
    surface: u32,
}

fn surface_point(io: MeshIo) -> SurfacePoint {
    var mesh = unpack_varying(io);
    let surface = mesh.draw;
    mesh.draw = draw_of_surface(surface);
    return SurfacePoint(mesh, surface);
}

fn visible(p: SurfacePoint, front_facing: bool) -> Visible {
    let l = labels_of(p.mesh, front_facing);
    return Visible(p.surface, l.instance, l.normal, l.semantic_class, l.linear_depth);
}

@fragment
fn fs_visibility_labelled(io: MeshIo, @builtin(front_facing) front_facing: bool) -> Visible {
    return visible(surface_point(io), front_facing);
}

@fragment
fn fs_visibility_masked(io: MeshIo, @builtin(front_facing) front_facing: bool) -> Visible {
    let p = surface_point(io);
    // Derivatives first, in uniform control flow, as the shading pass takes them.
    let d = uv_derivatives_of(p.mesh);
    let material = material_of(p.mesh);
    if base_color_of(p.mesh, material, d).a < material.alpha_cutoff {
        discard;
    }
    return visible(p, front_facing);
}
