// The forward pass's fragment stages over the shading of mesh/shading.wgsl:
// opaque and alpha-tested surfaces (with the view's labels beside the
// colour when it asks for them), blended surfaces, the environment behind
// the scene and a batch camera's tile cleared alone.

#include "mesh/shading.wgsl"
#include "mesh/vertex_stage.wgsl"

@fragment
fn fs_opaque(io: MeshIo, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let mesh = unpack_varying(io);
    return opaque_color(mesh, front_facing);
}

@fragment
fn fs_masked(io: MeshIo, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let mesh = unpack_varying(io);
    return masked_color(mesh, front_facing);
}

// The shading pass of a view that asked for labels writes them with the
// colour (one geometry pass, not two): the colour of fs_opaque and
// fs_masked, the labels of mesh/labels.wgsl one location further on.
struct Labelled {
    @location(0) color: vec4<f32>,
    @location(1) instance: u32,
    @location(2) normal: vec4<f32>,
    @location(3) semantic_class: u32,
    @location(4) linear_depth: u32,
}

fn labelled(color: vec4<f32>, mesh: MeshVarying, front_facing: bool) -> Labelled {
    let l = labels_of(mesh, front_facing);
    return Labelled(color, l.instance, l.normal, l.semantic_class, l.linear_depth);
}

@fragment
fn fs_opaque_labelled(io: MeshIo, @builtin(front_facing) front_facing: bool) -> Labelled {
    let mesh = unpack_varying(io);
    return labelled(opaque_color(mesh, front_facing), mesh, front_facing);
}

@fragment
fn fs_masked_labelled(io: MeshIo, @builtin(front_facing) front_facing: bool) -> Labelled {
    let mesh = unpack_varying(io);
    return labelled(masked_color(mesh, front_facing), mesh, front_facing);
}

// Transparent surfaces: premultiplied alpha (blend One, OneMinusSrcAlpha).
@fragment
fn fs_blend(io: MeshIo, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let mesh = unpack_varying(io);
    let d = derivatives_of(mesh);
    let handle = material_handle_of(mesh);
    if handle == INVALID_SLOT {
        return STALE_DRAW_COLOR;
    }
    let shaded = shade(mesh, front_facing, material_at(handle), d);
    let alpha = clamp(shaded.a, 0.0, 1.0);
    // Premultiplied and at most HDR_MAX × alpha, so blending over a target
    // texel of at most HDR_MAX stays at most HDR_MAX.
    return vec4<f32>(fit_hdr(shaded.rgb) * alpha, alpha);
}

// The environment behind the scene: a full-screen triangle at the far plane
// (reverse-Z depth 0, written with an always-passing test before any mesh,
// which then draws over it), radiance along each pixel's view ray.
struct SkyVarying {
    @builtin(position) position: vec4<f32>,
    @location(0) ndc: vec2<f32>,
}

@vertex
fn vs_sky(@builtin(vertex_index) index: u32) -> SkyVarying {
    let corner = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    let ndc = corner * 2.0 - 1.0;
    return SkyVarying(vec4<f32>(ndc, 0.0, 1.0), ndc);
}

@fragment
fn fs_sky(v: SkyVarying) -> @location(0) vec4<f32> {
    // Two points on the pixel's ray (reverse-Z: 1 is the near plane; 0.5
    // is finite even with an infinite far plane), for perspective and
    // orthographic views alike.
    let direction = normalize(unproject(v.ndc, 0.5) - unproject(v.ndc, 1.0));
    return output_color(fit_hdr(sample_environment(direction, 0.0)));
}

// A batch camera's tile cleared alone, when its atlas page keeps other
// cameras' images this frame (the page is loaded, not cleared): a
// full-screen triangle at the far plane (reverse-Z depth 0, written with an
// always-passing test), scissored to the tile, writing the colour the pass
// would have cleared to and zero labels. The colour comes in as override
// constants (one pipeline per clear colour).
override TILE_CLEAR_R: f32 = 0.0;
override TILE_CLEAR_G: f32 = 0.0;
override TILE_CLEAR_B: f32 = 0.0;
override TILE_CLEAR_A: f32 = 0.0;

@vertex
fn vs_tile_clear(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let corner = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    return vec4<f32>(corner * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn fs_tile_clear() -> Labelled {
    let color = vec4<f32>(TILE_CLEAR_R, TILE_CLEAR_G, TILE_CLEAR_B, TILE_CLEAR_A);
    return Labelled(color, 0u, vec4<f32>(0.0), 0u, 0u);
}
