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
#
# OXYGEN_BIN and BEVY_BIN name prebuilt binaries (release builds carried to
# a GPU machine, say) and skip the builds; OXYGEN_COMMIT must then name the
# commit they were built from (the record names it; a carried copy's .git
# may name another), else the script refuses to run (exit 2).
# OXYGEN_CPU_PATH=1 also runs Oxygen with OXYGEN_VISIBILITY=cpu in each
# round. With OXYGEN_RECORD_DIR set (a relative one is taken from the
# repository root, as oxygen-demo/src/record.rs does), the run is appended
# as one record to $OXYGEN_RECORD_DIR/peer_bench.jsonl
# (docs/records/README.md): every run's line, the medians and ratios of the
# table, both adapters and the command; its command.env keeps the variables
# record.rs keeps (RECORDED_ENV_PREFIXES: OXYGEN_, WGPU_, ..., MESA_, __GL_),
# less OXYGEN_RECORD_DIR and OXYGEN_COMMIT.
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

if [ -n "${OXYGEN_BIN:-}" ] && [ -n "${BEVY_BIN:-}" ]; then
    if [ -z "${OXYGEN_COMMIT:-}" ]; then
        echo "peer-bench: OXYGEN_BIN and BEVY_BIN are given but OXYGEN_COMMIT is not: name the commit" \
            "they were built from (OXYGEN_COMMIT=<hash>); a carried copy's .git may name another" >&2
        exit 2
    fi
    oxygen_bin=$OXYGEN_BIN
    bevy_bin=$BEVY_BIN
else
    echo "building Oxygen's cubes_bench and peer-bevy (release)…" >&2
    (cd "$root" && "${nice_cmd[@]}" cargo build --release --example cubes_bench >&2)
    bevy_target="${PEER_BEVY_TARGET:-$root/benches/peer-bevy/target}"
    (cd "$root/benches/peer-bevy" && CARGO_TARGET_DIR="$bevy_target" "${nice_cmd[@]}" cargo build --release >&2)
    oxygen_bin="${CARGO_TARGET_DIR:-$root/target}/release/examples/cubes_bench"
    bevy_bin="$bevy_target/release/peer-bevy"
fi

log="$(mktemp)"
trap 'rm -f "$log"' EXIT
for round in $(seq 1 "$rounds"); do
    for config in $configs; do
        n="${config%x*}"
        v="${config#*x}"
        echo "round $round/$rounds: N=$n V=$v" >&2
        # The loop's record is the harness's own (below), not each run's.
        env -u OXYGEN_RECORD_DIR "$oxygen_bin" "$n" "$v" "$frames" | tee -a "$log" >&2
        "$bevy_bin" "$n" "$v" "$frames" | tee -a "$log" >&2
        "$bevy_bin" "$n" "$v" "$frames" --msaa-off | sed 's/^bevy /bevy_nomsaa /' | tee -a "$log" >&2
        if [ "${OXYGEN_CPU_PATH:-0}" = 1 ]; then
            env -u OXYGEN_RECORD_DIR OXYGEN_VISIBILITY=cpu "$oxygen_bin" "$n" "$v" "$frames" | sed 's/^oxygen /oxygen_cpu /' | tee -a "$log" >&2
        fi
    done
done

# Median over rounds of each run's median_ms, per renderer and configuration.
python3 - "$log" "$rounds" "$frames" "$configs" "$root" <<'EOF'
import datetime, json, os, platform, re, statistics, subprocess, sys
log, rounds, frames, config_list, root = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5]
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
if ("oxygen_cpu", configs[0][0], configs[0][1]) in runs:
    print()
    print("Oxygen's CPU path (OXYGEN_VISIBILITY=cpu), same rounds: " + ", ".join(
        f"N={n} V={v}: {med('oxygen_cpu', n, v):.2f} ms" for n, v in configs))

# The record of the run, in docs/records' format.
record_dir = os.environ.get("OXYGEN_RECORD_DIR")
if record_dir:
    # Relative to the repository root, as oxygen-demo/src/record.rs takes it.
    record_dir = os.path.join(root, record_dir)
    def git(*args):
        try:
            return subprocess.run(["git", *args], cwd=root, capture_output=True, text=True,
                                  check=True).stdout.strip()
        except Exception:
            return None
    # A commit given names the binaries' build (carried away from their
    # checkout); the git state here says nothing about them then.
    given = os.environ.get("OXYGEN_COMMIT")
    commit = given or git("rev-parse", "HEAD") or "unknown"
    status = None if given else git("status", "--porcelain", "--untracked-files=no")
    # "NAME (Vulkan, DiscreteGpu, driver DRIVER INFO)", as peer-bevy prints it.
    bevy = adapters.get("bevy", "")
    m = re.match(r"(.*) \((\w+), (\w+), driver (\S*) ?(.*)\)$", bevy)
    adapter = ({"name": m[1], "backend": m[2], "device_type": m[3], "driver": m[4], "driver_info": m[5]}
               if m else {"name": bevy, "backend": "", "device_type": "", "driver": "", "driver_info": ""})
    # What oxygen-demo/src/record.rs keeps (RECORDED_ENV_PREFIXES), less the
    # record's own directory and commit.
    prefixes = ("OXYGEN_", "WGPU_", "MSAA_BENCH_", "VISIBILITY_", "CUBES_BENCH_", "BATCH_BENCH_", "ATLAS_", "MESA_", "__GL_")
    env = {k: v for k, v in sorted(os.environ.items())
           if k.startswith(prefixes) and k not in ("OXYGEN_RECORD_DIR", "OXYGEN_COMMIT")}
    rows = []
    for n, v in configs:
        row = {"n": n, "v": v}
        for who in ("oxygen", "oxygen_cpu", "bevy", "bevy_nomsaa"):
            if (who, n, v) in runs:
                row[f"{who}_ms_median"] = med(who, n, v)
                row[f"{who}_ms_rounds"] = runs[(who, n, v)]
                row[f"{who}_visible"] = statistics.mean(visible[(who, n, v)])
        row["bevy_over_oxygen"] = row["bevy_ms_median"] / row["oxygen_ms_median"]
        row["bevy_nomsaa_over_oxygen"] = row["bevy_nomsaa_ms_median"] / row["oxygen_ms_median"]
        rows.append(row)
    record = {
        "bench": "peer_bench",
        "commit": commit,
        "dirty": None if status is None else bool(status),
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "adapter": adapter,
        "host": {"available_parallelism": os.cpu_count(), "os": platform.system().lower(), "arch": platform.machine()},
        "command": {"argv": f"peer-bench.sh CONFIGS={config_list} ROUNDS={rounds} FRAMES={frames}",
                    "env": env},
        "values": {"rounds": int(rounds), "frames": int(frames), "oxygen_adapter": adapters.get("oxygen", ""),
                   "rows": rows, "lines": [l.rstrip("\n") for l in open(log) if "median_ms" in l]},
    }
    os.makedirs(record_dir, exist_ok=True)
    path = os.path.join(record_dir, "peer_bench.jsonl")
    with open(path, "a") as f:
        f.write(json.dumps(record) + "\n")
    print(f"record: appended to {path}", file=sys.stderr)
EOF
