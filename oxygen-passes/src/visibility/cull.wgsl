// GPU-driven visibility: frustum and occlusion culling of the GPU scene's
// instances, compacted into the view's DrawMetadata range and its instanced
// commands. The layout of the ranges and counters is drawn in
// oxygen-sceneprep's gpu_scene module.

#include "sceneprep/gpu_records.wgsl"
#include "visibility/constants"
#include "visibility/CullParams"
#include "visibility/hiz_test.wgsl"
// The GPU scene's records and the indirect commands, generated from their
// Rust declarations in oxygen-sceneprep.
#include "sceneprep/GpuInstance"
#include "sceneprep/GpuGroup"
#include "sceneprep/GpuLod"
#include "sceneprep/DrawIndexedIndirect"

// Every view's parameters: one for a view culled on its own, one per
// camera for a batch culled in one dispatch (the camera is the dispatch's
// z). Each invocation copies its view's into `params` first.
@group(0) @binding(0) var<storage, read> views: array<CullParams>;
var<private> params: CullParams;
@group(0) @binding(1) var<storage, read> instances: array<GpuInstance>;
@group(0) @binding(2) var<storage, read> groups: array<GpuGroup>;
@group(0) @binding(3) var<storage, read> lods: array<GpuLod>;
@group(0) @binding(4) var<storage, read_write> counts: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> history: array<u32>;
@group(0) @binding(6) var<storage, read_write> draws: array<DrawMetadata>;
@group(0) @binding(7) var<storage, read_write> commands: array<DrawIndexedIndirect>;
@group(0) @binding(8) var<storage, read> hiz_pyramid: array<f32>;

// The CPU path's test (Frustum::intersects_aabb): the box's corner farthest
// along each plane's normal must not be behind it.
fn in_frustum(instance: GpuInstance) -> bool {
    for (var p = 0u; p < 6u; p++) {
        let plane = params.planes[p];
        let corner = select(instance.aabb_min, instance.aabb_max, plane.xyz >= vec3<f32>(0.0));
        if dot(plane.xyz, corner) + plane.w < 0.0 {
            return false;
        }
    }
    return true;
}

// Whether this view tests the instance at all.
fn wanted(instance: GpuInstance) -> bool {
    return (params.flags & CULL_CASTERS_ONLY) == 0u || (instance.flags & INSTANCE_CASTS_SHADOWS) != 0u;
}

// The view phase's LOD choice: the last level whose threshold the sphere's
// projected diameter is below.
fn select_group(instance: GpuInstance) -> u32 {
    var group = instance.group;
    if instance.lod_count == 0u {
        return group;
    }
    let depth = -(dot(params.view_row_z.xyz, instance.sphere.xyz) + params.view_row_z.w);
    var fraction = instance.sphere.w * params.lod_scale;
    if params.perspective != 0u {
        fraction = instance.sphere.w * params.lod_scale / max(depth, params.near);
    }
    // The diameter's share of the viewport height (the CPU path's
    // projected_screen_fraction): radius × cot(fov / 2) / depth.
    let projected = fraction * params.lod_bias;
    for (var l = 0u; l < instance.lod_count; l++) {
        let lod = lods[instance.lod_first + l];
        if projected < lod.below_screen_fraction {
            group = lod.group;
        }
    }
    return group;
}

// Where counter `index` of this view is in `counts` (a batch's cameras
// share one buffer, each from its own base).
fn counter(index: u32) -> u32 {
    return params.counter_base + index;
}

// Coverage counters after the group counters, in 1/1024ths of the viewport:
// [the sum over drawn instances][the sum over groups of each group's sum,
// capped at one viewport][the indices of the drawn instances][one per
// group]. The CPU reads the first three back a frame later: the smaller of
// the first two is the layers a forward pass without a pre-pass would shade
// (the CPU path's estimate, with groups for its runs of one material), the
// third what a pre-pass would draw.
fn coverage_base() -> u32 {
    return params.group_counters + 2u * params.group_count;
}

// Adds the instance's share of the viewport (its sphere's projected disc,
// at most the whole viewport, as the CPU path's estimate counts it), rounded
// stochastically so that many tiny instances sum right.
fn add_coverage(i: u32, instance: GpuInstance, group: u32) {
    // Saturating, and each add capped: a wrapped count would read as a
    // cheap pre-pass.
    if atomicLoad(&counts[counter(coverage_base() + 2u)]) < 0x80000000u {
        atomicAdd(&counts[counter(coverage_base() + 2u)], min(groups[group].index_count, 0x00FFFFFFu));
    }
    let depth = -(dot(params.view_row_z.xyz, instance.sphere.xyz) + params.view_row_z.w);
    var fraction = instance.sphere.w * params.lod_scale;
    if params.perspective != 0u {
        fraction = fraction / max(depth, params.near);
    }
    let diameter = 2.0 * fraction;
    let coverage = min(params.disc * diameter * diameter, 1.0);
    var h = i * 0x9E3779B9u;
    h = (h ^ (h >> 16u)) * 0x85EBCA6Bu;
    let dither = f32(h >> 8u) / 16777216.0;
    let units = u32(coverage * 1024.0 + dither);
    // Saturating: a sum this large (a million viewports) already says
    // "pre-pass", and must not wrap around to a small one.
    if units > 0u && atomicLoad(&counts[counter(coverage_base())]) < 0x40000000u {
        atomicAdd(&counts[counter(coverage_base())], units);
        atomicAdd(&counts[counter(coverage_base() + 3u + group)], units);
    }
}

// A group's coverage, capped at one viewport, into the capped sum (once per
// group, after its draws are final).
fn add_capped_coverage(g: u32) {
    let units = atomicLoad(&counts[counter(coverage_base() + 3u + g)]);
    if units > 0u && atomicLoad(&counts[counter(coverage_base() + 1u)]) < 0x40000000u {
        atomicAdd(&counts[counter(coverage_base() + 1u)], min(units, 1024u));
    }
}

fn emit(group_index: u32, slot: u32, instance: GpuInstance) {
    let group = groups[group_index];
    var draw: DrawMetadata;
    draw.vertex_slot = group.vertex_slot;
    draw.index_slot = group.index_slot;
    draw.first_index = group.first_index;
    draw.index_count = group.index_count;
    draw.base_vertex = group.base_vertex;
    draw.instance_count = 1u;
    draw.transform_index = instance.transform_index;
    draw.material_handle = group.material;
    draw.pass_mask = group.pass_mask;
    draw.node_id = instance.node_id;
    draw.submesh = instance.submesh;
    draw.generation = params.generation;
    draw.attributes_slot = group.attributes_slot;
    draw.skin_slot = instance.skin_slot;
    draw.joint_base = instance.joint_base;
    draw.morph_base = instance.morph_base;
    draws[params.draw_slot + group.draw_base + slot] = draw;
}

fn command(group: GpuGroup, instances: u32, first: u32) -> DrawIndexedIndirect {
    return DrawIndexedIndirect(group.index_count, instances, group.index_slot + group.first_index,
        i32(group.vertex_slot) + group.base_vertex, group.draw_base + first);
}

// Phase 1. Frustum culling: every instance in the frustum is drawn.
// Occlusion culling: only those visible last frame are drawn now; the
// others wait for the depth pyramid (cull_late).
// The invocation's index: dispatches wider than 65 535 workgroups spill
// into y (more than four million instances or groups).
fn linear(id: vec3<u32>, workgroups: vec3<u32>) -> u32 {
    return id.x + id.y * workgroups.x * 64u;
}

@compute @workgroup_size(64)
fn cull_early(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    params = views[id.z];
    let i = linear(id, workgroups);
    if i >= params.instance_count {
        return;
    }
    let instance = instances[i];
    if !wanted(instance) {
        return;
    }
    let occlusion = (params.flags & CULL_OCCLUSION) != 0u;
    if !in_frustum(instance) {
        if occlusion {
            history[params.history_base + i] = 0u;
        }
        return;
    }
    if occlusion && history[params.history_base + i] == 0u {
        return;
    }
    let group = select_group(instance);
    let slot = atomicAdd(&counts[counter(params.group_counters + group)], 1u);
    emit(group, slot, instance);
    add_coverage(i, instance, group);
}

// Phase 1's commands (list A): one instanced command per group with draws,
// compacted at its partition's start and counted by the partition's counter.
@compute @workgroup_size(64)
fn commands_early(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    params = views[id.z];
    let g = linear(id, workgroups);
    if g >= params.group_count {
        return;
    }
    // With occlusion culling the late phase adds draws: it caps then.
    if (params.flags & CULL_OCCLUSION) == 0u {
        add_capped_coverage(g);
    }
    let drawn = atomicLoad(&counts[counter(params.group_counters + g)]);
    if drawn == 0u {
        return;
    }
    let group = groups[g];
    let c = atomicAdd(&counts[counter(group.partition_index)], 1u);
    commands[params.command_slot + group.command_base + c] = command(group, drawn, 0u);
}

// Phase 2 (occlusion): every instance in the frustum is tested against the
// pyramid of what phase 1 drew; the result is next frame's history, and the
// visible ones phase 1 did not draw are drawn now.
@compute @workgroup_size(64)
fn cull_late(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    params = views[id.z];
    let i = linear(id, workgroups);
    if i >= params.instance_count {
        return;
    }
    let instance = instances[i];
    if !wanted(instance) || !in_frustum(instance) {
        return;
    }
    let drawn_early = history[params.history_base + i] != 0u;
    // The box is widened by its coordinates' rounding at this distance from
    // the world origin, so that f32 projection error never hides it.
    let slack = (abs(instance.aabb_min) + abs(instance.aabb_max)) * 1e-6 + vec3<f32>(1e-6);
    let visible = hiz_visible(params.hiz_levels, params.hiz_size, params.view_projection,
        instance.aabb_min - slack, instance.aabb_max + slack);
    history[params.history_base + i] = select(0u, 1u, visible);
    if !visible || drawn_early {
        return;
    }
    let group = select_group(instance);
    let early = atomicLoad(&counts[counter(params.group_counters + group)]);
    let slot = early + atomicAdd(&counts[counter(params.group_counters + params.group_count + group)], 1u);
    emit(group, slot, instance);
    add_coverage(i, instance, group);
}

// Phase 2's commands: list B (the newly visible, drawn into the depth
// pre-pass second) and list C (every draw, for shading).
@compute @workgroup_size(64)
fn commands_late(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    params = views[id.z];
    let g = linear(id, workgroups);
    if g >= params.group_count {
        return;
    }
    add_capped_coverage(g);
    let early = atomicLoad(&counts[counter(params.group_counters + g)]);
    let late = atomicLoad(&counts[counter(params.group_counters + params.group_count + g)]);
    let group = groups[g];
    if late > 0u {
        let c = atomicAdd(&counts[counter(params.partition_count + group.partition_index)], 1u);
        commands[params.command_slot + params.group_count + group.command_base + c] = command(group, late, early);
    }
    if early + late > 0u {
        let c = atomicAdd(&counts[counter(2u * params.partition_count + group.partition_index)], 1u);
        commands[params.command_slot + 2u * params.group_count + group.command_base + c] =
            command(group, early + late, 0u);
    }
}
