// The cube layout every cube of the renderer shares (reflection probes,
// the environment, point-light shadow faces): six layers of a 2D array in
// the order +X, -X, +Y, -Y, +Z, -Z, each what an ordinary 90-degree camera
// looking along its axis sees (forward and up as in PROBE_FACE_AXES), so a
// lookup projects the direction onto that camera instead of using
// cube-map conventions.

fn cube_face_forward(face: u32) -> vec3<f32> {
    var forwards = array<vec3<f32>, 6>(
        vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(-1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0),
        vec3<f32>(0.0, -1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(0.0, 0.0, -1.0),
    );
    return forwards[face];
}

fn cube_face_up(face: u32) -> vec3<f32> {
    var ups = array<vec3<f32>, 6>(
        vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, -1.0),
        vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 1.0, 0.0),
    );
    return ups[face];
}

// The face whose camera looks along the major axis of `direction`.
fn cube_face(direction: vec3<f32>) -> u32 {
    let a = abs(direction);
    if a.x >= a.y && a.x >= a.z {
        return select(1u, 0u, direction.x >= 0.0);
    }
    if a.y >= a.z {
        return select(3u, 2u, direction.y >= 0.0);
    }
    return select(5u, 4u, direction.z >= 0.0);
}

// The face `direction` falls on and its UV there (xy: uv, z: face).
fn cube_face_uv(direction: vec3<f32>) -> vec3<f32> {
    let face = cube_face(direction);
    let forward = cube_face_forward(face);
    let up = cube_face_up(face);
    let depth = dot(direction, forward);
    let ndc = vec2<f32>(dot(direction, cross(forward, up)), dot(direction, up)) / depth;
    return vec3<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5, f32(face));
}

// The unnormalised direction through `uv` of `face`: the point of the
// face's plane at distance 1 (its length squared is 1 + x² + y²).
fn cube_face_point(face: u32, uv: vec2<f32>) -> vec3<f32> {
    let forward = cube_face_forward(face);
    let up = cube_face_up(face);
    let ndc = vec2<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
    return forward + cross(forward, up) * ndc.x + up * ndc.y;
}
