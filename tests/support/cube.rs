//! Cube faces read back from the GPU (environments, probes): which texel a
//! direction falls on, and how continuous the faces are across their seams.

use oxygen::prelude::*;

/// The face, x, y of the texel direction `d` falls on (the shader's lookup).
pub fn texel_of(d: Vec3, side: u32) -> (usize, u32, u32) {
    oxygen::core::environment::cube_texel_of(d, side)
}

/// Across every edge of every face: the mean jump between a border texel
/// and its neighbour on the next face, and the mean jump between
/// neighbouring texels inside the faces. A cube filtered face by face
/// breaks at the seams (the first far above the second); one filtered
/// across them does not.
pub fn seam_and_interior_jumps(faces: &[Vec<Vec3>], side: u32) -> (f32, f32) {
    use oxygen::core::environment::cube_texel_direction;
    let texel = |f: usize, x: u32, y: u32| faces[f][(y * side + x) as usize];
    let (mut seam, mut seams) = (0.0, 0.0);
    let (mut inner, mut inners) = (0.0, 0.0);
    for face in 0..6 {
        for y in 0..side {
            for x in 0..side {
                let here = texel(face, x, y);
                if x + 1 < side {
                    inner += (texel(face, x + 1, y) - here).length();
                    inners += 1.0;
                }
                if y + 1 < side {
                    inner += (texel(face, x, y + 1) - here).length();
                    inners += 1.0;
                }
                let border = x == 0 || y == 0 || x == side - 1 || y == side - 1;
                if !border {
                    continue;
                }
                // Step one texel outwards, across the nearest edge.
                let d = cube_texel_direction(face, x, y, side);
                let (forward, up) = oxygen::core::environment::CUBE_FACE_AXES[face];
                let right = forward.cross(up);
                let mut outward = Vec3::ZERO;
                if x == 0 {
                    outward -= right;
                }
                if x == side - 1 {
                    outward += right;
                }
                if y == 0 {
                    outward += up;
                }
                if y == side - 1 {
                    outward -= up;
                }
                let beyond = (d + outward * (2.0 / side as f32)).normalize();
                let (f, bx, by) = texel_of(beyond, side);
                if f != face {
                    seam += (texel(f, bx, by) - here).length();
                    seams += 1.0;
                }
            }
        }
    }
    (seam / seams, inner / inners)
}
