#!/usr/bin/env bash
# The main job: loads a shipped glTF scene (or the file given as $1), renders
# it through one view per glTF camera plus three orbit cameras, and writes one PNG
# per view into out/ (or the directory given as $2).
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v cargo >/dev/null 2>&1; then
  echo "[oxygen] cargo not found: install Rust (https://rustup.rs), then rerun $0" >&2
  exit 1
fi
scripts/ensure-gpu.sh
file=${1:-assets/AlphaBlendModeTest/AlphaBlendModeTest.glb}
out=${2:-out}
cargo run --locked --release --example gltf_viewer -- "$file" "$out"
echo "[oxygen] PNGs written to $(cd "$out" && pwd)/" >&2
