#!/usr/bin/env bash
# Peer benchmark: Oxygen (examples/cubes_bench.rs) against Bevy
# (benches/peer-bevy) on the same cubes scene, same adapter, same timing.
#
#   scripts/peer-bench.sh                       # N = 10000, V = 1 and 6, 3 rounds, 30 frames
#   CONFIGS="10000x1 10000x6 100000x1 100000x6" ROUNDS=3 FRAMES=30 scripts/peer-bench.sh
#
# Builds both in release (Bevy in its own project and target dir; its first
# build takes a while), then for each round and each configuration runs
# Oxygen, Bevy with its default MSAA 4× and Bevy with MSAA off, one after
# the other, so that a slow spell of a shared machine hits all three alike.
# Each run prints one line (`… median_ms=…`); the table takes, per
# configuration, the median over the rounds of each run's median frame.
#
# Adapter: both pick it from the environment. WGPU_BACKEND (read by wgpu
# on both sides) picks the backend; OXYGEN_ADAPTER (Oxygen) and
# WGPU_ADAPTER_NAME (Bevy) pick the adapter by a substring of its name.
# ADAPTER sets both (default: llvmpipe, i.e. Mesa's lavapipe on Vulkan);
# each run prints the adapter it got, and the table says which it was.
# Not part of CI: Bevy's build is long and the numbers depend on the machine.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
configs="${CONFIGS:-10000x1 10000x6}"
rounds="${ROUNDS:-3}"
frames="${FRAMES:-30}"
export WGPU_BACKEND="${WGPU_BACKEND:-vulkan}"
adapter="${ADAPTER:-llvmpipe}"
export OXYGEN_ADAPTER="$adapter" WGPU_ADAPTER_NAME="$adapter"
nice_cmd=(nice -n "${NICE:-10}")

echo "building Oxygen's cubes_bench and peer-bevy (release)…" >&2
(cd "$root" && "${nice_cmd[@]}" cargo build --release --example cubes_bench >&2)
bevy_target="${PEER_BEVY_TARGET:-$root/benches/peer-bevy/target}"
(cd "$root/benches/peer-bevy" && CARGO_TARGET_DIR="$bevy_target" "${nice_cmd[@]}" cargo build --release >&2)
oxygen_bin="${CARGO_TARGET_DIR:-$root/target}/release/examples/cubes_bench"
bevy_bin="$bevy_target/release/peer-bevy"

log="$(mktemp)"
trap 'rm -f "$log"' EXIT
for round in $(seq 1 "$rounds"); do
    for config in $configs; do
        n="${config%x*}"
        v="${config#*x}"
        echo "round $round/$rounds: N=$n V=$v" >&2
        "$oxygen_bin" "$n" "$v" "$frames" | tee -a "$log" >&2
        "$bevy_bin" "$n" "$v" "$frames" | tee -a "$log" >&2
        "$bevy_bin" "$n" "$v" "$frames" --msaa-off | sed 's/^bevy /bevy_nomsaa /' | tee -a "$log" >&2
    done
done

# Median over rounds of each run's median_ms, per renderer and configuration.
python3 - "$log" "$rounds" "$frames" <<'EOF'
import re, statistics, sys
log, rounds, frames = sys.argv[1], sys.argv[2], sys.argv[3]
runs, visible, adapters = {}, {}, {}
for line in open(log):
    if " adapter: " in line:
        who, name = line.split(" adapter: ", 1)
        adapters[who] = name.strip()
        continue
    fields = dict(kv.split("=", 1) for kv in line.split()[1:] if "=" in kv)
    if "median_ms" not in fields:
        continue
    key = (line.split()[0], int(fields["N"]), int(fields["V"]))
    runs.setdefault(key, []).append(float(fields["median_ms"]))
    visible.setdefault(key, []).append(float(fields["visible"]))
configs = sorted({(n, v) for (_, n, v) in runs})
med = lambda who, n, v: statistics.median(runs[(who, n, v)])
print("| N | V | Oxygen ms | Bevy ms (MSAA 4×, default) | Bevy / Oxygen | Bevy ms (MSAA off) | Bevy no-MSAA / Oxygen | in view (Oxygen / Bevy) |")
print("|---:|---:|---:|---:|---:|---:|---:|---:|")
for n, v in configs:
    o, b, bn = med("oxygen", n, v), med("bevy", n, v), med("bevy_nomsaa", n, v)
    vis = f"{statistics.mean(visible[('oxygen', n, v)]):.1%} / {statistics.mean(visible[('bevy', n, v)]):.1%}"
    print(f"| {n} | {v} | {o:.1f} | {b:.1f} | {b / o:.2f} | {bn:.1f} | {bn / o:.2f} | {vis} |")
print()
print(f"Median over {rounds} interleaved rounds of each run's median of {frames} frames (after warm-up),")
print("each frame timed from its start until the GPU finished it.")
for who in ("oxygen", "bevy"):
    print(f"{who} adapter: {adapters.get(who, '?')}")
EOF
