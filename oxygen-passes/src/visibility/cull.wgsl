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
// The GPU scene's ranks (GpuScene::ranks): each instance's place in its
// full-detail group's room, then each LOD entry's place in its group's.
@group(0) @binding(9) var<storage, read> ranks: array<u32>;

// The deterministic mode (CULL_DETERMINISTIC): the cull steps do not race
// for slots. Each survivor writes its instance number (+ 1, with
// LATE_SURVIVOR in the late phase) at its rank in its group's room of the
// view's occupancy (in `history`, from `occupancy_base`); the compact steps
// then walk each room in rank order, which is instance order, and emit the
// draws; every group writes its commands at a fixed place. What the GPU
// draws is then the same sequence whatever order its threads ran in.
const LATE_SURVIVOR: u32 = 0x80000000u;

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
// projected diameter is below, as (group, rank in the group's room) for
// instance `i`.
fn select_group(i: u32, instance: GpuInstance) -> vec2<u32> {
    var group = vec2<u32>(instance.group, ranks[i]);
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
            group = vec2<u32>(lod.group, ranks[params.instance_count + instance.lod_first + l]);
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
// capped at one viewport][the indices of the drawn instances][the drawn
// instances][one per group]. The CPU reads the first four back a frame
// later: the smaller of the first two is the layers a forward pass without
// a pre-pass would shade (the CPU path's estimate, with groups for its runs
// of one material), the third what a pre-pass would draw, the fourth the
// view's draws (its report).
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
    atomicAdd(&counts[counter(coverage_base() + 3u)], 1u);
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
        atomicAdd(&counts[counter(coverage_base() + 4u + group)], units);
    }
}

// A group's coverage, capped at one viewport, into the capped sum (once per
// group, after its draws are final).
fn add_capped_coverage(g: u32) {
    let units = atomicLoad(&counts[counter(coverage_base() + 4u + g)]);
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

fn deterministic() -> bool {
    return (params.flags & CULL_DETERMINISTIC) != 0u;
}

// Marks instance `i` as drawn by this phase (`tag`: 0 or LATE_SURVIVOR) at
// its rank in its group's room, for the compact step.
fn occupy(selected: vec2<u32>, i: u32, tag: u32) {
    history[params.occupancy_base + groups[selected.x].draw_base + selected.y] = (i + 1u) | tag;
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
    let selected = select_group(i, instance);
    if deterministic() {
        occupy(selected, i, 0u);
    } else {
        let slot = atomicAdd(&counts[counter(params.group_counters + selected.x)], 1u);
        emit(selected.x, slot, instance);
    }
    add_coverage(i, instance, selected.x);
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
    let group = groups[g];
    if deterministic() {
        // Every group of the partition in group order, empty ones too: the
        // count is the partition's group count, whoever adds first.
        atomicAdd(&counts[counter(group.partition_index)], 1u);
        commands[params.command_slot + g] = command(group, drawn, 0u);
        return;
    }
    if drawn == 0u {
        return;
    }
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
    let selected = select_group(i, instance);
    if deterministic() {
        occupy(selected, i, LATE_SURVIVOR);
    } else {
        let early = atomicLoad(&counts[counter(params.group_counters + selected.x)]);
        let slot = early + atomicAdd(&counts[counter(params.group_counters + params.group_count + selected.x)], 1u);
        emit(selected.x, slot, instance);
    }
    add_coverage(i, instance, selected.x);
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
    if deterministic() {
        // As commands_early: every group at its fixed place. List C draws
        // the merged room (compact_late), after the first.
        atomicAdd(&counts[counter(params.partition_count + group.partition_index)], 1u);
        commands[params.command_slot + params.group_count + g] = command(group, late, early);
        atomicAdd(&counts[counter(2u * params.partition_count + group.partition_index)], 1u);
        commands[params.command_slot + 2u * params.group_count + g] =
            command(group, early + late, params.shading_offset);
        return;
    }
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

// The deterministic mode's compact steps: one workgroup per group (the
// dispatch's x and y; the view is its z) walks the group's room in rank
// order, COMPACT_WIDTH entries at a time, and emits the marked instances
// in that order.
const COMPACT_WIDTH: u32 = 256u;
var<workgroup> scan: array<u32, 256>;

// The inclusive prefix sum of `value` over the workgroup (Hillis-Steele:
// log2(256) steps). Every invocation must call it; leaves the total in
// scan[COMPACT_WIDTH - 1].
fn workgroup_scan(lid: u32, value: u32) -> u32 {
    scan[lid] = value;
    workgroupBarrier();
    for (var offset = 1u; offset < COMPACT_WIDTH; offset = offset << 1u) {
        var add = 0u;
        if lid >= offset {
            add = scan[lid - offset];
        }
        workgroupBarrier();
        scan[lid] = scan[lid] + add;
        workgroupBarrier();
    }
    return scan[lid];
}

// Phase 1: the instances cull_early marked, in rank order, at the start of
// the group's room (list A); the group's early count.
@compute @workgroup_size(256)
fn compact_early(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>,
                 @builtin(local_invocation_index) lid: u32) {
    // Control flow reads only uniform values (read-only storage at
    // workgroup-uniform indices), as the barriers require.
    let view = views[wid.z];
    params = view;
    let g = wid.x + wid.y * workgroups.x;
    if g >= view.group_count {
        return;
    }
    let group = groups[g];
    let room = view.occupancy_base + group.draw_base;
    var written = 0u;
    for (var start = 0u; start < group.capacity; start += COMPACT_WIDTH) {
        var entry = 0u;
        if start + lid < group.capacity {
            entry = history[room + start + lid];
        }
        let keep = entry != 0u && (entry & LATE_SURVIVOR) == 0u;
        let at = workgroup_scan(lid, select(0u, 1u, keep));
        if keep {
            emit(g, written + at - 1u, instances[entry - 1u]);
        }
        written += scan[COMPACT_WIDTH - 1u];
        // Everyone has read the total before the next chunk overwrites it.
        workgroupBarrier();
    }
    if lid == 0u {
        atomicStore(&counts[counter(view.group_counters + g)], written);
    }
}

// Phase 2: the instances cull_late marked after list A's (list B), and
// every marked instance, early and late merged in rank order, in the second
// room (list C); the group's late count.
@compute @workgroup_size(256)
fn compact_late(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>,
                @builtin(local_invocation_index) lid: u32) {
    let view = views[wid.z];
    params = view;
    let g = wid.x + wid.y * workgroups.x;
    if g >= view.group_count {
        return;
    }
    let group = groups[g];
    let room = view.occupancy_base + group.draw_base;
    let early = atomicLoad(&counts[counter(view.group_counters + g)]);
    var late_written = 0u;
    var all_written = 0u;
    for (var start = 0u; start < group.capacity; start += COMPACT_WIDTH) {
        var entry = 0u;
        if start + lid < group.capacity {
            entry = history[room + start + lid];
        }
        let late = (entry & LATE_SURVIVOR) != 0u;
        // Two counts of at most 256 in one scan: late ones low, all high.
        let at = workgroup_scan(lid, select(0u, 1u, late) | select(0u, 1u << 16u, entry != 0u));
        if entry != 0u {
            let instance = instances[(entry & ~LATE_SURVIVOR) - 1u];
            if late {
                emit(g, early + late_written + (at & 0xFFFFu) - 1u, instance);
            }
            emit(g, view.shading_offset + all_written + (at >> 16u) - 1u, instance);
        }
        let total = scan[COMPACT_WIDTH - 1u];
        late_written += total & 0xFFFFu;
        all_written += total >> 16u;
        workgroupBarrier();
    }
    if lid == 0u {
        atomicStore(&counts[counter(view.group_counters + view.group_count + g)], late_written);
    }
}
