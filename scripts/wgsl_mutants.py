#!/usr/bin/env python3
"""Mutation testing for the WGSL shaders, which cargo-mutants cannot mutate.

Each mutant below is one deliberate break of a shading behaviour: a textual
edit (old -> new) of one shader file that must match its file exactly once
and leave a shader that still parses and validates, so that only a test of
the behaviour can notice it. For each mutant the script applies the edit,
builds and runs the rendering test binaries, records whether a test failed
("caught") or all passed ("missed"), and restores the file whatever happens
(an exception, Ctrl-C, SIGTERM, SIGHUP; after a kill -9 the journal in
target/wgsl-mutants/ restores it on the next start). A file someone else
edits meanwhile keeps their edit: only the mutation is undone.

    scripts/wgsl_mutants.py --check          # every mutant applies once and validates with naga; seconds, no GPU
    scripts/wgsl_mutants.py --check --one-by-one   # ... each mutant validated alone (a few minutes)
    scripts/wgsl_mutants.py --list           # the mutants, by subject
    scripts/wgsl_mutants.py                  # every mutant against every rendering test binary
    scripts/wgsl_mutants.py trace hiz        # only mutants whose name contains one of the words
    scripts/wgsl_mutants.py --record         # ... and append the run to docs/records/wgsl_mutants.jsonl

A mutant whose old text does not occur exactly once in its file fails the
script (naming it) before anything runs: the denominator is every mutant.
`--check` validates with oxygen-passes' naga test (shaders::validate_tests:
every shader module of the registry, src/shaders/registry.rs, composed on
every texture path, each entry point at its stage): first the
unmutated shaders, then rounds of mutants whose edits do not overlap,
applied together (a failing round is retried mutant by mutant to name the
culprit). A mutated file that test does not validate (none today: the
window composition shader, once embedded in src/windows.rs, is
oxygen-passes/src/present/compose_window.wgsl in the registry) is named in
the output.

The rendering test binaries are derived, never listed here: they are what
scripts/gpu-test-binaries prints (every tests/*.rs that renders; the list
scripts/test.sh runs again on GL), so a new GPU test binary counts
automatically. By default every mutant runs against all of them; the
binaries run one at a time (the binary that caught the mutant in the last
record, then its subject's hints, then the rest) up to the first failure.
`--tests a,b` restricts the binaries for a quicker look; such a run says so
in its table and record and is not a score. `--keep-going` runs every
binary for every mutant and lists every failing test. Tests run with CI=1
(a missing golden fails instead of being written from a mutated shader).

Output: a Markdown table for docs/testing.md (mutant, file, breaks, result,
first failing test) and per-subject scores on stdout, progress on stderr,
each mutant's cargo output in target/wgsl-mutants/logs/. `--record` appends
one line to docs/records/wgsl_mutants.jsonl in the records' format
(docs/records/README.md: bench, commit, dirty, date, adapter from
`cargo run --example adapter_info`, host, command, values; the commit is
OXYGEN_COMMIT when set, dirty then null, and command.env keeps what
oxygen-demo/src/record.rs keeps, as that writer does); `values` holds
the adapter line, the binaries, the tests that skipped in the baseline, and
per mutant its name, file, caught, first failing test and seconds.

Time (2 cores, lavapipe): the baseline builds and runs the whole GPU suite
once; then each mutant costs a rebuild of the shader's crate and `oxygen`,
and each binary it runs is linked as it runs (`cargo test --test B`), up
to the first failure (a few minutes when the first binaries catch it) or,
when missed, the whole suite. Expect several hours for all mutants; run a subject at a
time with the name words. Not part of CI.
"""

import argparse
import contextlib
import datetime
import json
import os
import re
import shlex
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

PASSES = "oxygen-passes/src/"
BRDF = PASSES + "shaders/brdf.wgsl"
SHADER = PASSES + "mesh/forward_lit.wgsl"
ENVIRONMENT = PASSES + "lighting/ibl/environment.wgsl"
VERTEX = PASSES + "mesh/mesh_vertex.wgsl"
DEPTH = PASSES + "mesh/depth_only.wgsl"
TONEMAP = PASSES + "post/tonemap_operator.wgsl"
TONEMAP_PASS = PASSES + "post/tonemap.wgsl"
CUBE_FILTER = PASSES + "lighting/ibl/cube_filter.wgsl"
SPLIT_SUM = PASSES + "lighting/split_sum.wgsl"
HIZ = PASSES + "visibility/hiz.wgsl"
HIZ_TEST = PASSES + "visibility/hiz_test.wgsl"
CULL = PASSES + "visibility/cull.wgsl"
TRACE = PASSES + "reference/trace.wgsl"
# The renderer's window composition (the root crate's compositor draws with it).
WINDOWS = PASSES + "present/compose_window.wgsl"
# Per-pixel labels (written by the shading pass or the labels pass, one
# function) and insets (issue 29). The depth copy runs on GL only,
# which this script's runs do not use.
LABELS = PASSES + "mesh/label_values.wgsl"
COMPOSITE = PASSES + "post/composite.wgsl"

# (name, file, old text, new text, what the mutant breaks), one list per
# subject; a mutant's name starts with its subject's prefix (SUBJECTS).
BRDF_MUTANTS = [
    ("brdf-no-cosine", BRDF,
     "return (diffuse + distribution * visibility * fresnel) * n_dot_l;",
     "return diffuse + distribution * visibility * fresnel;",
     "BRDF without the cosine term n·l"),
    ("brdf-no-specular", BRDF,
     "return (diffuse + distribution * visibility * fresnel) * n_dot_l;",
     "return diffuse * n_dot_l;",
     "no specular lobe (Lambert only)"),
    ("brdf-metals-keep-diffuse", BRDF,
     "let diffuse = (vec3<f32>(1.0) - fresnel) * (1.0 - metallic) * albedo / PI;",
     "let diffuse = (vec3<f32>(1.0) - fresnel) * albedo / PI;",
     "metals keep a Lambert diffuse term"),
    ("brdf-diffuse-ignores-fresnel", BRDF,
     "let diffuse = (vec3<f32>(1.0) - fresnel) * (1.0 - metallic) * albedo / PI;",
     "let diffuse = (1.0 - metallic) * albedo / PI;",
     "diffuse not reduced by what Fresnel reflects (energy added at grazing angles)"),
    ("brdf-no-smith-visibility", BRDF,
     "let visibility = 0.5 / (n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2)"
     " + n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2));",
     "let visibility = 0.25 / (n_dot_l * n_dot_v);",
     "specular without Smith masking-shadowing (G = 1)"),
    ("brdf-roughness-not-squared", BRDF,
     "let a = clamp(roughness * roughness, 0.002, 1.0);",
     "let a = clamp(roughness, 0.002, 1.0);",
     "GGX alpha = perceptual roughness (specular lobes too wide)"),
    ("brdf-no-fresnel-rise", BRDF,
     "let fresnel = f0 + (vec3<f32>(1.0) - f0) * schlick_weight(v_dot_h);",
     "let fresnel = f0;",
     "no Schlick Fresnel: reflectance stays F0 at grazing angles"),
    ("brdf-metals-untinted", BRDF,
     "let f0 = mix(vec3<f32>(0.04), albedo, metallic);",
     "let f0 = vec3<f32>(0.04);",
     "metals reflect with a dielectric's colourless F0 (gold turns grey)"),
]

LIGHT_MUTANTS = [
    ("light-spot-cone-ignored", BRDF,
     "attenuation *= spot_cone(light.cos_outer, light.cos_inner, dot(-l, light.direction));",
     "attenuation *= 1.0;",
     "spot lights light outside their cone"),
    ("light-spot-no-penumbra", BRDF,
     "return t * t * (3.0 - 2.0 * t);",
     "return select(0.0, 1.0, t > 0.0);",
     "spot cones lose the smooth step between inner and outer angle"),
    ("light-range-ignored", BRDF,
     "attenuation *= clamp(1.0 - ratio * ratio * ratio * ratio, 0.0, 1.0);",
     "attenuation *= 1.0;",
     "positional lights reach past their range"),
    ("light-no-inverse-square", BRDF,
     "var attenuation = 1.0 / distance_sq;",
     "var attenuation = 1.0;",
     "positional lights do not fall off with distance"),
    ("light-sun-direction-flipped", SHADER,
     "color += brdf_cosine(n, v, -light.direction, albedo, metallic, roughness)",
     "color += brdf_cosine(n, v, light.direction, albedo, metallic, roughness)",
     "raster shading lights the side facing away from directional lights"),
]

SHADOW_MUTANTS = [
    ("shadow-cascade-pcf-off", SHADER,
     "let r = i32(shadows.pcf_radius);",
     "let r = 0;",
     "cascade PCF radius ignored (hard shadow edges)"),
    ("shadow-cascade-normal-offset-off", SHADER,
     "let offset = geometric_normal * shadows.texel_world_size[i] * shadows.normal_offset;",
     "let offset = vec3<f32>(0.0);",
     "cascade lookups without the normal offset (acne)"),
    ("shadow-cascade-never-shadows", SHADER,
     "return lit / taps;",
     "return 1.0;",
     "cascades never shadow"),
    ("shadow-cascade-only-first", SHADER,
     "for (var i = 0u; i < shadows.count; i++) {",
     "for (var i = 0u; i < min(shadows.count, 1u); i++) {",
     "only the first cascade is used: no sun shadow beyond it"),
    ("shadow-tile-never-shadows", SHADER,
     "return lit / 9.0;",
     "return 1.0;",
     "spot and point shadow tiles never shadow"),
    ("shadow-tile-normal-offset-off", SHADER,
     "let offset = geometric_normal * distance * shadows.tile_texel_angle[slot / 4u][slot % 4u] * shadows.normal_offset;",
     "let offset = vec3<f32>(0.0);",
     "spot and point shadow lookups without the normal offset (acne)"),
    ("shadow-point-face-flipped", SHADER,
     "let tile = light.shadow_slot + cube_face(-l);",
     "let tile = light.shadow_slot + cube_face(l);",
     "point-light shadows read the opposite cube face"),
]

IBL_MUTANTS = [
    ("ibl-harmonics-scale-forgotten", ENVIRONMENT,
     "i32(PROBE_FACES), 0).rgb * 16.0;",
     "i32(PROBE_FACES), 0).rgb;",
     "irradiance harmonics read without their storage scale (diffuse light 16× too dark)"),
    ("ibl-irradiance-y-z-swapped", ENVIRONMENT,
     "e += harmonic(1u) * (0.488603 * n.y);\n    e += harmonic(2u) * (0.488603 * n.z);",
     "e += harmonic(1u) * (0.488603 * n.z);\n    e += harmonic(2u) * (0.488603 * n.y);",
     "irradiance's first band with y and z swapped (sky light arrives from the side)"),
    ("ibl-specular-level-ignores-roughness", ENVIRONMENT,
     "let lod = clamp(roughness, 0.0, 1.0) * f32(textureNumLevels(environment_faces) - 1u);",
     "let lod = 0.0;",
     "rough surfaces reflect the environment's sharp level 0"),
    ("ibl-probe-level-ignores-roughness", SHADER,
     "return clamp(roughness, 0.0, 1.0) * usable;",
     "return 0.0;",
     "rough surfaces reflect a probe's sharp level 0"),
    ("ibl-probe-not-nearest", SHADER,
     "best = i;",
     "best = 0u;",
     "surfaces reflect the first probe, not the nearest"),
    ("ibl-split-sum-axes-swapped", ENVIRONMENT,
     "clamp(vec2<f32>(n_dot_v, roughness),",
     "clamp(vec2<f32>(roughness, n_dot_v),",
     "split-sum table read with n·v and roughness swapped"),
    ("ibl-split-sum-scale-bias-swapped", ENVIRONMENT,
     "return f0 * ab.x + ab.y;",
     "return f0 * ab.y + ab.x;",
     "split-sum scale and bias swapped"),
]

CUBE_MUTANTS = [
    ("cube-ggx-roughness-not-squared", CUBE_FILTER,
     "let alpha = max(params.roughness * params.roughness, 1e-4);",
     "let alpha = max(params.roughness, 1e-4);",
     "prefiltered levels importance-sample a GGX lobe of alpha = roughness (too blurry)"),
    ("cube-ggx-no-filtered-lod", CUBE_FILTER,
     "let lod = clamp(0.5 * log2(sample_solid_angle / texel_solid_angle), 0.0, source_levels - 1.0);",
     "let lod = 0.0;",
     "GGX samples read level 0, not the level covering their solid angle (noise, lost sun)"),
    ("cube-ggx-stays-on-face", CUBE_FILTER,
     "at.xy, u32(at.z), lod).rgb * n_dot_l;",
     "at.xy, v.layer, lod).rgb * n_dot_l;",
     "GGX samples crossing a face seam read the texel's own face"),
    ("cube-box-mip-not-averaged", CUBE_FILTER,
     "return textureSampleLevel(source, source_sampler, v.uv, v.layer, 0.0);",
     "return textureSampleLevel(source, source_sampler, v.uv + 0.5 / vec2<f32>(textureDimensions(source, 0)), v.layer, 0.0);",
     "box mips copy one source texel instead of averaging 2×2 (copies blur)"),
    ("cube-harmonics-no-solid-angle", CUBE_FILTER,
     "let solid_angle = (2.0 / f32(side)) * (2.0 / f32(side)) / (d2 * sqrt(d2));",
     "let solid_angle = (2.0 / f32(side)) * (2.0 / f32(side));",
     "irradiance harmonics weigh every face texel alike (corners over-counted)"),
    ("cube-equirect-mirrored", CUBE_FILTER,
     "let longitude = atan2(d.x, -d.z);",
     "let longitude = atan2(-d.x, -d.z);",
     "equirectangular images land mirrored on the cube"),
]

SPLIT_SUM_MUTANTS = [
    ("splitsum-roughness-not-squared", SPLIT_SUM,
     "let a = clamp(roughness * roughness, 0.002, 1.0);",
     "let a = clamp(roughness, 0.002, 1.0);",
     "split-sum table integrates a GGX lobe of alpha = roughness"),
    ("splitsum-pdf-jacobian-dropped", SPLIT_SUM,
     "let weight = visibility * n_dot_l * 4.0 * v_dot_h / cos_theta;",
     "let weight = visibility * n_dot_l * 4.0;",
     "split-sum samples weighted without v·h / n·h (the half-vector pdf's Jacobian)"),
]

HIZ_MUTANTS = [
    ("hiz-reduce-keeps-nearest", HIZ,
     "var farthest = 1.0;\n    for (var y = first.y; y <= end.y; y++) {\n"
     "        for (var x = first.x; x <= end.x; x++) {\n"
     "            farthest = min(farthest, pyramid[level.src_offset + y * level.src_width + x]);",
     "var farthest = 0.0;\n    for (var y = first.y; y <= end.y; y++) {\n"
     "        for (var x = first.x; x <= end.x; x++) {\n"
     "            farthest = max(farthest, pyramid[level.src_offset + y * level.src_width + x]);",
     "depth pyramid keeps the nearest depth instead of the farthest"),
    ("hiz-reduce-odd-edge-dropped", HIZ,
     "let end = select(min(id.xy * 2u + vec2<u32>(1u), last), last, id.xy == size - vec2<u32>(1u));",
     "let end = min(id.xy * 2u + vec2<u32>(1u), last);",
     "odd-sized levels drop their last row and column from the next level"),
    ("hiz-test-level-too-fine", HIZ_TEST,
     "select(firstLeadingBit(extent), 0u, extent <= 1u)",
     "select(firstLeadingBit(extent) - 1u, 0u, extent <= 1u)",
     "hiz_visible reads a level one finer: its 3×3 texels no longer cover the box"),
]

CULL_MUTANTS = [
    ("cull-frustum-wrong-corner", CULL,
     "select(instance.aabb_min, instance.aabb_max, plane.xyz >= vec3<f32>(0.0))",
     "select(instance.aabb_max, instance.aabb_min, plane.xyz >= vec3<f32>(0.0))",
     "frustum test uses the box's nearest corner: boxes crossing a plane are culled"),
    ("cull-indirect-count-not-written", CULL,
     "let c = atomicAdd(&counts[counter(group.partition_index)], 1u);",
     "let c = atomicLoad(&counts[counter(group.partition_index)]);",
     "phase 1 writes its commands but not the indirect draw count"),
    ("cull-lod-ignored", CULL,
     "group = vec2<u32>(lod.group, ranks[params.instance_count + instance.lod_first + l]);",
     "group = vec2<u32>(instance.group, ranks[i]);",
     "GPU culling never switches to a coarser LOD"),
    ("cull-occlusion-late-draws-nothing", CULL,
     "if !visible || drawn_early {",
     "if true {",
     "occlusion phase 2 does not draw what became visible"),
    ("cull-occlusion-history-always-visible", CULL,
     "history[params.history_base + i] = select(0u, 1u, visible);",
     "history[params.history_base + i] = 1u;",
     "occlusion history marks everything visible (occlusion culls nothing)"),
    ("cull-batch-camera-ignored", CULL,
     "fn cull_early(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {\n    params = views[id.z];",
     "fn cull_early(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {\n    params = views[0u];",
     "a batch culled in one dispatch culls every camera with the first one's frustum"),
    ("cull-batch-counter-base-ignored", CULL,
     "    return params.counter_base + index;",
     "    return index;",
     "a batch's cameras count their draws in the first camera's counters"),
]

SKIN_MUTANTS = [
    ("skin-weights-ignored", VERTEX,
     "skinned_position += weights[k] * (world_transform_domain[base + joints[k]] * vec4<f32>(position, 1.0));",
     "skinned_position += world_transform_domain[base + joints[k]] * vec4<f32>(position, 1.0);",
     "every joint influence on a position counted fully (weights ignored)"),
    ("skin-first-joint-only", VERTEX,
     "world_transform_domain[base + joints[k]]",
     "world_transform_domain[base + joints[0]]",
     "every influence of a position uses the first influence's joint matrix"),
    ("skin-joint-base-ignored", VERTEX,
     "let base = scene.renderer.world_transforms_slot + draw.joint_base;",
     "let base = scene.renderer.world_transforms_slot;",
     "joint matrices read from the frame's first matrix, not the skin's"),
    ("skin-normals-not-skinned", VERTEX,
     "world_normal = skinned_normal;",
     "world_normal = normal;",
     "skinned normals stay in the mesh's bind pose"),
]

MORPH_MUTANTS = [
    ("morph-weights-ignored", VERTEX,
     "position += w * vec3<f32>(d.px, d.py, d.pz);",
     "position += vec3<f32>(d.px, d.py, d.pz);",
     "morph targets displace positions fully whatever their weight"),
    ("morph-normals-not-morphed", VERTEX,
     "normal += w * vec3<f32>(d.nx, d.ny, d.nz);",
     "normal += vec3<f32>(0.0);",
     "morph targets do not change normals"),
    ("morph-weight-slot-off-by-one", VERTEX,
     "let k = t + 2u;",
     "let k = t + 1u;",
     "target t reads the weight before its own (the first reads the target count)"),
]

TRACE_MUTANTS = [
    ("trace-bvh-second-child-skipped", TRACE,
     "local_stack[local_top + 1u] = local.first + 1u;",
     "local_stack[local_top + 1u] = local.first;",
     "mesh BVH traversal never visits a node's second child (triangles vanish)"),
    ("trace-bvh-not-closest-hit", TRACE,
     "if !(tuv.x > 0.0 && tuv.x < best.t) {",
     "if !(tuv.x > 0.0) {",
     "traversal keeps the last hit found, not the closest"),
    ("trace-no-direct-light", TRACE,
     "color += throughput * (s.emissive + direct_light(s, v, salt));",
     "color += throughput * s.emissive;",
     "no next-event estimation: lights reach the reference only by chance"),
    ("trace-sun-shadow-rays-off", TRACE,
     "let shadow = trace(Ray(offset_origin(s, l), l), 3.0e38, true, salt);",
     "let shadow = trace(Ray(offset_origin(s, l), l), 0.0, true, salt);",
     "directional lights' shadow rays never hit (no sun shadows in the reference)"),
    ("trace-escape-reversed", TRACE,
     "color += throughput * escaped(ray.dir);",
     "color += throughput * escaped(-ray.dir);",
     "escaping paths read the environment in the opposite direction"),
    ("trace-accumulation-restarts", TRACE,
     "total += running_sum[pixel].rgb;",
     "total += vec3<f32>(0.0);",
     "each frame's samples replace the running sum"),
    ("trace-mean-counts-this-frame-only", TRACE,
     "let mean = total / f32(max(params.samples_done + params.samples_this_frame, 1u));",
     "let mean = total / f32(max(params.samples_this_frame, 1u));",
     "the mean divides the whole sum by this frame's samples only"),
    ("trace-bounce-pdf-ignored", TRACE,
     "throughput *= brdf_cosine(s.normal, v, l, s.albedo, s.metallic, s.roughness) / pdf;",
     "throughput *= brdf_cosine(s.normal, v, l, s.albedo, s.metallic, s.roughness);",
     "sampled bounces not divided by their pdf (indirect light wrong)"),
]

TONEMAP_MUTANTS = [
    ("tonemap-exposure-ignored", TONEMAP,
     "max(safe * exposure, vec3<f32>(0.0))",
     "max(safe, vec3<f32>(0.0))",
     "the tone-map operator ignores exposure (both paths)"),
    # select(1.0, x, false) keeps the binding / override referenced, so only
    # the behaviour changes (no layout or pipeline-constant error).
    ("tonemap-pass-exposure-ignored", TONEMAP_PASS,
     "tone_map(hdr, params.exposure)",
     "tone_map(hdr, select(1.0, params.exposure, false))",
     "the tone-map pass ignores the view's exposure"),
    ("tonemap-in-pass-exposure-ignored", SHADER,
     "tone_map(radiance, EXPOSURE)",
     "tone_map(radiance, select(1.0, EXPOSURE, false))",
     "the in-pass tone map (TONE_MAP_OUTPUT) ignores exposure"),
]

ALPHA_MUTANTS = [
    ("alpha-cutoff-ignored-in-shading", SHADER,
     "if shaded.a < material.alpha_cutoff {",
     "if shaded.a < -1.0 {",
     "masked materials are not cut out by the shading pass"),
    ("alpha-cutoff-ignored-in-pre-pass", DEPTH,
     "a < material.alpha_cutoff {",
     "a < -1.0 {",
     "masked materials are not cut out by the depth pre-pass (and shadow maps)"),
    ("alpha-cutoff-ignored-by-tracer", TRACE,
     "return alpha >= material.alpha_cutoff;",
     "return true;",
     "the reference's rays hit the cut-out parts of masked materials"),
]

DOUBLE_SIDED_MUTANTS = [
    ("double-sided-normal-not-flipped", SHADER,
     "let oriented = select(world_normal, -world_normal, flip);",
     "let oriented = world_normal;",
     "back faces of double-sided surfaces lit with the front normal"),
    ("double-sided-tracer-normal-not-flipped", TRACE,
     "var n = normalize_or(select(-interpolated, interpolated, facing), geometric);",
     "var n = normalize_or(interpolated, geometric);",
     "the reference shades back faces with the front normal"),
]

GENERATION_MUTANTS = [
    ("generation-check-off", VERTEX,
     "if checking && draw.generation != scene.renderer.draw_metadata_generation {",
     "if checking && false {",
     "stale draw ranges are not flagged in debug mode"),
    ("generation-not-stamped-by-cull", CULL,
     "draw.generation = params.generation;",
     "draw.generation = 0u;",
     "GPU-culled draws carry no generation (flagged stale in debug mode)"),
]

COMPOSE_MUTANTS = [
    ("compose-upside-down", WINDOWS,
     "1.0 - uv.y * 2.0, 0.0, 1.0), uv);",
     "1.0 - uv.y * 2.0, 0.0, 1.0), vec2<f32>(uv.x, 1.0 - uv.y));",
     "windows show each view upside down"),
    ("compose-depth-inverted", WINDOWS,
     "return vec4<f32>(d, d, d, 1.0);",
     "return vec4<f32>(1.0 - d, 1.0 - d, 1.0 - d, 1.0);",
     "depth-only views composed as inverted grey (far white)"),
]

OUTPUT_MUTANTS = [
    ("output-label-not-offset", LABELS,
     "labels.instance = draw.node_id + 1u;",
     "labels.instance = draw.node_id;",
     "instance labels name the node before the one drawn (and 0 is a node)"),
    ("output-semantic-class-dropped", LABELS,
     "labels.semantic_class = normal_transform_domain",
     "labels.semantic_class = 0u * normal_transform_domain",
     "the semantic plane shows no class (the normal record's class is not read)"),
    ("output-linear-depth-behind", LABELS,
     "let linear_depth = -(scene.camera.view",
     "let linear_depth = (scene.camera.view",
     "linear depth measured behind the camera (negative distances)"),
    ("output-normal-back-face-kept", LABELS,
     "        n = -n;",
     "        n = n;",
     "back faces of double-sided surfaces labelled with the front normal"),
    ("output-composite-offset-ignored", COMPOSITE,
     "params.uv_offset + in.uv * params.uv_scale",
     "in.uv * params.uv_scale",
     "an inset shows the corner of the source's texture, not its view's tile"),
]

# (name prefix, subject, its mutants, test binaries likely to catch them).
# The hints only order the binaries (likely catchers first, so a caught
# mutant stops sooner); they never add or remove one.
SUBJECTS = [
    ("brdf", "BRDF (brdf.wgsl)", BRDF_MUTANTS, ["shading_finite", "reference_view", "gpu_golden", "gpu_render"]),
    ("light", "direct lights", LIGHT_MUTANTS, ["light_gating", "gpu_render", "gpu_golden", "shadow_quality"]),
    ("shadow", "shadows", SHADOW_MUTANTS, ["shadow_quality", "shadow_cascades", "gpu_golden"]),
    ("ibl", "image-based lighting", IBL_MUTANTS, ["environment", "probes", "reference_view"]),
    ("cube", "cube filter", CUBE_MUTANTS, ["environment", "probes"]),
    ("splitsum", "split-sum table", SPLIT_SUM_MUTANTS, ["environment"]),
    ("hiz", "HiZ", HIZ_MUTANTS, ["hiz_pyramid", "gpu_visibility"]),
    ("cull", "GPU culling", CULL_MUTANTS, ["gpu_visibility", "msaa", "batch_views"]),
    ("skin", "skinning", SKIN_MUTANTS, ["skinning", "gltf_animation"]),
    ("morph", "morphing", MORPH_MUTANTS, ["morph", "gltf_animation"]),
    ("trace", "reference tracer", TRACE_MUTANTS, ["reference_view"]),
    ("tonemap", "tone map", TONEMAP_MUTANTS, ["tonemap_exposure", "frame_economy"]),
    ("alpha", "masked alpha cutoff", ALPHA_MUTANTS, ["gpu_render", "gltf_materials", "reference_view"]),
    ("double-sided", "double-sided normals", DOUBLE_SIDED_MUTANTS, ["draw_order", "reference_view"]),
    ("generation", "generation check", GENERATION_MUTANTS, ["gpu_debug_generations", "gpu_visibility"]),
    ("compose", "window composition", COMPOSE_MUTANTS, ["windows", "viewer_window"]),
    ("output", "typed outputs: labels and insets", OUTPUT_MUTANTS, ["batch_views"]),
]

MUTANTS = [m for _, _, mutants, _ in SUBJECTS for m in mutants]

# The naga validation test of oxygen-passes: it composes every shader module
# of one list (src/shaders/registry.rs) on every texture path and validates
# each entry point at its stage.
VALIDATION_PACKAGE = "oxygen-passes"
VALIDATION_TEST = "shaders::validate_tests"
VALIDATION_COMMAND = ["cargo", "test", "-p", VALIDATION_PACKAGE, "--lib", VALIDATION_TEST]
# The registry names its WGSL files with include_str! (paths relative to
# it); the WGSL of oxygen-bindless and oxygen-sceneprep comes in through
# their constants.
REGISTRY = ROOT / VALIDATION_PACKAGE / "src" / "shaders" / "registry.rs"
REGISTERED_ELSEWHERE = ["oxygen-bindless/src/scene_constants.wgsl", "oxygen-bindless/src/textures/binding_array.wgsl",
                        "oxygen-bindless/src/textures/grouped_arrays.wgsl", "oxygen-sceneprep/src/gpu_records.wgsl"]

# Prints the binaries that render, one a line (shared with scripts/test.sh).
GPU_TEST_BINARIES = ROOT / "scripts" / "gpu-test-binaries"
# What oxygen-demo/src/record.rs keeps in a record's command.env
# (RECORDED_ENV_PREFIXES), less the record's own directory and commit.
RECORDED_ENV_PREFIXES = ("OXYGEN_", "WGPU_", "MSAA_BENCH_", "VISIBILITY_", "CUBES_BENCH_", "BATCH_BENCH_", "ATLAS_", "MESA_", "__GL_")
UNRECORDED_ENV = ("OXYGEN_RECORD_DIR", "OXYGEN_COMMIT")

WORK = ROOT / "target" / "wgsl-mutants"
JOURNAL = WORK / "journal.json"
LOGS = WORK / "logs"
RECORD = ROOT / "docs" / "records" / "wgsl_mutants.jsonl"


def shown(path):
    """`path` relative to the repository when inside it."""
    try:
        return str(path.relative_to(ROOT))
    except ValueError:
        return str(path)


def say(*parts):
    print(*parts, file=sys.stderr, flush=True)


class Failure(Exception):
    """A reason to stop with a non-zero exit (after restoring)."""


# ---- the mutant list ----

def subject_of(name):
    for prefix, subject, mutants, hints in SUBJECTS:
        if any(m[0] == name for m in mutants):
            return prefix, subject, hints
    raise KeyError(name)


def read(path):
    # Bytes, so that line endings and everything else survive byte for byte.
    return path.read_bytes().decode("utf-8")


def list_problems():
    """Every reason the list does not fit the sources, one line each."""
    problems = []
    seen = set()
    for prefix, subject, mutants, _ in SUBJECTS:
        for m in mutants:
            if len(m) != 5:
                problems.append(f"{m[0] if m else '?'}: not (name, file, old, new, breaks)")
                continue
            name, file, old, new, _what = m
            if name in seen:
                problems.append(f"{name}: name used twice")
            seen.add(name)
            if not name.startswith(prefix + "-"):
                problems.append(f"{name}: a {subject} mutant's name must start with '{prefix}-'")
            if not old or not new or old == new:
                problems.append(f"{name}: old and new must be non-empty and differ")
                continue
            path = ROOT / file
            if not path.is_file():
                problems.append(f"{name}: {file} does not exist")
                continue
            count = read(path).count(old)
            if count != 1:
                problems.append(f"{name}: its old text occurs {count} times in {file} (must be exactly once): {old!r}")
    return problems


def check_list():
    problems = list_problems()
    if problems:
        say(f"{len(problems)} mutant(s) do not fit the sources; nothing was run:")
        for p in problems:
            say("  " + p)
        raise Failure("fix the mutant list (scripts/wgsl_mutants.py) to fit today's shaders")


# ---- applying and restoring, whatever happens ----

@contextlib.contextmanager
def signals_deferred():
    """Holds SIGINT/SIGTERM/SIGHUP back while files are half written."""
    held = {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def write_atomically(path, text):
    tmp = path.with_name(f".{path.name}.wgsl-mutants-tmp")
    tmp.write_bytes(text.encode("utf-8"))
    os.chmod(tmp, path.stat().st_mode & 0o7777)
    os.replace(tmp, path)


def mutate(source, mutants):
    """`source` with each mutant applied (their old texts must not overlap)."""
    spans = sorted((source.index(m[2]), m) for m in mutants)
    for (start_a, a), (start_b, b) in zip(spans, spans[1:]):
        if start_a + len(a[2]) > start_b:
            raise ValueError(f"{a[0]} and {b[0]} overlap")
    for start, m in reversed(spans):
        source = source[:start] + m[3] + source[start + len(m[2]):]
    return source


def restore(entries):
    """Puts each file of the journal back; returns the files it could not."""
    stuck = []
    for file, entry in entries.items():
        path = ROOT / file
        current = read(path)
        if current == entry["original"]:
            continue
        if current == entry["mutated"]:
            write_atomically(path, entry["original"])
            continue
        # Someone edited the file while it was mutated: undo only the
        # mutation (a three-way merge of mutated -> original into the file as
        # it is now), keeping their edit, unless the two touch the same lines.
        merged = merge(current, entry["mutated"], entry["original"])
        if merged is not None:
            write_atomically(path, merged)
            say(f"warning: {file} changed while mutated; reverted only the mutation, kept the other edits")
            continue
        stuck.append(file)
    return stuck


def merge(current, base, other):
    """`current` with the change base -> other applied, or None on a conflict."""
    with tempfile.TemporaryDirectory() as tmp:
        paths = []
        for name, text in (("current", current), ("base", base), ("other", other)):
            path = Path(tmp) / name
            path.write_bytes(text.encode("utf-8"))
            paths.append(str(path))
        result = subprocess.run(["git", "merge-file", "-p", *paths], capture_output=True)
    return result.stdout.decode("utf-8") if result.returncode == 0 else None


def save_journal(entries):
    WORK.mkdir(parents=True, exist_ok=True)
    tmp = JOURNAL.with_suffix(".tmp")
    tmp.write_text(json.dumps(entries))
    os.replace(tmp, JOURNAL)


def recover_from_journal():
    """Restores what a killed run left mutated."""
    if not JOURNAL.exists():
        return
    entries = json.loads(JOURNAL.read_text())
    say(f"a previous run left mutated: {', '.join(entries)}; restoring")
    stuck = restore(entries)
    if stuck:
        raise Failure(f"could not restore {', '.join(stuck)} (edited since): compare with {JOURNAL} by hand")
    JOURNAL.unlink()


@contextlib.contextmanager
def applied(mutants):
    """The mutants applied (several per file when they do not overlap),
    restored on leaving, however it is left."""
    by_file = {}
    for m in mutants:
        by_file.setdefault(m[1], []).append(m)
    entries = {}
    try:
        with signals_deferred():
            for file, ms in by_file.items():
                original = read(ROOT / file)
                entries[file] = {"original": original, "mutated": mutate(original, ms)}
            save_journal(entries)
            for file, entry in entries.items():
                write_atomically(ROOT / file, entry["mutated"])
        yield
    finally:
        with signals_deferred():
            stuck = restore(entries)
            if not stuck and JOURNAL.exists():
                JOURNAL.unlink()
        if stuck:
            raise Failure(f"could not restore {', '.join(stuck)}: edited on the mutated lines meanwhile; "
                          f"the journal {shown(JOURNAL)} holds the originals")


def raise_interrupt(signum, _frame):
    raise KeyboardInterrupt(f"signal {signal.Signals(signum).name}")


# ---- commands ----

def run(command, log=None, timeout=None, env=None):
    """(exit status or None on timeout, output). Runs in its own process
    group, which is killed on timeout or interrupt."""
    started = time.time()
    process = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               env=env, start_new_session=True)
    try:
        output, _ = process.communicate(timeout=timeout)
        status = process.returncode
    except subprocess.TimeoutExpired:
        kill_group(process)
        output, _ = process.communicate()
        status = None
    except BaseException:
        kill_group(process)
        raise
    text = output.decode("utf-8", "replace")
    if log is not None:
        log.parent.mkdir(parents=True, exist_ok=True)
        with log.open("a") as f:
            f.write(f"$ {shlex.join(command)}   ({time.time() - started:.0f} s, status {status})\n{text}\n")
    return status, text


def kill_group(process):
    for sig, wait in ((signal.SIGTERM, 5), (signal.SIGKILL, 5)):
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            return
        try:
            process.wait(timeout=wait)
            return
        except subprocess.TimeoutExpired:
            continue


def test_env(skip_log=None):
    env = dict(os.environ)
    # Never write goldens or snapshots from a mutated shader: under CI a
    # missing golden fails instead of being written.
    env.pop("OXYGEN_UPDATE_GOLDEN", None)
    env["CI"] = "1"
    env["INSTA_UPDATE"] = "no"
    env.pop("OXYGEN_SKIP_LOG", None)
    if skip_log is not None:
        env["OXYGEN_SKIP_LOG"] = str(skip_log)
    return env


def gpu_test_binaries():
    result = subprocess.run([str(GPU_TEST_BINARIES)], cwd=ROOT, capture_output=True, text=True)
    binaries = sorted(result.stdout.split())
    if result.returncode != 0 or not binaries:
        raise Failure(f"{shown(GPU_TEST_BINARIES)} failed (status {result.returncode}) or listed no binary: "
                      f"{result.stderr.strip()}")
    return binaries


FAILED_LINE = re.compile(r"^test (\S+) \.\.\. FAILED", re.M)
CRASH_LINE = re.compile(r"process didn't exit successfully: .*\((signal: [^)]*|exit status: \d+)\)")


def first_failure(binary, output):
    match = FAILED_LINE.search(output)
    if match:
        return f"{binary}::{match.group(1)}"
    crash = CRASH_LINE.search(output)
    return f"{binary} ({crash.group(1)})" if crash else binary


def is_test_failure(output):
    """A test (or the test process) failed, as opposed to the build."""
    return bool(FAILED_LINE.search(output)) or "error: test failed, to rerun pass" in output


def build(binaries, log, env):
    command = ["cargo", "test", "-p", "oxygen", "--no-run"] + [a for b in binaries for a in ("--test", b)]
    status, output = run(command, log=log, env=env)
    if status != 0:
        tail = "\n".join(output.splitlines()[-25:])
        raise Failure(f"the test binaries do not build (not the shaders' doing: WGSL is compiled at run time):\n{tail}")


def run_binaries(binaries, log, env, timeout, keep_going):
    """[(binary, failing test or None, seconds)], stopping at the first
    failure unless keep_going."""
    results = []
    for binary in binaries:
        started = time.time()
        status, output = run(["cargo", "test", "-p", "oxygen", "--test", binary], log=log, timeout=timeout, env=env)
        seconds = time.time() - started
        if status is None:
            results.append((binary, f"{binary} (timeout after {timeout} s)", seconds))
        elif status == 0:
            results.append((binary, None, seconds))
        elif is_test_failure(output):
            results.append((binary, first_failure(binary, output), seconds))
        else:
            tail = "\n".join(output.splitlines()[-25:])
            raise Failure(f"cargo failed on {binary} without a test failing (a build problem?):\n{tail}")
        if results[-1][1] is not None and not keep_going:
            break
    return results


# ---- --check ----

def covered_files():
    """The WGSL files the validation test composes: the registry's."""
    registry = read(REGISTRY)
    files = set(REGISTERED_ELSEWHERE)
    for included in re.findall(r'include_str!\("([^"]+)"\)', registry):
        files.add(shown((REGISTRY.parent / included).resolve()))
    return files


def validate(log):
    """None when the naga validation passes, else its failure."""
    status, output = run(VALIDATION_COMMAND, log=log)
    if status == 0:
        return None
    if is_test_failure(output):
        lines = [l for l in output.splitlines() if "error" in l.lower() or "panicked" in l or "does not" in l]
        return "\n".join(lines[:12]) or "validation failed"
    tail = "\n".join(output.splitlines()[-25:])
    raise Failure(f"{VALIDATION_PACKAGE}'s {VALIDATION_TEST} does not build (someone's work in progress?):\n{tail}")


def rounds_of(mutants):
    """Groups of mutants with no two overlapping in one file."""
    rounds = []
    for m in mutants:
        source = read(ROOT / m[1])
        start = source.index(m[2])
        span = (m[1], start, start + len(m[2]))
        for r in rounds:
            if all(s[0] != span[0] or s[2] <= span[1] or span[2] <= s[1] for s, _ in r):
                r.append((span, m))
                break
        else:
            rounds.append([(span, m)])
    return [[m for _, m in r] for r in rounds]


def check(chosen, one_by_one):
    covered = covered_files()
    validated = [m for m in chosen if m[1] in covered]
    uncovered = [m for m in chosen if m[1] not in covered]
    say(f"{len(chosen)} mutant(s) apply exactly once; validating the {len(validated)} in files "
        f"{VALIDATION_TEST} covers with naga")
    log = LOGS / "check.log"
    if log.exists():
        log.unlink()
    started = time.time()
    failure = validate(log)
    if failure:
        raise Failure(f"the unmutated shaders fail {VALIDATION_TEST}; fix that first:\n{failure}")
    failed = {}
    rounds = [[m] for m in validated] if one_by_one else rounds_of(validated)
    for i, group in enumerate(rounds, 1):
        with applied(group):
            failure = validate(log)
        if one_by_one:
            say(f"[{i}/{len(rounds)}] {group[0][0]}: {'validates' if failure is None else 'FAILS'} "
                f"({time.time() - started:.0f} s)")
            if failure:
                failed[group[0][0]] = failure
                say("    " + failure.replace("\n", "\n    "))
            continue
        say(f"round {i}/{len(rounds)}: {len(group)} mutants applied together: "
            f"{'validate' if failure is None else 'FAIL, trying each alone'} ({time.time() - started:.0f} s)")
        if failure is None:
            continue
        for m in group:
            with applied([m]):
                failure = validate(log)
            if failure:
                failed[m[0]] = failure
                say(f"  {m[0]}: does not validate:\n    " + failure.replace("\n", "\n    "))
    print(f"| mutant | file | applies once | validates ({VALIDATION_PACKAGE} {VALIDATION_TEST}) |")
    print("|---|---|---|---|")
    for m in chosen:
        if m in uncovered:
            status = "not covered by the naga tests: checked only when a GPU test builds its pipeline"
        else:
            status = "**NO**" if m[0] in failed else "yes"
        print(f"| `{m[0]}` | {Path(m[1]).name} | yes | {status} |")
    for file in sorted({m[1] for m in uncovered}):
        say(f"note: {file} is not validated by {VALIDATION_TEST}; its mutants were only checked to apply once")
    say(f"--check: {len(chosen)} apply once, {len(validated) - len(failed)} of {len(validated)} validate, "
        f"{len(uncovered)} not covered ({time.time() - started:.0f} s)")
    if failed:
        raise Failure(f"mutants that do not validate: {', '.join(failed)}")


# ---- a run ----

def ordered(binaries, hints, previous):
    first = [b for b in [previous] + hints if b in binaries]
    first = list(dict.fromkeys(first))
    return first + [b for b in binaries if b not in first]


def previous_catchers():
    """Each mutant's first failing binary in the last recorded run."""
    catchers = {}
    if RECORD.exists():
        for line in RECORD.read_text().splitlines():
            try:
                for m in json.loads(line)["values"].get("mutants", []):
                    if m.get("first_failing_test"):
                        catchers[m["name"]] = re.split(r"::| ", m["first_failing_test"])[0]
            except (ValueError, AttributeError, KeyError, TypeError):
                continue
    return catchers


def git(*args):
    """git's output, or None when it fails."""
    result = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True)
    return result.stdout.strip() if result.returncode == 0 else None


ADAPTER_LINE = re.compile(r"^adapter: (.*) \((\w+), (\w+), driver (\S*) ?(.*)\)$")


def adapter_of(env):
    """(the adapter line adapter_info prints, the record's adapter object or
    None). GpuContext::describe prints `name (backend, type, driver driver
    info)`; the driver is taken as its first word, and the line is kept."""
    status, output = run(["cargo", "run", "--quiet", "--example", "adapter_info"], env=env)
    lines = output.strip().splitlines()
    line = next((l for l in lines if l.startswith("adapter:")), None)
    if status != 0 or line is None:
        return f"(adapter_info failed: {lines[-1] if lines else status})", None
    match = ADAPTER_LINE.match(line)
    if not match:
        return line, None
    keys = ("name", "backend", "device_type", "driver", "driver_info")
    return line, dict(zip(keys, match.groups()))


def new_record(chosen, binaries, restricted):
    """The record's fields but `values` (docs/records/README.md's format:
    bench, commit, dirty, date, adapter, host, command, values), taken
    before anything is mutated."""
    # A commit given names the build (as in oxygen-demo/src/record.rs): the
    # checkout's git state says nothing about it then.
    given = os.environ.get("OXYGEN_COMMIT")
    status = None if given else git("status", "--porcelain", "--untracked-files=no")
    files = sorted({m[1] for m in chosen})
    line, adapter = adapter_of(test_env())
    env = {k: v for k, v in sorted(os.environ.items())
           if k.startswith(RECORDED_ENV_PREFIXES) and k not in UNRECORDED_ENV}
    record = {
        "bench": RECORD.stem,
        "commit": given or git("rev-parse", "HEAD") or "unknown",
        "dirty": None if status is None else bool(status),
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "adapter": adapter,
        "host": {"available_parallelism": len(os.sched_getaffinity(0)), "os": sys.platform,
                 "arch": os.uname().machine},
        "command": {"argv": shlex.join(["scripts/wgsl_mutants.py"] + sys.argv[1:]), "env": env},
        "values": {
            "adapter_line": line,
            "uncommitted_mutated_files": [l[3:] for l in (git("status", "--porcelain", "--", *files) or "").splitlines()],
            "binaries": binaries,
            "restricted": restricted,
        },
    }
    say(line)
    return record


def mutation_run(chosen, args):
    binaries = gpu_test_binaries()
    if args.tests:
        wanted = [t for t in args.tests.split(",") if t]
        unknown = [t for t in wanted if t not in binaries]
        if unknown:
            raise Failure(f"not GPU test binaries: {', '.join(unknown)} (they are: {', '.join(binaries)})")
        binaries = [b for b in binaries if b in wanted]
        say(f"RESTRICTED to {len(binaries)} test binaries: a quick look, not a score")
    say(f"{len(binaries)} GPU test binaries: {' '.join(binaries)}")
    started_all = time.time()
    record = new_record(chosen, binaries, bool(args.tests)) if args.record else None

    # Baseline: every binary passes unmutated (and which tests skip here).
    baseline_log = LOGS / "baseline.log"
    skip_log = WORK / "baseline-skips.txt"
    for p in (baseline_log, skip_log):
        if p.exists():
            p.unlink()
    build(binaries, baseline_log, test_env())
    results = run_binaries(binaries, baseline_log, test_env(skip_log), args.timeout, keep_going=True)
    failing = [r[1] for r in results if r[1]]
    if failing:
        raise Failure(f"the unmutated shaders fail: {', '.join(failing)}; fix that first (log: {baseline_log})")
    skipped = sorted(set(l.split("\t")[0] for l in skip_log.read_text().splitlines())) if skip_log.exists() else []
    baseline_seconds = time.time() - started_all
    say(f"baseline passes ({baseline_seconds:.0f} s; the suite alone {sum(r[2] for r in results):.0f} s)")
    if skipped:
        say(f"{len(skipped)} tests skip on this adapter (a mutant only they could catch is missed): {', '.join(skipped)}")

    catchers = previous_catchers()
    rows = []
    try:
        for n, m in enumerate(chosen, 1):
            rows.append((m, run_mutant(m, binaries, catchers, args)))
            r = rows[-1][1]
            say(f"[{n}/{len(chosen)}] {m[0]}: {'caught by ' + r['first_failing_test'] if r['caught'] else 'MISSED'} "
                f"({r['seconds']:.0f} s)")
    except KeyboardInterrupt:
        if rows:
            say(f"interrupted after {len(rows)} of {len(chosen)} mutants (not recorded); so far:")
            print_table(rows, binaries, args, time.time() - started_all, baseline_seconds)
        raise
    total_seconds = time.time() - started_all
    caught = print_table(rows, binaries, args, total_seconds, baseline_seconds)
    if record is not None:
        record["values"].update({"baseline_seconds": round(baseline_seconds, 1), "skipped_tests": skipped,
                                 "caught": caught, "total": len(rows), "seconds": round(total_seconds, 1),
                                 "mutants": [r for _, r in rows]})
        RECORD.parent.mkdir(parents=True, exist_ok=True)
        with RECORD.open("a") as f:
            f.write(json.dumps(record, ensure_ascii=False) + "\n")
        say(f"recorded in {shown(RECORD)}")


def run_mutant(m, binaries, catchers, args):
    """Applies `m`, builds, runs the binaries (likely catchers first) up to
    the first failure, restores; the mutant's row."""
    name, file = m[0], m[1]
    _, _, hints = subject_of(name)
    log = LOGS / f"{name}.log"
    if log.exists():
        log.unlink()
    started = time.time()
    with applied([m]):
        # No build of every binary first: `cargo test --test B` links B
        # when it runs, so a mutant the first binaries catch costs their
        # links only, not all of them (half a minute or more a mutant).
        results = run_binaries(ordered(binaries, hints, catchers.get(name)), log, test_env(),
                               args.timeout, args.keep_going)
    failures = [r[1] for r in results if r[1]]
    row = {"name": name, "file": file, "caught": bool(failures),
           "first_failing_test": failures[0] if failures else None,
           "seconds": round(time.time() - started, 1)}
    if args.keep_going:
        row["failing"] = failures
    return row


def print_table(rows, binaries, args, total_seconds, baseline_seconds):
    """The table for docs/testing.md and the scores; the number caught."""
    caught = sum(1 for _, r in rows if r["caught"])
    print("| mutant | file | breaks | result | first failing test |")
    print("|---|---|---|---|---|")
    for m, r in rows:
        result = "caught" if r["caught"] else "**missed**"
        test = f"`{r['first_failing_test']}`" if r["first_failing_test"] else "—"
        print(f"| `{m[0]}` | {Path(m[1]).name} | {m[4]} | {result} | {test} |")
    print()
    for _, subject, mutants, _ in SUBJECTS:
        mine = [r for m, r in rows if m in mutants]
        if mine:
            print(f"- {subject}: {sum(r['caught'] for r in mine)} of {len(mine)} caught")
    restricted = f" (RESTRICTED to {len(binaries)} binaries: not a score)" if args.tests else ""
    print(f"\n{caught} of {len(rows)} caught ({100.0 * caught / max(len(rows), 1):.0f} %){restricted}, "
          f"{total_seconds / 60:.0f} minutes in all (baseline {baseline_seconds / 60:.0f})", flush=True)
    return caught


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("words", nargs="*", help="only mutants whose name contains one of these")
    parser.add_argument("--check", action="store_true",
                        help="only check that every mutant applies once and validates with naga (no GPU)")
    parser.add_argument("--one-by-one", action="store_true",
                        help="with --check: validate each mutant alone instead of in rounds of non-overlapping ones")
    parser.add_argument("--list", action="store_true", help="list the mutants by subject and exit")
    parser.add_argument("--record", action="store_true", help=f"append the run to {shown(RECORD)}")
    parser.add_argument("--tests", help="comma-separated GPU test binaries to run instead of all (not a score)")
    parser.add_argument("--keep-going", action="store_true",
                        help="run every binary for every mutant and list every failing test")
    parser.add_argument("--timeout", type=int, default=1800,
                        help="seconds one test binary may run before the mutant counts as caught by a timeout")
    args = parser.parse_args()
    if args.record and (args.check or args.list):
        parser.error("--record goes with a mutation run, not --check or --list")

    signal.signal(signal.SIGTERM, raise_interrupt)
    signal.signal(signal.SIGHUP, raise_interrupt)
    try:
        recover_from_journal()
        if args.list:
            for prefix, subject, mutants, _ in SUBJECTS:
                print(f"{subject}: {len(mutants)}")
                for m in mutants:
                    print(f"  {m[0]:<42} {Path(m[1]).name:<22} {m[4]}")
            print(f"{len(MUTANTS)} mutants")
        check_list()
        if args.list:
            return 0
        chosen = [m for m in MUTANTS if not args.words or any(w in m[0] for w in args.words)]
        if not chosen:
            raise Failure(f"no mutant's name contains any of: {' '.join(args.words)}")
        if args.check:
            check(chosen, args.one_by_one)
        else:
            mutation_run(chosen, args)
        return 0
    except Failure as e:
        say(f"wgsl_mutants: {e}")
        return 1
    except KeyboardInterrupt as e:
        say(f"wgsl_mutants: interrupted ({str(e) or 'SIGINT'}); files restored")
        return 130


if __name__ == "__main__":
    sys.exit(main())
