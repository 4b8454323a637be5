// Interleaved gradient noise (Jimenez 2014): a value in [0, 1) for a pixel
// position that varies over a few pixels with no visible pattern; what the
// screen-space effects turn their samples by from pixel to pixel.
fn interleaved_gradient_noise(pixel: vec2<f32>) -> f32 {
    return fract(52.9829189 * fract(dot(pixel, vec2<f32>(0.06711056, 0.00583715))));
}
