#!/usr/bin/env bash
# Runs the benches whose figures docs/performance.md and docs/accuracy.md
# quote for a hardware GPU, with the arguments the docs give, and collects
# their records (oxygen_demo::record) in one folder. This is the script the
# H100 tables come from; the records it writes are committed under
# docs/records/ (docs/records/README.md).
#
#   scripts/gpu-records.sh BIN_DIR RECORD_DIR [GROUP..]
#
# BIN_DIR holds release builds of the bench examples (built elsewhere, e.g.
# `cargo build --release --examples` and copied, stripped, to a GPU machine);
# RECORD_DIR receives <bench>.jsonl files and a log per run. OXYGEN_COMMIT
# must name the commit the binaries were built from (records name it; a
# carried copy's .git may name another): without it the script refuses to
# run (exit 2), unless BIN_DIR is inside this checkout's target/ and the
# checkout's tracked files are clean (`git status --porcelain
# --untracked-files=no`), when it takes `git rev-parse HEAD`. GROUPs
# (default: all) split the work so that each part fits one sitting:
#   draws      draw_path_bench, raster_floor, record_bench, indirect_count_cost
#   frame      shadow_bench, hdr_format_bench, prepass_bench, cubes_bench (pre-pass), msaa_bench
#   visibility visibility_bench (field, city, the static-frame aims)
#   lighting   environment_bench, accuracy_atlas
#   msaa-parts msaa_bench's frame taken apart (MSAA_BENCH_GRAPH, MSAA_BENCH_REPEAT)
#   first-frame record_bench's first frame with the drivers' shader caches off
#   lavapipe   the docs' lavapipe columns (smaller sizes, for the 2-core
#              machine without a GPU): shadow_bench, hdr_format_bench,
#              prepass_bench, msaa_bench, environment_bench, and the
#              ScenePrep bench through cargo (CPU only), run in this
#              checkout (the script's ..), whatever the caller's directory
# Each run's stdout/stderr goes to RECORD_DIR/<n>-<bench>.log; a failing run
# is reported and the others go on; the exit status is non-zero if any failed.
set -uo pipefail
. "$(dirname "$0")/usage.sh"

[ $# -ge 2 ] || usage
root=$(cd "$(dirname "$0")/.." && pwd -P)
bin=$(cd "$1" && pwd -P)
out=$2
shift 2

# The records must name the commit the binaries were built from.
if [ -z "${OXYGEN_COMMIT:-}" ]; then
  case "$bin/" in
    "$root/target/"*)
      if ! head=$(git -C "$root" rev-parse HEAD) || ! changes=$(git -C "$root" status --porcelain --untracked-files=no); then
        echo "[gpu-records] OXYGEN_COMMIT is not set and git cannot say what $root is at: set OXYGEN_COMMIT" >&2
        exit 2
      fi
      if [ -n "$changes" ]; then
        echo "[gpu-records] OXYGEN_COMMIT is not set and $root has uncommitted changes to tracked files:" \
          "the binaries in $bin need not be HEAD's; commit (and rebuild) or set OXYGEN_COMMIT" >&2
        exit 2
      fi
      export OXYGEN_COMMIT=$head
      echo "[gpu-records] OXYGEN_COMMIT=$head (this clean checkout's HEAD; BIN_DIR is in its target/)" >&2
      ;;
    *)
      echo "[gpu-records] OXYGEN_COMMIT is not set: name the commit the binaries in $bin were built from" \
        "(OXYGEN_COMMIT=<hash> $0 ...); a carried copy's .git may name another" >&2
      exit 2
      ;;
  esac
fi
groups=${*:-draws frame visibility lighting}  # lavapipe only when named
mkdir -p "$out"
out=$(cd "$out" && pwd)
export OXYGEN_RECORD_DIR="$out"

say() { printf '[gpu-records] %s\n' "$*" >&2; }
n=0
failed=()
# run BENCH [ENV=VALUE..] -- ARGS..: one bench run, logged.
run() {
  local bench=$1
  shift
  local envs=()
  while [ $# -gt 0 ] && [ "$1" != "--" ]; do envs+=("$1"); shift; done
  [ "${1:-}" = "--" ] && shift
  n=$((n + 1))
  local log
  log=$(printf '%s/%02d-%s.log' "$out" "$n" "$bench")
  say "$bench ${envs[*]} $* (log: $log)"
  local start=$SECONDS
  if env "${envs[@]}" "$bin/$bench" "$@" >"$log" 2>&1; then
    say "  done in $((SECONDS - start)) s"
  else
    say "  FAILED (exit $?) after $((SECONDS - start)) s; last lines:"
    tail -5 "$log" >&2
    failed+=("$bench $*")
  fi
}

for group in $groups; do
  case "$group" in
    draws)
      run draw_path_bench -- 100000
      run draw_path_bench -- 1000000
      run raster_floor -- 10000
      run raster_floor -- 100000
      run raster_floor -- 1000000
      run record_bench -- 20000 direct
      run record_bench -- 20000 mdi
      run indirect_count_cost -- 60
      ;;
    frame)
      run shadow_bench -- 10000
      run hdr_format_bench -- 1920 60
      run hdr_format_bench -- 3840 30
      run prepass_bench -- 10000
      for prepass in auto on off; do
        run cubes_bench OXYGEN_PREPASS=$prepass -- 10000 1 20
        run cubes_bench OXYGEN_PREPASS=$prepass -- 100000 1 20
      done
      run msaa_bench -- 1920 2500 40
      run msaa_bench -- 1920 0 40
      run msaa_bench -- 3840 10000 40
      ;;
    visibility)
      run visibility_bench -- field 10000,100000 1,6,24 10
      run visibility_bench -- field 1000000 1,6 8
      run visibility_bench -- city 4096,16384 1,6 10
      run visibility_bench VISIBILITY_PATHS=gpu VISIBILITY_GPU_BUSY_MS=16.7 -- field 10000 1 40
      run visibility_bench VISIBILITY_PATHS=gpu -- field 1000000 1 40
      ;;
    lighting)
      run environment_bench -- 7
      run tone_map_effects_bench -- 1280 40
      run accuracy_atlas -- "$out/atlas" 1280 16384
      ;;
    msaa-parts)
      for graph in full no-pre-pass pre-pass unlit; do
        run msaa_bench MSAA_BENCH_GRAPH=$graph -- 1920 0 40
      done
      for repeat in 2 8; do
        run msaa_bench MSAA_BENCH_GRAPH=unlit MSAA_BENCH_REPEAT=$repeat -- 1920 0 40
      done
      run msaa_bench MSAA_BENCH_GRAPH=unlit -- 3840 0 40
      ;;
    first-frame)
      # Mesa's and NVIDIA's on-disk shader caches off: the first frame pays
      # for every pipeline's compilation.
      for mode in direct mdi; do
        run record_bench MESA_SHADER_CACHE_DISABLE=true __GL_SHADER_DISK_CACHE=0 -- 20000 "$mode"
      done
      ;;
    lavapipe)
      run shadow_bench -- 10000
      run hdr_format_bench -- 1280 10
      run tone_map_effects_bench -- 1280 10
      run prepass_bench -- 10000
      run msaa_bench -- 640 400 20
      run msaa_bench -- 640 0 20
      run environment_bench -- 3
      n=$((n + 1))
      say "prep (cargo bench -p oxygen-sceneprep --bench prep)"
      if ! (cd "$root" && cargo bench --locked -p oxygen-sceneprep --bench prep) >"$(printf '%s/%02d-prep.log' "$out" "$n")" 2>&1; then
        say "  FAILED"
        failed+=("prep")
      fi
      ;;
    *)
      say "unknown group '$group' (draws, frame, visibility, lighting, msaa-parts, first-frame, lavapipe)"
      exit 2
      ;;
  esac
done

if [ "${#failed[@]}" -ne 0 ]; then
  say "failed: ${failed[*]}"
  exit 1
fi
say "records in $out: $(ls "$out"/*.jsonl 2>/dev/null | xargs -n1 basename | tr '\n' ' ')"
