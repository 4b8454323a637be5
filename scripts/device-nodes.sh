#!/usr/bin/env bash
# The render-node and renderer-group runs of docs/performance.md ("Views over
# render nodes"), as run on a lent machine with two or more GPUs (issue 34).
# Expects the release binaries node_bench, oxygen-node and group_bench in
# $BIN (default .ab/cur) and OXYGEN_RECORD_DIR set; each bench appends its
# own record there. Usage: scripts/device-nodes.sh [quick]
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BIN:-.ab/cur}
frames=${FRAMES:-10}
export NODE_BENCH_NODE="$bin/oxygen-node" NODE_BENCH_SPREAD=1
run() { echo "+ $*" >&2; env "$@"; }

# Render nodes, one per GPU, alternately 1 and 2: the ring of 1 024 cameras
# of 128 x 128 and the field of 256 views of 640 x 360, images read back
# (colour) and not (each view's output only its tag).
for planes in color none; do
  run NODE_BENCH_PLANES=$planes "$bin/node_bench" 1000 128x128 1024 1,2,1,2 "$frames"
  run NODE_BENCH_PLANES=$planes "$bin/node_bench" 10000 640x360 256 1,2,1,2 "$frames"
done
# The same images on one GPU and on two (deterministic mode): the hashes of
# the last frame's images in each row.
run NODE_BENCH_DETERMINISTIC=1 "$bin/node_bench" 1000 128x128 1024 1,2 3
run NODE_BENCH_DETERMINISTIC=1 "$bin/node_bench" 10000 640x360 256 1,2 3
# In one process, for comparison on the same machine, images read back.
run GROUP_BENCH_READBACK=1 "$bin/group_bench" 1000 128x128 1024 1,2 "$frames"
run GROUP_BENCH_READBACK=1 "$bin/group_bench" 10000 640x360 256 1,2 "$frames"
