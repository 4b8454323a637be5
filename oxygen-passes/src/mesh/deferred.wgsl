// Deferred shading of a batch's cameras: one compute pass per atlas page
// shades each pixel the visibility pass (mesh/visibility.wgsl) saw a
// surface at, with the forward pass's own shading code (`shade`, through
// `opaque_color_at`), and writes the display colour of every pixel of the
// cameras' tiles (the clear colour or the environment where nothing was
// drawn). The surface point is rebuilt from the pixel's surface id (its
// draw and the vertex that starts its triangle, mesh/visibility.wgsl): the
// triangle is found among those starting at that vertex (the geometry's
// triangle table, before its indices), its three corners come through the vertex stage's function
// (`mesh_vertex`: morphs, skins and all), and the pixel centre's
// perspective-correct barycentrics weight them; the screen derivatives
// shading needs (texture level of detail, normal mapping) come from the
// same weights one pixel to the right and one down, where the fragment
// stage takes differences across its 2 × 2 quad.
//
// Why: on GPUs where only part of the chip runs fragment shaders (two
// TPCs of an H100 or H200), a compute pass shades the same pixels about
// 30 times faster (examples/shading_probe.rs, docs/performance.md), and a
// small camera's tiny triangles waste most of each fragment quad besides.

#include "mesh/shading.wgsl"

#include "mesh/deferred_constants"
#include "mesh/DeferredParams"
#include "mesh/DeferredTile"

@group(3) @binding(0) var<uniform> deferred: DeferredParams;
@group(3) @binding(1) var<storage, read> deferred_cameras: array<SceneConstants>;
@group(3) @binding(2) var<storage, read> deferred_tiles: array<DeferredTile>;
// The shared index buffer (the heap's `Indices` domain): each geometry's
// triangle table, the table's length, then its indices.
@group(3) @binding(3) var<storage, read> deferred_indices: array<u32>;
@group(3) @binding(4) var deferred_visibility: texture_2d<u32>;
// The page's display colour, through a unorm view of it: a storage texture
// cannot be sRGB, so the encoding is done here and the other passes view
// the same bytes as sRGB.
@group(3) @binding(5) var deferred_output: texture_storage_2d<rgba8unorm, write>;

// The sRGB encoding the hardware applies when a fragment writes an sRGB
// target (IEC 61966-2-1).
fn encode_srgb(c: vec3<f32>) -> vec3<f32> {
    let x = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    return select(1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - 0.055, x * 12.92, x <= vec3<f32>(0.0031308));
}

// A point of the tile (pixels from its top-left corner) in normalised
// device coordinates (y up).
fn tile_ndc(p: vec2<f32>) -> vec2<f32> {
    let size = vec2<f32>(deferred.size);
    return vec2<f32>(p.x / size.x * 2.0 - 1.0, 1.0 - p.y / size.y * 2.0);
}

// Perspective-correct barycentrics of the point at `ndc` in the triangle of
// clip-space corners a, b, c: the weights w (summing to 1) whose clip-space
// point Σ w_i c_i projects to `ndc`. With columns v_i = (x, y, w) of the
// corners, M w is proportional to (ndc, 1), so w is M⁻¹ (ndc, 1)
// normalised: no division by a corner's w, right for corners behind the
// camera too.
fn barycentrics(a: vec4<f32>, b: vec4<f32>, c: vec4<f32>, ndc: vec2<f32>) -> vec3<f32> {
    let q = vec3<f32>(ndc, 1.0);
    let e = vec3<f32>(dot(cross(b.xyw, c.xyw), q), dot(cross(c.xyw, a.xyw), q), dot(cross(a.xyw, b.xyw), q));
    let sum = e.x + e.y + e.z;
    // Only a triangle seen exactly edge-on sums to nothing, and the
    // rasterizer gave such a triangle no pixel.
    if !(abs(sum) > 1e-30) {
        return vec3<f32>(1.0, 0.0, 0.0);
    }
    return e / sum;
}

// The surface point weighted by `w` from the corners a, b, c.
fn weighted(a: MeshVarying, b: MeshVarying, c: MeshVarying, w: vec3<f32>) -> MeshVarying {
    var m = a;
    m.clip_position = a.clip_position * w.x + b.clip_position * w.y + c.clip_position * w.z;
    m.world_position = a.world_position * w.x + b.world_position * w.y + c.world_position * w.z;
    m.world_normal = a.world_normal * w.x + b.world_normal * w.y + c.world_normal * w.z;
    m.uv = a.uv * w.x + b.uv * w.y + c.uv * w.z;
    m.color = a.color * w.x + b.color * w.y + c.color * w.z;
    m.uv1 = a.uv1 * w.x + b.uv1 * w.y + c.uv1 * w.z;
    return m;
}

// How far outside a triangle (in its barycentrics) the pixel centre may
// seem and still be taken as the rasterizer's: its fixed-point edges and
// this rebuild's float ones disagree by rounding at the edges.
const INSIDE_SLACK: f32 = 1e-3;

// Triangle `t` (indices 3t..3t + 3 from the draw's index slot) of draw
// `draw_index`: the vertex index of its corner k.
fn corner_index(draw: DrawMetadata, t: u32, k: u32) -> u32 {
    return u32(i32(deferred_indices[draw.index_slot + 3u * t + k]) + i32(draw.vertex_slot) + draw.base_vertex);
}

// Triangle `t`'s three corners through the vertex stage's function.
struct Triangle {
    a: MeshVarying,
    b: MeshVarying,
    c: MeshVarying,
}

fn triangle_of(draw: DrawMetadata, draw_index: u32, t: u32) -> Triangle {
    return Triangle(
        mesh_vertex(draw_index, corner_index(draw, t, 0u)),
        mesh_vertex(draw_index, corner_index(draw, t, 1u)),
        mesh_vertex(draw_index, corner_index(draw, t, 2u)),
    );
}

// Whether the triangle of clip-space corners a, b, c faces the camera as
// the draw's pipeline sees it: counter-clockwise on screen (clockwise for a
// mirrored draw), the sign of the determinant of the corners' (x, y, w),
// which is the screen winding times their w.
fn faces_front(draw: DrawMetadata, a: vec4<f32>, b: vec4<f32>, c: vec4<f32>) -> bool {
    let counter_clockwise = dot(a.xyw, cross(b.xyw, c.xyw)) > 0.0;
    return counter_clockwise != ((draw.pass_mask & PASS_MIRRORED) != 0u);
}

// How surely the rasterizer drew candidate `t` at the point at `ndc`, with
// its depth there; the greater rank wins, then (within ranks 1 and 2) the
// nearer depth: 2 the point is inside, 1 inside within rounding, 0
// outside (then the less outside wins), -1 the candidate cannot have been
// drawn there (a culled back face, or cut out by its alpha).
struct Candidate {
    rank: i32,
    score: f32,
    depth: f32,
}

fn candidate(draw: DrawMetadata, draw_index: u32, t: u32, ndc: vec2<f32>) -> Candidate {
    let corners = triangle_of(draw, draw_index, t);
    let ca = corners.a.clip_position;
    let cb = corners.b.clip_position;
    let cc = corners.c.clip_position;
    let w = barycentrics(ca, cb, cc, ndc);
    let score = min(w.x, min(w.y, w.z));
    // Reverse-Z: the nearer surface has the larger depth.
    let depth = dot(w, vec3<f32>(ca.z, cb.z, cc.z)) / dot(w, vec3<f32>(ca.w, cb.w, cc.w));
    var rank = select(select(0, 1, score >= -INSIDE_SLACK), 2, score >= 0.0);
    if (draw.pass_mask & PASS_DOUBLE_SIDED) == 0u && !faces_front(draw, ca, cb, cc) {
        rank = -1;
    } else if rank > 0 && (draw.pass_mask & PASS_MASKED) != 0u {
        // The visibility pass cut out what the alpha cuts out; its mip
        // level is not known here, so the alpha is read at the finest.
        let mesh = weighted(corners.a, corners.b, corners.c, w);
        let material = material_at(material_handle_of(mesh));
        if base_color_of(mesh, material, UvDerivatives()).a < material.alpha_cutoff {
            rank = -1;
        }
    }
    return Candidate(rank, score, depth);
}

// The triangle (its number in the geometry) of draw `draw_index` that
// starts at index value `corner` and that the rasterizer drew at the point
// at `ndc`: the only one when one triangle starts there (a box's every
// corner), else the best candidate of the draw's own index range
// (`candidate`), exact depth ties going as the visibility pass's depth
// test sent them (`last_tie_wins`: the later triangle, else the earlier).
fn triangle_at(draw: DrawMetadata, draw_index: u32, corner: u32, ndc: vec2<f32>) -> u32 {
    let table = draw.index_slot - 1u - deferred_indices[draw.index_slot - 1u];
    let begin = deferred_indices[table + corner];
    let end = deferred_indices[table + corner + 1u];
    if end - begin <= 1u {
        return deferred_indices[table + begin];
    }
    let first = draw.first_index / 3u;
    let last = (draw.first_index + draw.index_count) / 3u;
    let later_wins_ties = (deferred.flags & DEFERRED_LAST_TIE_WINS) != 0u;
    var best = deferred_indices[table + begin];
    var best_c = Candidate(-2, 0.0, 0.0);
    for (var k = begin; k < end; k++) {
        let t = deferred_indices[table + k];
        if t < first || t >= last {
            continue;
        }
        let c = candidate(draw, draw_index, t, ndc);
        var better = c.rank > best_c.rank;
        if c.rank == best_c.rank {
            if c.rank > 0 {
                better = c.depth > best_c.depth || (later_wins_ties && c.depth == best_c.depth);
            } else {
                better = c.score > best_c.score;
            }
        }
        if better {
            best = t;
            best_c = c;
        }
    }
    return best;
}

// The colour of tile pixel `local` (page pixel `page`), where the surface
// starting at index value `corner` of the camera's draw `draw_index` was
// seen.
fn surface_color(draw_index: u32, corner: u32, local: vec2<u32>, page: vec2<u32>) -> vec4<f32> {
    let draw = draw_metadata_domain[scene.renderer.draw_metadata_slot + draw_index];
    let centre = vec2<f32>(local) + 0.5;
    let corners = triangle_of(draw, draw_index, triangle_at(draw, draw_index, corner, tile_ndc(centre)));
    let a = corners.a;
    let b = corners.b;
    let c = corners.c;
    let ca = a.clip_position;
    let cb = b.clip_position;
    let cc = c.clip_position;
    var mesh = weighted(a, b, c, barycentrics(ca, cb, cc, tile_ndc(centre)));
    // Without textures the derivatives only give the facet's direction
    // (shading's stand-in for a normal without one): the triangle's edges
    // give it exactly, for no more reconstruction.
    var d = Derivatives(b.world_position - a.world_position, c.world_position - a.world_position, UvDerivatives());
    if HAS_TEXTURES {
        let right = weighted(a, b, c, barycentrics(ca, cb, cc, tile_ndc(centre + vec2<f32>(1.0, 0.0))));
        let below = weighted(a, b, c, barycentrics(ca, cb, cc, tile_ndc(centre + vec2<f32>(0.0, 1.0))));
        d = Derivatives(
            right.world_position - mesh.world_position,
            below.world_position - mesh.world_position,
            UvDerivatives(right.uv - mesh.uv, below.uv - mesh.uv, right.uv1 - mesh.uv1, below.uv1 - mesh.uv1),
        );
    }
    // What the fragment stage's position builtin holds: the framebuffer
    // pixel centre (the page's), depth, 1 / w.
    let clip = mesh.clip_position;
    mesh.clip_position = vec4<f32>(vec2<f32>(page) + 0.5, clip.z / clip.w, 1.0 / clip.w);
    return opaque_color_at(mesh, faces_front(draw, ca, cb, cc), d);
}

// Behind the scene: the environment along the pixel's ray, or the clear colour.
fn background_color(local: vec2<u32>) -> vec4<f32> {
    if (deferred.flags & DEFERRED_SKY) == 0u {
        return deferred.clear;
    }
    let ndc = tile_ndc(vec2<f32>(local) + 0.5);
    let direction = normalize(unproject(ndc, 0.5) - unproject(ndc, 1.0));
    return output_color(fit_hdr(sample_environment(direction, 0.0)));
}

@compute @workgroup_size(8, 8)
fn cs_deferred(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(workgroup_id) group: vec3<u32>,
) {
    // The workgroup's tile: the third dispatch dimension.
    if group.z >= deferred.tiles {
        return;
    }
    let tile = deferred_tiles[group.z];
    scene = deferred_cameras[tile.camera];
    if id.x >= deferred.size.x || id.y >= deferred.size.y {
        return;
    }
    let page = tile.origin + id.xy;
    let surface = textureLoad(deferred_visibility, page, 0).x;
    var color: vec4<f32>;
    if surface == 0u {
        color = background_color(id.xy);
    } else {
        let bits = scene.renderer.surface_vertex_bits;
        let corner = surface & ((1u << bits) - 1u);
        color = surface_color((surface >> bits) - 1u, corner, id.xy, page);
    }
    textureStore(deferred_output, page, vec4<f32>(encode_srgb(color.rgb), color.a));
}
