#!/usr/bin/env bash
# Runs every Oxygen test, as CI does (.ci/run calls exactly this).
#
# 1. checks for a Rust toolchain;
# 2. makes sure a Vulkan driver is there (installs Mesa's lavapipe when run as
#    root on Debian/Ubuntu; otherwise prints the command to run);
# 3. prints the adapter the GPU tests will use;
# 4. runs the whole workspace's tests (unit, snapshot, layout, GPU).
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v cargo >/dev/null 2>&1; then
  echo "[oxygen] cargo not found: install Rust (https://rustup.rs), then rerun $0" >&2
  exit 1
fi
scripts/ensure-gpu.sh

echo "[oxygen] building tests (the first build compiles wgpu and takes a few minutes)" >&2
cargo build --locked --workspace --tests --examples
echo "[oxygen] adapter used by the GPU tests:" >&2
cargo run --locked --quiet --example adapter_info
cargo test --locked --workspace "$@"
echo "[oxygen] all tests passed" >&2
