#!/usr/bin/env bash
# One timed libFuzzer run of the importer (fuzz/, target import_gltf), its
# outcome appended as a record to docs/records/fuzz_import_gltf.jsonl (or
# $OXYGEN_RECORD_DIR): executions, seconds, corpus growth, peak memory and
# whether it found anything. docs/security.md quotes the last such record.
#
#   scripts/fuzz-record.sh [SECONDS]      # default 480
#
# Needs cargo-fuzz (`cargo install --locked cargo-fuzz`); libFuzzer's
# instrumentation flags are nightly-only, which RUSTC_BOOTSTRAP=1 allows on
# the stable toolchain (the only one this project's machines have); the
# record's command.env says so. `seconds_run` is libFuzzer's own "Done N runs
# in S second(s)", null when it printed none. The commit is OXYGEN_COMMIT
# when set (dirty then null, as oxygen-demo/src/record.rs does), else git's.
set -euo pipefail
cd "$(dirname "$0")/.."

say() { printf '[fuzz] %s\n' "$*" >&2; }
seconds=${1:-480}
record_dir=${OXYGEN_RECORD_DIR:-docs/records}
command -v cargo-fuzz >/dev/null || { say "cargo-fuzz is missing: cargo install --locked cargo-fuzz"; exit 1; }

bootstrap=1
log=$(mktemp)
trap 'rm -f "$log"' EXIT
mkdir -p fuzz/corpus/import_gltf
say "building and running import_gltf for $seconds s (log: $log)"
set +e
(cd fuzz && RUSTC_BOOTSTRAP=$bootstrap cargo fuzz run import_gltf corpus/import_gltf seeds/import_gltf -- \
  -dict=gltf.dict -timeout=10 -max_len=65536 -max_total_time="$seconds" -print_final_stats=1) >"$log" 2>&1
status=$?
set -e
tail -15 "$log" >&2

python3 - "$log" "$status" "$seconds" "$record_dir" "$bootstrap" <<'PY'
import datetime, json, os, platform, re, subprocess, sys
log, status, seconds, record_dir, bootstrap = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
text = open(log, errors="replace").read()
stats = {k: int(v) for k, v in re.findall(r"^stat::(\w+):\s+(\d+)", text, re.M)}
done = re.search(r"Done (\d+) runs in (\d+) second", text)
if "number_of_executed_units" not in stats and not done:
    sys.exit("[fuzz] the run printed no statistics: it did not start (see the log above)")
finding = status != 0 or "==ERROR" in text or "panicked at" in text or "deadly signal" in text
def git(*args):
    try:
        return subprocess.run(["git", *args], capture_output=True, text=True, check=True).stdout.strip()
    except Exception:
        return None
# A commit given names the build (as oxygen-demo/src/record.rs): this
# checkout's git state says nothing about it then.
given = os.environ.get("OXYGEN_COMMIT")
commit = given or git("rev-parse", "HEAD") or "unknown"
status_lines = None if given else git("status", "--porcelain", "--untracked-files=no")
corpus = len(os.listdir("fuzz/corpus/import_gltf"))
record = {
    "bench": "fuzz_import_gltf",
    "commit": commit,
    "dirty": None if status_lines is None else bool(status_lines),
    "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
    "adapter": None,
    "host": {"available_parallelism": os.cpu_count(), "os": platform.system().lower(), "arch": platform.machine()},
    "command": {"argv": f"fuzz-record.sh {seconds}", "env": {"RUSTC_BOOTSTRAP": bootstrap}},
    "values": {
        "seconds_asked": seconds,
        "executions": stats.get("number_of_executed_units", int(done[1]) if done else 0),
        # libFuzzer's own count; null when it printed none (not the seconds asked).
        "seconds_run": int(done[2]) if done else None,
        "new_units_added": stats.get("new_units_added", 0),
        "peak_rss_mb": stats.get("peak_rss_mb", 0),
        "corpus_files": corpus,
        "findings": 1 if finding else 0,
        "exit_status": status,
    },
}
os.makedirs(record_dir, exist_ok=True)
path = os.path.join(record_dir, "fuzz_import_gltf.jsonl")
with open(path, "a") as f:
    f.write(json.dumps(record, separators=(",", ":")) + "\n")
print(f"[fuzz] {record['values']}; record appended to {path}", file=sys.stderr)
sys.exit(1 if finding else 0)
PY
