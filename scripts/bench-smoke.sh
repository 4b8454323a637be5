#!/usr/bin/env bash
# Smoke run of every bench: each runs once, at toy sizes, in the dev
# profile (the test build's artefacts), with OXYGEN_RECORD_DIR pointing at a
# temporary directory; then each must have exited 0 and written at least one
# well-formed record (docs/records/README.md). Measures nothing: it proves
# that every bench still runs to the end and still writes its record.
#
#   scripts/bench-smoke.sh                 # WGPU_BACKEND defaults to vulkan
#   BENCH_SMOKE_KEEP=dir scripts/bench-smoke.sh   # keep the records and logs in dir
#
# (Each run's folder in dir, run<i>-<bench>, is removed and made afresh first,
# so that a reused dir never lends a run the records of an earlier one.)
#
# Fails (naming the bench) when a bench panics, exits non-zero, runs past
# BENCH_SMOKE_TIMEOUT seconds (default 300), or writes no record or a
# malformed one; and when a bench exists that this script does not run
# (examples/*_bench.rs, *_cost.rs, *_floor.rs, accuracy_atlas.rs, and every
# crate's benches/*.rs), so that a new bench is never forgotten.
set -euo pipefail
cd "$(dirname "$0")/.."

say() { printf '[bench-smoke] %s\n' "$*" >&2; }

export WGPU_BACKEND="${WGPU_BACKEND:-vulkan}"
case "$WGPU_BACKEND" in
  vulkan | gl) OXYGEN_BACKENDS="$WGPU_BACKEND" scripts/ensure-gpu.sh ;;
esac
timeout_s="${BENCH_SMOKE_TIMEOUT:-300}"

if [ -n "${BENCH_SMOKE_KEEP:-}" ]; then
  work="$BENCH_SMOKE_KEEP"
  mkdir -p "$work"
else
  work="$(mktemp -d)"
  trap 'rm -rf "$work"' EXIT
fi

# Every run: bench name (its record is <name>.jsonl), how it runs
# (example: its binary from the workspace build; sceneprep: the oxygen-sceneprep bench
# through `cargo test`, unoptimised), cpu or gpu (a GPU bench's record must
# name its adapter), its arguments (@OUT@: a directory of its own) and,
# optionally, VAR=value words it runs with.
runs=(
  "batch_bench|example|gpu|16 32x32 1,2 1"
  "batch_bench|example|gpu|16 32x32 1,2 1|BATCH_BENCH_INTERLEAVE=1 BATCH_BENCH_MODES=batch"
  "cubes_bench|example|gpu|16 2 2"
  "group_bench|example|gpu|16 32x32 2 1,2 1"
  "node_bench|example|gpu|16 32x32 4 1,2 1"
  "draw_path_bench|example|gpu|16"
  "environment_bench|example|gpu|1 --smoke"
  "hdr_format_bench|example|gpu|64 1"
  "light_bench|example|gpu|32 1 1,16"
  "indirect_count_cost|example|gpu|1"
  "msaa_bench|example|gpu|64 4 1"
  "prepass_bench|example|gpu|16 1"
  "raster_floor|example|gpu|16 1"
  "readback_probe|example|gpu|256x64 2 2000"
  "shading_probe|example|gpu|256x64 4 1"
  "record_bench|example|gpu|4 direct 1,2"
  "shadow_bench|example|gpu|16"
  "tone_map_effects_bench|example|gpu|64 1"
  "overlay_bench|example|gpu|200 64 1"
  "schedule_bench|example|gpu|4 1 1"
  "visibility_bench|example|gpu|field 16 1 1"
  "visibility_bench|example|gpu|city 16 1 1"
  "accuracy_atlas|example|gpu|@OUT@ 8 4"
  "sensor_rig|example|gpu|assets/AlphaBlendModeTest/AlphaBlendModeTest.glb @OUT@ --cameras 2 --size 32x32 --frames 1"
  "sensor_rig|example|gpu|assets/BoxTextured/BoxTextured.glb @OUT@ --cameras 2 --size 32x32 --frames 1 --deferred"
  "prep|sceneprep|cpu|--smoke"
)

failed=()

# Every bench in the tree must be run above.
listed=" "
for run in "${runs[@]}"; do listed+="${run%%|*} "; done
for file in examples/*_bench.rs oxygen-node/examples/*_bench.rs examples/*_cost.rs examples/*_floor.rs examples/*_probe.rs examples/accuracy_atlas.rs */benches/*.rs; do
  [ -e "$file" ] || continue
  name="$(basename "$file" .rs)"
  case "$listed" in
    *" $name "*) ;;
    *)
      say "FAIL $name: $file is a bench that this script does not run (add it to runs=(...))"
      failed+=("$name (not run by scripts/bench-smoke.sh)")
      ;;
  esac
done

say "building the examples and the sceneprep bench (dev profile)"
started=$SECONDS
# With --workspace, as scripts/test.sh builds: a build of one package
# resolves its dependencies' features for that package alone and compiles
# dozens of crates again (minutes on two cores). The examples then run
# from target/ (the render-node bench starts the oxygen-node program
# beside it).
cargo build --locked --workspace --bins --examples
cargo test --locked --workspace --no-run --bench prep
say "build: $((SECONDS - started)) s"

total_start=$(date +%s.%N)
summary=()
for i in "${!runs[@]}"; do
  IFS='|' read -r name kind device args vars <<<"${runs[$i]}"
  dir="$work/run$i-$name"
  # Afresh: with BENCH_SMOKE_KEEP reused, an old run's records would
  # otherwise pass for this run's (a bench that stopped writing included).
  rm -rf "$dir"
  mkdir -p "$dir/out"
  args="${args//@OUT@/$dir/out}"
  read -r -a argv <<<"$args"
  read -r -a env_words <<<"${vars:-}"
  case "$kind" in
    example) command=(env "${env_words[@]}" "target/debug/examples/$name" "${argv[@]}") ;;
    sceneprep) command=(env "${env_words[@]}" cargo test --locked --quiet --workspace --bench "$name" -- "${argv[@]}") ;;
    *) say "unknown kind $kind"; exit 2 ;;
  esac
  start=$(date +%s.%N)
  status=0
  OXYGEN_RECORD_DIR="$dir/records" timeout "$timeout_s" "${command[@]}" >"$dir/log" 2>&1 || status=$?
  seconds=$(python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" "$start" "$(date +%s.%N)")
  line="${vars:+$vars }$name $args: ${seconds} s"
  problem=""
  if [ "$status" -eq 124 ]; then
    problem="timed out after $timeout_s s"
  elif [ "$status" -ne 0 ]; then
    problem="exited with status $status"
  else
    # Prints the number of records, or exits with what is wrong.
    problem=$(python3 - "$dir/records" "$name" "$device" 2>&1 <<'EOF'
import json, os, re, sys

directory, bench, device = sys.argv[1], sys.argv[2], sys.argv[3]
path = os.path.join(directory, bench + ".jsonl")
if not os.path.isfile(path):
    sys.exit(f"wrote no record ({path} missing)")

def refuse(constant):
    raise ValueError(f"{constant} is not JSON")

date = re.compile(r"^\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}Z$")
records = 0
with open(path, encoding="utf-8") as lines:
    for number, line in enumerate(lines, 1):
        where = f"{path}:{number}"
        try:
            record = json.loads(line, parse_constant=refuse)
        except ValueError as error:
            sys.exit(f"{where}: not JSON: {error}")
        if not isinstance(record, dict):
            sys.exit(f"{where}: not an object")
        fields = ["bench", "commit", "dirty", "date", "adapter", "host", "command", "values"]
        if list(record) != fields:
            sys.exit(f"{where}: fields {list(record)}, expected {fields}")
        problems = []
        if record["bench"] != bench:
            problems.append(f"bench is {record['bench']!r}")
        if not isinstance(record["commit"], str) or not record["commit"]:
            problems.append("commit is not a non-empty string")
        if record["dirty"] is not None and not isinstance(record["dirty"], bool):
            problems.append("dirty is not a boolean or null")
        if not isinstance(record["date"], str) or not date.match(record["date"]):
            problems.append(f"date {record['date']!r} is not UTC ISO 8601")
        adapter = record["adapter"]
        adapter_fields = ["name", "backend", "device_type", "driver", "driver_info"]
        if adapter is None:
            if device == "gpu":
                problems.append("a GPU bench's record names no adapter")
        elif not isinstance(adapter, dict) or not all(isinstance(adapter.get(f), str) for f in adapter_fields):
            problems.append(f"adapter {adapter!r} lacks one of {adapter_fields}")
        host = record["host"]
        if not isinstance(host, dict) or not isinstance(host.get("available_parallelism"), int) \
                or not isinstance(host.get("os"), str):
            problems.append(f"host {host!r} lacks available_parallelism or os")
        command = record["command"]
        if not isinstance(command, dict) or not isinstance(command.get("argv"), str) \
                or not isinstance(command.get("env"), dict):
            problems.append(f"command {command!r} is not {{argv, env}}")
        elif command["argv"].split(" ")[0] != bench:
            problems.append(f"command.argv {command['argv']!r} does not start with {bench}")
        if not isinstance(record["values"], dict) or not record["values"]:
            problems.append("values is not a non-empty object")
        if problems:
            sys.exit(f"{where}: " + "; ".join(problems))
        records += 1
if records == 0:
    sys.exit(f"{path} is empty")
print(records)
EOF
    ) || true
  fi
  if [ "$status" -eq 0 ] && [[ "$problem" =~ ^[0-9]+$ ]]; then
    say "ok   $line ($problem record$([ "$problem" = 1 ] || echo s))"
    summary+=("ok   $line")
  else
    say "FAIL $line: $problem"
    tail -n 30 "$dir/log" | sed 's/^/    /' >&2
    summary+=("FAIL $line: $problem")
    failed+=("$name ($problem)")
  fi
done
total=$(python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" "$total_start" "$(date +%s.%N)")

say "summary (WGPU_BACKEND=$WGPU_BACKEND):"
printf '  %s\n' "${summary[@]}" >&2
say "total: $total s for ${#runs[@]} runs (after the build)"
if [ "${#failed[@]}" -gt 0 ]; then
  say "FAILED: ${failed[*]}"
  exit 1
fi
say "every bench ran and wrote its record"
