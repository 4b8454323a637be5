#!/usr/bin/env bash
# Before/after benchmark of a change that must not change speed: the same
# benches from two builds, run interleaved on one machine, so that a slow
# spell of a shared GPU hits both alike (odd rounds run the old build first,
# even rounds the new).
#
#   scripts/ab-bench.sh BEFORE_DIR AFTER_DIR RECORD_DIR
#
# BEFORE_DIR and AFTER_DIR hold release builds of cubes_bench,
# visibility_bench and record_bench; BEFORE_COMMIT and AFTER_COMMIT must name
# the commits they were built from (each run's record names its commit).
# ROUNDS (default 3) rounds of every configuration below (AB_CONFIGS, as
# `bench|arguments;bench|arguments`, replaces them, e.g. for a smoke run). Every run writes
# its own record (oxygen_demo::record) into RECORD_DIR/<bench>.jsonl, tagged
# OXYGEN_AB=before|after in its command.env; scripts/ab_summary.py then
# pairs them (median of each side's per-run medians, after ÷ before),
# prints the table and appends one record to RECORD_DIR/ab_bench.jsonl.
# Each run's output goes to RECORD_DIR/logs/.
set -uo pipefail
. "$(dirname "$0")/usage.sh"

[ $# -eq 3 ] || usage
root=$(cd "$(dirname "$0")/.." && pwd -P)
before=$(cd "$1" && pwd -P)
after=$(cd "$2" && pwd -P)
mkdir -p "$3/logs"
out=$(cd "$3" && pwd -P)
: "${BEFORE_COMMIT:?BEFORE_COMMIT must name the commit BEFORE_DIR was built from}"
: "${AFTER_COMMIT:?AFTER_COMMIT must name the commit AFTER_DIR was built from}"
rounds=${ROUNDS:-3}

# bench|arguments: the configurations the issue's figures were measured with.
configs=(
  "cubes_bench|10000 1 20"
  "cubes_bench|100000 6 20"
  "visibility_bench|field 10000 1,16,64 8"
  "record_bench|20000 mdi"
)

if [ -n "${AB_CONFIGS:-}" ]; then
  IFS=';' read -r -a configs <<<"$AB_CONFIGS"
fi

say() { printf '[ab-bench] %s\n' "$*" >&2; }
failed=0
n=0
run_one() { # label dir commit bench args
  local label=$1 dir=$2 commit=$3 bench=$4 args=$5
  n=$((n + 1))
  local log
  log=$(printf '%s/logs/%03d-%s-%s.log' "$out" "$n" "$label" "$bench")
  say "round $round: $label $bench $args"
  # shellcheck disable=SC2086 # the arguments are words
  if ! OXYGEN_AB=$label OXYGEN_COMMIT=$commit OXYGEN_RECORD_DIR=$out "$dir/$bench" $args >"$log" 2>&1; then
    say "FAILED: $label $bench $args (log: $log)"
    failed=1
  fi
}

for round in $(seq 1 "$rounds"); do
  for config in "${configs[@]}"; do
    bench=${config%%|*}
    args=${config#*|}
    if [ $((round % 2)) = 1 ]; then
      run_one before "$before" "$BEFORE_COMMIT" "$bench" "$args"
      run_one after "$after" "$AFTER_COMMIT" "$bench" "$args"
    else
      run_one after "$after" "$AFTER_COMMIT" "$bench" "$args"
      run_one before "$before" "$BEFORE_COMMIT" "$bench" "$args"
    fi
  done
done
python3 "$root/scripts/ab_summary.py" "$out" || failed=1
exit $failed
