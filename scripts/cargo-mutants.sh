#!/usr/bin/env bash
# cargo-mutants over the CPU logic of one crate, one shard at a time, each
# shard's outcome kept under docs/records/mutants/ (docs/testing.md keeps
# the scores and explains the survivors).
#
#   scripts/cargo-mutants.sh SCOPE K N      # shard K of N (0-based) of SCOPE
#   scripts/cargo-mutants.sh SCOPE list     # the mutants of SCOPE, one a line
#
# SCOPE is one of:
#   core       oxygen-core (all CPU logic: the device code is oxygen-gpu's)
#   bindless   oxygen-bindless without its GPU buffers, samplers and bind groups
#   sceneprep  oxygen-sceneprep (its tests and oxygen-bindless's)
#   passes     oxygen-passes' CPU helpers (half floats); the rest of that
#              crate records GPU work, measured by scripts/wgsl_mutants.py
#              and the GPU tests
#   importer   the root crate's glTF importer and .hdr loader (untrusted input),
#              tested by the importer's CPU tests, the mutant corpus,
#              tests/gltf_animation.rs and tests/morph.rs (animations and
#              morph targets) and tests/environment.rs (which loads .hdr
#              files; these render, on
#              whatever adapter the machine gives: lavapipe here)
#   gpu        oxygen-gpu's CPU logic: read-back texel decoding (half floats,
#              Rg11b10), HDR images, label sets, target and atlas sizes and
#              layouts, the bind-group layout builder, the gpu_struct layout
#              checks, adapter ranking; not what needs a device (creating
#              contexts and targets, reading back), which the GPU tests cover
#   root       the root crate's CPU logic outside the importer: batches,
#              graphs, renderer groups, schedules (and the renderer's
#              schedules subsystem), windows' rectangles, the view registry,
#              shadow planning, the renderer's recording order and executor,
#              read-back images (not the Renderer methods that read a
#              device), tested by the root crate's unit tests (--lib); the
#              rest of the root crate records and reads GPU work, reached by
#              the GPU tests (see docs/testing.md)
#   streams    the CPU side of batch streaming (renderer/streams.rs: page
#              layouts in a staging buffer, cutting mapped pages into the
#              cameras' blocks, frames' accessors, spare buffers), tested by
#              the root crate's unit tests; not the rings' copies, mappings
#              and threads, which tests/batch_views.rs covers on a device
#   targets    the target budget's arithmetic (a view's target bytes and its
#              admission), tested by the root crate's unit tests; not the
#              allocation of targets and atlases, which needs a device
#   timing     GPU timing's decoding of a timestamp readback into seconds
#              (not the queries and their mapping, which need a device)
#   demo       oxygen-demo's record writer and span timer (the evidence the
#              benches and tests write; the demo scenes themselves are
#              fixtures, checked by the tests that render them)
#   node       oxygen-node (render nodes: placement, membership, take-over,
#              the wire headers' checks, the node program), tested by its
#              unit tests and tests/render_nodes.rs (three node processes on
#              loopback, rendering on whatever adapter the machine gives)
#
# OXYGEN_MUTANTS_TIMEOUT sets cargo-mutants' per-mutant test timeout in
# seconds (default 300; 90 for the node scope, whose rig test is then told
# to wait 30 s at most: OXYGEN_NODE_TEST_WAIT_S). A mutant that makes a
# worker loop for ever costs the whole timeout: sceneprep's worker-pool
# mutants are run with 60 (its baseline tests take a few seconds).
#
# A full run is long on a 2-core machine (about 13 s a mutant for the CPU
# crates, about a minute for the importer, whose every mutant relinks the
# seven test binaries of its scope): shards let it go on across sessions. The
# shard's outcomes.json is copied to
# docs/records/mutants/<SCOPE>-<K>-of-<N>.json and its summary printed.
#
# OXYGEN_MUTANTS_BASELINE=skip skips the unmutated build and test that
# cargo-mutants runs first in every shard (about five minutes of an
# importer shard): use it for a run of shards in a tree whose baseline an
# earlier shard has already seen pass. Set OXYGEN_MUTANTS_TIMEOUT with it,
# since the timeout can no longer be derived from the baseline's time.
#
# OXYGEN_MUTANTS_IN_PLACE=1 mutates this checkout's files in place instead of
# a fresh copy per shard (whose first build is a whole wgpu build, minutes on
# two cores): use it only in a checkout of its own (`git worktree add`),
# never in one you are editing.
set -euo pipefail
. "$(dirname "$0")/usage.sh"
cd "$(dirname "$0")/.."

say() { printf '[mutants] %s\n' "$*" >&2; }
[ $# -ge 2 ] || usage
scope=$1

case "$scope" in
  core)
    args=(-p oxygen-core --test-package oxygen-core)
    ;;
  bindless)
    args=(-p oxygen-bindless --test-package oxygen-bindless --test-package oxygen-sceneprep
      --exclude 'oxygen-bindless/src/heap.rs'
      -E 'TextureHeap::|create_sampler|create_texture|build_bind_group|write_level|SceneConstantsBuffer::|allocate_texture_slot|array_view')
    ;;
  sceneprep)
    args=(-p oxygen-sceneprep --test-package oxygen-sceneprep --test-package oxygen-bindless)
    ;;
  passes)
    args=(-p oxygen-passes --test-package oxygen-passes --file oxygen-passes/src/lighting/ibl/half.rs)
    ;;
  importer)
    # --cargo-arg, not --cargo-test-arg: the build of each mutant then
    # links these seven test binaries only, not the root crate's forty and
    # its examples (about half of each mutant's time on two cores).
    args=(-p oxygen --file 'src/gltf_import/**' --file src/environment_file.rs
      --cargo-arg=--test=gltf_import --cargo-arg=--test=gltf_untrusted
      --cargo-arg=--test=gltf_fuzz_corpus --cargo-arg=--lib
      --cargo-arg=--test=environment --cargo-arg=--test=gltf_animation
      --cargo-arg=--test=morph)
    ;;
  gpu)
    args=(-p oxygen-gpu --test-package oxygen-gpu
      -E 'GpuContext::|pick_adapter|ViewTargets::(create|depth_only|probe_face|render_depth_view|atlas_layer)|TileAtlas::view_targets|create_layout|single_layer_view|shared_instance|in texture_2d$')
    ;;
  root)
    args=(-p oxygen --file src/batch.rs --file src/graph.rs --file 'src/group/**'
      --file src/schedule.rs --file src/windows.rs --file src/renderer/record.rs
      --file src/renderer/schedules.rs --file src/renderer/readback.rs
      --file src/views.rs --file src/shadows.rs
      -E 'Renderer::(view_draws|read_|view_targets|not_rendered|prepared_frame)'
      --cargo-arg=--lib
      # The importer's unit tests (9 of the 10 seconds of the root crate's
      # unit tests) reach none of these files.
      --cargo-test-arg=-- --cargo-test-arg=--skip --cargo-test-arg=gltf_import)
    ;;
  streams)
    args=(-p oxygen --file src/renderer/streams.rs
      -E 'Ring::|Streams::(new|after_submit|take)\b|arrive|\bcut\b|Slot::new|Renderer::|PageLayout::of'
      --cargo-arg=--lib
      --cargo-test-arg=-- --cargo-test-arg=--skip --cargo-test-arg=gltf_import)
    ;;
  targets)
    args=(-p oxygen --file src/renderer/targets.rs -F 'Targets::(bytes_for|admit)'
      --cargo-arg=--lib
      --cargo-test-arg=-- --cargo-test-arg=--skip --cargo-test-arg=gltf_import)
    ;;
  timing)
    args=(-p oxygen --file src/renderer/gpu_timer.rs -F 'span_seconds'
      --cargo-arg=--lib
      --cargo-test-arg=-- --cargo-test-arg=--skip --cargo-test-arg=gltf_import)
    ;;
  demo)
    args=(-p oxygen-demo --test-package oxygen-demo
      --file oxygen-demo/src/record.rs --file oxygen-demo/src/span_times.rs)
    ;;
  node)
    args=(-p oxygen-node --test-package oxygen-node)
    # The rig test's waits (120 s each, for lavapipe on a busy machine)
    # shortened: the unmutated suite takes about 5 s, and a mutant that
    # makes a frame wait for ever is then caught in 30 s, not 120.
    export OXYGEN_NODE_TEST_WAIT_S="${OXYGEN_NODE_TEST_WAIT_S:-30}"
    default_timeout=90
    ;;
  *)
    say "unknown scope '$scope' (core, bindless, sceneprep, passes, importer, gpu, demo, root, streams, targets, timing, node)"
    exit 2
    ;;
esac

if [ "$2" = list ]; then
  exec cargo mutants --list "${args[@]}"
fi
k=$2
n=${3:?shard count}
command -v cargo-mutants >/dev/null || { say "cargo-mutants is missing: cargo install --locked cargo-mutants"; exit 1; }
out=target/mutants/$scope-$k-of-$n
mkdir -p "$out" docs/records/mutants
say "$scope: shard $k of $n (output: $out)"
set +e
in_place=()
if [ "${OXYGEN_MUTANTS_IN_PLACE:-}" = 1 ]; then
  in_place=(--in-place)
fi
baseline=(--baseline "${OXYGEN_MUTANTS_BASELINE:-run}")
cargo mutants "${args[@]}" "${in_place[@]}" "${baseline[@]}" --shard "$k/$n" --timeout "${OXYGEN_MUTANTS_TIMEOUT:-${default_timeout:-300}}" --output "$out"
status=$?
set -e
# cargo-mutants exits 2 when mutants were missed, 3 on timeouts: a result,
# not a failure of the run. Anything else is.
case "$status" in
  0 | 2 | 3) ;;
  *) say "cargo mutants failed (exit $status)"; exit "$status" ;;
esac
cp "$out/mutants.out/outcomes.json" "docs/records/mutants/$scope-$k-of-$n.json"
python3 - "$out/mutants.out/outcomes.json" <<'PY'
import json, sys
outcomes = json.load(open(sys.argv[1]))
counts = {}
for o in outcomes.get("outcomes", []):
    if o.get("scenario") == "Baseline":
        continue
    summary = o.get("summary", "?")
    counts[summary] = counts.get(summary, 0) + 1
caught = counts.get("CaughtMutant", 0) + counts.get("Timeout", 0)
missed = counts.get("MissedMutant", 0)
viable = caught + missed
score = f"{100 * caught / viable:.1f} %" if viable else "n/a"
print(f"[mutants] {counts}; caught {caught} of {viable} viable: {score}")
PY
