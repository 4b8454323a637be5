// The vertex stage's outputs for a scene whose meshes carry no vertex
// colours and no second UV set: three locations. Vertex-bound work (a
// batch of small cameras, a field of many views) pays for every location
// a vertex writes, so the UV rides in the spare lanes of the position and
// the normal and the draw's index is the only flat one.

const HAS_VERTEX_ATTRIBUTES: bool = false;

struct MeshIo {
    // Invariant so that the shading pass reproduces the pre-pass depth bit
    // for bit and its GreaterEqual test passes exactly on the visible surface.
    @builtin(position) @invariant clip_position: vec4<f32>,
    @location(0) position_u: vec4<f32>,
    @location(1) normal_v: vec4<f32>,
    @location(2) @interpolate(flat) draw: u32,
}

fn pack_varying(m: MeshVarying) -> MeshIo {
    return MeshIo(m.clip_position, vec4<f32>(m.world_position, m.uv.x), vec4<f32>(m.world_normal, m.uv.y), m.draw);
}

fn unpack_varying(io: MeshIo) -> MeshVarying {
    return MeshVarying(
        io.clip_position,
        io.position_u.xyz,
        io.normal_v.xyz,
        vec2<f32>(io.position_u.w, io.normal_v.w),
        io.draw,
        vec4<f32>(1.0),
        vec2<f32>(0.0),
    );
}
