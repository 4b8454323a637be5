#!/usr/bin/env bash
# The main job: renders the demo scene through two registered views and
# writes one PNG per view into out/ (or the directory given as $1).
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v cargo >/dev/null 2>&1; then
  echo "[oxygen] cargo not found: install Rust (https://rustup.rs), then rerun $0" >&2
  exit 1
fi
scripts/ensure-gpu.sh
out=${1:-out}
cargo run --locked --release --example multi_view -- "$out"
echo "[oxygen] PNGs written to $(cd "$out" && pwd)/" >&2
