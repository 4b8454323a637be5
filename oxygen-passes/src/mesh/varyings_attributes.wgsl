// The vertex stage's outputs for a scene where some mesh carries vertex
// colours or a second UV set (glTF COLOR_0, TEXCOORD_1): those two take a
// location each after the three of mesh/varyings_plain.wgsl.

const HAS_VERTEX_ATTRIBUTES: bool = true;

struct MeshIo {
    // Invariant so that the shading pass reproduces the pre-pass depth bit
    // for bit and its GreaterEqual test passes exactly on the visible surface.
    @builtin(position) @invariant clip_position: vec4<f32>,
    @location(0) position_u: vec4<f32>,
    @location(1) normal_v: vec4<f32>,
    @location(2) @interpolate(flat) draw: u32,
    @location(3) color: vec4<f32>,
    @location(4) uv1: vec2<f32>,
}

fn pack_varying(m: MeshVarying) -> MeshIo {
    return MeshIo(
        m.clip_position,
        vec4<f32>(m.world_position, m.uv.x),
        vec4<f32>(m.world_normal, m.uv.y),
        m.draw,
        m.color,
        m.uv1,
    );
}

fn unpack_varying(io: MeshIo) -> MeshVarying {
    return MeshVarying(
        io.clip_position,
        io.position_u.xyz,
        io.normal_v.xyz,
        vec2<f32>(io.position_u.w, io.normal_v.w),
        io.draw,
        io.color,
        io.uv1,
    );
}
