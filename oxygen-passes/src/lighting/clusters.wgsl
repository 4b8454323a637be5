// Clustered light culling (lighting/clusters.rs): one invocation per 32-bit
// word of every cluster of the view's grid, setting bit b of word w when
// positional light 32 w + b may reach the cluster. A light reaches a
// cluster when its range sphere touches the cluster's view-space bounding
// box, widened by a relative 1e-3 so that rounding never drops a light that
// lights a pixel of it; a light without a range reaches every cluster.

#include "bindless/constants"
#include "sceneprep/constants"
#include "sceneprep/gpu_records.wgsl"
#include "bindless/domains"
#include "lighting/ClusterParams"

@group(1) @binding(0) var<uniform> params: ClusterParams;
@group(1) @binding(1) var<storage, read_write> cluster_bits: array<u32>;

// The point `depth` metres in front of the eye on the ray through `ndc`:
// two points of the ray from the inverse projection (reverse-Z: 1 is the
// near plane, 0.5 farther), then the one at that depth. Right for
// perspective and orthographic projections alike.
fn point_at_depth(ndc: vec2<f32>, depth: f32) -> vec3<f32> {
    let a4 = params.inverse_projection * vec4<f32>(ndc, 1.0, 1.0);
    let b4 = params.inverse_projection * vec4<f32>(ndc, 0.5, 1.0);
    let a = a4.xyz / a4.w;
    let b = b4.xyz / b4.w;
    // The two points differ in depth for any projection that has one
    // (b is farther); the guard keeps a degenerate one finite.
    let t = (depth + a.z) / max(a.z - b.z, 1e-30);
    return a + (b - a) * t;
}

// The depths slice `k` spans (GridShape::slice_depths), widened by a
// relative 1e-4 so that a pixel on a boundary lies in either neighbour.
fn slice_depths(k: u32) -> vec2<f32> {
    let first = params.depth.x;
    let inverse_log_ratio = params.depth.y;
    var start = min(params.depth.z, first);
    if k == 1u {
        start = first;
    } else if k > 1u {
        start = first * exp(f32(k - 1u) / inverse_log_ratio);
    }
    var end = params.depth.w;
    if k + 1u < params.grid.z {
        end = select(first * exp(f32(k) / inverse_log_ratio), first, k == 0u);
    }
    return vec2<f32>(start - abs(start) * 1e-4, end + abs(end) * 1e-4);
}

@compute @workgroup_size(64)
fn assign_lights(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    let index = id.x + id.y * workgroups.x * 64u;
    let words = params.grid.w;
    let tiles = params.grid.xy;
    let clusters = tiles.x * tiles.y * params.grid.z;
    if index >= clusters * words {
        return;
    }
    let cluster = index / words;
    let word = index % words;
    let tile = vec2<u32>(cluster % tiles.x, (cluster / tiles.x) % tiles.y);
    let slice = cluster / (tiles.x * tiles.y);

    // The cluster's bounding box in view space: its tile's four corners
    // (in NDC, y up, widened by 1e-4) at both ends of its slice.
    let ndc_min = vec2<f32>(tile) / vec2<f32>(tiles) * 2.0 - 1.0 - 1e-4;
    let ndc_max = vec2<f32>(tile + 1u) / vec2<f32>(tiles) * 2.0 - 1.0 + 1e-4;
    let depths = slice_depths(slice);
    var box_min = vec3<f32>(3.4e38);
    var box_max = vec3<f32>(-3.4e38);
    for (var c = 0u; c < 8u; c++) {
        let ndc = vec2<f32>(select(ndc_min.x, ndc_max.x, (c & 1u) != 0u), select(ndc_min.y, ndc_max.y, (c & 2u) != 0u));
        let p = point_at_depth(ndc, select(depths.x, depths.y, (c & 4u) != 0u));
        box_min = min(box_min, p);
        box_max = max(box_max, p);
    }

    var bits = 0u;
    let first = word * 32u;
    let count = min(32u, params.lights.y - min(first, params.lights.y));
    for (var b = 0u; b < count; b++) {
        let light = positional_light_domain[params.lights.x + first + b];
        if light.range <= 0.0 {
            bits |= 1u << b;
            continue;
        }
        let center = (params.view * vec4<f32>(light.position, 1.0)).xyz;
        let nearest = clamp(center, box_min, box_max);
        let offset = nearest - center;
        let reach = light.range * 1.001 + 1e-4;
        if dot(offset, offset) <= reach * reach {
            bits |= 1u << b;
        }
    }
    cluster_bits[index] = bits;
}
